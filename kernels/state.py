"""Robot state kernels: conversions between MuJoCo's generalized coordinates and Newton's ``joint_q`` / ``joint_qd``,
the base frame computed once per step for every consumer (:func:`compute_base_frame`), indexed state writes and
resets, the divergence check, and the base motion of the differentiable rollout.

For a robot whose root is a free joint at the world origin, the two layouts differ only in the root:
    MuJoCo  qpos[0:7] = (p, q_wxyz);  qvel[0:3] = v of the body origin, world frame; qvel[3:6] = omega, body frame
    Newton  q[0:7]    = (p, q_xyzw);  qd[0:3]   = v of the body COM, world frame;    qd[3:6]   = omega, world frame
Hinge coordinates are identical and in the same order (both walk the tree depth-first).
"""

from __future__ import annotations

import warp as wp


@wp.func
def com_velocity_from_origin(v_origin: wp.vec3, omega_world: wp.vec3, rot: wp.quat, com_local: wp.vec3) -> wp.vec3:
    """v_com = v_origin + omega x (R c) [m/s]: velocity of the COM from that of the body origin."""
    return v_origin + wp.cross(omega_world, wp.quat_rotate(rot, com_local))


@wp.kernel
def mujoco_state_to_newton(
    mj_state: wp.array2d(dtype=wp.float64),
    qpos_start: int,
    root_com: wp.vec3,
    # outputs
    joint_q: wp.array2d(dtype=wp.float32),
    joint_qd: wp.array2d(dtype=wp.float32),
):
    """Mirror MuJoCo full-physics state rows (N, nstate) into Newton ``joint_q`` (N, nq) and ``joint_qd`` (N, nv)."""
    world = wp.tid()
    nq = joint_q.shape[1]
    nv = joint_qd.shape[1]
    a = qpos_start
    rot = wp.quat(
        wp.float32(mj_state[world, a + 4]),
        wp.float32(mj_state[world, a + 5]),
        wp.float32(mj_state[world, a + 6]),
        wp.float32(mj_state[world, a + 3]),
    )
    for i in range(3):
        joint_q[world, i] = wp.float32(mj_state[world, a + i])
    joint_q[world, 3] = rot[0]
    joint_q[world, 4] = rot[1]
    joint_q[world, 5] = rot[2]
    joint_q[world, 6] = rot[3]
    for i in range(7, nq):
        joint_q[world, i] = wp.float32(mj_state[world, a + i])
    b = a + nq
    v_o = wp.vec3(
        wp.float32(mj_state[world, b]), wp.float32(mj_state[world, b + 1]), wp.float32(mj_state[world, b + 2])
    )
    w_b = wp.vec3(
        wp.float32(mj_state[world, b + 3]), wp.float32(mj_state[world, b + 4]), wp.float32(mj_state[world, b + 5])
    )
    w_w = wp.quat_rotate(rot, w_b)
    v_c = com_velocity_from_origin(v_o, w_w, rot, root_com)
    for i in range(3):
        joint_qd[world, i] = v_c[i]
        joint_qd[world, 3 + i] = w_w[i]
    for i in range(6, nv):
        joint_qd[world, i] = wp.float32(mj_state[world, b + i])


@wp.kernel
def newton_state_to_mujoco(
    joint_q: wp.array2d(dtype=wp.float32),
    joint_qd: wp.array2d(dtype=wp.float32),
    env_ids: wp.array(dtype=wp.int32),
    qpos_start: int,
    root_com: wp.vec3,
    # outputs
    mj_state: wp.array2d(dtype=wp.float64),
):
    """Write Newton coordinates of the robots in ``env_ids`` into their MuJoCo state rows (inverse of the above)."""
    i = wp.tid()
    world = env_ids[i]
    nq = joint_q.shape[1]
    nv = joint_qd.shape[1]
    a = qpos_start
    rot = wp.normalize(wp.quat(joint_q[world, 3], joint_q[world, 4], joint_q[world, 5], joint_q[world, 6]))
    for k in range(3):
        mj_state[world, a + k] = wp.float64(joint_q[world, k])
    mj_state[world, a + 3] = wp.float64(rot[3])
    mj_state[world, a + 4] = wp.float64(rot[0])
    mj_state[world, a + 5] = wp.float64(rot[1])
    mj_state[world, a + 6] = wp.float64(rot[2])
    for k in range(7, nq):
        mj_state[world, a + k] = wp.float64(joint_q[world, k])
    b = a + nq
    v_c = wp.vec3(joint_qd[world, 0], joint_qd[world, 1], joint_qd[world, 2])
    w_w = wp.vec3(joint_qd[world, 3], joint_qd[world, 4], joint_qd[world, 5])
    v_o = v_c - wp.cross(w_w, wp.quat_rotate(rot, root_com))
    w_b = wp.quat_rotate_inv(rot, w_w)
    for k in range(3):
        mj_state[world, b + k] = wp.float64(v_o[k])
        mj_state[world, b + 3 + k] = wp.float64(w_b[k])
    for k in range(6, nv):
        mj_state[world, b + k] = wp.float64(joint_qd[world, k])


@wp.func
def heading_yaw(rot: wp.quat) -> float:
    """psi = atan2(2 (w z + x y), 1 - 2 (y^2 + z^2)) [rad]: the yaw (heading) of a base quaternion, xyzw order."""
    return wp.atan2(2.0 * (rot[3] * rot[2] + rot[0] * rot[1]), 1.0 - 2.0 * (rot[1] * rot[1] + rot[2] * rot[2]))


@wp.kernel
def compute_base_frame(
    joint_q: wp.array2d(dtype=wp.float32),
    joint_qd: wp.array2d(dtype=wp.float32),
    # outputs
    base_lin_vel: wp.array2d(dtype=wp.float32),
    base_ang_vel: wp.array2d(dtype=wp.float32),
    projected_gravity: wp.array2d(dtype=wp.float32),
    base_height: wp.array(dtype=wp.float32),
    base_yaw: wp.array(dtype=wp.float32),
):
    """One thread per robot: the free base's state in its own frame, from Newton rows (position 0:3, quaternion
    xyzw 3:7 of ``joint_q``; world-frame COM velocity 0:3 and angular velocity 3:6 of ``joint_qd``).

    v_b = R^T v [m/s], w_b = R^T w [rad/s], g_b = R^T (0, 0, -1) [-] (N, 3) each; height p_z [m] and yaw
    :func:`heading_yaw` [rad] (N,). R^T is ``wp.quat_rotate_inv`` of the quaternion as stored (not renormalised),
    the rotation the reward kernel applies."""
    i = wp.tid()
    q = wp.quat(joint_q[i, 3], joint_q[i, 4], joint_q[i, 5], joint_q[i, 6])
    v = wp.quat_rotate_inv(q, wp.vec3(joint_qd[i, 0], joint_qd[i, 1], joint_qd[i, 2]))
    w = wp.quat_rotate_inv(q, wp.vec3(joint_qd[i, 3], joint_qd[i, 4], joint_qd[i, 5]))
    g = wp.quat_rotate_inv(q, wp.vec3(0.0, 0.0, -1.0))
    for k in range(3):
        base_lin_vel[i, k] = v[k]
        base_ang_vel[i, k] = w[k]
        projected_gravity[i, k] = g[k]
    base_height[i] = joint_q[i, 2]
    base_yaw[i] = heading_yaw(q)


BASE_FRAME_OUTPUTS = (
    ("base_lin_vel", 3),
    ("base_ang_vel", 3),
    ("projected_gravity", 3),
    ("base_height", 0),
    ("base_yaw", 0),
)
"""Names of :func:`compute_base_frame`'s outputs in order, with their width (0: a (N,) array)."""


@wp.kernel
def gather_actuated(
    joint_q: wp.array2d(dtype=wp.float32),
    joint_qd: wp.array2d(dtype=wp.float32),
    coord_index: wp.array(dtype=wp.int32),
    dof_index: wp.array(dtype=wp.int32),
    # outputs
    actuated_q: wp.array2d(dtype=wp.float32),
    actuated_qd: wp.array2d(dtype=wp.float32),
):
    """Copy the 16 actuated joints' positions [rad] and velocities [rad/s] into project order, (N, 16) each."""
    world, j = wp.tid()
    actuated_q[world, j] = joint_q[world, coord_index[j]]
    actuated_qd[world, j] = joint_qd[world, dof_index[j]]


@wp.kernel
def scatter_state_rows(
    env_ids: wp.array(dtype=wp.int32),
    q_rows: wp.array2d(dtype=wp.float32),
    qd_rows: wp.array2d(dtype=wp.float32),
    # outputs
    joint_q: wp.array2d(dtype=wp.float32),
    joint_qd: wp.array2d(dtype=wp.float32),
):
    """Write row i of ``q_rows`` (k, nq) / ``qd_rows`` (k, nv) into robot ``env_ids[i]`` of ``joint_q`` / ``joint_qd``
    (indexed reset or state overwrite on the device, no host round trip)."""
    i = wp.tid()
    world = env_ids[i]
    for k in range(joint_q.shape[1]):
        joint_q[world, k] = q_rows[i, k]
    for k in range(joint_qd.shape[1]):
        joint_qd[world, k] = qd_rows[i, k]


@wp.kernel
def clear_contact_rows(
    env_ids: wp.array(dtype=wp.int32),
    # outputs
    wheel_force: wp.array2d(dtype=wp.float32),
    wheel_contact: wp.array2d(dtype=wp.int32),
    body_collision: wp.array2d(dtype=wp.int32),
    unstable: wp.array(dtype=wp.int32),
):
    """Zero the contact summaries (wheel forces and flags, body-collision flags) and the divergence flag of robots
    ``env_ids``."""
    i = wp.tid()
    world = env_ids[i]
    for k in range(wheel_force.shape[1]):
        wheel_force[world, k] = 0.0
        wheel_contact[world, k] = 0
    for k in range(body_collision.shape[1]):
        body_collision[world, k] = 0
    unstable[world] = 0


@wp.func
def state_is_bad(value: float, limit: float) -> bool:
    """A coordinate or velocity that is non-finite or beyond ``limit`` in magnitude: a diverged simulation."""
    return not (wp.abs(value) <= limit)  # false for NaN and +-inf as well


@wp.kernel
def flag_unstable(
    joint_q: wp.array2d(dtype=wp.float32),
    joint_qd: wp.array2d(dtype=wp.float32),
    joint_torque: wp.array2d(dtype=wp.float32),
    position_limit: float,
    velocity_limit: float,
    # outputs
    unstable: wp.array(dtype=wp.int32),
):
    """Set ``unstable[world]`` to 1 when any coordinate of the robot exceeds ``position_limit`` (m or rad), any velocity
    ``velocity_limit`` (m/s or rad/s), or any value (torques included) is non-finite; leave it unchanged otherwise."""
    world = wp.tid()
    bad = int(0)
    for k in range(joint_q.shape[1]):
        if state_is_bad(joint_q[world, k], position_limit):
            bad = 1
    for k in range(joint_qd.shape[1]):
        if state_is_bad(joint_qd[world, k], velocity_limit):
            bad = 1
    for k in range(joint_torque.shape[1]):
        if state_is_bad(joint_torque[world, k], 1.0e30):
            bad = 1
    if bad == 1:
        unstable[world] = 1


@wp.kernel
def accumulate_base_motion(
    body_q: wp.array2d(dtype=wp.transform),
    body_qd: wp.array2d(dtype=wp.spatial_vector),
    trunk: int,
    weight: float,
    # outputs (accumulated with +=)
    base_velocity: wp.array2d(dtype=wp.float32),
    base_height: wp.array(dtype=wp.float32),
):
    """One thread per robot: add weight * the trunk COM velocity in the base frame (v_x, v_y [m/s], w_z [rad/s]) and
    weight * the trunk height [m]. Newton's body_qd holds the COM velocity and the angular velocity in the world
    frame."""
    world = wp.tid()
    x = body_q[world, trunk]
    rot = wp.transform_get_rotation(x)
    v = wp.quat_rotate_inv(rot, wp.spatial_top(body_qd[world, trunk]))
    w = wp.quat_rotate_inv(rot, wp.spatial_bottom(body_qd[world, trunk]))
    wp.atomic_add(base_velocity, world, 0, weight * v[0])
    wp.atomic_add(base_velocity, world, 1, weight * v[1])
    wp.atomic_add(base_velocity, world, 2, weight * w[2])
    wp.atomic_add(base_height, world, weight * wp.transform_get_translation(x)[2])
