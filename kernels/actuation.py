"""Joint actuation: leg position PD, wheel velocity PID, motor-strength scaling and torque limits.

References:
    Leg PD (Kp 40, Kd 1) and wheel velocity control: the paper's first author's public sim-to-sim harness,
    summarised in ``../shared/reference/SIMULATION_FACTS.md``. Joint order and torque limits:
    ``wqwarp/robot/constants.py`` (12 leg joints FR, FL, RR, RL x (hip, thigh, calf), then 4 wheels).

Per physics substep, for actuated joint ``j`` of robot ``w``::

    tau_j = clip(strength_wj * ctrl_j, -limit_j, limit_j)
    ctrl_j = leg_pd_torque(...)     for j < 12   (position target [rad])
    ctrl_j = wheel_pid_torque(...)  for j >= 12  (velocity target [rad/s])
"""

from __future__ import annotations

import warp as wp

NUM_ACTUATED = wp.constant(16)
NUM_LEG_JOINTS = wp.constant(12)
NUM_WHEELS = wp.constant(4)


@wp.func
def leg_pd_torque(q_target: float, q: float, qd: float, kp: float, kd: float, limit: float) -> float:
    """tau = clip(kp * (q_target - q) - kd * qd, -limit, limit) [N m].

    Position PD of one leg joint: q_target, q [rad], qd [rad/s], kp [N m/rad], kd [N m s/rad], limit [N m].
    """
    return wp.clamp(kp * (q_target - q) - kd * qd, -limit, limit)


@wp.func
def wheel_pid_torque(
    qd_target: float,
    qd: float,
    integral: float,
    prev_error: float,
    kp: float,
    ki: float,
    kd: float,
    i_limit: float,
    limit: float,
    dt: float,
) -> wp.vec3:
    """tau = clip(kp * e + ki * I + kd * (e - e_prev) / dt, -limit, limit) [N m], e = qd_target - qd [rad/s].

    Velocity PID of one wheel. The integral I [rad] is updated as ``clamp(I + e * dt, -i_limit, i_limit)``
    (anti-windup by clamping), except that it is held when the step would increase |I| while the unclipped output
    computed with the held integral, ``u = kp * e + ki * I + kd * de``, is already beyond ``limit`` in the step's
    direction (conditional integration). The derivative acts on the error difference, so the first step after a
    reset (e_prev = 0) sees the full error as a difference.

    Returns:
        wp.vec3(tau [N m], new integral I [rad], error e [rad/s]); the caller stores I and e for the next step.
    """
    e = qd_target - qd
    de = (e - prev_error) / dt
    u_held = kp * e + ki * integral + kd * de
    step = e * dt
    i_new = wp.clamp(integral + step, -i_limit, i_limit)
    if wp.abs(u_held) > limit and u_held * step > 0.0 and wp.abs(integral + step) > wp.abs(integral):
        i_new = integral
    tau = wp.clamp(kp * e + ki * i_new + kd * de, -limit, limit)
    return wp.vec3(tau, i_new, e)


@wp.struct
class ActuationGains:
    """Gains of the actuation kernel (``SimConfig``'s, one set for every robot)."""

    leg_kp: float
    """Leg PD stiffness [N m/rad]."""
    leg_kd: float
    """Leg PD damping [N m s/rad]."""
    wheel_kp: float
    """Wheel PID proportional gain [N m s/rad]."""
    wheel_ki: float
    """Wheel PID integral gain [N m/rad]."""
    wheel_kd: float
    """Wheel PID derivative gain [N m s^2/rad]."""
    wheel_i_limit: float
    """Bound of the wheel integral [rad]."""
    dt: float
    """Physics substep [s]."""


def actuation_gains(
    *, leg_kp: float, leg_kd: float, wheel_kp: float, wheel_ki: float, wheel_kd: float, wheel_i_limit: float, dt: float
) -> ActuationGains:
    """An :class:`ActuationGains` from its fields (units there)."""
    g = ActuationGains()
    g.leg_kp, g.leg_kd, g.wheel_kp, g.wheel_ki = leg_kp, leg_kd, wheel_kp, wheel_ki
    g.wheel_kd, g.wheel_i_limit, g.dt = wheel_kd, wheel_i_limit, dt
    return g


@wp.kernel
def apply_actuation(
    joint_q: wp.array2d(dtype=wp.float32),
    joint_qd: wp.array2d(dtype=wp.float32),
    coord_index: wp.array(dtype=wp.int32),
    dof_index: wp.array(dtype=wp.int32),
    leg_q_target: wp.array2d(dtype=wp.float32),
    wheel_qd_target: wp.array2d(dtype=wp.float32),
    gains: ActuationGains,
    torque_limit: wp.array(dtype=wp.float32),
    motor_strength: wp.array2d(dtype=wp.float32),
    wheel_integral_in: wp.array2d(dtype=wp.float32),
    wheel_prev_error_in: wp.array2d(dtype=wp.float32),
    # outputs
    wheel_integral_out: wp.array2d(dtype=wp.float32),
    wheel_prev_error_out: wp.array2d(dtype=wp.float32),
    joint_torque: wp.array2d(dtype=wp.float32),
    joint_f: wp.array2d(dtype=wp.float32),
):
    """One thread per robot: PD on the 12 leg joints, PID on the 4 wheels, strength scale, clip, scatter into joint_f.

    The wheel PID state is read from ``*_in`` and written to ``*_out``. Passing the same arrays updates it in place
    (the simulator); separate arrays overwrite nothing, so that ``wp.Tape`` can run the adjoint (differentiable
    rollouts, ``wqwarp.diff.rollout``; in place, the adjoint would replay on the updated state)."""
    world = wp.tid()
    for j in range(NUM_ACTUATED):
        limit = torque_limit[j]
        q = joint_q[world, coord_index[j]]
        qd = joint_qd[world, dof_index[j]]
        ctrl = wp.float32(0.0)
        if j < NUM_LEG_JOINTS:
            ctrl = leg_pd_torque(leg_q_target[world, j], q, qd, gains.leg_kp, gains.leg_kd, limit)
        else:
            k = j - NUM_LEG_JOINTS
            pid = wheel_pid_torque(
                wheel_qd_target[world, k],
                qd,
                wheel_integral_in[world, k],
                wheel_prev_error_in[world, k],
                gains.wheel_kp,
                gains.wheel_ki,
                gains.wheel_kd,
                gains.wheel_i_limit,
                limit,
                gains.dt,
            )
            ctrl = pid[0]
            wheel_integral_out[world, k] = pid[1]
            wheel_prev_error_out[world, k] = pid[2]
        tau = wp.clamp(motor_strength[world, j] * ctrl, -limit, limit)
        joint_torque[world, j] = tau
        joint_f[world, dof_index[j]] = tau


@wp.kernel
def reset_wheel_pid(
    env_ids: wp.array(dtype=wp.int32),
    # outputs
    wheel_integral: wp.array2d(dtype=wp.float32),
    wheel_prev_error: wp.array2d(dtype=wp.float32),
):
    """Zero the wheel PID state (integral and previous error) of robots ``env_ids``; dim = len(env_ids)."""
    i = wp.tid()
    world = env_ids[i]
    for k in range(NUM_WHEELS):
        wheel_integral[world, k] = 0.0
        wheel_prev_error[world, k] = 0.0


def launch_actuation(
    joint_q: wp.array,
    joint_qd: wp.array,
    leg_q_target: wp.array,
    wheel_qd_target: wp.array,
    torque_limit: wp.array,
    motor_strength: wp.array,
    wheel_integral: wp.array,
    wheel_prev_error: wp.array,
    joint_torque: wp.array,
    joint_f: wp.array,
    coord_index: wp.array,
    dof_index: wp.array,
    *,
    leg_kp: float,
    leg_kd: float,
    wheel_kp: float,
    wheel_ki: float,
    wheel_kd: float,
    wheel_i_limit: float,
    dt: float,
    wheel_integral_out: wp.array | None = None,
    wheel_prev_error_out: wp.array | None = None,
    device=None,
    record_cmd: bool = False,
):
    """Compute and apply the actuated-joint torques of every robot for one physics substep (:func:`apply_actuation`).

    All arrays are float32; ``W`` = world_count. Flat Newton arrays (``model.joint_q`` etc.) can be passed as
    ``arr.reshape((W, per_world))``.

    Args:
        joint_q: (W, coords_per_world) joint coordinates; actuated joint j at column ``coord_index[j]`` [rad].
        joint_qd: (W, dofs_per_world) joint velocities; actuated joint j at column ``dof_index[j]`` [rad/s].
        leg_q_target: (W, 12) leg position targets [rad].
        wheel_qd_target: (W, 4) wheel velocity targets [rad/s].
        torque_limit: (16,) torque limit per actuated joint [N m].
        motor_strength: (W, 16) multiplicative torque scale (domain randomisation) [-], applied after PD/PID.
        wheel_integral: (W, 4) wheel PID integral state [rad], read (and updated in place without ``*_out``).
        wheel_prev_error: (W, 4) wheel PID previous velocity error [rad/s], likewise.
        joint_torque: (W, 16) output torques [N m].
        joint_f: (W, dofs_per_world) generalized forces; columns ``dof_index`` are written [N m],
            the others are left untouched.
        coord_index, dof_index: (16,) int32 column of each actuated joint (project order) in a world's
            ``joint_q`` / ``joint_qd`` row (``wqwarp.robot.asset.RobotLayout``).
        leg_kp, leg_kd, wheel_kp, wheel_ki, wheel_kd, wheel_i_limit, dt: :class:`ActuationGains`.
        wheel_integral_out, wheel_prev_error_out: (W, 4) where the updated PID state goes (default: in place), for
            a taped rollout.
        device: Warp device to launch on (default: the arrays' device).
        record_cmd: return the prepared launch instead of running it (replay it with ``.launch()``).
    """
    gains = actuation_gains(
        leg_kp=leg_kp,
        leg_kd=leg_kd,
        wheel_kp=wheel_kp,
        wheel_ki=wheel_ki,
        wheel_kd=wheel_kd,
        wheel_i_limit=wheel_i_limit,
        dt=dt,
    )
    i_out = wheel_integral if wheel_integral_out is None else wheel_integral_out
    e_out = wheel_prev_error if wheel_prev_error_out is None else wheel_prev_error_out
    return wp.launch(
        apply_actuation,
        dim=joint_q.shape[0],
        inputs=[
            joint_q,
            joint_qd,
            coord_index,
            dof_index,
            leg_q_target,
            wheel_qd_target,
            gains,
            torque_limit,
            motor_strength,
            wheel_integral,
            wheel_prev_error,
        ],
        outputs=[i_out, e_out, joint_torque, joint_f],
        record_cmd=record_cmd,
        device=device or joint_q.device,
    )


def launch_reset_wheel_pid(env_ids: wp.array, wheel_integral: wp.array, wheel_prev_error: wp.array, device=None):
    """Zero the wheel PID state of the robots ``env_ids`` ((n,) int32); state arrays are (W, 4) float32."""
    if env_ids.shape[0] == 0:
        return
    wp.launch(
        reset_wheel_pid,
        dim=env_ids.shape[0],
        inputs=[env_ids],
        outputs=[wheel_integral, wheel_prev_error],
        device=device or env_ids.device,
    )
