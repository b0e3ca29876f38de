"""Open loop in physics: the legs track the nominal gait with PD, the wheels its nominal speeds; no policy."""

from __future__ import annotations

import numpy as np
import pytest
import warp as wp

from wqwarp.control.nominal import NominalGait
from wqwarp.sim.config import SimConfig
from wqwarp.sim.simulator import Simulator


def _run_open_loop(gait: str, command, seconds: float, n: int = 2, device: str = "cpu"):
    sim = Simulator(SimConfig(num_envs=n, device=device))
    ng = NominalGait(n, device)
    ng.reset(np.arange(n), ng.gait_ids(gait))
    ng.command.assign(np.tile(np.asarray(command, np.float32), (n, 1)))
    trunk_hits, z, swing_seen = 0, [], np.zeros(4, bool)
    for _ in range(int(round(seconds / sim.policy_dt))):
        ng.step(sim.actuated_q[:, :12], sim.wheel_contact, sim.policy_dt)
        wp.copy(sim.leg_q_target, ng.leg_joint_target)
        wp.copy(sim.wheel_qd_target, ng.wheel_velocity)
        sim.step()
        trunk_hits += int(sim.body_collision.numpy()[:, 0].sum())
        z.append(sim.joint_q.numpy()[:, 2].copy())
        swing_seen |= (ng.swing_psi.numpy() >= 0).any(0)
    return sim, trunk_hits, np.asarray(z), swing_seen


def test_trotting_in_place_for_ten_seconds_keeps_the_trunk_off_the_ground(device):
    sim, trunk_hits, z, swing_seen = _run_open_loop("trotting", (0.0, 0.0, 0.0), 10.0, device=device)
    assert swing_seen.all()  # every leg did swing
    assert trunk_hits == 0
    assert np.all(np.isfinite(z)) and z.min() > 0.15


def test_driving_gait_moves_the_base_forward(device):
    sim, trunk_hits, z, _ = _run_open_loop("driving", (0.5, 0.0, 0.0), 3.0, device=device)
    x = sim.joint_q.numpy()[:, 0]
    assert trunk_hits == 0
    assert np.all(x > 1.0), x  # ~1.4 m expected at 0.5 m/s after spin-up
    vx = sim.joint_qd.numpy()[:, 0]
    assert vx == pytest.approx(np.full_like(vx, 0.5), rel=0.15)


def test_walking_gait_stands_up(device):
    _, trunk_hits, z, swing_seen = _run_open_loop("walking", (0.0, 0.0, 0.0), 4.0, device=device)
    assert swing_seen.all() and trunk_hits == 0 and z.min() > 0.15
