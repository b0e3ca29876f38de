"""Helpers shared by the tests (imported as ``helpers``: pytest puts ``tests/`` on the path)."""

from __future__ import annotations

import contextlib
import io


def quiet_runner(cfg, steps_per_env: int = 24, log_dir: str | None = None, seed: int | None = None, train=None):
    """A ``WqRunner`` on a fresh env of the config ``cfg``, with rsl-rl's printout of the networks silenced. With
    ``seed``: ``cfg.seed = seed`` and ``torch.manual_seed(seed)`` before the env is built, as ``train/ppo_newton.py``
    does. ``train``: the PPO settings (default ``TrainConfig(num_steps_per_env=steps_per_env)``)."""
    import torch

    from wqwarp.rl.config import TrainConfig
    from wqwarp.rl.env import WheeledGo1Env
    from wqwarp.rl.runner import WqRunner

    if seed is not None:
        cfg.seed = seed
        torch.manual_seed(seed)
    env = WheeledGo1Env(cfg)
    with contextlib.redirect_stdout(io.StringIO()):
        train = train or TrainConfig(num_steps_per_env=steps_per_env)
        return WqRunner(env, train.rsl_rl_dict(), log_dir=log_dir, device="cpu")


def task_runner(task: str, num_envs: int, seed: int, steps_per_env: int = 24, overrides: dict | None = None):
    """:func:`quiet_runner` of task ``task`` (``wqwarp.rl.tasks``: ``ours`` the recipe, ``ours-paper`` the paper's
    method) with ``overrides`` (dotted path -> value) set over it, as ``train/ppo_newton.py`` resolves it, with
    ``num_envs`` robots and seed ``seed``."""
    from wqwarp.rl.tasks import TASKS, set_path

    cfg, train = TASKS[task].make()
    for path, value in (overrides or {}).items():
        set_path({"env": cfg, "train": train}, path, value)
    cfg.sim.num_envs = num_envs
    train.num_steps_per_env = steps_per_env
    return quiet_runner(cfg, steps_per_env, seed=seed, train=train)


def first_iteration(task: str, num_envs: int, seed: int, steps_per_env: int = 8, overrides: dict | None = None):
    """A runner of ``task`` (with ``overrides``) after one training iteration (rsl-rl's printout silenced)."""
    runner = task_runner(task, num_envs, seed, steps_per_env, overrides)
    with contextlib.redirect_stdout(io.StringIO()):
        runner.learn(1)
    return runner
