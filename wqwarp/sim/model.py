"""Newton-model set-up and index helpers shared by :class:`wqwarp.sim.simulator.Simulator`, its physics backends
(``wqwarp.sim.backends``) and the differentiable path (``wqwarp.diff.rollout``)."""

from __future__ import annotations

import numpy as np
import warp as wp

from wqwarp.kernels.contacts import ShapeSlots
from wqwarp.robot import constants as C


def index_array(env_ids, device, count: int) -> wp.array:
    """Robot indices as an int32 Warp array on ``device``. A Warp array or a torch tensor already on the device is
    used in place (no host round trip, no range check); a list or NumPy array is checked against ``[0, count)`` and
    copied once."""
    import torch

    if isinstance(env_ids, wp.array):
        return env_ids
    if isinstance(env_ids, torch.Tensor):
        return wp.from_torch(env_ids.reshape(-1).to(torch.int32).contiguous())
    ids = np.asarray(env_ids, dtype=np.int32).reshape(-1)
    if ids.size and (ids.min() < 0 or ids.max() >= count):
        raise IndexError(f"env_ids out of range [0, {count})")
    return wp.array(ids, dtype=wp.int32, device=device)


def apply_joint_model(model, layout, name: str) -> None:
    """Set the passive joint model ``name`` (``SimConfig.joint_model``) on the actuated joints of every world of a
    finalized Newton ``model``, before a solver is built from it (Newton converts ``joint_damping``,
    ``joint_armature`` and ``joint_friction`` to MuJoCo's ``dof_damping``, ``dof_armature`` and
    ``dof_frictionloss``). ``asset`` leaves the model as loaded."""
    if name == "asset":
        return
    worlds = model.joint_dof_count // layout.dofs_per_world
    dofs = (np.arange(worlds)[:, None] * layout.dofs_per_world + np.asarray(layout.actuated_dof)[None, :]).ravel()
    for key, value in C.AUTHORS_JOINT_MODEL.items():
        arr = getattr(model, f"joint_{key}")
        host = arr.numpy()
        host[dofs] = value
        arr.assign(host)


def shape_slots(model, layout) -> ShapeSlots:
    """Per Newton shape: its world, its wheel slot (0-3, -1 if not a wheel) and its collision-body slot
    (``constants.COLLISION_BODY_NAMES``, -1 if none), as int32 Warp arrays, and the ground plane's shape index."""
    shape_body = model.shape_body.numpy()
    shape_world = model.shape_world.numpy()
    wheel_slot = np.full(model.shape_count, -1, np.int32)
    body_slot = np.full(model.shape_count, -1, np.int32)
    ground = -1
    for s in range(model.shape_count):
        bdy = shape_body[s]
        if bdy < 0:
            ground = s
            continue
        local = bdy - shape_world[s] * layout.bodies_per_world
        hits = np.nonzero(layout.wheel_body == local)[0]
        if hits.size:
            wheel_slot[s] = hits[0]
        hits = np.nonzero(layout.collision_body == local)[0]
        if hits.size:
            body_slot[s] = hits[0]
    as_wp = lambda a: wp.array(a, dtype=wp.int32, device=model.device)  # noqa: E731
    slots = ShapeSlots()
    slots.world, slots.wheel_slot = as_wp(np.maximum(shape_world, 0).astype(np.int32)), as_wp(wheel_slot)
    slots.body_slot, slots.ground_shape = as_wp(body_slot), ground
    return slots
