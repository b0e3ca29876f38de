"""rsl-rl's OnPolicyRunner for the wqwarp env: the algorithm is :class:`wqwarp.rl.algorithm.WqPPO` (PPO with the
state estimator and the power predictor as extensions), the logger :class:`wqwarp.rl.progress.ProgressLogger`.

:class:`WqRunner` adds only what rsl-rl does not do by configuration: torchrun on the CPU (a ``gloo`` process
group), the env collecting training data for the extensions while :meth:`WqRunner.learn` runs, and checkpoints that
also hold the observation layout, the env config and the random streams, written atomically and checked against the
env on load. The onboard policy is exported by ``wqwarp.rl.export``.
"""

from __future__ import annotations

import dataclasses
import os

import numpy as np
import torch
from rsl_rl.runners import OnPolicyRunner

from wqwarp import __version__
from wqwarp.rl.algorithm import WqPPO
from wqwarp.rl.config import to_dict
from wqwarp.rl.env import WheeledGo1Env
from wqwarp.rl.progress import ProgressLogger
from wqwarp.utils.io import atomic_path

CHECKPOINT_FORMAT = 2
"""2: the extensions' state beside the algorithm's (``WqPPO.save``); 1 (still read): in ``infos``."""
READABLE_FORMATS = (1, 2)


class WqRunner(OnPolicyRunner):
    """OnPolicyRunner with the env's training-data collection, CPU torchrun and checkpoint checks (module
    docstring)."""

    env: WheeledGo1Env
    alg: WqPPO
    train_config: dict | None = None
    """The run's ``TrainConfig`` as a dict (``to_dict``), stored in every checkpoint as ``infos['train_cfg']`` when
    set, so that ``--resume`` continues with the PPO settings the run had."""

    def __init__(self, env: WheeledGo1Env, train_cfg: dict, log_dir: str | None = None, device: str = "cpu"):
        super().__init__(env, train_cfg, log_dir=log_dir, device=device)
        if not isinstance(self.alg, WqPPO):
            raise TypeError(
                f"WqRunner needs algorithm.class_name 'wqwarp.rl.algorithm:WqPPO', got {type(self.alg).__name__}"
            )
        self.logger = ProgressLogger(
            log_dir=log_dir,
            cfg=self.cfg,
            env_cfg=self.env.cfg,
            num_envs=self.env.num_envs,
            is_distributed=self.is_distributed,
            gpu_world_size=self.gpu_world_size,
            gpu_global_rank=self.gpu_global_rank,
            device=self.device,
            iteration_log=self.env.gait_selector.log_scalars,
        )

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
        self.cfg["multi_gpu"] = {
            "global_rank": self.gpu_global_rank,
            "local_rank": self.gpu_local_rank,
            "world_size": world,
        }
        if not dist.is_initialized():
            dist.init_process_group(backend="gloo", rank=self.gpu_global_rank, world_size=world)

    def ranks_in_sync(self) -> dict[str, float]:
        """Under torch.distributed: the largest parameter difference between this rank and rank 0 of each network
        (actor, critic, and the extensions': estimator, power predictor), taken over all ranks; 0 when all ranks
        hold the same networks. ``{}`` outside torch.distributed."""
        import torch.distributed as dist

        if not (self.is_distributed and dist.is_initialized()):
            return {}
        nets = {"actor": self.alg.actor, "critic": self.alg.critic}
        for learner in self.alg.learners:
            for module in learner.modules():
                nets["estimator" if learner.key == "estimator" else "predictor"] = module
        out = {}
        for name, net in nets.items():
            flat = torch.cat(
                [
                    t.detach().reshape(-1).float()
                    for t in list(net.parameters()) + list(net.buffers())
                    if t.is_floating_point()
                ]
            )
            ref = flat.clone()
            dist.broadcast(ref, src=0)
            diff = (flat - ref).abs().max().reshape(1)
            dist.all_reduce(diff, op=dist.ReduceOp.MAX)
            out[name] = float(diff)
        return out

    def learn(self, num_learning_iterations: int, init_at_random_ep_len: bool = False) -> None:
        """rsl-rl's learning loop with the env collecting training data for the extensions; the temperature schedule
        starts at the current iteration."""
        self.alg.set_iteration(self.current_learning_iteration)
        self.env.collect_training_data = True
        try:
            super().learn(num_learning_iterations, init_at_random_ep_len)
        finally:
            self.env.collect_training_data = False

    def _env_infos(self) -> dict:
        env = self.env
        return {
            "format": CHECKPOINT_FORMAT,
            "wqwarp_version": __version__,
            "obs_layout": env.obs_layout,
            "num_actions": env.num_actions,
            "env_cfg": to_dict(env.cfg),
            **({"train_cfg": self.train_config} if self.train_config is not None else {}),
            "rng": {
                "torch": torch.get_rng_state(),
                "env": env.gen.get_state(),
                **({"cuda": torch.cuda.get_rng_state(env.device)} if env.device.startswith("cuda") else {}),
            },
        }

    def save(self, path: str, infos: dict | None = None) -> None:
        """rsl-rl's save with :meth:`_env_infos` (plus ``infos``), atomically: a crash never leaves a truncated
        checkpoint."""
        merged = self._env_infos()
        merged.update(infos or {})
        with atomic_path(path) as tmp:
            super().save(tmp, merged)

    def load(
        self,
        path: str,
        load_cfg: dict | None = None,
        strict: bool = True,
        map_location: str | None = None,
        restore_rng: bool = False,
    ):
        """Load a checkpoint written by :meth:`save` after checking it fits the env (:func:`check_compatible`).
        ``restore_rng`` (resuming a training run) also restores the random streams (torch's, the env's and the gait
        selector's generators) where they stood at the checkpoint instead of restarting them from the seed (the
        robots themselves restart: their states are not saved); evaluation leaves it off, so that its own seed
        decides commands, pushes and resets."""
        try:
            ckpt = torch.load(path, weights_only=False, map_location=map_location or self.device)
        except Exception as e:  # noqa: BLE001 - a truncated or foreign file raises many types
            detail = " ".join(str(e).split())[:200]
            raise ValueError(f"{path} is not a readable checkpoint ({type(e).__name__}: {detail})") from e
        if not isinstance(ckpt, dict):
            raise ValueError(f"{path} is not a wqwarp checkpoint (holds a {type(ckpt).__name__})")
        check_compatible(ckpt.get("infos") or {}, self.env, path)
        cfg = {
            "actor": True,
            "critic": True,
            "optimizer": True,
            "iteration": True,
            "rnd": True,
            "estimator": True,
            "gait_selector": True,
            "reward_ramp": True,
            **(load_cfg or {}),
            "rng": restore_rng,
        }
        try:
            infos = super().load(path, cfg, strict, map_location or self.device)
        except ValueError as e:
            raise ValueError(f"{path}: {e}") from e
        rng = infos.get("rng") if restore_rng else None
        selector_gen = self.env.gait_selector.gen if rng else None
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


def gait_differences(saved: dict, current: dict) -> list[str]:
    """``"<field> <saved> in the checkpoint, <current> here"`` for each parameter of one gait that differs."""
    out = []
    for key, value in current.items():
        old = saved.get(key)
        same = (
            (old == value)
            if isinstance(value, str)
            else old is not None
            and bool(np.allclose(np.asarray(old, dtype=float), np.asarray(value, dtype=float), rtol=0.0, atol=1e-9))
        )
        if not same:
            out.append(f"{key} {old} in the checkpoint, {value} here")
    return out


def check_compatible(infos: dict, env: WheeledGo1Env, path: str) -> None:
    """Raise ValueError if a checkpoint was trained with another observation or action layout or gait set."""
    layout = [tuple(x) for x in infos.get("obs_layout", [])]
    if not layout or infos.get("format") not in READABLE_FORMATS:
        raise ValueError(f"{path} is not a wqwarp checkpoint (no observation layout recorded)")
    library = ((infos.get("env_cfg") or {}).get("gait") or {}).get("library")  # recorded since gaits are config
    if library is not None and [g["name"] for g in library] != list(env.gait_names):
        raise ValueError(
            f"{path} was trained with the gaits {[g['name'] for g in library]}, this env runs {list(env.gait_names)}"
        )
    for saved, gait in zip(library or [], env.cfg.gait.library, strict=False):
        if differences := gait_differences(saved, dataclasses.asdict(gait)):
            raise ValueError(
                f"{path} was trained with another {gait.name!r} gait ({'; '.join(differences)}): run "
                "the checkpoint's gait library (a tuned gait: --env.gait.tuned FILE)"
            )
    if layout != [tuple(x) for x in env.obs_layout] or infos.get("num_actions") != env.num_actions:
        raise ValueError(
            f"{path} was trained with another observation/action layout ({infos.get('num_actions')} "
            f"actions, {sum(k for _, k in layout)} observations) than this preset "
            f"({env.num_actions} actions, {env.num_obs} observations)"
        )
