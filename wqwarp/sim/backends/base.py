"""The interface every physics backend of :class:`wqwarp.sim.simulator.Simulator` implements.

The simulator owns the Newton model and state, every per-robot buffer (``wqwarp.sim.buffers.SimBuffers``), the
actuation and power kernels, the divergence check and the base-frame update; a backend owns only what its physics
engine needs: it is built on a simulator whose model, state and buffers exist, and per policy step advances the
state by ``decimation`` substeps and writes the contact summaries. Adding a backend: one subclass in its own module
and one entry in ``wqwarp.sim.config.BACKEND_CLASSES`` (its name, which is also a choice of ``SimConfig.backend``).
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from typing import TYPE_CHECKING, ClassVar

import numpy as np
import warp as wp

if TYPE_CHECKING:
    from wqwarp.sim.simulator import Simulator


class PhysicsBackend(ABC):
    """One physics engine stepping the robots of a :class:`~wqwarp.sim.simulator.Simulator` (``sim``)."""

    name: ClassVar[str]
    """Its ``SimConfig.backend`` name."""
    requires_cpu: ClassVar[bool] = False
    """Runs only on Warp's CPU device."""

    def __init__(self, sim: Simulator) -> None:
        self.sim = sim
        """The simulator whose model, state, control and buffers this backend steps and writes."""

    @abstractmethod
    def step_substeps(self, actuate: bool) -> None:
        """Advance ``sim.cfg.decimation`` substeps, each ``sim.actuate_substep()`` (if ``actuate``) then physics, and
        leave Newton's ``joint_q`` / ``joint_qd`` / ``body_q`` / ``body_qd`` current and ``sim.wheel_force`` (N, 4)
        [N] / ``sim.body_collision`` (N, 9) written for the last substep."""

    def reset_rows(self, env_ids: wp.array) -> None:
        """Robots ``env_ids`` were reset to new coordinates (already written and announced by :meth:`state_written`):
        clear solver state that would carry over (warm starts, applied forces). Default: nothing kept."""
        return

    def state_written(self, env_ids: wp.array) -> None:
        """``joint_q`` / ``joint_qd`` of robots ``env_ids`` (non-empty) were overwritten: copy them into any state the
        engine keeps apart from Newton's. Default: the engine steps Newton's state itself."""
        return

    def set_dynamics(self, friction: np.ndarray, damping_ratio: np.ndarray, added_mass: np.ndarray) -> None:
        """Per-robot ground friction [-], contact damping ratio [-] and mass added to the trunk [kg], each (N,)
        float64 (``Simulator.set_dynamics`` maps restitution to the damping ratio)."""
        raise ValueError(
            f"backend {self.name!r} does not randomise dynamics (friction, restitution, mass); "
            "turn domain randomisation off"
        )
