"""Open loop in physics: the legs track the nominal gait with PD, the wheels its nominal speeds; no policy."""

from __future__ import annotations

import numpy as np
import pytest

from wqwarp.control.driver import OpenLoopDriver
from wqwarp.sim.config import SimConfig
from wqwarp.sim.simulator import Simulator


def _run_open_loop(gait: str, command, seconds: float, n: int = 2, device: str = "cpu"):
    sim = Simulator(SimConfig(num_envs=n, device=device))
    drv = OpenLoopDriver(sim, gait, command)
    trunk_hits, z, swing_seen = 0, [], np.zeros(4, bool)

    def record(k: int, in_window: bool) -> None:
        nonlocal trunk_hits, swing_seen
        trunk_hits += int(sim.body_collision.numpy()[:, 0].sum())
        z.append(sim.joint_q.numpy()[:, 2].copy())
        swing_seen |= (drv.nominal.swing_psi.numpy() >= 0).any(0)

    drv.run(seconds, on_step=record)
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


def test_the_driver_is_the_hand_written_loop_for_each_contact_source():
    """``OpenLoopDriver`` steps exactly the loop it replaces (nominal gait from the measured legs and the sim's or
    all-ground contact flags, targets copied, one sim step), bit for bit; without a sim the gait runs alone from the
    default legs; an unknown contact source is refused."""
    import warp as wp

    from wqwarp.control.nominal import NominalGait
    from wqwarp.robot import constants as C

    for contact in ("sim", "ground"):
        sim = Simulator(SimConfig(num_envs=2))
        OpenLoopDriver(sim, "walking", (0.3, 0.0, 0.1), contact=contact).run(0.3)
        ref = Simulator(SimConfig(num_envs=2))
        ng = NominalGait(2, "cpu")
        ng.reset(np.arange(2), ng.gait_ids("walking"))
        ng.command.assign(np.tile(np.float32([0.3, 0.0, 0.1]), (2, 1)))
        ground = wp.ones((2, 4), dtype=wp.int32)
        for _ in range(round(0.3 / ref.policy_dt)):
            ng.step(ref.actuated_q[:, :12], ref.wheel_contact if contact == "sim" else ground, ref.policy_dt)
            wp.copy(ref.leg_q_target, ng.leg_joint_target)
            wp.copy(ref.wheel_qd_target, ng.wheel_velocity)
            ref.step()
        np.testing.assert_array_equal(sim.joint_q.numpy(), ref.joint_q.numpy())
        np.testing.assert_array_equal(sim.p_cost.numpy(), ref.p_cost.numpy())
    alone = OpenLoopDriver(None, "trotting", (0.2, 0.0, 0.0), dt=0.02)
    assert alone.run(0.5, warmup_s=0.1) == 25 and alone.steps_taken == 30
    ng = NominalGait(1, "cpu")
    ng.reset([0], ng.gait_ids("trotting"))
    ng.command.assign(np.float32([[0.2, 0.0, 0.0]]))
    legs = wp.array(np.float32(C.DEFAULT_JOINT_POS[:12])[None], dtype=wp.float32)
    for _ in range(30):
        ng.step(legs, wp.ones((1, 4), dtype=wp.int32), 0.02)
    np.testing.assert_array_equal(alone.nominal.leg_joint_target.numpy(), ng.leg_joint_target.numpy())
    with pytest.raises(ValueError, match="contact source"):
        OpenLoopDriver(None, contact="air")
