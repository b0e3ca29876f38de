"""Leg FK / IK (kernels/kinematics.py) against NumPy and hand values."""

import numpy as np
import pytest
import warp as wp

from wqwarp import constants
from wqwarp.kernels import kinematics

DEVICES = ["cpu"] + (["cuda:0"] if wp.is_cuda_available() else [])
SIDES = np.array(constants.LEG_SIDE_SIGN)


def _fk(q: np.ndarray, device: str) -> np.ndarray:
    return kinematics.compute_leg_fk(wp.array(q.astype(np.float32), dtype=float, device=device)).numpy()


def _ik(p: np.ndarray, device: str) -> np.ndarray:
    return kinematics.compute_leg_ik(wp.array(p.astype(np.float32), dtype=wp.vec3, device=device)).numpy()


def _fk_numpy(q: np.ndarray) -> np.ndarray:
    """(n, 12) -> (n, 4, 3) with the NumPy reference."""
    q = q.reshape(-1, 4, 3)
    return np.stack([kinematics.leg_fk_numpy(q[:, leg], SIDES[leg]) for leg in range(4)], axis=1)


@pytest.mark.parametrize("device", DEVICES)
def test_fk_hand_value_zero_angles(device):
    # straight leg: thigh + calf below the thigh joint, calf x offset -0.015, lateral 0.08 + 0.0245
    p = _fk(np.zeros((1, 12)), device)[0]
    expected = np.array([[-0.015, s * 0.1045, -0.446] for s in SIDES])
    np.testing.assert_allclose(p, expected, atol=1e-6)


@pytest.mark.parametrize("device", DEVICES)
def test_fk_matches_numpy(device):
    rng = np.random.default_rng(0)
    lo, hi = np.array(constants.LEG_JOINT_RANGES).T
    q = rng.uniform(lo, hi, size=(16, 12))
    np.testing.assert_allclose(_fk(q, device), _fk_numpy(q), atol=1e-6)


@pytest.mark.parametrize("device", DEVICES)
def test_ik_nominal_stance_is_default_angles(device):
    p = np.array([[[0.0, s * 0.1045, -constants.NOMINAL_BODY_HEIGHT] for s in SIDES]])
    q = _ik(p, device).reshape(4, 3)
    for leg in range(4):
        np.testing.assert_allclose(q[leg], constants.DEFAULT_LEG_ANGLES, atol=1e-4)


@pytest.mark.parametrize("device", DEVICES)
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


@pytest.mark.parametrize("device", DEVICES)
def test_ik_unreachable_is_clamped_and_finite(device):
    p = np.array([[[0.0, 0.0, -1.0], [0.5, 0.5, 0.5], [0.0, -0.1045, 0.0], [0.0, 0.0, 0.0]]])
    q = _ik(p, device)
    lo, hi = np.array(constants.LEG_JOINT_RANGES).T
    assert np.all(np.isfinite(q))
    assert np.all(q >= lo - 1e-6) and np.all(q <= hi + 1e-6)
