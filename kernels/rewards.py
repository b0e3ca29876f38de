"""Reward terms of the paper's Table II, one ``@wp.func`` each, and the kernel that weighs and sums them.

Term columns follow ``wqwarp.rl.config.REWARD_TERMS``:
    0 track_vx  1 track_vy  2 track_wz  3 residual  4 orientation  5 lin_vel_z  6 ang_vel_xy  7 joint_acc
    8 torques   9 action_smoothness  10 collision  11 energy
The step reward is sum_k w_k * r_k * dt (legged_gym convention); a term whose weight is 0 is not evaluated.
"""

from __future__ import annotations

import warp as wp

NUM_TERMS = 12


@wp.func
def tracking_reward(cmd: float, actual: float, sigma: float) -> float:
    """exp(-sigma (cmd - actual)^2) [-]: Table II velocity tracking (sigma = 4)."""
    e = cmd - actual
    return wp.exp(-sigma * e * e)


@wp.func
def squared_norm_xy(v: wp.vec3) -> float:
    """||v_xy||^2: orientation (projected gravity g_xy) and angular velocity (w_xy) penalties."""
    return v[0] * v[0] + v[1] * v[1]


@wp.kernel
def compute_rewards(
    joint_q: wp.array2d(dtype=wp.float32),
    joint_qd: wp.array2d(dtype=wp.float32),
    command: wp.array2d(dtype=wp.float32),
    action: wp.array2d(dtype=wp.float32),
    prev_action: wp.array2d(dtype=wp.float32),
    prev2_action: wp.array2d(dtype=wp.float32),
    actuated_qd: wp.array2d(dtype=wp.float32),
    prev_actuated_qd: wp.array2d(dtype=wp.float32),
    torque_sq: wp.array(dtype=wp.float32),
    power_sq: wp.array(dtype=wp.float32),
    body_collision: wp.array2d(dtype=wp.int32),
    weight: wp.array(dtype=wp.float32),
    sigma: float,
    dt: float,
    # outputs
    reward: wp.array(dtype=wp.float32),
    term: wp.array2d(dtype=wp.float32),
    episode_sum: wp.array2d(dtype=wp.float32),
):
    """One thread per robot. ``term`` (N, 12) gets the weighted terms w_k r_k dt, ``episode_sum`` accumulates them,
    ``reward`` (N,) their sum. ``joint_q`` / ``joint_qd``: Newton rows of a free-floating base (quaternion xyzw at
    3:7, world-frame linear / angular velocity at 0:3 / 3:6); velocities are rotated into the base frame.
    ``actuated_qd``: (N, 16) project order. ``torque_sq`` = sum_j tau_j^2 and ``power_sq`` = sum_j (tau_j qd_j)^2,
    (N,), averaged over the physics substeps of the step (``wqwarp.kernels.power``), like p_cost."""
    i = wp.tid()
    q = wp.quat(joint_q[i, 3], joint_q[i, 4], joint_q[i, 5], joint_q[i, 6])
    v = wp.quat_rotate_inv(q, wp.vec3(joint_qd[i, 0], joint_qd[i, 1], joint_qd[i, 2]))
    w = wp.quat_rotate_inv(q, wp.vec3(joint_qd[i, 3], joint_qd[i, 4], joint_qd[i, 5]))
    g = wp.quat_rotate_inv(q, wp.vec3(0.0, 0.0, -1.0))
    total = float(0.0)
    for k in range(NUM_TERMS):
        wk = weight[k]
        r = float(0.0)
        if wk != 0.0:
            if k == 0:
                r = tracking_reward(command[i, 0], v[0], sigma)
            elif k == 1:
                r = tracking_reward(command[i, 1], v[1], sigma)
            elif k == 2:
                r = tracking_reward(command[i, 2], w[2], sigma)
            elif k == 3:  # residual ||a_t||
                s = float(0.0)
                for j in range(action.shape[1]):
                    s += action[i, j] * action[i, j]
                r = wp.sqrt(s)
            elif k == 4:
                r = squared_norm_xy(g)
            elif k == 5:
                r = v[2] * v[2]
            elif k == 6:
                r = squared_norm_xy(w)
            elif k == 7:  # ||qdd||^2 by finite difference over the policy step
                for j in range(actuated_qd.shape[1]):
                    a = (actuated_qd[i, j] - prev_actuated_qd[i, j]) / dt
                    r += a * a
            elif k == 8:  # ||tau||^2, substep average
                r = torque_sq[i]
            elif k == 9:  # (a_t + a_{t-2} - 2 a_{t-1})^2
                for j in range(action.shape[1]):
                    d = action[i, j] + prev2_action[i, j] - 2.0 * prev_action[i, j]
                    r += d * d
            elif k == 10:
                for c in range(body_collision.shape[1]):
                    r += float(body_collision[i, c])
            elif k == 11:  # ||tau * qd||^2: squared norm of the joint powers, substep average
                r = power_sq[i]
        rk = wk * r * dt
        term[i, k] = rk
        episode_sum[i, k] += rk
        total += rk
    reward[i] = total
