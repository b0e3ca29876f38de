"""Helpers shared by the tests (imported as ``helpers``: pytest puts ``tests/`` on the path)."""

from __future__ import annotations

import contextlib
import io


def quiet_runner(cfg, steps_per_env: int = 24, log_dir: str | None = None, seed: int | None = None):
    """A ``WqRunner`` on a fresh env of the config ``cfg``, with rsl-rl's printout of the networks silenced. With
    ``seed``: ``cfg.seed = seed`` and ``torch.manual_seed(seed)`` before the env is built, as ``train/ppo_newton.py``
    does."""
    import torch

    from wqwarp.rl.config import TrainConfig
    from wqwarp.rl.env import WheeledGo1Env
    from wqwarp.rl.runner import WqRunner

    if seed is not None:
        cfg.seed = seed
        torch.manual_seed(seed)
    env = WheeledGo1Env(cfg)
    with contextlib.redirect_stdout(io.StringIO()):
        return WqRunner(env, TrainConfig(num_steps_per_env=steps_per_env).rsl_rl_dict(), log_dir=log_dir,
                        device="cpu")  # fmt: skip


def preset_runner(preset: str, num_envs: int, seed: int, steps_per_env: int = 24):
    """:func:`quiet_runner` of preset ``preset`` with ``num_envs`` robots and seed ``seed``."""
    from wqwarp.rl.presets import make_preset

    cfg = make_preset(preset)
    cfg.sim.num_envs = num_envs
    return quiet_runner(cfg, steps_per_env, seed=seed)


def first_iteration(preset: str, num_envs: int, seed: int, steps_per_env: int = 8):
    """A runner of ``preset`` after one training iteration (rsl-rl's printout silenced)."""
    runner = preset_runner(preset, num_envs, seed, steps_per_env)
    with contextlib.redirect_stdout(io.StringIO()):
        runner.learn(1)
    return runner
