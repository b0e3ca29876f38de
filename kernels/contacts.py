"""Per-robot contact summaries: wheel contact forces and body-collision flags.

Slots of a robot's contact summary (``constants``): wheel k of leg k in 0..3 gives ``wheel_force[w, k]``; collision
body c (trunk, then thigh and calf per leg) gives ``body_collision[w, c]``.
"""

from __future__ import annotations

import warp as wp


@wp.kernel
def accumulate_newton_contacts(
    contact_count: wp.array(dtype=wp.int32),
    shape0: wp.array(dtype=wp.int32),
    shape1: wp.array(dtype=wp.int32),
    contact_f: wp.array(dtype=wp.spatial_vector),
    shape_world: wp.array(dtype=wp.int32),
    shape_wheel_slot: wp.array(dtype=wp.int32),
    shape_body_slot: wp.array(dtype=wp.int32),
    ground_shape: int,
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
    a = shape0[i]
    b = shape1[i]
    s = a
    if a == ground_shape:
        s = b
    elif b != ground_shape:
        return
    if s < 0:
        return
    world = shape_world[s]
    k = shape_wheel_slot[s]
    if k >= 0:
        f = wp.spatial_top(contact_f[i])
        wp.atomic_add(wheel_force, world, k, wp.length(f))
    c = shape_body_slot[s]
    if c >= 0:
        body_collision[world, c] = 1


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
    shape_world: wp.array(dtype=wp.int32),
    shape_wheel_slot: wp.array(dtype=wp.int32),
    shape_body_slot: wp.array(dtype=wp.int32),
    ground_shape: int,
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
    s = a
    if a == ground_shape:
        s = b
    elif b != ground_shape:
        return
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
    if depth <= 0.0:
        return
    world = shape_world[s]
    k = shape_wheel_slot[s]
    if k >= 0:
        wp.atomic_add(wheel_force, world, k, ke * depth)
    c = shape_body_slot[s]
    if c >= 0:
        body_collision[world, c] = 1
