"""Leg FK / IK (kernels/kinematics.py) against NumPy and hand values."""

import numpy as np
import warp as wp

from wqwarp.kernels import kinematics
from wqwarp.robot import constants

SIDES = np.array(constants.LEG_SIDE_SIGN)


def _fk(q: np.ndarray, device: str, point=constants.WHEEL_CENTER_IN_CALF) -> np.ndarray:
    return kinematics.compute_leg_fk(wp.array(q.astype(np.float32), dtype=float, device=device), point=point).numpy()


def _ik(p: np.ndarray, device: str, point=constants.WHEEL_CENTER_IN_CALF) -> np.ndarray:
    arr = wp.array(p.astype(np.float32), dtype=wp.vec3, device=device)
    return kinematics.compute_leg_ik(arr, point=point).numpy()


def _fk_numpy(q: np.ndarray, point=constants.WHEEL_CENTER_IN_CALF) -> np.ndarray:
    """(n, 12) -> (n, 4, 3) with the NumPy reference."""
    q = q.reshape(-1, 4, 3)
    return np.stack([kinematics.leg_fk_numpy(q[:, leg], SIDES[leg], point) for leg in range(4)], axis=1)


def test_fk_hand_value_zero_angles(device):
    # straight leg: thigh + calf below the thigh joint, calf x offset -0.015; the wheel sits INBOARD of the calf
    # (authors' MJCF): lateral 0.08 - 0.0245 = 0.0555 from the hip joint
    p = _fk(np.zeros((1, 12)), device)[0]
    expected = np.array([[-0.015, s * 0.0555, -0.446] for s in SIDES])
    np.testing.assert_allclose(p, expected, atol=1e-6)
    # the foot point (calf end) of the straight leg: (0, s 0.08, -0.426)
    p = _fk(np.zeros((1, 12)), device, constants.FOOT_IN_CALF)[0]
    np.testing.assert_allclose(p, np.array([[0.0, s * 0.08, -0.426] for s in SIDES]), atol=1e-6)


def test_fk_matches_numpy(device):
    rng = np.random.default_rng(0)
    lo, hi = np.array(constants.LEG_JOINT_RANGES).T
    q = rng.uniform(lo, hi, size=(16, 12))
    np.testing.assert_allclose(_fk(q, device), _fk_numpy(q), atol=1e-6)


def test_foot_ik_of_the_default_stance_gives_the_default_angles(device):
    q = np.array(constants.DEFAULT_JOINT_POS[:12])
    p = _fk_numpy(q[None], constants.FOOT_IN_CALF)
    # hand value: thigh 1.08, calf -2.16 put the calf end straight below the thigh joint, 2 * 0.213 cos(1.08) deep
    thigh_joint = np.stack([np.zeros(4), SIDES * 0.08 * np.cos(0.1), 0.08 * np.sin(0.1) * np.ones(4)], 1)
    np.testing.assert_allclose(np.linalg.norm(p[0] - thigh_joint, axis=1), 0.426 * np.cos(1.08), atol=1e-9)
    np.testing.assert_allclose(p[0, :, 0], 0.0, atol=1e-9)
    np.testing.assert_allclose(_ik(p, device, constants.FOOT_IN_CALF)[0], q, atol=1e-4)


def test_foot_ik_round_trip(device):
    rng = np.random.default_rng(3)
    q = rng.uniform([-0.6, 0.3, -2.6] * 4, [0.6, 1.6, -1.0] * 4, size=(256, 12))
    p = _fk_numpy(q, constants.FOOT_IN_CALF)
    q_ik = _ik(p, device, constants.FOOT_IN_CALF)
    err = np.linalg.norm(_fk_numpy(q_ik, constants.FOOT_IN_CALF) - p, axis=-1)
    assert err.max() < 1e-5, err.max()


def test_ik_fk_round_trip(device):
    rng = np.random.default_rng(1)
    # reachable targets: FK of joint angles inside the ranges, on the IK branch (wheel below the thigh joint)
    q = rng.uniform([-0.7, -0.5, -2.7] * 4, [0.7, 2.0, -0.95] * 4, size=(512, 12))
    q_no_hip = q.reshape(-1, 4, 3).copy()
    q_no_hip[..., 0] = 0.0
    below = np.all(_fk_numpy(q_no_hip)[..., 2] < -0.02, axis=1)  # wheel below the thigh joint (the IK branch)
    q = q[below]
    assert len(q) > 100
    p = _fk_numpy(q)
    q_ik = _ik(p, device)
    lo, hi = np.array(constants.LEG_JOINT_RANGES).T
    assert np.all(q_ik >= lo - 1e-6) and np.all(q_ik <= hi + 1e-6)
    err = np.linalg.norm(_fk_numpy(q_ik) - p, axis=-1)
    assert err.max() < 1e-5, err.max()
    np.testing.assert_allclose(q_ik, q, atol=2e-3)  # unique solution on this branch


def test_ik_unreachable_is_clamped_and_finite(device):
    p = np.array([[[0.0, 0.0, -1.0], [0.5, 0.5, 0.5], [0.0, -0.0555, 0.0], [0.0, 0.0, 0.0]]])
    q = _ik(p, device)
    lo, hi = np.array(constants.LEG_JOINT_RANGES).T
    assert np.all(np.isfinite(q))
    assert np.all(q >= lo - 1e-6) and np.all(q <= hi + 1e-6)
