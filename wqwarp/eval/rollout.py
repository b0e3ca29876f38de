"""How evaluation drives an environment: :func:`start_rollout` prepares and resets it for one rollout, and
:func:`evaluation_session` gives every setting a protocol changes back afterwards (so protocols run back to back on
one env give what each gives on a fresh one)."""

from __future__ import annotations

import contextlib
from collections.abc import Iterator

import numpy as np
import torch
import warp as wp


def base_velocity(env) -> torch.Tensor:
    """(N, 3) measured (v_x, v_y, w_z) of the base in its own frame [m/s, rad/s]."""
    b = env.base_state()
    return torch.stack([b["lin_vel"][:, 0], b["lin_vel"][:, 1], b["ang_vel"][:, 2]], 1)


def start_rollout(env, commands: torch.Tensor, seconds: float):
    """Prepare ``env`` for a ``seconds``-long evaluation rollout and reset it: no time-outs within it, no random
    pushes (the protocol applies its own), ``commands`` (N, 3) held across resets, nothing learning. Returns the
    first observations. Inside :func:`evaluation_session` all of this is undone when the session ends."""
    env.collect_training_data = False
    env.max_episode_length = int(np.ceil((seconds + 1.0) / env.dt))
    env.push_interval_steps = 0
    env.hold_commands(commands)
    return env.reset()


def _clone(t: torch.Tensor | None) -> torch.Tensor | None:
    return None if t is None else t.clone()


@contextlib.contextmanager
def evaluation_session(env) -> Iterator[None]:
    """Run a protocol on ``env`` and leave it as it was found: learning flag, episode length, push schedule, held
    commands, forced gait, requested gaits, the gait-switch counter's last running gaits, phase residuals, step
    counter and the random generators are restored on exit (the robots' physical state is not: every rollout starts
    with :func:`start_rollout`, a reset)."""
    saved = {
        "collect": env.collect_training_data,
        "max_episode_length": env.max_episode_length,
        "push_interval_steps": env.push_interval_steps,
        "common_step_counter": env.common_step_counter,
        "held": _clone(env.held_commands),
        "commands": env.commands.clone(),
        "rng": env.gen.get_state(),
        "selector": env.gait_selector.snapshot(),  # forced gait, switch memory, its random stream
        "gait_id": None if env.nominal is None else wp.to_torch(env.nominal.gait_id).clone(),
        # the phase residual of the last action: a reset keeps it, and the first observation shows it
        "phase_residual": None if env.nominal is None else wp.to_torch(env.nominal.phase_residual).clone(),
    }
    try:
        yield
    finally:
        env.collect_training_data = saved["collect"]
        env.max_episode_length = saved["max_episode_length"]
        env.push_interval_steps = saved["push_interval_steps"]
        env.common_step_counter = saved["common_step_counter"]
        env.hold_commands(saved["held"])
        env.commands[:] = saved["commands"]
        env.gen.set_state(saved["rng"])
        env.gait_selector.restore(saved["selector"])
        if env.nominal is not None:
            wp.to_torch(env.nominal.gait_id)[:] = saved["gait_id"]
            wp.to_torch(env.nominal.phase_residual)[:] = saved["phase_residual"]
