"""Velocity commands: random (v_x, v_y, w_z) in the base frame, drawn per robot (``CommandConfig``).

A sample is uniform in the configured ranges; with probability ``single_axis_prob`` only one axis keeps its value
(the axis drawn with odds ``single_axis_weights``, equal by default), with probability ``zero_prob`` the command is
zero (standing still). Every draw comes from the env's generator, in a fixed order, so a seed gives the same
commands."""

from __future__ import annotations

import torch

from wqwarp.rl.config import CommandConfig


def uniform(gen: torch.Generator, rng: tuple[float, float], shape, device) -> torch.Tensor:
    """lo + (hi - lo) U[0, 1) of ``shape`` from ``gen``."""
    lo, hi = rng
    return lo + (hi - lo) * torch.rand(shape, generator=gen, device=device)


def sample_commands(cfg: CommandConfig, k: int, gen: torch.Generator, device) -> torch.Tensor:
    """(k, 3) commands v_x, v_y [m/s], w_z [rad/s] in the base frame."""
    cmd = torch.stack(
        [
            uniform(gen, cfg.vx_range, (k,), device),
            uniform(gen, cfg.vy_range, (k,), device),
            uniform(gen, cfg.wz_range, (k,), device),
        ],
        dim=1,
    )
    u = torch.rand(k, generator=gen, device=device)
    single = u < cfg.single_axis_prob
    w = cfg.single_axis_weights
    if w[0] == w[1] == w[2]:
        axis = torch.randint(0, 3, (k,), generator=gen, device=device)
    elif k == 0:
        axis = torch.zeros(0, dtype=torch.long, device=device)
    else:
        odds = torch.tensor(w, dtype=torch.float32, device=device)
        axis = torch.multinomial(odds.expand(k, 3), 1, replacement=True, generator=gen)[:, 0]
    keep = torch.nn.functional.one_hot(axis, 3).float()
    cmd = torch.where(single[:, None], cmd * keep, cmd)
    zero = (u >= cfg.single_axis_prob) & (u < cfg.single_axis_prob + cfg.zero_prob)
    cmd[zero] = 0.0
    return cmd
