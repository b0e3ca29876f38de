"""Reward terms of the paper's Table II, one ``@wp.func`` each, and the factory of the kernel that weighs and sums them.

Every term has the signature ``term(inp: RewardInputs, i: int, v: wp.vec3, w: wp.vec3, g: wp.vec3) -> float``: the
inputs of robot ``i`` and its base-frame linear velocity v [m/s], angular velocity w [rad/s] and projected gravity g
[-] (read once per robot from the simulator's base frame). The registry ``wqwarp.rl.rewards`` names the terms, their
order (the kernel's output columns), weights and NumPy references; :func:`make_reward_kernel` unrolls one kernel
over the registered terms. The step reward is sum_k w_k * r_k * dt (legged_gym convention); a term whose weight is 0
is not evaluated.
"""

from __future__ import annotations

import warp as wp


@wp.struct
class RewardInputs:
    """Per-robot inputs of the reward terms (arrays of N robots)."""

    base_lin_vel: wp.array2d(dtype=wp.float32)
    """(N, 3) base linear velocity in the base frame [m/s] (``wqwarp.kernels.state.compute_base_frame``)."""
    base_ang_vel: wp.array2d(dtype=wp.float32)
    """(N, 3) base angular velocity in the base frame [rad/s]."""
    projected_gravity: wp.array2d(dtype=wp.float32)
    """(N, 3) gravity direction (0, 0, -1) in the base frame [-]."""
    command: wp.array2d(dtype=wp.float32)
    """(N, 3) commanded v_x, v_y [m/s], w_z [rad/s], base frame."""
    action: wp.array2d(dtype=wp.float32)
    """a_t (N, A), raw policy action."""
    prev_action: wp.array2d(dtype=wp.float32)
    """a_{t-1} (N, A)."""
    prev2_action: wp.array2d(dtype=wp.float32)
    """a_{t-2} (N, A)."""
    actuated_qd: wp.array2d(dtype=wp.float32)
    """(N, 16) actuated joint velocities after the step, project order [rad/s]."""
    prev_actuated_qd: wp.array2d(dtype=wp.float32)
    """(N, 16) the same before the step [rad/s]."""
    torque_sq: wp.array(dtype=wp.float32)
    """(N,) sum_j tau_j^2, averaged over the physics substeps of the step [N^2 m^2] (``wqwarp.kernels.power``)."""
    power_sq: wp.array(dtype=wp.float32)
    """(N,) sum_j (tau_j qd_j)^2, substep average [W^2]."""
    p_cost: wp.array(dtype=wp.float32)
    """(N,) sum_j |tau_j| |qd_j|, substep average [W] (``wqwarp.kernels.power``)."""
    body_collision: wp.array2d(dtype=wp.int32)
    """(N, 9) 1 for each trunk / thigh / calf body touching the ground."""
    actuated_q: wp.array2d(dtype=wp.float32)
    """(N, 16) actuated joint positions after the step, project order (legs first) [rad]."""
    joint_soft_low: wp.array(dtype=wp.float32)
    """(12,) soft lower limit of each leg joint [rad]: range centre minus ``soft_joint_limit`` x half width."""
    joint_soft_high: wp.array(dtype=wp.float32)
    """(12,) soft upper limit of each leg joint [rad]."""
    sigma: float
    """Tracking sharpness: the 4 in exp(-4 err^2) [1/(m/s)^2]."""
    dt: float
    """Policy step [s]."""


@wp.func
def tracking_reward(cmd: float, actual: float, sigma: float) -> float:
    """exp(-sigma (cmd - actual)^2) [-]: Table II velocity tracking (sigma = 4)."""
    e = cmd - actual
    return wp.exp(-sigma * e * e)


@wp.func
def squared_norm_xy(v: wp.vec3) -> float:
    """||v_xy||^2: orientation (projected gravity g_xy) and angular velocity (w_xy) penalties."""
    return v[0] * v[0] + v[1] * v[1]


@wp.func
def track_vx(inp: RewardInputs, i: int, v: wp.vec3, w: wp.vec3, g: wp.vec3) -> float:
    """exp(-sigma (v_x^cmd - v_x)^2) [-]: linear velocity tracking along the base x axis."""
    return tracking_reward(inp.command[i, 0], v[0], inp.sigma)


@wp.func
def track_vy(inp: RewardInputs, i: int, v: wp.vec3, w: wp.vec3, g: wp.vec3) -> float:
    """exp(-sigma (v_y^cmd - v_y)^2) [-]: linear velocity tracking along the base y axis."""
    return tracking_reward(inp.command[i, 1], v[1], inp.sigma)


@wp.func
def track_wz(inp: RewardInputs, i: int, v: wp.vec3, w: wp.vec3, g: wp.vec3) -> float:
    """exp(-sigma (w_z^cmd - w_z)^2) [-]: yaw rate tracking."""
    return tracking_reward(inp.command[i, 2], w[2], inp.sigma)


@wp.func
def residual(inp: RewardInputs, i: int, v: wp.vec3, w: wp.vec3, g: wp.vec3) -> float:
    """||a_t|| [-]: L2 norm of the raw action (the residual)."""
    s = float(0.0)
    for j in range(inp.action.shape[1]):
        s += inp.action[i, j] * inp.action[i, j]
    return wp.sqrt(s)


@wp.func
def orientation(inp: RewardInputs, i: int, v: wp.vec3, w: wp.vec3, g: wp.vec3) -> float:
    """||g_xy||^2 [-]: projected gravity off the base z axis."""
    return squared_norm_xy(g)


@wp.func
def lin_vel_z(inp: RewardInputs, i: int, v: wp.vec3, w: wp.vec3, g: wp.vec3) -> float:
    """v_z^2 [m^2/s^2]: vertical base velocity."""
    return v[2] * v[2]


@wp.func
def ang_vel_xy(inp: RewardInputs, i: int, v: wp.vec3, w: wp.vec3, g: wp.vec3) -> float:
    """||w_xy||^2 [rad^2/s^2]: roll and pitch rates."""
    return squared_norm_xy(w)


@wp.func
def joint_acc(inp: RewardInputs, i: int, v: wp.vec3, w: wp.vec3, g: wp.vec3) -> float:
    """||qdd||^2 [rad^2/s^4]: the 16 joint accelerations by finite difference over the policy step."""
    r = float(0.0)
    for j in range(inp.actuated_qd.shape[1]):
        a = (inp.actuated_qd[i, j] - inp.prev_actuated_qd[i, j]) / inp.dt
        r += a * a
    return r


@wp.func
def torques(inp: RewardInputs, i: int, v: wp.vec3, w: wp.vec3, g: wp.vec3) -> float:
    """||tau||^2 [N^2 m^2]: squared joint torques, substep average."""
    return inp.torque_sq[i]


@wp.func
def action_smoothness(inp: RewardInputs, i: int, v: wp.vec3, w: wp.vec3, g: wp.vec3) -> float:
    """||a_t + a_{t-2} - 2 a_{t-1}||^2 [-]: second difference of the actions."""
    r = float(0.0)
    for j in range(inp.action.shape[1]):
        d = inp.action[i, j] + inp.prev2_action[i, j] - 2.0 * inp.prev_action[i, j]
        r += d * d
    return r


@wp.func
def collision(inp: RewardInputs, i: int, v: wp.vec3, w: wp.vec3, g: wp.vec3) -> float:
    """sum_c 1[body c touches the ground] [-]: trunk, thigh and calf contacts."""
    r = float(0.0)
    for c in range(inp.body_collision.shape[1]):
        r += float(inp.body_collision[i, c])
    return r


@wp.func
def energy(inp: RewardInputs, i: int, v: wp.vec3, w: wp.vec3, g: wp.vec3) -> float:
    """||tau * qd||^2 [W^2]: squared norm of the joint powers, substep average."""
    return inp.power_sq[i]


@wp.func
def p_cost(inp: RewardInputs, i: int, v: wp.vec3, w: wp.vec3, g: wp.vec3) -> float:
    """sum_j |tau_j| |qd_j| [W]: the paper's power cost, substep average (beyond Table II)."""
    return inp.p_cost[i]


@wp.func
def joint_limits(inp: RewardInputs, i: int, v: wp.vec3, w: wp.vec3, g: wp.vec3) -> float:
    """sum_j max(0, l_j - q_j) + max(0, q_j - u_j) [rad]: leg joints beyond their soft limits (beyond Table II)."""
    r = float(0.0)
    for j in range(inp.joint_soft_low.shape[0]):
        q = inp.actuated_q[i, j]
        r += wp.max(inp.joint_soft_low[j] - q, 0.0) + wp.max(q - inp.joint_soft_high[j], 0.0)
    return r


_KERNELS: dict[tuple[wp.Function, ...], wp.Kernel] = {}


def make_reward_kernel(terms: tuple[wp.Function, ...]) -> wp.Kernel:
    """The kernel weighing and summing ``terms`` (term funcs in column order), built once per term tuple.

    Launch with ``dim=N``, inputs ``(inp: RewardInputs, weight (K,) float32)``, outputs ``(reward (N,), term (N, K),
    episode_sum (N, K))``: ``term`` gets the weighted terms w_k r_k dt, ``episode_sum`` accumulates them, ``reward``
    their sum. The loop over the terms is unrolled at code generation (``wp.static``), one call per term."""
    terms = tuple(terms)
    if terms in _KERNELS:
        return _KERNELS[terms]

    @wp.kernel(module="unique")
    def sum_rewards(
        inp: RewardInputs,
        weight: wp.array(dtype=wp.float32),
        # outputs
        reward: wp.array(dtype=wp.float32),
        term: wp.array2d(dtype=wp.float32),
        episode_sum: wp.array2d(dtype=wp.float32),
    ):
        i = wp.tid()
        v = wp.vec3(inp.base_lin_vel[i, 0], inp.base_lin_vel[i, 1], inp.base_lin_vel[i, 2])
        w = wp.vec3(inp.base_ang_vel[i, 0], inp.base_ang_vel[i, 1], inp.base_ang_vel[i, 2])
        g = wp.vec3(inp.projected_gravity[i, 0], inp.projected_gravity[i, 1], inp.projected_gravity[i, 2])
        total = float(0.0)
        for k in range(wp.static(len(terms))):
            wk = weight[k]
            r = float(0.0)
            if wk != 0.0:
                r = wp.static(terms[k])(inp, i, v, w, g)
            rk = wk * r * inp.dt
            term[i, k] = rk
            episode_sum[i, k] += rk
            total += rk
        reward[i] = total

    _KERNELS[terms] = sum_rewards
    return sum_rewards
