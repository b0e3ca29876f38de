"""The CPU path (mujoco.rollout) and Newton's SolverMuJoCo (mujoco_warp, here on Warp's CPU device) agree.

Tolerance over 1 s (50 policy steps) of driving and turning from the default pose: base position within 1.5 cm (the
turning robot drifts ~2 % of its 0.4 m path), leg angles within 0.05 rad (the robot swinging its thighs; the other
agrees to 1e-5), wheel angles within 0.2 rad (they integrate slip), base velocity within 0.05 m/s, mean p_cost within
10 %. Both run MuJoCo's algorithms on the same converted model; the differences are float32 (Warp) vs float64 (C).
"""

from __future__ import annotations

import numpy as np

from wqwarp.robot import constants as C
from wqwarp.sim.config import SimConfig
from wqwarp.sim.simulator import Simulator


def _rollout(backend: str) -> list[np.ndarray]:
    sim = Simulator(SimConfig(num_envs=2, backend=backend, device="cpu"))
    side = np.asarray(C.LEG_SIDE_SIGN, np.float32)
    target = np.stack([np.full(4, 6.0, np.float32), 6.0 - 2.0 * side]).astype(np.float32)  # drive; drive + turn
    sim.wheel_qd_target.assign(target)
    legs = np.tile(np.asarray(C.DEFAULT_JOINT_POS[:12], np.float32), (2, 1))
    out, p_cost = [], []
    for i in range(50):
        legs[1, 1::3] = C.DEFAULT_JOINT_POS[1] + 0.15 * np.sin(2 * np.pi * 1.5 * i * sim.policy_dt)
        sim.leg_q_target.assign(legs)
        sim.step()
        p_cost.append(sim.p_cost.numpy().copy())
        out.append(
            np.concatenate([sim.joint_q.numpy(), sim.joint_qd.numpy(), sim.wheel_contact.numpy()], axis=1).copy()
        )
    return out, np.mean(p_cost, axis=0), sim.layout


def test_cpu_rollout_matches_mujoco_warp():
    a, pa, lay = _rollout("mujoco_cpu")
    b, pb, _ = _rollout("mujoco_warp")
    legs, wheels = lay.actuated_coord[:12], lay.actuated_coord[12:]
    a, b = np.stack(a), np.stack(b)
    assert np.all(np.isfinite(a)) and np.all(np.isfinite(b))
    np.testing.assert_allclose(a[:, :, 0:3], b[:, :, 0:3], atol=1.5e-2)  # base position [m]
    np.testing.assert_allclose(a[:, :, legs], b[:, :, legs], atol=5e-2)  # leg joint angles [rad]
    np.testing.assert_allclose(a[:, :, wheels], b[:, :, wheels], atol=0.2)  # wheel angles [rad]: integrate slip
    np.testing.assert_allclose(a[:, :, 23:26], b[:, :, 23:26], atol=5e-2)  # base velocity [m/s]
    assert np.mean(a[:, :, -4:] == b[:, :, -4:]) > 0.95  # wheel contact flags
    np.testing.assert_allclose(pa, pb, rtol=0.1, atol=0.5)  # mean p_cost over the rollout [W]
    assert a[-1, 0, 0] > 0.3  # it did drive
