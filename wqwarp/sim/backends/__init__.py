"""Physics backends of :class:`wqwarp.sim.simulator.Simulator`, one class per engine behind
:class:`~wqwarp.sim.backends.base.PhysicsBackend`, chosen by ``SimConfig.backend`` through :data:`BACKENDS`: the
classes of the registry ``wqwarp.sim.config.BACKEND_CLASSES`` (names and modules, readable without physics)."""

from __future__ import annotations

import importlib

from wqwarp.sim.backends.base import PhysicsBackend
from wqwarp.sim.config import BACKEND_CLASSES


def _load(name: str) -> type[PhysicsBackend]:
    module, _, cls = BACKEND_CLASSES[name].partition(":")
    return getattr(importlib.import_module(module), cls)


BACKENDS: dict[str, type[PhysicsBackend]] = {name: _load(name) for name in BACKEND_CLASSES}
"""Backend class by ``SimConfig.backend`` name (``auto`` is resolved by ``SimConfig.resolved_backend``)."""

__all__ = ["BACKENDS", "PhysicsBackend"]
