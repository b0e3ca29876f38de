"""Physics backends of :class:`wqwarp.sim.simulator.Simulator`, one class per engine behind
:class:`~wqwarp.sim.backends.base.PhysicsBackend`, chosen by ``SimConfig.backend`` through :data:`BACKENDS`."""

from __future__ import annotations

from wqwarp.sim.backends.base import PhysicsBackend
from wqwarp.sim.backends.featherstone import FeatherstoneBackend
from wqwarp.sim.backends.mujoco_cpu import MujocoCpuBackend
from wqwarp.sim.backends.mujoco_warp import MujocoWarpBackend

BACKENDS: dict[str, type[PhysicsBackend]] = {
    cls.name: cls for cls in (MujocoCpuBackend, MujocoWarpBackend, FeatherstoneBackend)
}
"""Backend class by ``SimConfig.backend`` name (``auto`` is resolved by ``SimConfig.resolved_backend``)."""

__all__ = ["BACKENDS", "FeatherstoneBackend", "MujocoCpuBackend", "MujocoWarpBackend", "PhysicsBackend"]
