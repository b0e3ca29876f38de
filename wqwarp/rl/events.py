"""Randomisation events of the env (``DomainRandConfig``): per-robot dynamics drawn once at start-up, and pushes.

References:
    Paper, Sec. IV (Evaluation): pushes are random velocity perturbations along the trunk's forward and lateral
    directions, updated every 15 s; its critic observes friction, restitution and disturbances (Sec. III-C). The
    ranges are ours (``DomainRandConfig``).
"""

from __future__ import annotations

import torch

from wqwarp.rl.commands import uniform
from wqwarp.rl.config import DomainRandConfig


def sample_dynamics(dr: DomainRandConfig, n: int, gen: torch.Generator, device) -> dict[str, torch.Tensor]:
    """Per-robot ``friction`` [-], ``restitution`` [-], ``added_mass`` [kg] (n,) and, when randomised,
    ``motor_strength`` (n, 16) [-], drawn in this order; without randomisation the nominal friction, no restitution,
    no added mass and no ``motor_strength`` entry (the simulator's default is kept)."""
    if not dr.enabled:
        zeros = torch.zeros(n, device=device)
        return {
            "friction": torch.full((n,), float(dr.nominal_friction), device=device),
            "restitution": zeros,
            "added_mass": zeros.clone(),
        }
    return {
        "friction": uniform(gen, dr.friction_range, (n,), device),
        "restitution": uniform(gen, dr.restitution_range, (n,), device),
        "added_mass": uniform(gen, dr.added_mass_range, (n,), device),
        "motor_strength": uniform(gen, dr.motor_strength_range, (n, 16), device),
    }


def push_to_world(yaw: torch.Tensor, dv: torch.Tensor) -> torch.Tensor:
    """A velocity impulse (N, 2) along the trunk's x and y axes [m/s] as the world-frame (x, y) change, given the
    trunk's yaw (N,) [rad]: R_z(yaw) dv."""
    c, s = torch.cos(yaw), torch.sin(yaw)
    return torch.stack([c * dv[:, 0] - s * dv[:, 1], s * dv[:, 0] + c * dv[:, 1]], dim=1)
