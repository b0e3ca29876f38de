"""Tests of kernels/actuation.py: each func against NumPy and a hand value; the kernel's scatter, scaling and reset."""

from __future__ import annotations

import numpy as np
import warp as wp

from wqwarp.kernels.actuation import (
    launch_actuation,
    launch_reset_wheel_pid,
    leg_pd_torque,
    wheel_pid_torque,
)
from wqwarp.robot.constants import TORQUE_LIMITS

NUM_ENVS = 4
COORDS, DOFS, Q_START, QD_START = 23, 22, 7, 6
GAINS = dict(leg_kp=40.0, leg_kd=1.0, wheel_kp=2.0, wheel_ki=5.0, wheel_kd=0.01, wheel_i_limit=0.3, dt=0.005)


@wp.kernel
def _eval_leg_pd(args: wp.array2d(dtype=wp.float32), out: wp.array(dtype=wp.float32)):
    i = wp.tid()
    out[i] = leg_pd_torque(args[i, 0], args[i, 1], args[i, 2], args[i, 3], args[i, 4], args[i, 5])


@wp.kernel
def _eval_wheel_pid(args: wp.array2d(dtype=wp.float32), out: wp.array(dtype=wp.vec3)):
    i = wp.tid()
    a = args[i]
    out[i] = wheel_pid_torque(a[0], a[1], a[2], a[3], a[4], a[5], a[6], a[7], a[8], a[9])


def np_leg_pd(q_target, q, qd, kp, kd, limit):
    return np.clip(kp * (q_target - q) - kd * qd, -limit, limit)


def np_wheel_pid(qd_target, qd, integral, prev_error, kp, ki, kd, i_limit, limit, dt):
    e = qd_target - qd
    de = (e - prev_error) / dt
    u_held = kp * e + ki * integral + kd * de
    step = e * dt
    hold = (np.abs(u_held) > limit) & (u_held * step > 0) & (np.abs(integral + step) > np.abs(integral))
    i_new = np.where(hold, integral, np.clip(integral + step, -i_limit, i_limit))
    tau = np.clip(kp * e + ki * i_new + kd * de, -limit, limit)
    return tau, i_new, e


def run_leg_pd(rows, device):
    args = wp.array(np.asarray(rows, dtype=np.float32), dtype=wp.float32, device=device)
    out = wp.zeros(args.shape[0], dtype=wp.float32, device=device)
    wp.launch(_eval_leg_pd, dim=args.shape[0], inputs=[args], outputs=[out], device=device)
    return out.numpy()


def run_wheel_pid(rows, device):
    args = wp.array(np.asarray(rows, dtype=np.float32), dtype=wp.float32, device=device)
    out = wp.zeros(args.shape[0], dtype=wp.vec3, device=device)
    wp.launch(_eval_wheel_pid, dim=args.shape[0], inputs=[args], outputs=[out], device=device)
    return out.numpy()


def test_leg_pd_matches_numpy_and_hand_values(device):
    rng = np.random.default_rng(0)
    n = 64
    rows = np.stack(
        [
            rng.uniform(-2, 2, n),
            rng.uniform(-2, 2, n),
            rng.uniform(-20, 20, n),
            rng.uniform(0, 80, n),
            rng.uniform(0, 3, n),
            rng.uniform(5, 40, n),
        ],
        axis=1,
    ).astype(np.float32)
    np.testing.assert_allclose(run_leg_pd(rows, device), np_leg_pd(*rows.T.astype(np.float64)), rtol=1e-5, atol=1e-5)
    # 40 * (0.5 - 0.4) - 1 * 2 = 2; 40 * 1 = 40 clips at 23.7; -40 * 1 - 0 clips at -35.55.
    hand = run_leg_pd(
        [[0.5, 0.4, 2.0, 40, 1, 23.7], [1.0, 0.0, 0.0, 40, 1, 23.7], [0.0, 1.0, 0.0, 40, 1, 35.55]], device
    )
    np.testing.assert_allclose(hand, [2.0, 23.7, -35.55], rtol=1e-6)


def test_wheel_pid_matches_numpy(device):
    rng = np.random.default_rng(1)
    n = 256
    rows = np.stack(
        [
            rng.uniform(-30, 30, n),  # qd_target
            rng.uniform(-30, 30, n),  # qd
            rng.uniform(-0.3, 0.3, n),  # integral
            rng.uniform(-30, 30, n),  # prev_error
            np.full(n, 0.3),
            np.full(n, 5.0),
            np.full(n, 1e-3),
            np.full(n, 0.3),
            np.full(n, 6.0),
            np.full(n, 0.01),
        ],
        axis=1,
    ).astype(np.float32)
    out = run_wheel_pid(rows, device)
    tau, i_new, e = np_wheel_pid(*rows.T.astype(np.float64))
    np.testing.assert_allclose(out[:, 0], tau, rtol=1e-5, atol=1e-5)
    np.testing.assert_allclose(out[:, 1], i_new, rtol=1e-5, atol=1e-5)
    np.testing.assert_allclose(out[:, 2], e, rtol=1e-5, atol=1e-5)
    saturated = np.abs(tau) >= 6.0 - 1e-6
    assert saturated.any() and (~saturated).any()


def test_wheel_pid_hand_values(device):
    # Columns: qd_target, qd, I, e_prev, kp, ki, kd, i_limit, limit, dt.
    rows = [
        # Integral clamp: 0.95 + 10 * 0.01 = 1.05 -> 1.0; tau = 0.1 * 10 + 1 * 1.0 = 2.0 (u_held 1.95 < 100).
        [10.0, 0.0, 0.95, 10.0, 0.1, 1.0, 0.0, 1.0, 100.0, 0.01],
        # Saturated (u_held = 10 + 0.5 > 6) and the step grows |I|: hold I = 0.5; tau clips to 6.
        [10.0, 0.0, 0.5, 10.0, 1.0, 1.0, 0.0, 1.0, 6.0, 0.01],
        # Saturated (u_held = 10 - 0.5 > 6) but the step shrinks |I|: integrate, I = -0.4; tau clips to 6.
        [10.0, 0.0, -0.5, 10.0, 1.0, 1.0, 0.0, 1.0, 6.0, 0.01],
        # e = 5, de = (5 - 10) / 0.01 = -500: u_held = 5 + 0.2 - 15 < -6, opposite to the step: integrate, I = 0.25;
        # tau = clip(5 + 0.25 - 15) = -6.
        [3.0, -2.0, 0.2, 10.0, 1.0, 1.0, 0.03, 1.0, 6.0, 0.01],
        # Derivative: e = 2, e_prev = 1, dt = 0.01 -> de = 100; tau = 1 * 2 + 0 + 0.01 * 100 = 3; I = 0.02.
        [2.0, 0.0, 0.0, 1.0, 1.0, 0.0, 0.01, 1.0, 6.0, 0.01],
    ]
    out = run_wheel_pid(rows, device)
    expected = [[2.0, 1.0, 10.0], [6.0, 0.5, 10.0], [6.0, -0.4, 10.0], [-6.0, 0.25, 5.0], [3.0, 0.02, 2.0]]
    np.testing.assert_allclose(out, expected, rtol=1e-5, atol=1e-6)


def np_actuation(q, qd, leg_target, wheel_target, limit, strength, integral, prev_error, g):
    leg = np_leg_pd(
        leg_target, q[:, Q_START : Q_START + 12], qd[:, QD_START : QD_START + 12], g["leg_kp"], g["leg_kd"], limit[:12]
    )
    wheel, i_new, e = np_wheel_pid(
        wheel_target,
        qd[:, QD_START + 12 : QD_START + 16],
        integral,
        prev_error,
        g["wheel_kp"],
        g["wheel_ki"],
        g["wheel_kd"],
        g["wheel_i_limit"],
        limit[12:],
        g["dt"],
    )
    tau = np.clip(strength * np.concatenate([leg, wheel], axis=1), -limit, limit)
    return tau, i_new, e


def test_apply_actuation_matches_numpy_over_steps(device):
    rng = np.random.default_rng(2)
    limit = np.asarray(TORQUE_LIMITS, dtype=np.float32)
    strength = rng.uniform(0.7, 1.3, (NUM_ENVS, 16)).astype(np.float32)
    f_sentinel = rng.uniform(-1, 1, (NUM_ENVS, DOFS)).astype(np.float32)
    wp_arr = lambda a: wp.array(np.asarray(a, dtype=np.float32), dtype=wp.float32, device=device)  # noqa: E731
    integral = wp.zeros((NUM_ENVS, 4), dtype=wp.float32, device=device)
    prev_error = wp.zeros((NUM_ENVS, 4), dtype=wp.float32, device=device)
    torque = wp.zeros((NUM_ENVS, 16), dtype=wp.float32, device=device)
    joint_f = wp_arr(f_sentinel)
    np_i, np_e = np.zeros((NUM_ENVS, 4)), np.zeros((NUM_ENVS, 4))
    for _ in range(3):
        q = rng.uniform(-2, 2, (NUM_ENVS, COORDS)).astype(np.float32)
        qd = rng.uniform(-20, 20, (NUM_ENVS, DOFS)).astype(np.float32)
        leg_target = rng.uniform(-2, 2, (NUM_ENVS, 12)).astype(np.float32)
        wheel_target = (qd[:, QD_START + 12 :] + rng.uniform(-3, 3, (NUM_ENVS, 4))).astype(np.float32)
        launch_actuation(
            wp_arr(q),
            wp_arr(qd),
            wp_arr(leg_target),
            wp_arr(wheel_target),
            wp_arr(limit),
            wp_arr(strength),
            integral,
            prev_error,
            torque,
            joint_f,
            coord_index=wp.array(np.arange(Q_START, Q_START + 16), dtype=wp.int32, device=device),
            dof_index=wp.array(np.arange(QD_START, QD_START + 16), dtype=wp.int32, device=device),
            device=device,
            **GAINS,
        )
        tau, np_i, np_e = np_actuation(q, qd, leg_target, wheel_target, limit, strength, np_i, np_e, GAINS)
        np.testing.assert_allclose(torque.numpy(), tau, rtol=1e-5, atol=1e-5)
        np.testing.assert_allclose(integral.numpy(), np_i, rtol=1e-5, atol=1e-5)
        np.testing.assert_allclose(prev_error.numpy(), np_e, rtol=1e-5, atol=1e-5)
        f = joint_f.numpy()
        np.testing.assert_array_equal(f[:, QD_START : QD_START + 16], torque.numpy())
        np.testing.assert_array_equal(f[:, :QD_START], f_sentinel[:, :QD_START])
        np.testing.assert_array_equal(f[:, QD_START + 16 :], f_sentinel[:, QD_START + 16 :])
    assert np.all(np.abs(torque.numpy()) <= limit + 1e-6)


def test_motor_strength_scales_before_clip(device):
    # Robot 0: hip PD gives 2.0 N m, strength 0.5 -> 1.0. Robot 1: 20.2 N m, strength 2 -> 40.4, clipped to 23.7.
    q = np.zeros((2, COORDS), dtype=np.float32)
    qd = np.zeros((2, DOFS), dtype=np.float32)
    q[:, Q_START] = 0.4
    qd[:, QD_START] = 2.0
    leg_target = np.zeros((2, 12), dtype=np.float32)
    leg_target[0, 0] = 0.5
    leg_target[1, 0] = 0.955  # 40 * 0.555 - 2 = 20.2
    strength = np.ones((2, 16), dtype=np.float32)
    strength[0, 0], strength[1, 0] = 0.5, 2.0
    wp_arr = lambda a: wp.array(np.asarray(a, dtype=np.float32), dtype=wp.float32, device=device)  # noqa: E731
    torque = wp.zeros((2, 16), dtype=wp.float32, device=device)
    launch_actuation(
        wp_arr(q),
        wp_arr(qd),
        wp_arr(leg_target),
        wp.zeros((2, 4), dtype=wp.float32, device=device),
        wp_arr(TORQUE_LIMITS),
        wp_arr(strength),
        wp.zeros((2, 4), dtype=wp.float32, device=device),
        wp.zeros((2, 4), dtype=wp.float32, device=device),
        torque,
        wp.zeros((2, DOFS), dtype=wp.float32, device=device),
        coord_index=wp.array(np.arange(Q_START, Q_START + 16), dtype=wp.int32, device=device),
        dof_index=wp.array(np.arange(QD_START, QD_START + 16), dtype=wp.int32, device=device),
        device=device,
        **GAINS,
    )
    np.testing.assert_allclose(torque.numpy()[:, 0], [1.0, 23.7], rtol=1e-5)


def test_reset_wheel_pid_zeroes_only_listed_robots(device):
    rng = np.random.default_rng(3)
    i0 = rng.uniform(0.1, 1, (NUM_ENVS, 4)).astype(np.float32)
    e0 = rng.uniform(0.1, 1, (NUM_ENVS, 4)).astype(np.float32)
    integral = wp.array(i0, dtype=wp.float32, device=device)
    prev_error = wp.array(e0, dtype=wp.float32, device=device)
    env_ids = wp.array([1, 3], dtype=wp.int32, device=device)
    launch_reset_wheel_pid(env_ids, integral, prev_error, device=device)
    keep = np.array([True, False, True, False])
    np.testing.assert_array_equal(integral.numpy()[keep], i0[keep])
    np.testing.assert_array_equal(prev_error.numpy()[keep], e0[keep])
    assert not integral.numpy()[~keep].any() and not prev_error.numpy()[~keep].any()
