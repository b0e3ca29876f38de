"""Load the wheeled Go1 USD into Newton and describe where the project's joints and bodies live in the model.

Newton orders a USD articulation depth-first by prim name (FL, FR, RL, RR), while the project uses FR, FL, RR, RL
(``wqwarp.robot.constants``). :class:`RobotLayout` holds the per-world index maps between the two, so kernels index
``joint_q`` / ``joint_qd`` / ``body_q`` through small int arrays and nothing else depends on Newton's order.
"""

from __future__ import annotations

import os
from dataclasses import dataclass

import newton
import numpy as np

from wqwarp.robot import constants as C


@dataclass(frozen=True)
class RobotLayout:
    """Index maps of one robot (one world) inside a Newton model, relative to the world's first entry."""

    coords_per_world: int
    """Length of one world's ``joint_q`` row (7 free-joint coordinates + 16 revolute)."""
    dofs_per_world: int
    """Length of one world's ``joint_qd`` row (6 + 16)."""
    bodies_per_world: int
    actuated_coord: np.ndarray
    """(16,) int32: ``joint_q`` column of each actuated joint, project order."""
    actuated_dof: np.ndarray
    """(16,) int32: ``joint_qd`` column of each actuated joint, project order."""
    wheel_body: np.ndarray
    """(4,) int32: body of each wheel, leg order."""
    collision_body: np.ndarray
    """(9,) int32: trunk then thigh and calf of each leg (``constants.COLLISION_BODY_NAMES``)."""
    trunk_body: int
    total_mass: float
    """Mass of one robot [kg]."""


def _short(label: str) -> str:
    return label.rsplit("/", 1)[-1]


def robot_usd_path() -> str:
    """The robot asset: ``$WQWARP_ROBOT_USD`` if set (a modified robot), else the packaged wheeled Go1."""
    return os.environ.get("WQWARP_ROBOT_USD") or C.WHEELED_GO1_USD


def is_mjcf(path: str) -> bool:
    """Whether a robot description is an MJCF file (by its ``.xml`` extension); anything else is read as USD."""
    return path.lower().endswith(".xml")


def add_robot(builder: newton.ModelBuilder, usd_path: str | None = None) -> None:
    """Add one wheeled Go1 (free-floating base) to ``builder``; self-collisions off (legs cannot reach each other).
    ``usd_path`` is a USD or an MJCF (``.xml``, e.g. the paper authors' MuJoCo robot); an MJCF's wheel joints whose
    axis points to -y are turned to +y (:func:`_wheels_roll_forward`). A missing or unreadable asset is a ValueError
    naming the file."""
    usd_path = usd_path or robot_usd_path()
    if not os.path.isfile(usd_path):
        raise ValueError(
            f"robot asset {usd_path} does not exist (regenerate it with tools/build_wheeled_go1.py, or "
            "reinstall wqwarp)"
        )
    joints, shapes = builder.joint_count, builder.shape_count
    try:
        if is_mjcf(usd_path):  # the simulator's own options (time step, solver) stay
            builder.add_mjcf(usd_path, enable_self_collisions=False, floating=True, parse_mujoco_options=False)
        else:
            builder.add_usd(usd_path, enable_self_collisions=False, floating=True)
    except Exception as e:  # noqa: BLE001 - USD, MJCF and Newton raise many types for a broken file
        detail = " ".join(str(e).split())[:300]  # USD's messages span lines: keep the error to one
        raise ValueError(f"robot asset {usd_path} could not be read: {type(e).__name__}: {detail}") from e
    if builder.joint_count - joints < len(C.ACTUATED_JOINT_NAMES):
        raise ValueError(
            f"robot asset {usd_path} holds {builder.joint_count - joints} joints; the wheeled Go1 has "
            f"{len(C.ACTUATED_JOINT_NAMES)} actuated ones"
        )
    if is_mjcf(usd_path):
        _wheels_roll_forward(builder, joints, usd_path)
        for k in range(shapes, builder.shape_count):  # its own floor: the scene's ground plane is the one ground
            if builder.shape_body[k] == -1:
                builder.shape_flags[k] &= ~int(newton.ShapeFlags.COLLIDE_SHAPES | newton.ShapeFlags.COLLIDE_PARTICLES)


def _wheels_roll_forward(builder: newton.ModelBuilder, first_joint: int, path: str) -> None:
    """Turn every wheel joint of the robot added from joint ``first_joint`` on whose axis points to -y (body y,
    in the zero pose) so that it points to +y: a positive wheel speed then rolls the robot forward, the project's
    convention, on every leg. The same mechanism (axis -a at angle -q is axis a at angle q); the paper authors'
    MJCF has the right wheels' axes at -y."""
    import warp as wp

    names = [_short(k) for k in builder.joint_label[first_joint:]]
    q = {i: wp.quat_identity() for i in range(-1, builder.body_count)}  # body -> orientation in the zero pose
    for j in range(first_joint, builder.joint_count):  # parents come before children
        q[builder.joint_child[j]] = (
            q[builder.joint_parent[j]] * builder.joint_X_p[j].q * wp.quat_inverse(builder.joint_X_c[j].q)
        )
    for name in C.WHEEL_JOINT_NAMES:
        if name not in names:
            raise ValueError(f"robot asset {path} has no joint {name}")
        j = first_joint + names.index(name)
        dof = builder.joint_qd_start[j]
        axis = wp.vec3(*builder.joint_axis[dof])
        frame = q[builder.joint_parent[j]] * builder.joint_X_p[j].q  # the joint frame, where its axis is given
        world = wp.quat_rotate(frame, axis)
        if abs(world[1]) < 0.9 * wp.length(world):
            raise ValueError(f"robot asset {path}: {name}'s axis {tuple(world)} is not along the trunk's y")
        if world[1] < 0:
            builder.joint_axis[dof] = tuple(-float(a) for a in axis)


def _builder() -> newton.ModelBuilder:
    b = newton.ModelBuilder()
    newton.solvers.SolverMuJoCo.register_custom_attributes(b)
    # Contact gap 0 (MuJoCo's default) instead of Newton's 0.1 m: the gap only adds inactive contacts, which cost
    # narrow-phase time and would count as "touching" in contact sensors.
    b.default_shape_cfg.gap = 0.0
    return b


def robot_builder(usd_path: str | None = None) -> newton.ModelBuilder:
    """A builder holding one robot, for replication into worlds."""
    b = _builder()
    add_robot(b, usd_path)
    return b


def scene_builder(world_count: int, usd_path: str | None = None) -> newton.ModelBuilder:
    """``world_count`` robots, one per Newton world, on a shared ground plane."""
    if world_count < 1:
        raise ValueError(f"world_count must be >= 1, got {world_count}")
    template = robot_builder(usd_path)
    scene = _builder()
    scene.replicate(template, world_count)
    scene.add_ground_plane()
    return scene


def robot_layout(model: newton.Model) -> RobotLayout:
    """Index maps of world 0 of ``model`` (every world holds the same robot)."""
    world_count = model.world_count
    n_joint = model.joint_count // world_count
    n_body = model.body_count // world_count
    joint_names = [_short(k) for k in model.joint_label[:n_joint]]
    body_names = [_short(k) for k in model.body_label[:n_body]]
    q_start = model.joint_q_start.numpy()
    qd_start = model.joint_qd_start.numpy()
    try:
        joints = [joint_names.index(n) for n in C.ACTUATED_JOINT_NAMES]
        wheel = [body_names.index(n) for n in C.WHEEL_BODY_NAMES]
        coll = [body_names.index(n) for n in C.COLLISION_BODY_NAMES]
    except ValueError as e:
        raise ValueError(f"robot asset lacks a joint or body the project expects: {e}") from None
    mass = float(model.body_mass.numpy()[:n_body].sum())
    return RobotLayout(
        coords_per_world=model.joint_coord_count // world_count,
        dofs_per_world=model.joint_dof_count // world_count,
        bodies_per_world=n_body,
        actuated_coord=np.array([q_start[j] for j in joints], dtype=np.int32),
        actuated_dof=np.array([qd_start[j] for j in joints], dtype=np.int32),
        wheel_body=np.array(wheel, dtype=np.int32),
        collision_body=np.array(coll, dtype=np.int32),
        trunk_body=body_names.index(C.TRUNK_BODY),
        total_mass=mass,
    )


def default_joint_q(layout: RobotLayout, base_height: float = C.DEFAULT_BASE_HEIGHT) -> np.ndarray:
    """One world's ``joint_q`` row in the default pose: base at ``base_height``, level, legs at the default angles."""
    q = np.zeros(layout.coords_per_world, dtype=np.float32)
    q[2] = base_height
    q[6] = 1.0  # quaternion xyzw identity
    q[layout.actuated_coord] = np.asarray(C.DEFAULT_JOINT_POS, dtype=np.float32)
    return q
