"""Per-robot contact summaries: wheel contact forces and body-collision flags.

Slots of a robot's contact summary (``constants``): wheel k of leg k in 0..3 gives ``wheel_force[w, k]``; collision
body c (trunk, then thigh and calf per leg) gives ``body_collision[w, c]``.
"""

from __future__ import annotations

import warp as wp


@wp.struct
class ShapeSlots:
    """Where a Newton shape's ground contact goes in the per-robot summaries (``wqwarp.sim.model.shape_slots``)."""

    world: wp.array(dtype=wp.int32)
    """(S,) robot (world) of each shape."""
    wheel_slot: wp.array(dtype=wp.int32)
    """(S,) wheel slot 0-3 of each shape, -1 if it is not a wheel."""
    body_slot: wp.array(dtype=wp.int32)
    """(S,) collision-body slot (``constants.COLLISION_BODY_NAMES``), -1 if none."""
    ground_shape: int
    """Index of the ground plane's shape."""


@wp.func
def ground_contact_shape(a: int, b: int, ground_shape: int) -> int:
    """The robot's shape in a contact between shapes ``a`` and ``b`` if the other one is the ground, else -1."""
    if a == ground_shape:
        return b
    if b == ground_shape:
        return a
    return -1


@wp.func
def record_ground_contact(
    s: int,
    force: float,
    slots: ShapeSlots,
    wheel_force: wp.array2d(dtype=wp.float32),
    body_collision: wp.array2d(dtype=wp.int32),
):
    """Add ``force`` [N] to the wheel slot of robot shape ``s`` (if it is a wheel) and flag its collision-body slot
    (if it has one)."""
    world = slots.world[s]
    k = slots.wheel_slot[s]
    if k >= 0:
        wp.atomic_add(wheel_force, world, k, force)
    c = slots.body_slot[s]
    if c >= 0:
        body_collision[world, c] = 1


@wp.kernel
def accumulate_newton_contacts(
    contact_count: wp.array(dtype=wp.int32),
    shape0: wp.array(dtype=wp.int32),
    shape1: wp.array(dtype=wp.int32),
    contact_f: wp.array(dtype=wp.spatial_vector),
    slots: ShapeSlots,
    # outputs
    wheel_force: wp.array2d(dtype=wp.float32),
    body_collision: wp.array2d(dtype=wp.int32),
):
    """One thread per Newton contact: add |f| [N] of a wheel-ground contact to its wheel; flag body-ground contacts.

    ``wheel_force`` and ``body_collision`` must be zeroed before the launch.
    """
    i = wp.tid()
    if i >= contact_count[0]:
        return
    s = ground_contact_shape(shape0[i], shape1[i], slots.ground_shape)
    if s < 0:
        return
    f = wp.length(wp.spatial_top(contact_f[i]))
    record_ground_contact(s, f, slots, wheel_force, body_collision)


@wp.kernel
def contacts_from_sensordata(
    sensordata: wp.array2d(dtype=wp.float64),
    wheel_found_col: wp.array(dtype=wp.int32),
    body_found_col: wp.array(dtype=wp.int32),
    # outputs
    wheel_force: wp.array2d(dtype=wp.float32),
    body_collision: wp.array2d(dtype=wp.int32),
):
    """One thread per robot: read MuJoCo contact sensors (``found`` then 3 force components for a wheel; ``found``
    for a body) into the per-robot summaries. Force magnitude [N]."""
    world = wp.tid()
    for k in range(wheel_found_col.shape[0]):
        c = wheel_found_col[k]
        f = wp.vec3(
            wp.float32(sensordata[world, c + 1]),
            wp.float32(sensordata[world, c + 2]),
            wp.float32(sensordata[world, c + 3]),
        )
        wheel_force[world, k] = wp.length(f) if sensordata[world, c] > wp.float64(0.0) else 0.0
    for k in range(body_found_col.shape[0]):
        body_collision[world, k] = wp.where(sensordata[world, body_found_col[k]] > wp.float64(0.0), 1, 0)


@wp.kernel
def accumulate_penalty_contacts(
    contact_count: wp.array(dtype=wp.int32),
    shape0: wp.array(dtype=wp.int32),
    shape1: wp.array(dtype=wp.int32),
    point0: wp.array(dtype=wp.vec3),
    point1: wp.array(dtype=wp.vec3),
    normal: wp.array(dtype=wp.vec3),
    margin0: wp.array(dtype=wp.float32),
    margin1: wp.array(dtype=wp.float32),
    body_q: wp.array(dtype=wp.transform),
    shape_body: wp.array(dtype=wp.int32),
    slots: ShapeSlots,
    ke: float,
    # outputs
    wheel_force: wp.array2d(dtype=wp.float32),
    body_collision: wp.array2d(dtype=wp.int32),
):
    """One thread per Newton contact of a penalty (spring-damper) solver: add the elastic normal force ke * depth
    [N] of a wheel-ground contact to its wheel, flag a penetrating body-ground contact. The depth is computed as in
    Newton's ``eval_body_contact`` (the contact points in their body frames, moved by the margins along the
    normal); the damping and friction parts of the force are left out. Zero both outputs before the launch."""
    i = wp.tid()
    if i >= contact_count[0]:
        return
    a = shape0[i]
    b = shape1[i]
    s = ground_contact_shape(a, b, slots.ground_shape)
    if s < 0:
        return
    n = -normal[i]
    pa = point0[i]
    pb = point1[i]
    if a >= 0 and shape_body[a] >= 0:
        pa = wp.transform_point(body_q[shape_body[a]], pa) - margin0[i] * n
    if b >= 0 and shape_body[b] >= 0:
        pb = wp.transform_point(body_q[shape_body[b]], pb) + margin1[i] * n
    depth = -wp.dot(n, pa - pb)
    if depth > 0.0:
        record_ground_contact(s, ke * depth, slots, wheel_force, body_collision)


@wp.kernel
def anchor_contact_points(
    contact_count: wp.array(dtype=wp.int32),
    shape0: wp.array(dtype=wp.int32),
    shape1: wp.array(dtype=wp.int32),
    point0: wp.array(dtype=wp.vec3),
    point1: wp.array(dtype=wp.vec3),
    body_q: wp.array(dtype=wp.transform),
    shape_body: wp.array(dtype=wp.int32),
    shape_anchor: wp.array(dtype=wp.int32),
    # outputs
    anchored0: wp.array(dtype=wp.vec3),
    anchored1: wp.array(dtype=wp.vec3),
):
    """One thread per contact (run outside the tape, after collision detection): re-express each contact point from
    its shape's body frame in the frame of the shape's anchor body (``shape_anchor``; for a wheel its calf, which does
    not spin with it; else the body itself). A ground point (no body) stays in world coordinates."""
    i = wp.tid()
    if i >= contact_count[0]:
        return
    a = shape0[i]
    b = shape1[i]
    p = point0[i]
    if a >= 0 and shape_body[a] >= 0:
        world = wp.transform_point(body_q[shape_body[a]], p)
        p = wp.transform_point(wp.transform_inverse(body_q[shape_anchor[a]]), world)
    anchored0[i] = p
    p = point1[i]
    if b >= 0 and shape_body[b] >= 0:
        world = wp.transform_point(body_q[shape_body[b]], p)
        p = wp.transform_point(wp.transform_inverse(body_q[shape_anchor[b]]), world)
    anchored1[i] = p


@wp.func
def penalty_contact_force(depth: float, vn: float, vt: wp.vec3, ke: float, kd: float, kf: float, mu: float):
    """Spring-damper contact force along (normal, tangent) as Newton's semi-implicit contact computes it
    (``eval_body_contact``): normal f_n = ke depth + kd max(-vn, 0) (pushing apart) and a regularised Coulomb
    friction f_t = -kf v_t capped at mu f_n [N]. depth > 0 penetrating [m], vn normal velocity of the robot point
    (< 0 approaching) [m/s], vt tangential velocity [m/s]. Returns (f_n, |f_t| scale k, 0) with f_t = -k v_t."""
    fn = ke * depth - kd * wp.min(vn, 0.0)
    k = kf
    limit = mu * fn
    speed_sq = wp.dot(vt, vt)
    if limit > 0.0 and kf > 0.0:
        slip = limit / kf
        if speed_sq > slip * slip:
            k = limit / wp.sqrt(speed_sq)
    else:
        k = 0.0
    return wp.vec3(fn, k, 0.0)


@wp.kernel
def anchored_penalty_contacts(
    contact_count: wp.array(dtype=wp.int32),
    shape0: wp.array(dtype=wp.int32),
    shape1: wp.array(dtype=wp.int32),
    anchored0: wp.array(dtype=wp.vec3),
    anchored1: wp.array(dtype=wp.vec3),
    normal: wp.array(dtype=wp.vec3),
    margin0: wp.array(dtype=wp.float32),
    margin1: wp.array(dtype=wp.float32),
    body_q: wp.array(dtype=wp.transform),
    body_qd: wp.array(dtype=wp.spatial_vector),
    body_com: wp.array(dtype=wp.vec3),
    shape_body: wp.array(dtype=wp.int32),
    shape_anchor: wp.array(dtype=wp.int32),
    ke: float,
    kd: float,
    kf: float,
    mu: float,
    # outputs (accumulated)
    body_f: wp.array(dtype=wp.spatial_vector),
):
    """One thread per robot-ground contact, for differentiable rollouts: Newton's spring-damper contact force
    (:func:`penalty_contact_force`), with the robot's contact point carried by its anchor body
    (:func:`anchor_contact_points`) instead of the body it belongs to. For a wheel the point then stays at the
    bottom of the wheel as it spins, as collision detection would put it at the next substep, so the gradient has
    no spurious dependence on the wheel's spin angle (with Newton's own evaluation the point turns with the wheel
    within a substep: the contact velocity, and so the damping and friction, change with the spin angle). The
    forward force is the same. The wrench (force, torque about the COM, world frame) is added to the body's
    ``body_f``, the external force Featherstone applies."""
    i = wp.tid()
    if i >= contact_count[0]:
        return
    a = shape0[i]
    b = shape1[i]
    # orient so that side r is the robot shape and side g the ground
    s = a
    pr = anchored0[i]
    pg = anchored1[i]
    mr = margin0[i]
    n = -normal[i]  # from the ground towards the robot shape (Newton stores A-to-B)
    if a < 0 or shape_body[a] < 0:
        s = b
        pr = anchored1[i]
        pg = anchored0[i]
        mr = margin1[i]
        n = normal[i]
    if s < 0:
        return
    body = shape_body[s]
    if body < 0:
        return
    xr = wp.transform_point(body_q[shape_anchor[s]], pr) - mr * n
    xg = pg  # the ground has no body: Newton applies no margin to its point
    depth = -wp.dot(n, xr - xg)
    if depth <= 0.0:
        return
    com = wp.transform_point(body_q[body], body_com[body])
    r = xr - com
    v = wp.spatial_top(body_qd[body]) + wp.cross(wp.spatial_bottom(body_qd[body]), r)
    vn = wp.dot(n, v)
    vt = v - n * vn
    f = penalty_contact_force(depth, vn, vt, ke, kd, kf, mu)
    force = n * f[0] - vt * f[1]
    wp.atomic_add(body_f, body, wp.spatial_vector(force, wp.cross(r, force)))
