"""Names, order and geometry of the wheeled Go1, in one place.

Every module that indexes legs, joints or bodies imports them from here.

References:
    Go1 kinematics, limits and masses: MuJoCo Menagerie ``unitree_go1/go1.xml`` (BSD-3, commit 1f39894) and Unitree's
    ``go1_description`` URDF, summarised in ``../shared/reference/go1/FACTS.md``.
    Wheel numbers: the paper's first author's public sim-to-sim harness (MIT), summarised in
    ``../shared/reference/SIMULATION_FACTS.md``; AK80-6 data sheet (T-Motor) for the wheel motor.

Actuated joint order (16), used for every per-joint array (targets, torques, velocities, actions)::

    index  0  1  2 | 3  4  5 | 6  7  8 | 9 10 11 | 12 13 14 15
    leg    FR      | FL      | RR      | RL      | wheels FR FL RR RL
    joint  hip thigh calf (each leg)             |

Leg order FR, FL, RR, RL is the Go1 MJCF order (qpos and actuators). Wheels come after the 12 leg joints, as
in public Go2-W deploy configs (wheel indices 12-15).
"""

from __future__ import annotations

import math
import os

LEG_NAMES: tuple[str, ...] = ("FR", "FL", "RR", "RL")
"""Leg order used everywhere: front-right, front-left, rear-right, rear-left."""

NUM_LEGS = 4
JOINTS_PER_LEG = 3
NUM_LEG_JOINTS = 12
NUM_WHEELS = 4
NUM_ACTUATED = 16

LEG_JOINT_KINDS: tuple[str, ...] = ("hip", "thigh", "calf")
LEG_JOINT_NAMES: tuple[str, ...] = tuple(f"{leg}_{kind}_joint" for leg in LEG_NAMES for kind in LEG_JOINT_KINDS)
WHEEL_JOINT_NAMES: tuple[str, ...] = tuple(f"{leg}_wheel_joint" for leg in LEG_NAMES)
ACTUATED_JOINT_NAMES: tuple[str, ...] = LEG_JOINT_NAMES + WHEEL_JOINT_NAMES
"""The 16 actuated joints in project order: 12 leg joints (leg-major), then 4 wheels."""

WHEEL_INDICES: tuple[int, ...] = (12, 13, 14, 15)
"""Indices of the wheel joints inside the 16 actuated joints."""
JOINT_KIND_INDICES: dict[str, tuple[int, ...]] = {
    "hip": tuple(range(0, NUM_LEG_JOINTS, JOINTS_PER_LEG)),
    "thigh": tuple(range(1, NUM_LEG_JOINTS, JOINTS_PER_LEG)),
    "knee": tuple(range(2, NUM_LEG_JOINTS, JOINTS_PER_LEG)),  # the calf joint
    "wheel": WHEEL_INDICES,
}
"""Indices, inside the 16 actuated joints, of each kind of joint over the four legs."""

# Sign of each leg's side: +1 for a left leg (y > 0), -1 for a right leg; +1 for front (x > 0), -1 for rear.
LEG_SIDE_SIGN: tuple[float, ...] = (-1.0, 1.0, -1.0, 1.0)
LEG_FRONT_SIGN: tuple[float, ...] = (1.0, 1.0, -1.0, -1.0)

# --- Kinematics (metres), FACTS.md "Frames and kinematics" -------------------------------------------------------
HIP_OFFSET_X = 0.1881
"""|x| of the hip (abduction) joint origin in the trunk frame [m] (go1.xml)."""
HIP_OFFSET_Y = 0.04675
"""|y| of the hip joint origin in the trunk frame [m] (go1.xml)."""
THIGH_OFFSET_Y = 0.08
"""|y| of the thigh joint origin from the hip body [m]; left +, right - (go1.xml)."""
THIGH_LENGTH = 0.213
"""Knee origin from the thigh joint, along -z [m] (go1.xml)."""
CALF_LENGTH = 0.213
"""Foot centre from the knee, along -z [m] (go1.xml); the wheel replaces the foot."""

# --- Wheel (SIMULATION_FACTS.md, public wheeled-Go1 harness) ------------------------------------------------------
WHEEL_RADIUS = 0.075
"""Wheel (tyre) radius [m]."""
WHEEL_WIDTH = 0.03
"""Wheel width [m]."""
WHEEL_MASS = 0.2023
"""Wheel mass [kg]."""
WHEEL_MOTOR_MASS = 0.514
"""Wheel-motor link fixed at the calf end [kg] (harness value; AK80-6 alone is 0.485 kg)."""
WHEEL_CENTER_IN_CALF = (-0.015, -0.0245, -0.233)
"""Wheel centre in the calf frame [m] for a left leg; the y sign flips on a right leg. INBOARD of the calf, as in the
authors' public model (xu-yang16/wheeled-quadruped-sim2sim ``resources/wheeled_go1/xml/wheeled_go1.xml``: FR wheel
body at calf-frame y = +0.0085 with its collision cylinder a further 0.016 along the axis, i.e. y = +0.0245 on the
right legs, FL at -0.0085 - 0.016 = -0.0245; the URDF ``resources/wheeled_go1/meshes/wheeled_go1.urdf`` agrees)."""
WHEEL_MOTOR_IN_CALF = (-0.015, 0.0025, -0.233)
"""Wheel-motor (AK80-6) centre in the calf frame [m] for a left leg (y flips on a right leg): coaxial with the wheel,
where the authors' MJCF puts its collision cylinder (r 0.049, half-width 0.01375; FR at y = -0.0025, FL at +0.0025).
Their calf inertial (0.650 kg, COM z -0.208) is the Menagerie calf plus a 0.514 kg mass at this point."""
WHEEL_ARMATURE = 6.07e-5 * 36.0
"""Wheel-joint armature [kg m^2]: the AK80-6 rotor inertia (6.07e-5 kg m^2) reflected through its 6:1 gearbox."""
WHEEL_AIRBORNE_INERTIA = 0.5 * WHEEL_MASS * WHEEL_RADIUS**2 + WHEEL_ARMATURE
"""Inertia a wheel-speed controller drives when the wheel is off the ground [kg m^2]: the wheel's axial inertia
(solid cylinder, 5.7e-4) plus the armature, 2.75e-3 in all. It bounds the explicit velocity-feedback gain."""
AUTHORS_JOINT_MODEL = {"damping": 0.01, "armature": 0.01, "friction": 0.2}
"""The passive joint model of the authors' MuJoCo robot, a class default for every joint: damping [N m s/rad],
armature [kg m^2] and friction loss (dry friction) [N m] (xu-yang16/wheeled-quadruped-sim2sim
``resources/wheeled_go1/xml/wheeled_go1.xml`` line 11: ``<joint damping="0.01" armature="0.01" frictionloss="0.2"/>``).
Keys are Newton's ``joint_damping`` / ``joint_armature`` / ``joint_friction`` without the prefix."""
AUTHORS_GROUND_FRICTION = 0.6
"""Sliding friction of every contact in the authors' MuJoCo model [-] (same file, line 7: geom default
``friction="0.6 0.3 0.3"``)."""
WHEEL_TORQUE_LIMIT = 6.0
"""Wheel torque limit [N m]: AK80-6 rated torque (peak 12 N m)."""
WHEEL_VELOCITY_LIMIT = 38.2
"""Wheel speed limit [rad/s]: AK80-6 top speed at 24 V (365 rpm)."""
WHEEL_FORWARD_SIGN = 1.0
"""Wheel joint axes point +y, so a positive wheel speed rolls the robot forward (+x).

The paper's Eq. (3) carries a leading minus because its wheel axes point the other way.
"""

# --- Joint limits and torque limits, FACTS.md "Joint limits and actuators" ----------------------------------------
HIP_RANGE = (-0.863, 0.863)
THIGH_RANGE = (-0.686, 4.501)
CALF_RANGE = (-2.818, -0.888)
HIP_TORQUE_LIMIT = 23.7
THIGH_TORQUE_LIMIT = 23.7
CALF_TORQUE_LIMIT = 35.55
HIP_VELOCITY_LIMIT = 30.1
THIGH_VELOCITY_LIMIT = 30.1
CALF_VELOCITY_LIMIT = 20.06

LEG_JOINT_RANGES: tuple[tuple[float, float], ...] = (HIP_RANGE, THIGH_RANGE, CALF_RANGE) * NUM_LEGS
TORQUE_LIMITS: tuple[float, ...] = (HIP_TORQUE_LIMIT, THIGH_TORQUE_LIMIT, CALF_TORQUE_LIMIT) * NUM_LEGS + (
    WHEEL_TORQUE_LIMIT,
) * NUM_WHEELS
"""Torque limit of each actuated joint, project order [N m]."""

# --- Nominal gait geometry and default pose (the authors' trajectory generator) ------------------------------------
FOOT_IN_CALF = (0.0, 0.0, -CALF_LENGTH)
"""The point the authors' trajectory generator places and its leg IK solves for [m], calf frame: the calf end (Go1's
foot point; ``sim/policy_manager/PMTG.py``: IK with hip 0.08, thigh 0.213, calf 0.213 m). The nominal gait's h_b and
the policy's foot residuals refer to this point; the wheel centre hangs 0.02 m below and 0.015 m behind it."""
NOMINAL_BODY_HEIGHT = 0.2
"""h_b: foot point (calf end) below the hip joint in stance [m] (PMTG.py ``body_height``; config
``sim/policy_manager/policy_config/my_legged_robot_config.py`` pmtg.body_height = 0.2)."""
NOMINAL_SWING_HEIGHT = 0.1
"""h_s: swing clearance [m] (config pmtg.max_clearance = 0.1)."""
NOMINAL_FOOT_XY = ((0.0149, -0.09525), (0.0149, 0.09525), (0.0321, -0.09525), (0.0321, 0.09525))
"""Nominal stance foot point (x, y) in each hip frame [m], legs FR, FL, RR, RL: PMTG.py's nominal foot positions in
the base frame ``HIP_POSITION`` (+-0.203 / -0.156, +-0.142) minus its ``HIP_OFFSETS`` (+-0.1881, +-0.04675)."""
MAX_HORIZONTAL_OFFSET = 0.05
"""Horizontal swing amplitude [m]: swing x = -0.05 sin(2 pi psi); the driving gait holds x = -0.05 (config
pmtg.max_horizontal_offset = 0.05; PMTG.py ``gen_foot_trajectory_axis_z``)."""
DEFAULT_LEG_ANGLES_RIGHT = (-0.1, 1.08, -2.16)
DEFAULT_LEG_ANGLES_LEFT = (0.1, 1.08, -2.16)
"""Default (hip, thigh, calf) [rad] of a right / left leg: the authors' reset stance and observation offset
(config ``init_state.default_joint_angles``: hip -+0.1, thigh 1.08, calf -2.16). Foot point 0.201 m below the hip."""
DEFAULT_JOINT_POS: tuple[float, ...] = (
    DEFAULT_LEG_ANGLES_RIGHT + DEFAULT_LEG_ANGLES_LEFT + DEFAULT_LEG_ANGLES_RIGHT + DEFAULT_LEG_ANGLES_LEFT
) + (0.0,) * NUM_WHEELS
"""Default positions of the 16 actuated joints, project order [rad]."""


def _default_base_height() -> float:
    """Trunk-origin height [m] at which the wheels of the default pose touch flat ground (computed, not tuned)."""
    hip, thigh, calf = DEFAULT_LEG_ANGLES_LEFT
    cx, cy, cz = WHEEL_CENTER_IN_CALF
    # wheel centre in the thigh frame, then the hip body frame, then the abduction about x (as kernels/kinematics)
    tx = cx * math.cos(calf) + cz * math.sin(calf)
    tz = -THIGH_LENGTH - cx * math.sin(calf) + cz * math.cos(calf)
    z_b = -tx * math.sin(thigh) + tz * math.cos(thigh)
    y_b = THIGH_OFFSET_Y + cy
    z = y_b * math.sin(hip) + z_b * math.cos(hip)
    return -z + WHEEL_RADIUS


DEFAULT_BASE_HEIGHT = _default_base_height()
"""Trunk-origin height of the default pose on flat ground [m] (0.292 m: wheel centre 0.217 m below the hips)."""

# --- Bodies used for contact / collision reporting ---------------------------------------------------------------
TRUNK_BODY = "trunk"
COLLISION_BODY_NAMES: tuple[str, ...] = ("trunk",) + tuple(
    f"{leg}_{part}" for leg in LEG_NAMES for part in ("thigh", "calf")
)
"""Bodies whose ground contact counts as a collision (reward) - index 0, the trunk, also terminates an episode."""
WHEEL_BODY_NAMES: tuple[str, ...] = tuple(f"{leg}_wheel" for leg in LEG_NAMES)


def _asset_dir() -> str:
    """``usd/`` of the ``wqwarp.assets`` package data (the repository's ``assets/usd`` in a source or editable
    install, the installed copy otherwise); the source tree's folder when the package data cannot be resolved."""
    try:
        from importlib.resources import files

        found = files("wqwarp.assets") / "usd"
        if found.is_dir():
            return str(found)
    except (ModuleNotFoundError, TypeError):
        pass
    return os.path.join(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))), "assets", "usd")


ASSET_DIR = _asset_dir()
WHEELED_GO1_USD = os.path.join(ASSET_DIR, "wheeled_go1.usda")
"""The committed wheeled Go1 asset, written by ``tools/build_wheeled_go1.py``."""
