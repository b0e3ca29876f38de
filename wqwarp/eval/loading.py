"""Load a trained checkpoint into an environment for evaluation, rollouts and export.

The environment is built from the configuration the checkpoint records (``infos['env_cfg']``, read whole by
``wqwarp.rl.config.from_dict``), never from a preset's today defaults; evaluation changes only what
``wqwarp.eval.physics.evaluation_config`` names, before the env is built.
"""

from __future__ import annotations

import contextlib
import io
import json
import os
import sys
from dataclasses import dataclass

import torch

from wqwarp.eval.physics import evaluation_config
from wqwarp.rl.config import EnvConfig, TrainConfig, env_config_from_dict
from wqwarp.rl.env import WheeledGo1Env
from wqwarp.rl.presets import check_preset, infer_preset


@dataclass
class PolicyRunner:
    """An environment and the deterministic policy of a checkpoint (``policy(obs) -> actions``)."""

    env: WheeledGo1Env
    policy: object
    preset: str
    iteration: int


def checkpoint_preset(path: str) -> str | None:
    """The preset (method) recorded next to a checkpoint (``config.json`` of its run: its task's method, or the
    ``--preset`` of a run written before the task registry), if any."""
    from wqwarp.rl.tasks import TASKS

    cfg = os.path.join(os.path.dirname(os.path.abspath(path)), "config.json")
    if os.path.isfile(cfg):
        with open(cfg, encoding="utf-8") as f:
            record = json.load(f)
        if record.get("task") in TASKS:
            return TASKS[record["task"]].method
        return record.get("args", {}).get("preset")
    return None


def checkpoint_infos(path: str) -> dict:
    """A checkpoint's ``infos`` (what ``WqRunner.save`` records beside the networks: ``env_cfg``, ``train_cfg``,
    layout, random streams); ValueError if the file is unreadable or records no environment configuration."""
    try:
        ckpt = torch.load(path, map_location="cpu", weights_only=False)
    except Exception as e:  # noqa: BLE001 - pickle, zip and EOF errors all mean the same to the user
        raise ValueError(f"{path} is not a readable checkpoint ({type(e).__name__}: {e})") from None
    infos = (ckpt.get("infos") or {}) if isinstance(ckpt, dict) else {}
    if not isinstance(infos, dict) or not isinstance(infos.get("env_cfg"), dict):
        raise ValueError(f"{path} records no environment configuration (not a wqwarp checkpoint, or an old one)")
    return infos


def checkpoint_env_config(path: str) -> EnvConfig:
    """The environment configuration a checkpoint was trained with (its ``infos['env_cfg']``), read whole
    (``wqwarp.rl.config.from_dict``); ValueError if the file records none or one this version cannot read."""
    infos = checkpoint_infos(path)
    migrated: list[str] = []
    try:
        cfg = env_config_from_dict(infos["env_cfg"], migrated)
    except ValueError as e:
        raise ValueError(f"{path}: cannot read its environment configuration: {e}") from None
    for note in migrated:
        print(f"note: {os.path.basename(path)} predates a setting: {note}", file=sys.stderr)
    return cfg


def checkpoint_gait_names(path: str) -> tuple[str, ...]:
    """Names of the gait library a checkpoint was trained with, by gait id (to size a batch before the env is
    built); ValueError as :func:`make_policy_runner` for a missing or unreadable checkpoint."""
    if not os.path.isfile(path):
        raise ValueError(f"no such checkpoint: {path}")
    return tuple(g.name for g in checkpoint_env_config(path).gait.library)


def make_policy_runner(
    checkpoint: str,
    preset: str | None,
    num_envs: int,
    device: str = "cpu",
    cfg: EnvConfig | None = None,
    dt: float | None = None,
    evaluation_selection: str | None = None,
    physics: str = "train",
    seed: int | None = None,
    criterion: str | None = None,
    robot: str | None = None,
) -> PolicyRunner:
    """Build the environment from the configuration stored in ``checkpoint`` (with ``evaluation_config``'s named
    overrides; ``cfg`` replaces it entirely) and load the policy, estimator and gait selector. ``preset`` is the
    label of the results; if given it must match how the checkpoint was trained. Raises ValueError for a missing
    file, a checkpoint without a readable configuration, another observation/action layout, a wrong preset, a dt
    that does not divide the policy step, an unknown ``physics`` (``wqwarp.eval.physics.PHYSICS_VARIANTS``), or a
    ``criterion`` (overriding the checkpoint's gait selection rule) that the checkpoint cannot run; ``robot`` is the
    robot description a ``physics`` variant that builds one reads."""
    from wqwarp.rl.runner import WqRunner

    if not os.path.isfile(checkpoint):
        raise ValueError(f"no such checkpoint: {checkpoint}")
    recorded = checkpoint_preset(checkpoint)
    if cfg is None:
        trained = checkpoint_env_config(checkpoint)
        if preset is not None:
            check_preset(preset, trained, checkpoint)
        recorded = recorded or infer_preset(trained)
        cfg = evaluation_config(
            trained,
            num_envs,
            device,
            dt=dt,
            evaluation_selection=evaluation_selection,
            physics=physics,
            seed=seed,
            criterion=criterion,
            robot=robot,
        )
    preset = preset or recorded or "unknown"
    env = WheeledGo1Env(cfg)
    env.collect_training_data = False  # playback, evaluation and export: estimator and predictor as saved
    with contextlib.redirect_stdout(io.StringIO()):
        runner = WqRunner(env, TrainConfig().rsl_rl_dict(), log_dir=None, device=env.device)
    runner.load(checkpoint)
    if criterion is not None:
        sel = env.gait_selector
        if sel.name != "predictive":
            raise ValueError(f"a selection criterion needs a predictive preset, not {preset}")
        if env.cfg.predictor.tracking_head and not sel.tracker_fitted:
            raise ValueError(
                f"criterion {criterion} needs a tracking head; {os.path.basename(checkpoint)} was trained "
                f"with {trained.predictor.criterion} and has none"
            )
    policy = runner.get_inference_policy(device=env.device)
    return PolicyRunner(env=env, policy=policy, preset=preset, iteration=int(runner.current_learning_iteration))
