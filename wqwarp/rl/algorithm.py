"""rsl-rl's PPO with the paper's two auxiliary learners as extensions: the state estimator and the power predictor.

The train config names the class (``algorithm.class_name = "wqwarp.rl.algorithm:WqPPO"``); rsl-rl's runner builds it
through :meth:`WqPPO.construct_algorithm`, which attaches the env's learners. Each learner is an extension in the shape
of rsl-rl's own (``rsl_rl.extensions``): after PPO's update it fits on the rollout just collected and adds its loss to
``update()``'s dict (logged as ``Loss/estimator``, ``Loss/predictor``), saves and loads with the algorithm, and is
broadcast from rank 0 at the start and averaged across ranks after each fit under torch.distributed.

Order inside :meth:`WqPPO.update` (the random streams are consumed in it): PPO's update, the estimator fit, the
power-predictor fit, then the temperature schedule and the reward ramp (``RewardConfig.ramp_terms``, a third,
stateless extension) move to the next iteration.
"""

from __future__ import annotations

import math
from collections import deque
from typing import TYPE_CHECKING, Literal

import torch
import torch.distributed as dist
from rsl_rl.algorithms import PPO
from rsl_rl.utils import resolve_callable
from tensordict import TensorDict
from torch import nn

from wqwarp.rl.estimator import EstimatorTrainer
from wqwarp.rl.gait_selection import GaitSelector, PredictiveGaitSelector
from wqwarp.utils.checked_config import require

if TYPE_CHECKING:
    from wqwarp.rl.env import WheeledGo1Env


def sync_module(module: nn.Module, op: Literal["broadcast", "average"]) -> None:
    """Under torch.distributed: ``broadcast`` rank 0's floating-point parameters and buffers to every rank, or
    ``average`` them across ranks (sum / world size); nothing outside torch.distributed."""
    if not (dist.is_available() and dist.is_initialized()):
        return
    world = dist.get_world_size()
    for t in list(module.parameters()) + list(module.buffers()):
        if not t.is_floating_point():
            continue
        if op == "broadcast":
            dist.broadcast(t.data, src=0)
        else:
            dist.all_reduce(t.data, op=dist.ReduceOp.SUM)
            t.data /= world


class EstimatorLearner:
    """The state estimator z_t = (v_x, v_y, h) as an extension: MSE regression on the (history, true state) pairs
    the env stored during the rollout (``wqwarp.rl.estimator``)."""

    key = "estimator"
    """Name of its loss (``Loss/estimator``) and of its entries in a checkpoint."""

    def __init__(self, trainer: EstimatorTrainer):
        self.trainer = trainer
        """Holds the estimator network, its optimizer and the pairs collected since the last fit."""

    def modules(self) -> list[nn.Module]:
        """Networks kept identical across ranks."""
        return [self.trainer.estimator]

    def fit(self) -> dict[str, float]:
        """Fit on the rollout's pairs; the mean squared error [(m/s)^2 and m^2 mixed]."""
        return {self.key: self.trainer.fit()}

    def set_iteration(self, iteration: int) -> None:
        """The estimator has no schedule."""

    def state_dict(self) -> dict:
        return {
            f"{self.key}_state_dict": self.trainer.estimator.state_dict(),
            f"{self.key}_optimizer_state_dict": self.trainer.optimizer.state_dict(),
        }

    def load_state_dict(self, saved: dict, strict: bool, rng: bool) -> None:
        """Network and optimizer from :meth:`state_dict`'s entries of ``saved`` (no random stream of its own)."""
        self.trainer.estimator.load_state_dict(saved[f"{self.key}_state_dict"], strict=strict)
        if f"{self.key}_optimizer_state_dict" in saved:
            self.trainer.optimizer.load_state_dict(saved[f"{self.key}_optimizer_state_dict"])


class RewardRampLearner:
    """The reward curriculum as an extension: moves the env's ramped weights (``RewardConfig.ramp_terms``) to the
    iteration. The ramp is a function of the iteration, which the checkpoint holds; with the skill gate
    (``RewardConfig.ramp_gate_vy_error``) it also keeps the recent iterations' mean v_y errors and the iteration the
    gate opened, and saves both."""

    key = "reward_ramp"

    def __init__(self, env: WheeledGo1Env):
        self.env = env
        r = env.cfg.reward
        self.gated = env.ramp_gated
        self.errors: deque[float] = deque(maxlen=max(1, r.ramp_gate_window))
        """Mean Metrics/vy_error of the latest rollouts (the gate's window)."""
        self.opened_at: int | None = None
        """PPO iteration at which the gated ramp started (None: not yet)."""
        self.iteration = 0

    def modules(self) -> list[nn.Module]:
        return []

    def fit(self) -> dict[str, float]:
        """After iteration ``self.iteration``'s rollout: add its mean v_y error to the window and open the gate for
        the next iteration once the window is full, ramp_start is reached and its mean is below the threshold."""
        if not self.gated or self.opened_at is not None:
            return {}
        err = self.env.take_gate_error()
        if err is not None:
            self.errors.append(err)
        r = self.env.cfg.reward
        if len(self.errors) < self.errors.maxlen or self.iteration < r.ramp_start:
            return {}
        mean = sum(self.errors) / len(self.errors)
        if mean < r.ramp_gate_vy_error:
            self.opened_at = self.iteration + 1
            print(
                f"reward ramp: gate opened for iteration {self.opened_at} (mean v_y error of the last "
                f"{len(self.errors)} iterations {mean:.3f} < {r.ramp_gate_vy_error:g} m/s)",
                flush=True,
            )
        return {}

    def set_iteration(self, iteration: int) -> None:
        self.iteration = int(iteration)
        self.env.set_iteration(iteration, self.opened_at)

    def state_dict(self) -> dict:
        if not self.gated:
            return {}
        return {f"{self.key}_state_dict": {"opened_at": self.opened_at, "errors": list(self.errors)}}

    def load_state_dict(self, saved: dict, strict: bool, rng: bool) -> None:
        """The gate's window and opening iteration from :meth:`state_dict` (nothing without the gate; a checkpoint
        without them starts the gate afresh)."""
        state = saved.get(f"{self.key}_state_dict")
        if not self.gated or state is None:
            return
        self.opened_at = state["opened_at"]
        self.errors.clear()
        self.errors.extend(state["errors"])


class GaitSelectorLearner:
    """The gait selector as an extension: with predictive selection the power predictor (masked regression on the
    labelled power windows of the replay buffer, ``wqwarp.rl.gait_selection``) and the softmax temperature schedule;
    the fixed and ``none`` selectors only save their name (a checkpoint of another selector is refused)."""

    key = "gait_selector"
    """Name of its entry in a checkpoint."""

    def __init__(self, selector: GaitSelector):
        self.selector = selector

    def modules(self) -> list[nn.Module]:
        """Networks kept identical across ranks (the power predictor, if any)."""
        sel = self.selector
        if not isinstance(sel, PredictiveGaitSelector):
            return []
        return [sel.predictor] if sel.tracker is None else [sel.predictor, sel.tracker]

    def fit(self) -> dict[str, float]:
        """Fit the power predictor; its masked regression loss (in target standard deviations squared)."""
        out = self.selector.fit()
        return {"predictor": out["loss"]} if "loss" in out else {}

    def set_iteration(self, iteration: int) -> None:
        """Move the temperature schedule to the PPO iteration the coming rollout belongs to."""
        self.selector.set_iteration(iteration)

    def state_dict(self) -> dict:
        return {f"{self.key}_state_dict": self.selector.state_dict()}

    def load_state_dict(self, saved: dict, strict: bool, rng: bool) -> None:
        """The selector's state (name check, predictor, optimizer, schedule position); its random stream only with
        ``rng`` (resuming a training run)."""
        state = saved.get(f"{self.key}_state_dict")
        if state is None:
            if isinstance(self.selector, PredictiveGaitSelector):
                raise ValueError(
                    "the checkpoint holds no power predictor; it cannot drive the predictive gait selection"
                )
            return
        self.selector.load_state_dict(state if rng else {k: v for k, v in state.items() if k != "rng"})


LEGACY_KEYS = {
    "estimator_state_dict": "estimator",
    "estimator_optimizer_state_dict": "estimator_optimizer",
    "gait_selector_state_dict": "gait_selector",
}
"""Checkpoint entry -> where checkpoints of format 1 kept it (in ``infos``)."""


def kl_rule(lr: float, kl: float, desired_kl: float) -> float:
    """rsl-rl 5.5.1's adaptive rule (``PPO.update``, before each minibatch): the rate divided by 1.5 when ``kl`` is
    above 2x ``desired_kl``, multiplied by 1.5 when it is positive and below half, within [1e-5, 1e-2]."""
    if kl > desired_kl * 2.0:
        return max(1e-5, lr / 1.5)
    if 0.0 < kl < desired_kl / 2.0:
        return min(1e-2, lr * 1.5)
    return lr


class WqPPO(PPO):
    """PPO (``rsl_rl.algorithms.PPO``) with the state estimator and the power predictor as extensions (module
    docstring).

    Reference:
        - Schulman et al. "Proximal policy optimization algorithms." arXiv preprint arXiv:1707.06347 (2017).
    """

    def __init__(
        self,
        *args,
        update_threads: int | None = None,
        init_std_groups: list[float] | None = None,
        kl_per_update: bool = False,
        **kwargs,
    ) -> None:
        """``init_std_groups``: the initial action std of each action group (``TrainConfig.init_noise_std_groups``,
        groups of ``wqwarp.rl.observations.action_groups``), written into the actor's std parameter.
        ``kl_per_update``: adapt the learning rate to ``desired_kl`` once per update (``TrainConfig.schedule``
        ``adaptive_update``, with rsl-rl's schedule ``fixed``) instead of before every minibatch."""
        super().__init__(*args, **kwargs)
        self.kl_per_update = bool(kl_per_update)
        if self.kl_per_update and self.desired_kl is None:
            raise ValueError("kl_per_update needs desired_kl")
        self.update_kl: float | None = None
        """KL of the policy after the last update against the one that collected its rollout (mean over the
        rollout's transitions; with ``kl_per_update``)."""
        if init_std_groups:
            self.set_group_std(init_std_groups)
        self.update_threads = update_threads
        """Torch intra-op threads during the update and the fits (None: leave torch's setting); collection keeps
        torch's setting (``wqwarp.utils.threads``: the physics threads run then)."""
        self.learners: list[EstimatorLearner | GaitSelectorLearner | RewardRampLearner] = []
        """The extensions, in the order they fit (:meth:`attach`)."""
        self.aux_losses: dict[str, float] = {}
        """Losses of the last fits of the extensions."""
        self.iteration = 0
        """PPO iteration the coming rollout belongs to (the temperature schedule's position)."""
        self.mean_actors: torch.Tensor | None = None
        """(N,) bool: robots that act with the actor's mean while training, to label the power predictor with what
        evaluation runs (``PredictorConfig.label_source = "mean"``; the gait selector's ``label_robots``). Their
        transitions stay in the storage (the critic and the return of the others are unchanged) but carry
        advantage 0 and return = value, so neither PPO loss learns from actions that were not sampled."""

    def set_group_std(self, stds: list[float]) -> None:
        """Set the actor's std per action group (one value per group, in ``action_groups`` order)."""
        from wqwarp.rl.observations import action_groups

        dist = self.actor.distribution
        param = getattr(dist, "std_param", None)
        log_param = getattr(dist, "log_std_param", None)
        target = param if param is not None else log_param
        if target is None:
            raise ValueError("init_noise_std_groups needs a Gaussian distribution with a state-independent std")
        groups = action_groups(target.shape[-1])
        if len(stds) != len(groups):
            raise ValueError(
                f"init_noise_std_groups: {len(stds)} values for the {len(groups)} action groups ({', '.join(groups)})"
            )
        with torch.no_grad():
            for value, cols in zip(stds, groups.values(), strict=True):
                target[cols] = float(value) if param is not None else math.log(float(value))

    @staticmethod
    def construct_algorithm(obs: TensorDict, env: WheeledGo1Env, cfg: dict, device: str) -> WqPPO:
        """rsl-rl's construction (actor, critic, storage; the class named in ``cfg``), then :meth:`attach`."""
        alg = PPO.construct_algorithm(obs, env, cfg, device)
        if not isinstance(alg, WqPPO):
            raise TypeError(f"algorithm.class_name must name WqPPO or a subclass, got {type(alg).__name__}")
        alg.attach(env)
        return alg

    def attach(self, env: WheeledGo1Env) -> None:
        """Take the env's estimator trainer, gait selector and reward ramp as the extensions (in that order), and
        the robots that act with the mean (:attr:`mean_actors`)."""
        self.learners = [
            EstimatorLearner(env.estimator_trainer),
            GaitSelectorLearner(env.gait_selector),
            RewardRampLearner(env),
        ]
        mask = env.gait_selector.label_robots
        if mask is not None and self.normalize_advantage_per_mini_batch:
            raise ValueError(
                "predictor.label_source = mean needs normalize_advantage_per_mini_batch off (the "
                "mean-acting robots' zero advantages are taken out of the whole-rollout normalisation)"
            )
        self.mean_actors = None if mask is None else mask.to(self.device)

    def act(self, obs: TensorDict) -> torch.Tensor:
        """rsl-rl's sampled actions, except for :attr:`mean_actors`, which take the mean (with its log-probability:
        the transition records what ran)."""
        actions = super().act(obs)
        if self.mean_actors is None:
            return actions
        t = self.transition
        t.actions = torch.where(self.mean_actors[:, None], self.actor.output_mean.detach(), actions)
        t.actions_log_prob = self.actor.get_output_log_prob(t.actions).detach()
        return t.actions

    def compute_returns(self, obs: TensorDict) -> None:
        """rsl-rl's returns and advantages; the :attr:`mean_actors`' transitions get advantage 0 and return = value,
        and the others' advantages are normalised among themselves."""
        super().compute_returns(obs)
        if self.mean_actors is None:
            return
        st, mean, keep = self.storage, self.mean_actors, ~self.mean_actors
        adv = (st.returns - st.values)[:, keep]  # rsl-rl's normalisation counted the mean actors: redone without
        st.advantages = torch.zeros_like(st.values)
        st.advantages[:, keep] = (adv - adv.mean()) / (adv.std() + 1e-8)
        st.returns[:, mean] = st.values[:, mean]

    def set_iteration(self, iteration: int) -> None:
        """Start (or resume) counting PPO iterations at ``iteration``."""
        self.iteration = int(iteration)
        for learner in self.learners:
            learner.set_iteration(self.iteration)

    def update(self) -> dict[str, float]:
        """PPO's update, then each extension's fit; returns PPO's mean losses and the extensions' losses."""
        before = torch.get_num_threads()
        if self.update_threads:
            torch.set_num_threads(self.update_threads)
        try:
            loss_dict = super().update()
            if self.kl_per_update:
                self.adapt_learning_rate()
                loss_dict["kl"] = self.update_kl
            loss_dict.update(self.fit_extensions())
        finally:
            torch.set_num_threads(before)
        return loss_dict

    def adapt_learning_rate(self) -> None:
        """rsl-rl's adaptive rule (:func:`kl_rule`) applied once, to the KL of the updated policy (the one that
        collects the next rollout: its normaliser moved too) against the one that collected the rollout, over all
        the rollout's transitions. The storage still holds the rollout: rsl-rl's ``clear`` only rewinds its
        cursor."""
        st = self.storage
        obs = st.observations.flatten(0, 1)
        old = tuple(p.flatten(0, 1) for p in st.distribution_params)
        dist = self.actor.distribution
        with torch.inference_mode():
            dist.update(self.actor(obs))  # the Gaussian's deterministic output is the MLP's: no sample drawn
            kl = self.actor.get_kl_divergence(old, dist.params).mean()
            if self.is_multi_gpu:
                torch.distributed.all_reduce(kl, op=torch.distributed.ReduceOp.SUM)
                kl /= self.gpu_world_size
        self.update_kl = float(kl)
        self.learning_rate = kl_rule(self.learning_rate, self.update_kl, self.desired_kl)
        for group in self.optimizer.param_groups:
            group["lr"] = self.learning_rate

    def fit_extensions(self) -> dict[str, float]:
        """Fit every extension on the rollout just collected, average it across ranks, advance the schedules."""
        out: dict[str, float] = {}
        for learner in self.learners:
            out.update(learner.fit())
            if self.is_multi_gpu:
                for module in learner.modules():
                    sync_module(module, "average")
        self.set_iteration(self.iteration + 1)
        self.aux_losses = out
        return out

    def broadcast_parameters(self) -> None:
        """rsl-rl's broadcast of actor and critic from rank 0, and of the extensions' networks."""
        super().broadcast_parameters()
        for learner in self.learners:
            for module in learner.modules():
                sync_module(module, "broadcast")

    def save(self) -> dict:
        saved = super().save()
        for learner in self.learners:
            saved.update(learner.state_dict())
        return saved

    def load(self, loaded_dict: dict, load_cfg: dict | None, strict: bool) -> bool:
        """rsl-rl's load, then the extensions' (``load_cfg`` keys ``estimator`` and ``gait_selector``; ``rng``
        restores the gait selector's random stream). Checkpoints of format 1 kept the extensions in ``infos``."""
        if load_cfg is None:
            load_cfg = {
                "actor": True,
                "critic": True,
                "optimizer": True,
                "iteration": True,
                "rnd": True,
                "estimator": True,
                "gait_selector": True,
                "reward_ramp": True,
                "rng": True,
            }
        infos = loaded_dict.get("infos") or {}
        saved = {k: loaded_dict[k] if k in loaded_dict else infos.get(old) for k, old in LEGACY_KEYS.items()}
        saved = {k: v for k, v in saved.items() if v is not None}
        for learner in self.learners:  # entries added after format 1 (the gated reward ramp's)
            if (key := f"{learner.key}_state_dict") in loaded_dict:
                saved.setdefault(key, loaded_dict[key])
        load_iteration = super().load(loaded_dict, load_cfg, strict)
        for learner in self.learners:
            if load_cfg.get(learner.key):
                learner.load_state_dict(saved, strict, bool(load_cfg.get("rng")))
        return load_iteration


class KeptMeanActorsPPO(WqPPO):
    """The control of ``--env.predictor.label-source mean`` (``--train.algorithm-class
    wqwarp.rl.algorithm:KeptMeanActorsPPO``): the mean-acting robots still act with the mean and alone label the
    predictor, but their transitions train PPO like the others' (rsl-rl's returns and advantages for every robot).
    Biased, since a mean is not a sample of the Gaussian: a diagnostic that separates the option's labels from its
    exclusion of those robots (docs/studies/omnidirectional), not a training choice."""

    def compute_returns(self, obs: TensorDict) -> None:
        PPO.compute_returns(self, obs)


def resolve_algorithm_class(name: str) -> type:
    """The class ``"module:Class"`` names (imported: torch and rsl-rl come with it); ValueError naming
    ``TrainConfig.algorithm_class`` unless it is WqPPO or a subclass of it."""
    owner = "TrainConfig.algorithm_class"
    try:
        cls = resolve_callable(name)  # how rsl-rl's runner reads algorithm.class_name
    except (ImportError, AttributeError, ValueError) as e:
        raise ValueError(f"{owner} {name!r} does not import: {e}") from None
    require(isinstance(cls, type) and issubclass(cls, WqPPO), owner, f"must name WqPPO or a subclass, got {name!r}")
    return cls
