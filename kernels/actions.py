"""Turn the policy's action and the nominal gait into leg joint targets and wheel speed targets.

Residual presets (20 actions: dphi (4), dp (12, x y z per leg), dv (4))::

    p_des = p_n + clip(s_p a_p, +-c_p)  -> foot IK -> q_des (leg PD)    p: foot point (calf end), hip frame
    v_des = clip([v_n] + s_v a_v, +-c_v)                 (wheel PID; v_n only with nominal wheel velocities)

Baseline (16 actions: joint offsets (12), wheel speeds (4)): q_des = q_default + s_q a_q, v_des = clip(s_v a_v).
"""

from __future__ import annotations

import warp as wp

from .kinematics import LEG_SIDE, foot_ik


@wp.kernel
def residual_targets(
    action: wp.array2d(dtype=wp.float32),
    foot_target: wp.array2d(dtype=wp.vec3),
    nominal_wheel_velocity: wp.array2d(dtype=wp.float32),
    use_nominal_wheels: int,
    foot_scale: float,
    foot_clip: float,
    wheel_scale: float,
    wheel_clip: float,
    # outputs
    foot_residual: wp.array2d(dtype=wp.vec3),
    leg_q_target: wp.array2d(dtype=wp.float32),
    wheel_qd_target: wp.array2d(dtype=wp.float32),
):
    """Per (world, leg): desired foot point p_n + dp in the hip frame [m] -> IK -> 3 joint targets [rad]; wheel
    speed target [rad/s]. Action columns: 4 + 3 leg + axis for dp, 16 + leg for dv."""
    world, leg = wp.tid()
    dp = wp.vec3(0.0, 0.0, 0.0)
    for k in range(3):
        dp[k] = wp.clamp(foot_scale * action[world, 4 + 3 * leg + k], -foot_clip, foot_clip)
    foot_residual[world, leg] = dp
    q = foot_ik(foot_target[world, leg] + dp, LEG_SIDE[leg])
    for k in range(3):
        leg_q_target[world, 3 * leg + k] = q[k]
    v = wheel_scale * action[world, 16 + leg]
    if use_nominal_wheels != 0:
        v += nominal_wheel_velocity[world, leg]
    wheel_qd_target[world, leg] = wp.clamp(v, -wheel_clip, wheel_clip)


@wp.kernel
def joint_offset_targets(
    action: wp.array2d(dtype=wp.float32),
    default_leg_q: wp.array(dtype=wp.float32),
    joint_scale: float,
    wheel_scale: float,
    wheel_clip: float,
    # outputs
    leg_q_target: wp.array2d(dtype=wp.float32),
    wheel_qd_target: wp.array2d(dtype=wp.float32),
):
    """Baseline, per world: q_des = q_default + s_q a[0:12] [rad]; v_des = clip(s_v a[12:16]) [rad/s]."""
    world = wp.tid()
    for j in range(12):
        leg_q_target[world, j] = default_leg_q[j] + joint_scale * action[world, j]
    for k in range(4):
        wheel_qd_target[world, k] = wp.clamp(wheel_scale * action[world, 12 + k], -wheel_clip, wheel_clip)


@wp.kernel
def offset_targets(
    leg_q_nominal: wp.array2d(dtype=wp.float32),
    wheel_qd_nominal: wp.array2d(dtype=wp.float32),
    leg_offset: wp.array2d(dtype=wp.float32),
    wheel_offset: wp.array2d(dtype=wp.float32),
    # outputs
    leg_q_target: wp.array2d(dtype=wp.float32),
    wheel_qd_target: wp.array2d(dtype=wp.float32),
):
    """Per world: q_des = q_n + dq [rad], v_des = v_n + dv [rad/s], constant offsets on the nominal targets (the
    leg- and wheel-target inputs whose gradients a differentiable rollout reports); no clipping, so the sum stays
    differentiable."""
    world = wp.tid()
    for j in range(12):
        leg_q_target[world, j] = leg_q_nominal[world, j] + leg_offset[world, j]
    for k in range(4):
        wheel_qd_target[world, k] = wheel_qd_nominal[world, k] + wheel_offset[world, k]
