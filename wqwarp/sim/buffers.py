"""The per-robot arrays of a :class:`wqwarp.sim.simulator.Simulator` (controls, actuation state, power, contacts,
divergence flags, project-order joints, base frame), declared once with shapes and units."""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np
import warp as wp

from wqwarp.kernels import power
from wqwarp.kernels.state import BASE_FRAME_OUTPUTS
from wqwarp.robot import constants as C


@dataclass(eq=False, repr=False)
class SimBuffers:
    """Per-robot control and measurement arrays of a :class:`Simulator`, shape (N, ...), float32 unless noted.
    :class:`Simulator` holds them as its own attributes (``sim.p_cost``, ``sim.leg_q_target``, ...); compared and
    hashed by identity (``eq=False``), like the simulator."""

    leg_q_target: wp.array
    """(N, 12) leg position targets [rad] (input)."""
    wheel_qd_target: wp.array
    """(N, 4) wheel velocity targets [rad/s] (input)."""
    motor_strength: wp.array
    """(N, 16) torque scale of each actuated joint [-] (input, domain randomisation)."""
    torque_limit: wp.array
    """(16,) torque limit of each actuated joint [N m]."""
    joint_torque: wp.array
    """(N, 16) applied torques of the last substep [N m], project order."""
    wheel_integral: wp.array
    """(N, 4) wheel-PID integral state [rad]."""
    wheel_prev_error: wp.array
    """(N, 4) wheel-PID previous velocity error [rad/s]."""
    p_cost: wp.array
    """(N,) paper power cost sum |tau| |qd| [W], substep average (``wqwarp.kernels.power``)."""
    p_mech: wp.array
    """(N,) positive mechanical power [W], substep average."""
    p_elec: wp.array
    """(N,) electrical power the battery pays for the 16 joints [W], substep average (``wqwarp.robot.motors``)."""
    p_cost_legs: wp.array
    """(N,) p_cost of the 12 leg joints [W]."""
    p_cost_wheels: wp.array
    """(N,) p_cost of the 4 wheels [W]."""
    p_mech_legs: wp.array
    """(N,) p_mech of the legs [W]."""
    p_mech_wheels: wp.array
    """(N,) p_mech of the wheels [W]."""
    p_elec_legs: wp.array
    """(N,) p_elec of the legs [W] (their signed bus share under a shared bus)."""
    p_elec_wheels: wp.array
    """(N,) p_elec of the wheels [W]."""
    p_copper_legs: wp.array
    """(N,) copper (I^2 R) loss of the leg motors [W], inside p_elec_legs."""
    p_copper_wheels: wp.array
    """(N,) copper loss of the wheel motors [W], inside p_elec_wheels."""
    torque_sq: wp.array
    """(N,) substep average of sum tau^2 [(N m)^2]."""
    power_sq: wp.array
    """(N,) substep average of sum (tau qd)^2 [W^2]."""
    wheel_force: wp.array
    """(N, 4) wheel-ground normal force [N]."""
    wheel_contact: wp.array
    """(N, 4) int32: 1 where ``wheel_force`` exceeds ``SimConfig.contact_threshold``."""
    body_collision: wp.array
    """(N, 9) int32: 1 where a body of ``constants.COLLISION_BODY_NAMES`` touches the ground."""
    unstable: wp.array
    """(N,) int32: 1 for a robot whose simulation diverged in this step (the caller must reset it)."""
    actuated_q: wp.array
    """(N, 16) actuated joint positions [rad], project order."""
    actuated_qd: wp.array
    """(N, 16) actuated joint velocities [rad/s], project order."""
    base_lin_vel: wp.array
    """(N, 3) trunk COM velocity in the base frame [m/s] (``kernels.state.compute_base_frame``)."""
    base_ang_vel: wp.array
    """(N, 3) trunk angular velocity in the base frame [rad/s]."""
    projected_gravity: wp.array
    """(N, 3) unit gravity direction (0, 0, -1) in the base frame [-]."""
    base_height: wp.array
    """(N,) trunk height above the ground plane [m]."""
    base_yaw: wp.array
    """(N,) trunk heading atan2(2 (w z + x y), 1 - 2 (y^2 + z^2)) [rad]."""

    @staticmethod
    def allocate(n: int) -> dict[str, wp.array]:
        """Arrays of N robots on the current Warp device, at their initial values (default leg pose, strength 1)."""
        f32 = wp.float32
        return dict(
            leg_q_target=wp.array(np.tile(np.asarray(C.DEFAULT_JOINT_POS[:12], np.float32), (n, 1)), dtype=f32),
            wheel_qd_target=wp.zeros((n, 4), dtype=f32),
            motor_strength=wp.ones((n, 16), dtype=f32),
            torque_limit=wp.array(np.asarray(C.TORQUE_LIMITS, np.float32), dtype=f32),
            joint_torque=wp.zeros((n, 16), dtype=f32),
            wheel_integral=wp.zeros((n, 4), dtype=f32),
            wheel_prev_error=wp.zeros((n, 4), dtype=f32),
            **{name: wp.zeros(n, dtype=f32) for name in power.POWER_OUTPUTS},
            wheel_force=wp.zeros((n, 4), dtype=f32),
            wheel_contact=wp.zeros((n, 4), dtype=wp.int32),
            body_collision=wp.zeros((n, len(C.COLLISION_BODY_NAMES)), dtype=wp.int32),
            unstable=wp.zeros(n, dtype=wp.int32),
            actuated_q=wp.zeros((n, 16), dtype=f32),
            actuated_qd=wp.zeros((n, 16), dtype=f32),
            **{name: wp.zeros((n, w) if w else n, dtype=f32) for name, w in BASE_FRAME_OUTPUTS},
        )


BUFFER_NAMES: tuple[str, ...] = tuple(f.name for f in fields(SimBuffers))
"""Names of every :class:`SimBuffers` array, in declaration order (what ``Simulator.torch_views`` returns besides the
Newton state)."""
