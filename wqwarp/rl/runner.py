"""rsl-rl's OnPolicyRunner with the paper's auxiliary learners, and export of the onboard policy.

:class:`WqRunner` adds to rsl-rl's loop, without changing it: while :meth:`WqRunner.learn` runs, the env collects
training data (``WheeledGo1Env.collect_training_data``); after each PPO update the runner fits the state estimator
and the gait selector's power predictor on the data of that rollout (never inside ``VecEnv.step``), keeps them
identical across ranks under torchrun, moves the temperature schedule, and writes the ``Gait/*`` and
``Predictor/*`` scalars. Checkpoints hold the estimator, the gait selector (predictor, its optimizer, the schedule
position), the observation layout and the env config. :func:`export_onboard_policy` writes what the robot runs.
"""

from __future__ import annotations

import copy
import json
import os

import torch
from rsl_rl.runners import OnPolicyRunner
from torch import nn

from wqwarp import __version__
from wqwarp.rl.config import to_dict
from wqwarp.rl.env import WheeledGo1Env, observation_layout
from wqwarp.robot.constants import ACTUATED_JOINT_NAMES

CHECKPOINT_FORMAT = 1


def _sync_module(module: nn.Module, op: str) -> None:
    """Under torch.distributed: ``broadcast`` rank 0's parameters and buffers, or ``average`` them across ranks."""
    import torch.distributed as dist

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


class WqRunner(OnPolicyRunner):
    """OnPolicyRunner with the estimator and power predictor fitted after each PPO update (module docstring)."""

    env: WheeledGo1Env

    def __init__(self, env: WheeledGo1Env, train_cfg: dict, log_dir: str | None = None, device: str = "cpu"):
        super().__init__(env, train_cfg, log_dir=log_dir, device=device)
        self._aux_iteration = 0
        self.last_aux: dict[str, float] = {}
        """Losses of the last auxiliary fit (estimator, predictor)."""
        self.last_gait_scalars: dict[str, float] = {}
        """``Gait/*`` and ``Predictor/*`` scalars of the last iteration (also on the console)."""
        self.update_threads: int | None = None
        """Torch intra-op threads during the PPO update and the auxiliary fits (None: leave torch's setting);
        collection keeps torch's setting (``wqwarp.utils.threads``: the physics threads run then)."""
        ppo_update = self.alg.update

        def update(*args, **kwargs):
            before = torch.get_num_threads()
            if self.update_threads:
                torch.set_num_threads(self.update_threads)
            try:
                loss_dict = ppo_update(*args, **kwargs)
                loss_dict.update(self.fit_auxiliary())
            finally:
                torch.set_num_threads(before)
            return loss_dict

        self.alg.update = update
        log = self.logger.log

        def log_with_gait(**kw):
            self.last_gait_scalars = self.env.gait_selector.log_scalars()
            if self.logger.writer is not None:
                for k, v in self.last_gait_scalars.items():
                    self.logger.writer.add_scalar(k, v, kw["it"])
            return log(**kw)

        self.logger.log = log_with_gait

    def _configure_multi_gpu(self) -> None:
        """rsl-rl's multi-GPU set-up, and the same on CPU: under torchrun with ``device="cpu"`` every rank joins a
        ``gloo`` process group (rsl-rl itself requires ``cuda:<LOCAL_RANK>`` and NCCL); PPO then averages gradients
        across ranks exactly as on GPUs."""
        world = int(os.getenv("WORLD_SIZE", "1"))
        if world <= 1 or str(self.device) != "cpu":
            super()._configure_multi_gpu()
            return
        import torch.distributed as dist

        self.gpu_world_size = world
        self.is_distributed = True
        self.gpu_local_rank = int(os.getenv("LOCAL_RANK", "0"))
        self.gpu_global_rank = int(os.getenv("RANK", "0"))
        self.cfg["multi_gpu"] = {"global_rank": self.gpu_global_rank, "local_rank": self.gpu_local_rank,
                                 "world_size": world}  # fmt: skip
        if not dist.is_initialized():
            dist.init_process_group(backend="gloo", rank=self.gpu_global_rank, world_size=world)

    def ranks_in_sync(self) -> dict[str, float]:
        """Under torch.distributed: the largest parameter difference between this rank and rank 0 of each network
        (actor, critic, estimator, power predictor), taken over all ranks; 0 when all ranks hold the same
        networks. ``{}`` outside torch.distributed."""
        import torch.distributed as dist

        if not (self.is_distributed and dist.is_initialized()):
            return {}
        nets = {"actor": self.alg.actor, "critic": self.alg.critic, "estimator": self.env.estimator}
        if hasattr(self.env.gait_selector, "predictor"):
            nets["predictor"] = self.env.gait_selector.predictor
        out = {}
        for name, net in nets.items():
            flat = torch.cat([t.detach().reshape(-1).float() for t in list(net.parameters()) + list(net.buffers())
                              if t.is_floating_point()])  # fmt: skip
            ref = flat.clone()
            dist.broadcast(ref, src=0)
            diff = (flat - ref).abs().max().reshape(1)
            dist.all_reduce(diff, op=dist.ReduceOp.MAX)
            out[name] = float(diff)
        return out

    def fit_auxiliary(self) -> dict[str, float]:
        """Fit the state estimator and the power predictor on the rollout just collected; keep them identical
        across ranks; advance the temperature schedule to the next iteration. Returns their losses."""
        env = self.env
        out = {"estimator": env.estimator_trainer.fit()}
        pred = env.gait_selector.fit()
        if "loss" in pred:
            out["predictor"] = pred["loss"]
        if self.is_distributed:
            _sync_module(env.estimator, "average")
            if hasattr(env.gait_selector, "predictor"):
                _sync_module(env.gait_selector.predictor, "average")
        self._aux_iteration += 1
        env.gait_selector.set_iteration(self._aux_iteration)
        self.last_aux = out
        return out

    def learn(self, num_learning_iterations: int, init_at_random_ep_len: bool = False) -> None:
        """rsl-rl's learning loop with the env collecting training data for the auxiliary learners."""
        env = self.env
        self._aux_iteration = self.current_learning_iteration
        env.gait_selector.set_iteration(self._aux_iteration)
        if self.is_distributed:
            _sync_module(env.estimator, "broadcast")
            if hasattr(env.gait_selector, "predictor"):
                _sync_module(env.gait_selector.predictor, "broadcast")
        env.collect_training_data = True
        try:
            super().learn(num_learning_iterations, init_at_random_ep_len)
        finally:
            env.collect_training_data = False

    def _env_infos(self) -> dict:
        env = self.env
        return {
            "format": CHECKPOINT_FORMAT,
            "wqwarp_version": __version__,
            "estimator": env.estimator.state_dict(),
            "estimator_optimizer": env.estimator_trainer.optimizer.state_dict(),
            "gait_selector": env.gait_selector.state_dict(),
            "obs_layout": env.obs_layout,
            "num_actions": env.num_actions,
            "env_cfg": to_dict(env.cfg),
            "rng": {"torch": torch.get_rng_state(), "env": env.gen.get_state(),
                    **({"cuda": torch.cuda.get_rng_state(env.device)} if env.device.startswith("cuda") else {})},
        }  # fmt: skip

    def save(self, path: str, infos: dict | None = None) -> None:
        """Save atomically (temporary file, then rename): a crash never leaves a truncated checkpoint."""
        merged = self._env_infos()
        merged.update(infos or {})
        tmp = path + ".tmp"
        super().save(tmp, merged)
        os.replace(tmp, path)

    def load(self, path: str, load_cfg: dict | None = None, strict: bool = True, map_location: str | None = None,
             restore_rng: bool = False):  # fmt: skip
        """Load a checkpoint written by :meth:`save`. ``restore_rng`` (resuming a training run) also restores the
        random streams (torch's, the env's and the gait selector's generators) where they stood at the checkpoint
        instead of restarting them from the seed (the robots themselves restart: their states are not saved);
        evaluation leaves it off, so that its own seed decides commands, pushes and resets."""
        try:
            ckpt = torch.load(path, weights_only=False, map_location=map_location or self.device)
        except Exception as e:  # noqa: BLE001 - a truncated or foreign file raises many types
            detail = " ".join(str(e).split())[:200]
            raise ValueError(f"{path} is not a readable checkpoint ({type(e).__name__}: {detail})") from e
        if not isinstance(ckpt, dict):
            raise ValueError(f"{path} is not a wqwarp checkpoint (holds a {type(ckpt).__name__})")
        infos = ckpt.get("infos") or {}
        check_compatible(infos, self.env, path)
        infos = super().load(path, load_cfg, strict, map_location or self.device)
        self.env.estimator.load_state_dict(infos["estimator"])
        if "estimator_optimizer" in infos:
            self.env.estimator_trainer.optimizer.load_state_dict(infos["estimator_optimizer"])
        if "gait_selector" in infos:
            state = infos["gait_selector"]
            if not restore_rng:
                state = {k: v for k, v in state.items() if k != "rng"}
            self.env.gait_selector.load_state_dict(state)
        elif self.env.gait_selector.name == "predictive":
            raise ValueError(f"{path} holds no power predictor; it cannot drive the predictive gait selection")
        rng = infos.get("rng") if restore_rng else None
        selector_gen = getattr(self.env.gait_selector, "gen", None) if rng else None
        sel_rng = selector_gen.get_state() if selector_gen is not None else None  # as loaded, before the refresh
        self.env.refresh_after_load()
        if rng:  # after the refresh: the streams continue exactly where the checkpoint left them
            torch.set_rng_state(rng["torch"].cpu())
            self.env.gen.set_state(rng["env"].cpu())
            if sel_rng is not None:
                selector_gen.set_state(sel_rng)
            if "cuda" in rng and self.env.device.startswith("cuda"):
                torch.cuda.set_rng_state(rng["cuda"].cpu(), self.env.device)
        return infos


def check_compatible(infos: dict, env: WheeledGo1Env, path: str) -> None:
    """Raise ValueError if a checkpoint was trained with another observation or action layout."""
    layout = [tuple(x) for x in infos.get("obs_layout", [])]
    if not layout or infos.get("format") != CHECKPOINT_FORMAT:
        raise ValueError(f"{path} is not a wqwarp checkpoint (no observation layout recorded)")
    if layout != [tuple(x) for x in env.obs_layout] or infos.get("num_actions") != env.num_actions:
        raise ValueError(f"{path} was trained with another observation/action layout ({infos.get('num_actions')} "
                         f"actions, {sum(k for _, k in layout)} observations) than this preset "
                         f"({env.num_actions} actions, {env.num_obs} observations)")  # fmt: skip


class OnboardPolicy(nn.Module):
    """Everything the robot runs at 50 Hz: proprioceptive history (B, H, D) -> estimator z_t -> o_t -> actor.

    The newest history row is o_t without z_t (``wqwarp.rl.env.observation_layout`` minus ``estimate``), unnormalised
    and scaled exactly as in training; z_t is inserted before the command.
    """

    def __init__(self, actor: nn.Module, estimator: nn.Module, split: int, z_scale: torch.Tensor):
        super().__init__()
        self.actor = actor
        self.estimator = estimator
        self.split = split
        self.register_buffer("z_scale", z_scale)

    def observation(self, history: torch.Tensor) -> torch.Tensor:
        """o_t (B, D + 3) from the history: the newest row with z_t inserted."""
        z = self.estimator(history.reshape(history.shape[0], -1)) * self.z_scale
        latest = history[:, -1]
        return torch.cat([latest[:, : self.split], z, latest[:, self.split :]], dim=1)

    def forward(self, history: torch.Tensor) -> torch.Tensor:
        return self.actor(self.observation(history))


class OnboardPolicyWithPredictor(OnboardPolicy):
    """:class:`OnboardPolicy` plus the power predictor: history -> (actions (B, A), predicted p_cost per gait (B, G)
    [W]). The robot selects argmin over the predicted powers once per decision interval (see ``policy.json``)."""

    def __init__(self, actor: nn.Module, estimator: nn.Module, split: int, z_scale: torch.Tensor,
                 predictor: nn.Module):  # fmt: skip
        super().__init__(actor, estimator, split, z_scale)
        self.predictor = predictor

    def forward(self, history: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:  # type: ignore[override]
        obs = self.observation(history)
        return self.actor(obs), self.predictor(obs)


def export_onboard_policy(runner: WqRunner, out_dir: str) -> dict[str, str]:
    """Write ``policy.pt`` (TorchScript), ``policy.onnx`` and ``policy.json`` (layout, scales, gait selection rule)
    to ``out_dir``. With predictive gait selection the module also returns each gait's predicted power."""
    from wqwarp.control.gaits import GAIT_NAMES

    env = runner.env
    os.makedirs(out_dir, exist_ok=True)
    actor = runner.alg.get_policy().as_jit().to("cpu").eval()
    estimator = copy.deepcopy(env.estimator).to("cpu").eval()
    split = 3 + 3 + 12 + 16 + 18
    s = env.cfg.obs.lin_vel_scale
    z_scale = torch.tensor([s, s, 1.0])
    selector = env.gait_selector
    predictive = selector.name == "predictive"
    if predictive:
        predictor = copy.deepcopy(selector.predictor).to("cpu").eval()
        model = OnboardPolicyWithPredictor(actor, estimator, split, z_scale, predictor).eval()
        outputs = ["actions", "predicted_power"]
    else:
        model = OnboardPolicy(actor, estimator, split, z_scale).eval()
        outputs = ["actions"]
    H, D = env.cfg.obs.history_length, env.proprio_dim
    dummy = torch.zeros(1, H, D)
    paths = {}
    scripted = torch.jit.script(model)
    paths["torchscript"] = os.path.join(out_dir, "policy.pt")
    scripted.save(paths["torchscript"] + ".tmp")
    os.replace(paths["torchscript"] + ".tmp", paths["torchscript"])
    paths["onnx"] = os.path.join(out_dir, "policy.onnx")
    batch = {name: {0: "batch"} for name in ["history", *outputs]}  # any batch size (one robot onboard, N in sim)
    torch.onnx.export(model, (dummy,), paths["onnx"] + ".tmp", input_names=["history"], output_names=outputs,
                      dynamic_axes=batch, opset_version=18, dynamo=False)  # fmt: skip
    os.replace(paths["onnx"] + ".tmp", paths["onnx"])
    paths["json"] = os.path.join(out_dir, "policy.json")
    meta = {
        "wqwarp_version": __version__,
        "history_length": H,
        "proprio_dim": D,
        "num_actions": env.num_actions,
        "outputs": outputs,
        "observation_layout_with_estimate": observation_layout(env.num_actions),
        "estimate_inserted_at": split,
        "policy_dt": env.dt,
        "joint_order": list(ACTUATED_JOINT_NAMES),
        "env_cfg": to_dict(env.cfg),
    }
    if predictive:
        p = env.cfg.predictor
        meta["gait_selection"] = {
            "gaits": list(GAIT_NAMES),
            "predicted_power": "mean p_cost = sum |tau| |qd| over the next horizon_s, per gait in 'gaits' order [W]",
            "horizon_s": p.horizon_s,
            "decision_interval_s": p.decision_interval_s,
            "rule": "every decision_interval_s, counted from the first full policy step run in the selected gait, "
            "request gait = argmin(predicted_power) (the paper's softmax(-p/tau) with tau -> 0). A request takes "
            "effect at the first policy step at which no leg of the running gait is in swing; until then the "
            "running gait continues. The gait part of the observation (phase, frequency, DF_swing, nominal wheel "
            "speeds) always describes the running gait.",
        }
    tmp = paths["json"] + ".tmp"
    with open(tmp, "w", encoding="utf-8") as f:
        json.dump(meta, f, indent=2)
    os.replace(tmp, paths["json"])
    return paths
