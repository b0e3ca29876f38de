"""THE open-loop nominal-gait driver: nominal gait -> leg joint targets and wheel speeds -> physics, with no policy.

Per policy step (:meth:`OpenLoopDriver.step`)::

    nominal.step(measured legs q (N, 12) [rad], wheel contact flags (N, 4), dt)   # Eq. (1)-(3) + leg IK
    sim.leg_q_target    <- nominal.leg_joint_target  (N, 12) [rad]
    sim.wheel_qd_target <- nominal.wheel_velocity    (N, 4) [rad/s]
    sim.step()                                       # decimation x (actuation, power, physics)

What differs between uses is a parameter, not a copy: where the contact flags come from (``contact="sim"``: the
simulator's measured ``wheel_contact``, closing the gait's contact-dependent stance; ``"ground"``: all four wheels
on the ground, the nominal gait as a pure clock), the warm-up before a measuring window, and a per-step callback
that records. Without a simulator (``sim=None``) the nominal gait runs alone from the default leg pose with all
wheels on the ground (gait traces).

Example::

    from wqwarp.control.driver import OpenLoopDriver
    from wqwarp.sim.config import SimConfig
    from wqwarp.sim.simulator import Simulator

    sim = Simulator(SimConfig(num_envs=2))
    drv = OpenLoopDriver(sim, "trotting", command=(0.3, 0.0, 0.0))
    p_cost = []
    window = drv.run(seconds=3.0, warmup_s=1.0,
                     on_step=lambda k, in_window: in_window and p_cost.append(sim.p_cost.numpy().mean()))
    mean_p_cost = sum(p_cost) / window  # [W] over the 3 s after a 1 s warm-up
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, Literal

import numpy as np
import warp as wp

from wqwarp.control.nominal import NominalGait
from wqwarp.robot import constants as C

if TYPE_CHECKING:
    from wqwarp.sim.simulator import Simulator

ContactSource = Literal["sim", "ground"]
CONTACT_SOURCES: tuple[str, ...] = ("sim", "ground")


class OpenLoopDriver:
    """The nominal gait ``gait`` of :class:`~wqwarp.control.nominal.NominalGait` driving ``sim`` open loop.

    Args:
        sim: the simulator to drive, or None for the nominal gait alone (then ``num_envs``, ``device`` and ``dt``
            give its size, device and policy step).
        gait: gait name in the nominal gait's library (``library`` in ``gait_kwargs``; default Table I).
        command: (3,) or (N, 3) base-frame command (v_x [m/s], v_y [m/s], w_z [rad/s]).
        contact: ``"sim"`` (measured wheel contact flags) or ``"ground"`` (all wheels on the ground).
        num_envs, device, dt: only without ``sim``: robots, Warp device, policy step [s].
        gait_kwargs: passed to :class:`NominalGait` (``library``, ``body_height``, ``swing_height``, ...).
    """

    def __init__(
        self,
        sim: Simulator | None,
        gait: str = "trotting",
        command: Sequence[float] = (0.0, 0.0, 0.0),
        *,
        contact: ContactSource = "sim",
        num_envs: int = 1,
        device: str = "cpu",
        dt: float = 0.02,
        **gait_kwargs,
    ):
        if contact not in CONTACT_SOURCES:
            raise ValueError(f"unknown contact source {contact!r}; choose one of {', '.join(CONTACT_SOURCES)}")
        self.sim = sim
        """The driven simulator (None: the nominal gait alone)."""
        self.num_envs = sim.num_envs if sim is not None else int(num_envs)
        self.device = sim.device if sim is not None else wp.get_device(device)
        self.dt = sim.policy_dt if sim is not None else float(dt)
        """Policy step [s]."""
        self.contact = contact
        """Where the wheel contact flags the gait reads come from: ``sim`` or ``ground``."""
        self.nominal = NominalGait(self.num_envs, self.device, **gait_kwargs)
        """The nominal gait (its outputs ``phase``, ``swing_psi``, ``foot_target``, ... are read by recorders)."""
        self.nominal.reset(np.arange(self.num_envs), self.nominal.gait_ids(gait))
        self.set_command(command)
        n = self.num_envs
        self._ground = wp.ones((n, 4), dtype=wp.int32, device=self.device)
        self._default_legs = wp.array(
            np.tile(np.asarray(C.DEFAULT_JOINT_POS[:12], np.float32), (n, 1)), dtype=wp.float32, device=self.device
        )
        self.steps_taken = 0
        """Policy steps run so far."""

    def set_command(self, command: Sequence[float] | np.ndarray) -> None:
        """Set the command, (3,) for every robot or (N, 3): v_x, v_y [m/s], w_z [rad/s] in the base frame."""
        c = np.broadcast_to(np.asarray(command, np.float32), (self.num_envs, 3))
        self.nominal.command.assign(np.ascontiguousarray(c))

    def step(self) -> None:
        """One policy step: the nominal gait from the measured legs and the contact flags, its targets into the
        simulator, one :meth:`Simulator.step` (only the gait without a simulator)."""
        sim, ng = self.sim, self.nominal
        legs = sim.actuated_q[:, :12] if sim is not None else self._default_legs
        contact = sim.wheel_contact if (sim is not None and self.contact == "sim") else self._ground
        ng.step(legs, contact, self.dt)
        if sim is not None:
            wp.copy(sim.leg_q_target, ng.leg_joint_target)
            wp.copy(sim.wheel_qd_target, ng.wheel_velocity)
            sim.step()
        self.steps_taken += 1

    def steps(self, seconds: float) -> int:
        """Whole policy steps in ``seconds`` [s] (rounded), as :meth:`run` counts them."""
        return round(seconds / self.dt)

    def run(self, seconds: float, warmup_s: float = 0.0, on_step: Callable[[int, bool], object] | None = None) -> int:
        """``warmup_s`` [s] then ``seconds`` [s] of policy steps (each rounded to whole steps); after every step
        ``on_step(k, in_window)`` with the step index k (0-based, warm-up included) and whether it is in the window
        after the warm-up. Returns the number of window steps."""
        warm, window = self.steps(warmup_s), self.steps(seconds)
        for k in range(warm + window):
            self.step()
            if on_step is not None:
                on_step(k, k >= warm)
        return window
