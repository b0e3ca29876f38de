"""Leg forward and inverse kinematics of the wheeled Go1 for a point fixed to the calf, in the hip frame.

The hip frame sits at the hip (abduction) joint origin with the trunk's axes (before the abduction rotation).
Chain of one leg, the same for all legs with ``side`` = +1 for a left leg and -1 for a right leg
(``constants.LEG_SIDE_SIGN``)::

    hip joint    rotates about x at the hip-frame origin                     (q_hip)
    thigh joint  at (0, side * 0.08, 0) in the hip body, rotates about y    (q_thigh)
    knee joint   at (0, 0, -0.213) in the thigh frame, rotates about y      (q_calf)
    point c      at (c_x, side * c_y, c_z) in the calf frame (c given for a left leg)

Two points matter: the **wheel centre** ``WHEEL_POINT`` = (-0.015, -0.0245, -0.233) (inboard; where the wheel
touches the ground, used for Eq. (3)'s lateral distance d) and the **foot point** ``FOOT_POINT`` = (0, 0, -0.213),
the calf end that the authors' trajectory generator places with its IK (the nominal gait and the policy's foot
residuals refer to it). ``leg_fk`` is the wheel centre's FK (Eq. (3)), ``foot_ik`` the foot point's IK (nominal gait
and residuals); ``leg_point_fk`` / ``leg_point_ik`` take any point (the launchers below and their tests).

References:
    Go1 geometry: ``wqwarp.robot.constants`` (MuJoCo Menagerie ``go1.xml`` and the authors' wheeled-Go1 model).
"""

from __future__ import annotations

import math

import numpy as np
import warp as wp

from wqwarp.robot import constants

# --- geometry as Warp constants, generated from constants.py ----------------------------------------------------
THIGH_OFFSET_Y = wp.constant(float(constants.THIGH_OFFSET_Y))
"""|y| of the thigh joint from the hip joint [m]."""
THIGH_LENGTH = wp.constant(float(constants.THIGH_LENGTH))
"""Knee below the thigh joint [m]."""
WHEEL_POINT = wp.constant(wp.vec3(*[float(x) for x in constants.WHEEL_CENTER_IN_CALF]))
"""Wheel centre in the calf frame of a left leg [m] (y mirrored on right legs)."""
FOOT_POINT = wp.constant(wp.vec3(*[float(x) for x in constants.FOOT_IN_CALF]))
"""Foot point (calf end) in the calf frame [m]."""

HIP_LOWER = wp.constant(float(constants.HIP_RANGE[0]))
HIP_UPPER = wp.constant(float(constants.HIP_RANGE[1]))
THIGH_LOWER = wp.constant(float(constants.THIGH_RANGE[0]))
THIGH_UPPER = wp.constant(float(constants.THIGH_RANGE[1]))
CALF_LOWER = wp.constant(float(constants.CALF_RANGE[0]))
CALF_UPPER = wp.constant(float(constants.CALF_RANGE[1]))
"""Joint ranges [rad] (constants.HIP_RANGE, THIGH_RANGE, CALF_RANGE)."""

LEG_SIDE = wp.constant(wp.vec4(*constants.LEG_SIDE_SIGN))
"""Side sign of each leg in project order FR, FL, RR, RL (+1 left, -1 right)."""

TWO_PI = wp.constant(2.0 * math.pi)


@wp.func
def wrap_angle(a: float, lower: float) -> float:
    """Angle a [rad] wrapped into [lower, lower + 2 pi)."""
    return a - TWO_PI * wp.floor((a - lower) / TWO_PI)


@wp.func
def leg_point_fk(q: wp.vec3, side: float, c: wp.vec3) -> wp.vec3:
    """Forward kinematics of the calf point c [m] (left-leg convention) in the hip frame from (hip, thigh, calf) q.

    p = R_x(q_hip) ((0, s 0.08, 0) + R_y(q_thigh) ((0, 0, -0.213) + R_y(q_calf) (c_x, s c_y, c_z))).
    """
    # point in the thigh frame (x-z plane; y is the constant lateral offset)
    c2 = wp.cos(q[2])
    s2 = wp.sin(q[2])
    tx = c[0] * c2 + c[2] * s2
    tz = -THIGH_LENGTH - c[0] * s2 + c[2] * c2
    # in the hip body frame
    c1 = wp.cos(q[1])
    s1 = wp.sin(q[1])
    x = tx * c1 + tz * s1
    z = -tx * s1 + tz * c1
    y = side * (THIGH_OFFSET_Y + c[1])
    # in the hip frame (abduction about x)
    c0 = wp.cos(q[0])
    s0 = wp.sin(q[0])
    return wp.vec3(x, y * c0 - z * s0, y * s0 + z * c0)


@wp.func
def leg_point_ik(p: wp.vec3, side: float, c: wp.vec3) -> wp.vec3:
    """Analytic leg inverse kinematics: (hip, thigh, calf) [rad] putting the calf point c at p [m] (hip frame).

    Branch: point below the thigh joint in the hip body frame (z < 0) and knee bent backwards (q_calf < 0), the
    Go1 configuration. Unreachable targets are projected onto the workspace boundary, and the result is clamped to
    the joint ranges, so the output is always a valid joint target.
    """
    lat = side * (THIGH_OFFSET_Y + c[1])
    reach = wp.sqrt(c[0] * c[0] + c[2] * c[2])  # knee to point in the calf's x-z plane
    gamma = wp.atan2(-c[2], c[0])  # c_x sin q - c_z cos q = reach sin(q + gamma)
    # abduction: R_x(q_hip) (lat, z_b) = (p_y, p_z) with z_b = -sqrt(p_y^2 + p_z^2 - lat^2)
    r_yz_sq = p[1] * p[1] + p[2] * p[2]
    z_b = -wp.sqrt(wp.max(r_yz_sq - lat * lat, 0.0))
    q_hip = wrap_angle(wp.atan2(p[2], p[1]) - wp.atan2(z_b, lat), -wp.pi)
    # knee from the thigh-to-point distance: r^2 = L1^2 + L2^2 + 2 L1 L2 sin(q_calf + gamma)
    x_b = p[0]
    r_sq = x_b * x_b + z_b * z_b
    k = (r_sq - THIGH_LENGTH * THIGH_LENGTH - reach * reach) / (2.0 * THIGH_LENGTH * reach)
    q_calf = wp.asin(wp.clamp(k, -1.0, 1.0)) - gamma
    # thigh: R_y rotates the angle atan2(x, z) by q_thigh
    c2 = wp.cos(q_calf)
    s2 = wp.sin(q_calf)
    tx = c[0] * c2 + c[2] * s2
    tz = -THIGH_LENGTH - c[0] * s2 + c[2] * c2
    q_thigh = wrap_angle(wp.atan2(x_b, z_b) - wp.atan2(tx, tz), THIGH_LOWER)
    return wp.vec3(
        wp.clamp(q_hip, HIP_LOWER, HIP_UPPER),
        wp.clamp(q_thigh, THIGH_LOWER, THIGH_UPPER),
        wp.clamp(q_calf, CALF_LOWER, CALF_UPPER),
    )


@wp.func
def leg_fk(q: wp.vec3, side: float) -> wp.vec3:
    """Wheel centre [m] in the hip frame from (hip, thigh, calf) q [rad]."""
    return leg_point_fk(q, side, WHEEL_POINT)


@wp.func
def foot_ik(p: wp.vec3, side: float) -> wp.vec3:
    """(hip, thigh, calf) [rad] putting the foot point (calf end) at p [m] (hip frame); see :func:`leg_point_ik`."""
    return leg_point_ik(p, side, FOOT_POINT)


@wp.kernel
def eval_leg_ik(
    target: wp.array2d(dtype=wp.vec3),
    point: wp.vec3,
    # outputs
    joint_q: wp.array2d(dtype=float),
):
    """Targets of the calf point ``point`` in the hip frames (world_count, 4) [m] -> leg joints (world_count, 12)."""
    world, leg = wp.tid()
    q = leg_point_ik(target[world, leg], LEG_SIDE[leg], point)
    for j in range(3):
        joint_q[world, 3 * leg + j] = q[j]


@wp.kernel
def eval_leg_fk(
    joint_q: wp.array2d(dtype=float),
    point: wp.vec3,
    # outputs
    pos: wp.array2d(dtype=wp.vec3),
):
    """Leg joint angles (world_count, 12) [rad] -> the calf point ``point`` in the hip frames (world_count, 4) [m]."""
    world, leg = wp.tid()
    q = wp.vec3(joint_q[world, 3 * leg], joint_q[world, 3 * leg + 1], joint_q[world, 3 * leg + 2])
    pos[world, leg] = leg_point_fk(q, LEG_SIDE[leg], point)


def compute_leg_ik(target: wp.array2d, joint_q: wp.array2d | None = None, point=constants.WHEEL_CENTER_IN_CALF):
    """Launch :func:`eval_leg_ik`.

    Args:
        target: targets of ``point`` in each leg's hip frame, (world_count, 4) vec3 [m], legs FR, FL, RR, RL.
        joint_q: optional output, (world_count, 12) float32; allocated on target's device when None.
        point: the calf point (left-leg convention) [m]: the wheel centre (default) or ``constants.FOOT_IN_CALF``.

    Returns:
        joint_q: (hip, thigh, calf) of each leg, leg-major, (world_count, 12) float32 [rad], clamped to the ranges.
    """
    world_count = target.shape[0]
    if joint_q is None:
        joint_q = wp.zeros((world_count, constants.NUM_LEG_JOINTS), dtype=float, device=target.device)
    wp.launch(
        eval_leg_ik,
        dim=(world_count, constants.NUM_LEGS),
        inputs=[target, wp.vec3(*point)],
        outputs=[joint_q],
        device=target.device,
    )
    return joint_q


def compute_leg_fk(joint_q: wp.array2d, pos: wp.array2d | None = None, point=constants.WHEEL_CENTER_IN_CALF):
    """Launch :func:`eval_leg_fk`.

    Args:
        joint_q: leg joint angles, leg-major (hip, thigh, calf) x FR, FL, RR, RL, (world_count, 12) float32 [rad].
        pos: optional output, (world_count, 4) vec3; allocated on joint_q's device when None.
        point: the calf point (left-leg convention) [m]: the wheel centre (default) or ``constants.FOOT_IN_CALF``.

    Returns:
        pos: ``point`` in each leg's hip frame, (world_count, 4) vec3 [m].
    """
    world_count = joint_q.shape[0]
    if pos is None:
        pos = wp.zeros((world_count, constants.NUM_LEGS), dtype=wp.vec3, device=joint_q.device)
    wp.launch(
        eval_leg_fk,
        dim=(world_count, constants.NUM_LEGS),
        inputs=[joint_q, wp.vec3(*point)],
        outputs=[pos],
        device=joint_q.device,
    )
    return pos


def leg_fk_numpy(q: np.ndarray, side: float, point=constants.WHEEL_CENTER_IN_CALF) -> np.ndarray:
    """NumPy reference of :func:`leg_point_fk` for q of shape (..., 3) [rad]; returns (..., 3) [m] (tests, tools)."""
    q = np.asarray(q, dtype=np.float64)
    c = np.asarray(point, dtype=np.float64)
    q0, q1, q2 = q[..., 0], q[..., 1], q[..., 2]
    tx = c[0] * np.cos(q2) + c[2] * np.sin(q2)
    tz = -constants.THIGH_LENGTH - c[0] * np.sin(q2) + c[2] * np.cos(q2)
    x = tx * np.cos(q1) + tz * np.sin(q1)
    z = -tx * np.sin(q1) + tz * np.cos(q1)
    y = side * (constants.THIGH_OFFSET_Y + c[1])
    return np.stack([x, y * np.cos(q0) - z * np.sin(q0), y * np.sin(q0) + z * np.cos(q0)], axis=-1)
