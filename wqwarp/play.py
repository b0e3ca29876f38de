"""Load a trained checkpoint into an environment for evaluation, rollouts and export."""

from __future__ import annotations

import contextlib
import io
import os
from dataclasses import dataclass

import torch

from wqwarp.config import EnvConfig, TrainConfig, make_preset
from wqwarp.env import WheeledGo1Env


@dataclass
class PolicyRunner:
    """An environment and the deterministic policy of a checkpoint (``policy(obs) -> actions``)."""

    env: WheeledGo1Env
    policy: object
    preset: str
    iteration: int


def checkpoint_preset(path: str) -> str | None:
    """The preset recorded next to a checkpoint (``config.json`` of its run), if any."""
    import json

    cfg = os.path.join(os.path.dirname(os.path.abspath(path)), "config.json")
    if os.path.isfile(cfg):
        with open(cfg, encoding="utf-8") as f:
            return json.load(f).get("args", {}).get("preset")
    return None


def make_env_config(preset: str, num_envs: int, device: str, evaluation: bool = True) -> EnvConfig:
    """The preset's config for ``num_envs`` robots; ``evaluation`` turns domain randomisation and pushes off."""
    cfg = make_preset(preset)
    cfg.sim.num_envs = num_envs
    cfg.sim.device = device
    if evaluation:
        cfg.domain_rand.enabled = False
    return cfg


def checkpoint_phase_residual_mode(path: str) -> str:
    """The phase-residual reading a checkpoint was trained with (its saved ``env_cfg``). Checkpoints written before
    the reading became a setting were trained with ``increment``."""
    import torch

    ckpt = torch.load(path, map_location="cpu", weights_only=False)
    infos = ckpt.get("infos") or {} if isinstance(ckpt, dict) else {}
    env_cfg = infos.get("env_cfg", {}) if isinstance(infos, dict) else {}
    return env_cfg.get("action", {}).get("phase_residual_mode", "increment")


def make_policy_runner(checkpoint: str, preset: str | None, num_envs: int, device: str = "cpu",
                       cfg: EnvConfig | None = None, dt: float | None = None) -> PolicyRunner:  # fmt: skip
    """Build the environment of ``preset`` (default: the one recorded with the checkpoint) and load the policy,
    estimator and gait selector of ``checkpoint``. ``dt`` [s] changes the physics step and keeps the 50 Hz policy
    step (decimation = policy step / dt). Raises ValueError for a missing file, another observation/action layout,
    or a dt that does not divide the policy step."""
    from wqwarp.runner import WqRunner

    if not os.path.isfile(checkpoint):
        raise ValueError(f"no such checkpoint: {checkpoint}")
    preset = preset or checkpoint_preset(checkpoint) or "no_predictor"
    if cfg is None:
        cfg = make_env_config(preset, num_envs, device)
        # until the whole configuration round-trips from checkpoints, at least the gait reading must match
        cfg.action.phase_residual_mode = checkpoint_phase_residual_mode(checkpoint)
    if dt is not None:
        policy_dt = cfg.sim.dt * cfg.sim.decimation
        dec = round(policy_dt / dt)
        if dt <= 0 or dec < 1 or abs(dec * dt - policy_dt) > 1e-9:
            raise ValueError(f"dt {dt} s does not divide the policy step {policy_dt} s")
        cfg.sim.dt, cfg.sim.decimation = dt, dec
    env = WheeledGo1Env(cfg)
    env.collect_training_data = False  # playback, evaluation and export: estimator and predictor as saved
    with contextlib.redirect_stdout(io.StringIO()):
        runner = WqRunner(env, TrainConfig().rsl_rl_dict(), log_dir=None, device=env.device)
    runner.load(checkpoint)
    policy = runner.get_inference_policy(device=env.device)
    return PolicyRunner(env=env, policy=policy, preset=preset, iteration=int(runner.current_learning_iteration))


@torch.no_grad()
def act(runner: PolicyRunner, obs) -> torch.Tensor:
    """Deterministic action of the policy for observations ``obs`` (a TensorDict)."""
    return runner.policy(obs)
