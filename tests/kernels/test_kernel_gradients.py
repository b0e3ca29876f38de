"""Gradients of the kernels recorded on ``wp.Tape`` match central finite differences (float32; tolerances below):
leg FK and IK, the leg PD torque inside the torque limit, the power terms away from zero torque and speed, the swing
height (Eq. 2) inside each cubic branch, the swing x offset, the nominal wheel velocity (Eq. 3) and the tracking
reward. A first step of the differentiable-simulation work (issue 13, item 1): the phase update across its wrap, the
full nominal-gait and reward kernels, and a smooth |x| for the power at zero are not covered yet."""

from __future__ import annotations

import numpy as np
import pytest
import warp as wp

from wqwarp import constants as C
from wqwarp.kernels.actuation import leg_pd_torque
from wqwarp.kernels.gait import nominal_wheel_velocity, swing_height, swing_x
from wqwarp.kernels.kinematics import compute_leg_fk, compute_leg_ik
from wqwarp.kernels.power import joule_power_term, p_cost_term, positive_mech_power_term
from wqwarp.kernels.rewards import tracking_reward

EPS = 1e-3  # float32: central differences with h = 1e-3 leave ~1e-4 relative noise
RTOL, ATOL = 2e-2, 2e-3


def _tape_grad(fn, x: np.ndarray, device: str) -> tuple[np.ndarray, np.ndarray]:
    """Jacobian-vector check: d sum(w * fn(x)) / dx by the tape, and by central differences, for a fixed random w."""
    xa = wp.array(x.astype(np.float32), dtype=float, device=device, requires_grad=True)
    out = fn(xa)
    w = np.random.default_rng(1).uniform(-1, 1, out.numpy().shape).astype(np.float32)
    tape = wp.Tape()
    with tape:
        out = fn(xa)
    out.grad = wp.array(w, dtype=out.dtype, device=device)
    tape.backward()
    grad = xa.grad.numpy().copy()
    tape.zero()
    num = np.zeros_like(x, dtype=np.float64)
    flat = x.reshape(-1)
    for i in range(flat.size):
        for sgn in (1, -1):
            xp = flat.copy()
            xp[i] += sgn * EPS
            o = fn(wp.array(xp.reshape(x.shape).astype(np.float32), dtype=float, device=device)).numpy()
            num.reshape(-1)[i] += sgn * float(np.sum(w * o.reshape(w.shape))) / (2 * EPS)
    return grad, num


def test_leg_fk_gradient(device):
    q = np.tile(np.asarray(C.DEFAULT_JOINT_POS[:12]), (2, 1)) + np.random.default_rng(0).uniform(-0.2, 0.2, (2, 12))
    fk = lambda qa: compute_leg_fk(qa.reshape((2, 12)))  # noqa: E731
    grad, num = _tape_grad(fk, q, device)
    np.testing.assert_allclose(grad, num, rtol=RTOL, atol=ATOL)


def test_leg_ik_gradient_inside_the_workspace(device):
    q = np.tile(np.asarray(C.DEFAULT_JOINT_POS[:12]), (1, 1))
    p = compute_leg_fk(wp.array(q.astype(np.float32), dtype=float, device=device)).numpy().reshape(1, 12)
    pa = wp.array(p.reshape(1, 4, 3).astype(np.float32), dtype=wp.vec3, device=device, requires_grad=True)
    tape = wp.Tape()
    with tape:
        out = compute_leg_ik(pa)
    w = np.random.default_rng(2).uniform(-1, 1, (1, 12)).astype(np.float32)
    out.grad = wp.array(w, dtype=float, device=device)
    tape.backward()
    grad = pa.grad.numpy().reshape(-1)
    num = np.zeros(12)
    for i in range(12):
        for sgn in (1, -1):
            pp = p.reshape(-1).copy()
            pp[i] += sgn * EPS
            o = compute_leg_ik(wp.array(pp.reshape(1, 4, 3).astype(np.float32), dtype=wp.vec3, device=device))
            num[i] += sgn * float(np.sum(w * o.numpy())) / (2 * EPS)
    np.testing.assert_allclose(grad, num, rtol=5e-2, atol=5e-2)  # IK is steeper: d q / d p ~ 1 / link length


@wp.kernel
def _pd(x: wp.array(dtype=float), out: wp.array(dtype=float)):
    i = wp.tid()
    out[i] = leg_pd_torque(x[4 * i], x[4 * i + 1], x[4 * i + 2], 40.0, 1.0, 23.7)


@wp.kernel
def _powers(x: wp.array(dtype=float), out: wp.array(dtype=float)):
    i = wp.tid()
    tau, qd = x[2 * i], x[2 * i + 1]
    out[3 * i] = p_cost_term(tau, qd)
    out[3 * i + 1] = positive_mech_power_term(tau, qd)
    out[3 * i + 2] = joule_power_term(tau, qd)


def _launch(kernel, n_out):
    def fn(xa):
        out = wp.zeros(n_out, dtype=float, device=xa.device, requires_grad=True)
        wp.launch(kernel, dim=n_out if kernel is _pd else n_out // 3, inputs=[xa], outputs=[out], device=xa.device)
        return out

    return fn


def test_leg_pd_torque_gradient_inside_the_limit(device):
    # (q_target, q, qd, unused) per joint; torques stay well inside +-23.7 N m
    x = np.array([0.1, 0.0, 0.5, 0, -0.2, -0.1, -1.0, 0, 0.8, 0.9, 2.0, 0], np.float64)
    grad, num = _tape_grad(_launch(_pd, 3), x, device)
    np.testing.assert_allclose(grad, num, rtol=RTOL, atol=ATOL)
    w = np.random.default_rng(1).uniform(-1, 1, 3)
    np.testing.assert_allclose(grad.reshape(3, 4)[:, :3], np.stack([40 * w, -40 * w, -1 * w], 1), rtol=1e-5)


@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_power_term_gradients_away_from_zero(device, sign):
    x = sign * np.array([3.0, 2.0, -1.5, 4.0, 0.7, -3.0], np.float64)  # (tau, qd) pairs, no zero component
    grad, num = _tape_grad(_launch(_powers, 9), x, device)
    np.testing.assert_allclose(grad, num, rtol=RTOL, atol=ATOL)


@wp.kernel
def _gait_terms(x: wp.array(dtype=float), out: wp.array(dtype=float)):
    i = wp.tid()
    psi, h_b, h_s, vx, wz = x[5 * i], x[5 * i + 1], x[5 * i + 2], x[5 * i + 3], x[5 * i + 4]
    out[4 * i] = swing_height(psi, h_b, h_s)  # Eq. (2), w.r.t. psi, h_b and h_s
    out[4 * i + 1] = swing_x(psi, 0.05)
    out[4 * i + 2] = nominal_wheel_velocity(vx, wz, 0.15, 0.075, 1.0)  # Eq. (3)
    out[4 * i + 3] = tracking_reward(vx, wz, 4.0)  # Table II tracking term (cmd, actual)


def test_gait_equations_and_tracking_reward_gradients(device):
    # psi inside each cubic branch (away from the branch point 0.5 and the stance boundary 0)
    x = np.array([0.2, 0.2, 0.1, 0.6, 0.3, 0.8, 0.22, 0.08, -0.4, 0.5, 0.45, 0.2, 0.1, 0.0, -0.7], np.float64)

    def fn(xa):
        out = wp.zeros(12, dtype=float, device=xa.device, requires_grad=True)
        wp.launch(_gait_terms, dim=3, inputs=[xa], outputs=[out], device=xa.device)
        return out

    grad, num = _tape_grad(fn, x, device)
    np.testing.assert_allclose(grad, num, rtol=RTOL, atol=ATOL)
