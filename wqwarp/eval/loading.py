"""Load a trained checkpoint into an environment for evaluation, rollouts and export.

The environment is built from the configuration the checkpoint records (``infos['env_cfg']``, read whole by
``wqwarp.rl.config.from_dict``), never from a preset's today defaults; evaluation changes only what
:func:`evaluation_config` names, before the env is built.
"""

from __future__ import annotations

import contextlib
import copy
import io
import math
import os
import sys
from dataclasses import dataclass

import torch

from wqwarp.rl.config import EnvConfig, TrainConfig, env_config_from_dict, make_preset
from wqwarp.rl.env import WheeledGo1Env
from wqwarp.robot.constants import AUTHORS_GROUND_FRICTION


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
    (``wqwarp.rl.config.from_dict``); ValueError if the file records none or one this version cannot read."""
    try:
        ckpt = torch.load(path, map_location="cpu", weights_only=False)
    except Exception as e:  # noqa: BLE001 - pickle, zip and EOF errors all mean the same to the user
        raise ValueError(f"{path} is not a readable checkpoint ({type(e).__name__}: {e})") from None
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


PHYSICS = {
    "train": {},
    "dt0.001": {"dt": 0.001},
    "authors": {"joint_model": "authors", "friction": AUTHORS_GROUND_FRICTION},
    "authors_dt0.001": {"dt": 0.001, "joint_model": "authors", "friction": AUTHORS_GROUND_FRICTION},
}
"""Physics configurations for sim-to-sim evaluation -> their overrides of the trained one. ``train``: as trained
(no randomisation: every contact at ``domain_rand.nominal_friction``); ``dt0.001``: the paper's physics step, 0.001 s
x 20 per policy step; ``authors``: the authors' MuJoCo robot's joint damping, armature and friction loss
(``SimConfig.joint_model``) and their ground friction 0.6; ``authors_dt0.001``: both."""


def evaluation_config(
    trained: EnvConfig,
    num_envs: int,
    device: str = "cpu",
    dt: float | None = None,
    domain_randomisation: bool = False,
    evaluation_selection: str | None = None,
    physics: str = "train",
    seed: int | None = None,
) -> EnvConfig:
    """A new config for evaluation from a checkpoint's ``trained`` one, with these named overrides only: robot count,
    device, domain randomisation and pushes (off by default; the protocol applies its own pushes), the physics step
    ``dt`` [s] (the 50 Hz policy step is kept: decimation = policy step / dt), the predictive selection outside
    training (``argmin`` or ``sample``), a :data:`PHYSICS` configuration (its dt yields to an explicit ``dt``) and the
    env's random ``seed`` (spawn yaws, pushes, sampled gaits). ``trained`` is not modified."""
    if physics not in PHYSICS:
        raise ValueError(f"unknown physics {physics!r}; choose from {', '.join(PHYSICS)}")
    over = PHYSICS[physics]
    dt = dt if dt is not None else over.get("dt")
    cfg = copy.deepcopy(trained)
    cfg.sim.num_envs = num_envs
    cfg.sim.device = device
    cfg.domain_rand.enabled = domain_randomisation
    cfg.seed = cfg.seed if seed is None else int(seed)
    cfg.sim.joint_model = over.get("joint_model", cfg.sim.joint_model)
    cfg.domain_rand.nominal_friction = over.get("friction", cfg.domain_rand.nominal_friction)
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


def _preset_differences(preset: str, cfg: EnvConfig) -> list[str]:
    """The behaviour settings that tell the paper's methods apart, where ``cfg`` differs from ``preset``."""
    ref = make_preset(preset)
    keys = (("gait.selection", ref.gait.selection, cfg.gait.selection),
            ("gait.fixed_gait", ref.gait.fixed_gait, cfg.gait.fixed_gait),
            ("action.use_nominal_legs", ref.action.use_nominal_legs, cfg.action.use_nominal_legs),
            ("action.use_nominal_wheels", ref.action.use_nominal_wheels, cfg.action.use_nominal_wheels))  # fmt: skip
    return [f"{k} {mine!r} (preset {preset}: {theirs!r})" for k, theirs, mine in keys if theirs != mine]


def infer_preset(cfg: EnvConfig) -> str | None:
    """The method (preset name) a configuration was trained as, from its behaviour settings; None if none fits."""
    from wqwarp.rl.config import PRESETS

    hits = [p for p in PRESETS if not _preset_differences(p, cfg)]
    return hits[0] if len(hits) == 1 else None


def _check_preset(preset: str, cfg: EnvConfig, path: str) -> None:
    """A preset named on the command line must be the method the checkpoint was trained as."""
    diff = _preset_differences(preset, cfg)
    if diff:
        raise ValueError(f"{path} was not trained as preset {preset!r}: {', '.join(diff)}")


def make_policy_runner(checkpoint: str, preset: str | None, num_envs: int, device: str = "cpu",
                       cfg: EnvConfig | None = None, dt: float | None = None,
                       evaluation_selection: str | None = None, physics: str = "train",
                       seed: int | None = None) -> PolicyRunner:  # fmt: skip
    """Build the environment from the configuration stored in ``checkpoint`` (with :func:`evaluation_config`'s named
    overrides; ``cfg`` replaces it entirely) and load the policy, estimator and gait selector. ``preset`` is the
    label of the results; if given it must match how the checkpoint was trained. Raises ValueError for a missing
    file, a checkpoint without a readable configuration, another observation/action layout, a wrong preset, a dt
    that does not divide the policy step, or an unknown ``physics`` (:data:`PHYSICS`)."""
    from wqwarp.rl.runner import WqRunner

    if not os.path.isfile(checkpoint):
        raise ValueError(f"no such checkpoint: {checkpoint}")
    recorded = checkpoint_preset(checkpoint)
    if cfg is None:
        trained = checkpoint_env_config(checkpoint)
        if preset is not None:
            _check_preset(preset, trained, checkpoint)
        recorded = recorded or infer_preset(trained)
        cfg = evaluation_config(
            trained, num_envs, device, dt=dt, evaluation_selection=evaluation_selection, physics=physics, seed=seed
        )
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


def parse_segments(text: str) -> list[tuple[tuple[float, float, float], float]]:
    """``"vx,vy,wz:s;..."`` -> [((vx, vy, wz), seconds), ...]; ValueError naming the bad segment."""
    out = []
    for part in [p.strip() for p in text.split(";") if p.strip()]:
        try:
            cmd, sec = part.split(":")
            v = tuple(float(x) for x in cmd.split(","))
            s = float(sec)
        except ValueError:
            raise ValueError(f"bad segment {part!r}: expected 'vx,vy,wz:seconds'") from None
        if len(v) != 3 or not all(math.isfinite(x) for x in (*v, s)) or s <= 0:
            raise ValueError(f"bad segment {part!r}: expected three finite velocities and seconds > 0")
        out.append((v, s))
    if not out:
        raise ValueError("no segments given")
    return out
