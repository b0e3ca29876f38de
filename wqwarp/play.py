"""Load a trained checkpoint into an environment for evaluation, rollouts and export.

The environment is built from the configuration the checkpoint records (``infos['env_cfg']``, read whole by
``wqwarp.config.from_dict``), never from a preset's today defaults; evaluation changes only what
:func:`evaluation_config` names, before the env is built.
"""

from __future__ import annotations

import contextlib
import copy
import io
import os
import sys
from dataclasses import dataclass

import torch

from wqwarp.config import EnvConfig, TrainConfig, env_config_from_dict, make_preset
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


def checkpoint_env_config(path: str) -> EnvConfig:
    """The environment configuration a checkpoint was trained with (its ``infos['env_cfg']``), read whole
    (``wqwarp.config.from_dict``); ValueError if the file records none or one this version cannot read."""
    ckpt = torch.load(path, map_location="cpu", weights_only=False)
    infos = (ckpt.get("infos") or {}) if isinstance(ckpt, dict) else {}
    if not isinstance(infos, dict) or "env_cfg" not in infos:
        raise ValueError(f"{path} records no environment configuration (not a wqwarp checkpoint, or an old one)")
    migrated: list[str] = []
    try:
        cfg = env_config_from_dict(infos["env_cfg"], migrated)
    except ValueError as e:
        raise ValueError(f"{path}: cannot read its environment configuration: {e}") from None
    for note in migrated:
        print(f"note: {os.path.basename(path)} predates a setting: {note}", file=sys.stderr)
    return cfg


def evaluation_config(
    trained: EnvConfig,
    num_envs: int,
    device: str = "cpu",
    dt: float | None = None,
    domain_randomisation: bool = False,
    evaluation_selection: str | None = None,
) -> EnvConfig:
    """A new config for evaluation from a checkpoint's ``trained`` one, with these named overrides only: robot count,
    device, domain randomisation and pushes (off by default; the protocol applies its own pushes), the physics step
    ``dt`` [s] (the 50 Hz policy step is kept: decimation = policy step / dt) and the predictive selection outside
    training (``argmin`` or ``sample``). ``trained`` is not modified."""
    cfg = copy.deepcopy(trained)
    cfg.sim.num_envs = num_envs
    cfg.sim.device = device
    cfg.domain_rand.enabled = domain_randomisation
    if dt is not None:
        policy_dt = cfg.sim.dt * cfg.sim.decimation
        dec = round(policy_dt / dt) if dt > 0 else 0
        if dt <= 0 or dec < 1 or abs(dec * dt - policy_dt) > 1e-9:
            raise ValueError(f"dt {dt} s does not divide the policy step {policy_dt} s")
        cfg.sim.dt, cfg.sim.decimation = dt, dec
    if evaluation_selection is not None:
        if evaluation_selection not in ("argmin", "sample"):
            raise ValueError(f"evaluation_selection must be argmin or sample, got {evaluation_selection!r}")
        cfg.predictor.evaluation_selection = evaluation_selection
    return cfg


def _check_preset(preset: str, cfg: EnvConfig, path: str) -> None:
    """A preset named on the command line must be the method the checkpoint was trained as."""
    ref = make_preset(preset)
    keys = (("gait.selection", ref.gait.selection, cfg.gait.selection),
            ("action.use_nominal_legs", ref.action.use_nominal_legs, cfg.action.use_nominal_legs),
            ("action.use_nominal_wheels", ref.action.use_nominal_wheels, cfg.action.use_nominal_wheels))  # fmt: skip
    diff = [f"{k} {mine!r} (preset {preset}: {theirs!r})" for k, theirs, mine in keys if theirs != mine]
    if diff:
        raise ValueError(f"{path} was not trained as preset {preset!r}: {', '.join(diff)}")


def make_policy_runner(checkpoint: str, preset: str | None, num_envs: int, device: str = "cpu",
                       cfg: EnvConfig | None = None, dt: float | None = None,
                       evaluation_selection: str | None = None) -> PolicyRunner:  # fmt: skip
    """Build the environment from the configuration stored in ``checkpoint`` (with :func:`evaluation_config`'s named
    overrides; ``cfg`` replaces it entirely) and load the policy, estimator and gait selector. ``preset`` is the
    label of the results; if given it must match how the checkpoint was trained. Raises ValueError for a missing
    file, a checkpoint without a readable configuration, another observation/action layout, a wrong preset, or a
    dt that does not divide the policy step."""
    from wqwarp.runner import WqRunner

    if not os.path.isfile(checkpoint):
        raise ValueError(f"no such checkpoint: {checkpoint}")
    recorded = checkpoint_preset(checkpoint)
    if cfg is None:
        trained = checkpoint_env_config(checkpoint)
        if preset is not None:
            _check_preset(preset, trained, checkpoint)
        cfg = evaluation_config(trained, num_envs, device, dt=dt, evaluation_selection=evaluation_selection)
    preset = preset or recorded or "unknown"
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
