"""kernels/state.py (MuJoCo <-> Newton coordinates) and kernels/actions.py against NumPy and hand values."""

from __future__ import annotations

import numpy as np
import pytest
import warp as wp

from wqwarp.kernels.actions import joint_offset_targets, residual_targets
from wqwarp.kernels.kinematics import leg_fk_numpy
from wqwarp.kernels.state import (
    BASE_FRAME_OUTPUTS,
    compute_base_frame,
    mujoco_state_to_newton,
    newton_state_to_mujoco,
)
from wqwarp.robot import constants as C

COM = np.array([0.0223, 0.002, -0.0005])


def _quat_xyzw_to_mat(q):
    x, y, z, w = q
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


def test_mujoco_newton_round_trip_and_free_joint_convention(device):
    rng = np.random.default_rng(3)
    n, nq, nv, off = 4, 23, 22, 1  # mjSTATE_FULLPHYSICS starts with time
    state = rng.normal(size=(n, off + nq + nv + 2))
    quat_wxyz = rng.normal(size=(n, 4))
    state[:, off + 3 : off + 7] = quat_wxyz / np.linalg.norm(quat_wxyz, axis=1, keepdims=True)
    s = wp.array(state, dtype=wp.float64, device=device)
    jq = wp.zeros((n, nq), dtype=wp.float32, device=device)
    jqd = wp.zeros((n, nv), dtype=wp.float32, device=device)
    wp.launch(mujoco_state_to_newton, dim=n, inputs=[s, off, wp.vec3(*COM)], outputs=[jq, jqd], device=device)
    q, qd = jq.numpy(), jqd.numpy()
    for i in range(n):
        w, x, y, z = state[i, off + 3 : off + 7]
        np.testing.assert_allclose(q[i, 3:7], [x, y, z, w], atol=1e-6)  # xyzw
        rot = _quat_xyzw_to_mat(q[i, 3:7])
        omega_w = rot @ state[i, off + nq + 3 : off + nq + 6]  # MuJoCo: body frame -> world
        v_com = state[i, off + nq : off + nq + 3] + np.cross(omega_w, rot @ COM)
        np.testing.assert_allclose(qd[i, 3:6], omega_w, atol=1e-5)
        np.testing.assert_allclose(qd[i, 0:3], v_com, atol=1e-5)
    np.testing.assert_allclose(q[:, 7:], state[:, off + 7 : off + nq], atol=1e-6)
    np.testing.assert_allclose(qd[:, 6:], state[:, off + nq + 6 : off + nq + nv], atol=1e-6)
    back = wp.zeros_like(s)
    ids = wp.array(np.arange(n, dtype=np.int32), dtype=wp.int32, device=device)
    wp.launch(newton_state_to_mujoco, dim=n, inputs=[jq, jqd, ids, off, wp.vec3(*COM)], outputs=[back], device=device)
    np.testing.assert_allclose(back.numpy()[:, off : off + nq + nv], state[:, off : off + nq + nv], atol=1e-5)


def test_residual_targets_add_clip_and_invert(device):
    n = 2
    side = np.asarray(C.LEG_SIDE_SIGN)
    # foot-point targets: the default pose's foot points (FK of the authors' reset stance)
    q_default = np.asarray(C.DEFAULT_JOINT_POS[:12]).reshape(4, 3)
    p_n = np.stack([leg_fk_numpy(q_default[k], side[k], C.FOOT_IN_CALF) for k in range(4)]).astype(np.float32)
    p_n = np.tile(p_n[None], (n, 1, 1))
    action = np.zeros((n, 20), np.float32)
    action[0, 4:7] = (0.1, 0.0, 0.25)  # FR: dp = (0.02, 0, 0.05) m
    action[1, 4:7] = (5.0, 0.0, 0.0)  # clipped to 0.3 m... then IK clamps to the workspace
    action[:, 16:20] = (1.0, -1.0, 20.0, 0.0)
    v_n = np.full((n, 4), 8.0, np.float32)
    f = lambda x, dt=wp.float32: wp.array(x, dtype=dt, device=device)  # noqa: E731
    dp = wp.zeros((n, 4), dtype=wp.vec3, device=device)
    q = wp.zeros((n, 12), dtype=wp.float32, device=device)
    v = wp.zeros((n, 4), dtype=wp.float32, device=device)
    for use_nominal in (1, 0):
        wp.launch(
            residual_targets,
            dim=(n, 4),
            inputs=[f(action), f(p_n, wp.vec3), f(v_n), use_nominal, 0.2, 0.3, 5.0, 40.0],
            outputs=[dp, q, v],
            device=device,
        )
        base = 8.0 if use_nominal else 0.0
        np.testing.assert_allclose(v.numpy()[0], np.clip(base + 5.0 * np.array([1, -1, 20, 0]), -40, 40))
    np.testing.assert_allclose(dp.numpy()[0, 0], (0.02, 0.0, 0.05), atol=1e-6)
    np.testing.assert_allclose(dp.numpy()[1, 0], (0.3, 0.0, 0.0), atol=1e-6)
    fk = leg_fk_numpy(q.numpy()[0, 0:3].astype(np.float64), side[0], C.FOOT_IN_CALF)
    np.testing.assert_allclose(fk, p_n[0, 0] + (0.02, 0.0, 0.05), atol=1e-4)  # foot IK of p_n + dp
    np.testing.assert_allclose(q.numpy()[0, 3:], C.DEFAULT_JOINT_POS[3:12], atol=1e-4)  # dp = 0 legs


def test_joint_offset_targets(device):
    a = np.zeros((1, 16), np.float32)
    a[0, 1], a[0, 12], a[0, 13] = 1.0, 2.0, 100.0
    q = wp.zeros((1, 12), dtype=wp.float32, device=device)
    v = wp.zeros((1, 4), dtype=wp.float32, device=device)
    default = wp.array(np.asarray(C.DEFAULT_JOINT_POS[:12], np.float32), dtype=wp.float32, device=device)
    wp.launch(
        joint_offset_targets,
        dim=1,
        inputs=[wp.array(a, dtype=wp.float32, device=device), default, 0.25, 5.0, 40.0],
        outputs=[q, v],
        device=device,
    )
    assert q.numpy()[0, 1] == pytest.approx(C.DEFAULT_JOINT_POS[1] + 0.25)
    np.testing.assert_allclose(v.numpy()[0], (10.0, 40.0, 0.0, 0.0))


def _quat_rotate_inv_numpy(q_xyzw: np.ndarray, v: np.ndarray) -> np.ndarray:
    """R(q)^T v for each row, R from the xyzw quaternion (normalised)."""
    return np.stack([_quat_xyzw_to_mat(qi / np.linalg.norm(qi)).T @ vi for qi, vi in zip(q_xyzw, v, strict=True)])


def test_compute_base_frame_against_numpy_and_hand_values(device):
    rng = np.random.default_rng(5)
    n = 6
    jq = rng.normal(size=(n, 23)).astype(np.float32)
    quat = rng.normal(size=(n, 4))
    jq[:, 3:7] = quat / np.linalg.norm(quat, axis=1, keepdims=True)
    jq[0, 3:7] = [0.0, 0.0, np.sin(0.3), np.cos(0.3)]  # hand value: yaw 0.6 rad about z, level
    jqd = rng.normal(size=(n, 22)).astype(np.float32)
    jqd[0, 0:6] = [1.0, 0.0, 0.0, 0.0, 0.0, 0.5]
    outs = [wp.zeros((n, w) if w else n, dtype=wp.float32, device=device) for _, w in BASE_FRAME_OUTPUTS]
    wp.launch(
        compute_base_frame,
        dim=n,
        inputs=[wp.array(jq, device=device), wp.array(jqd, device=device)],
        outputs=outs,
        device=device,
    )
    got = {name: a.numpy() for (name, _), a in zip(BASE_FRAME_OUTPUTS, outs, strict=True)}
    q = jq[:, 3:7].astype(np.float64)
    np.testing.assert_allclose(got["base_lin_vel"], _quat_rotate_inv_numpy(q, jqd[:, 0:3]), atol=1e-5)
    np.testing.assert_allclose(got["base_ang_vel"], _quat_rotate_inv_numpy(q, jqd[:, 3:6]), atol=1e-5)
    np.testing.assert_allclose(
        got["projected_gravity"], _quat_rotate_inv_numpy(q, np.tile([0, 0, -1.0], (n, 1))), atol=1e-5
    )
    np.testing.assert_array_equal(got["base_height"], jq[:, 2])
    x, y, z, w = q.T
    np.testing.assert_allclose(got["base_yaw"], np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z)), atol=1e-5)
    # hand values: heading 0.6 rad, 1 m/s forward in the world -> (cos 0.6, -sin 0.6) in the base, gravity straight down
    np.testing.assert_allclose(got["base_yaw"][0], 0.6, atol=1e-6)
    np.testing.assert_allclose(got["base_lin_vel"][0], [np.cos(0.6), -np.sin(0.6), 0.0], atol=1e-6)
    np.testing.assert_allclose(got["base_ang_vel"][0], [0.0, 0.0, 0.5], atol=1e-6)
    np.testing.assert_allclose(got["projected_gravity"][0], [0.0, 0.0, -1.0], atol=1e-6)
