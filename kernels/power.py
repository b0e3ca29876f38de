"""Power metrics per robot, averaged over the physics substeps of one policy step.

References:
    p_cost: the paper's power cost, sum over the 16 actuated joints of |tau_i| |qd_i|.
    p_elec: the electrical power the battery pays, per joint tau qd + (tau / (G k_m))^2 + (c + b |qd|) |qd| (the
    motor model of ``wqwarp.robot.motors``, one actuator type per joint), beyond the paper. It replaced the
    single-coefficient Joule model sum max(0.3 tau^2 + tau qd, 0) (``p_joule``, still read in old result files).

Usage per policy step: zero the output arrays; after each of the ``substeps`` physics substeps call
:func:`launch_power` with ``weight = 1 / substeps``; the arrays then hold substep averages. Outputs, each (W,):
``p_cost``, ``p_mech``, ``p_elec`` over all 16 joints [W]; the same split into legs (joints 0-11) and wheels
(12-15); the copper loss of each (``p_copper_legs``, ``p_copper_wheels``); ``torque_sq`` = sum tau_j^2 [(N m)^2]
and ``power_sq`` = sum (tau_j qd_j)^2 [W^2], the substep averages the reward's "joint torques" and "energy
efficiency" terms read (the energy term is the squared norm of the vector of joint powers, ||(tau_j qd_j)_j||^2,
averaged over the substeps like p_cost).
"""

from __future__ import annotations

from dataclasses import dataclass

import warp as wp

NUM_ACTUATED = wp.constant(16)
NUM_LEG_JOINTS = wp.constant(12)


@wp.func
def p_cost_term(tau: float, qd: float) -> float:
    """p = |tau| |qd| [W]: one joint's term of the paper's p_cost; tau [N m], qd [rad/s]."""
    return wp.abs(tau) * wp.abs(qd)


@wp.func
def smooth_abs(x: float, eps: float) -> float:
    """sqrt(x^2 + eps^2) - eps: a smooth |x| for gradients, same unit as x and eps (eps > 0).

    Equals 0 at x = 0 and |x| - eps + O(eps^2 / |x|) far from 0, so it underestimates |x| by at most eps; its slope
    is x / sqrt(x^2 + eps^2), which goes through 0 at x = 0 with slope 1 / eps instead of jumping from -1 to +1.
    Used only where gradients are taken (``wqwarp.diff.rollout``); every reported power uses the exact |x|.
    """
    return wp.sqrt(x * x + eps * eps) - eps


@wp.func
def p_cost_term_smooth(tau: float, qd: float, eps_tau: float, eps_qd: float) -> float:
    """Smooth p_cost term smooth_abs(tau, eps_tau) * smooth_abs(qd, eps_qd) [W] for gradients (see
    :func:`smooth_abs`); below |p_cost_term| by at most eps_tau |qd| + eps_qd |tau| + eps_tau eps_qd."""
    return smooth_abs(tau, eps_tau) * smooth_abs(qd, eps_qd)


@wp.func
def positive_mech_power_term(tau: float, qd: float) -> float:
    """p = max(tau qd, 0) [W]: positive mechanical power of one joint (no regeneration); tau [N m], qd [rad/s]."""
    return wp.max(tau * qd, 0.0)


@wp.func
def copper_loss_term(tau: float, copper: float) -> float:
    """p = copper tau^2 [W]: a motor's winding (I^2 R) loss at output torque tau [N m]; copper = 1 / (G k_m)^2
    [W / (N m)^2] with G the gear ratio and k_m the motor constant (``wqwarp.robot.motors``)."""
    return copper * tau * tau


@wp.func
def electrical_power_term(tau: float, qd: float, copper: float, coulomb: float, viscous: float) -> float:
    """p = tau qd + copper tau^2 + (coulomb + viscous |qd|) |qd| [W]: the electrical power one joint draws from the
    bus (negative while it generates); tau [N m], qd [rad/s], copper [W / (N m)^2], coulomb [N m], viscous
    [N m s / rad]."""
    return tau * qd + copper_loss_term(tau, copper) + (coulomb + viscous * wp.abs(qd)) * wp.abs(qd)


@wp.func
def battery_power(p: float, regeneration: float) -> float:
    """p if p >= 0, else regeneration * p [W]: what the battery pays for a bus power p, taking back the share
    ``regeneration`` (in [0, 1]) of generated power."""
    if p >= 0.0:
        return p
    return regeneration * p


@wp.kernel
def accumulate_power(
    joint_torque: wp.array2d(dtype=wp.float32),
    joint_qd: wp.array2d(dtype=wp.float32),
    dof_index: wp.array(dtype=wp.int32),
    copper: wp.array(dtype=wp.float32),
    coulomb: wp.array(dtype=wp.float32),
    viscous: wp.array(dtype=wp.float32),
    regeneration: float,
    shared_bus: int,
    weight: float,
    # outputs (accumulated with +=; the caller zeroes them at the start of each policy step)
    p_cost: wp.array(dtype=wp.float32),
    p_mech: wp.array(dtype=wp.float32),
    p_elec: wp.array(dtype=wp.float32),
    p_cost_legs: wp.array(dtype=wp.float32),
    p_cost_wheels: wp.array(dtype=wp.float32),
    p_mech_legs: wp.array(dtype=wp.float32),
    p_mech_wheels: wp.array(dtype=wp.float32),
    p_elec_legs: wp.array(dtype=wp.float32),
    p_elec_wheels: wp.array(dtype=wp.float32),
    p_copper_legs: wp.array(dtype=wp.float32),
    p_copper_wheels: wp.array(dtype=wp.float32),
    torque_sq: wp.array(dtype=wp.float32),
    power_sq: wp.array(dtype=wp.float32),
):
    """One thread per robot: add weight * (sum over the legs' and the wheels' joints) of each term.

    Electrical power: with ``shared_bus`` (1) the joints share the robot's DC bus, so one joint's generated power
    feeds the others and only the robot's net is settled with the battery (:func:`battery_power`); the legs' and
    wheels' shares are their signed sums. With 0 each joint settles with the battery on its own."""
    world = wp.tid()
    cost = wp.vec2(0.0, 0.0)
    mech = wp.vec2(0.0, 0.0)
    elec = wp.vec2(0.0, 0.0)
    cu = wp.vec2(0.0, 0.0)
    tsq = float(0.0)
    psq = float(0.0)
    for j in range(NUM_ACTUATED):
        tau = joint_torque[world, j]
        qd = joint_qd[world, dof_index[j]]
        g = 0
        if j >= NUM_LEG_JOINTS:
            g = 1
        # `v[g] += ...`, not `v[g] = v[g] + ...`: Warp 1.19's adjoint of the latter double-counts (NVIDIA/warp#1697)
        cost[g] += p_cost_term(tau, qd)
        mech[g] += positive_mech_power_term(tau, qd)
        pe = electrical_power_term(tau, qd, copper[j], coulomb[j], viscous[j])
        if shared_bus == 0:
            pe = battery_power(pe, regeneration)
        elec[g] += pe
        cu[g] += copper_loss_term(tau, copper[j])
        tsq += tau * tau
        psq += (tau * qd) * (tau * qd)
    total = elec[0] + elec[1]
    if shared_bus != 0:
        total = battery_power(total, regeneration)
    p_cost[world] += weight * (cost[0] + cost[1])
    p_mech[world] += weight * (mech[0] + mech[1])
    p_elec[world] += weight * total
    p_cost_legs[world] += weight * cost[0]
    p_cost_wheels[world] += weight * cost[1]
    p_mech_legs[world] += weight * mech[0]
    p_mech_wheels[world] += weight * mech[1]
    p_elec_legs[world] += weight * elec[0]
    p_elec_wheels[world] += weight * elec[1]
    p_copper_legs[world] += weight * cu[0]
    p_copper_wheels[world] += weight * cu[1]
    torque_sq[world] += weight * tsq
    power_sq[world] += weight * psq


POWER_OUTPUTS = (
    "p_cost",
    "p_mech",
    "p_elec",
    "p_cost_legs",
    "p_cost_wheels",
    "p_mech_legs",
    "p_mech_wheels",
    "p_elec_legs",
    "p_elec_wheels",
    "p_copper_legs",
    "p_copper_wheels",
    "torque_sq",
    "power_sq",
)
"""Names of :func:`accumulate_power`'s outputs, in order; each is a (W,) float32 array."""
REPORTED_POWER = ("p_cost", "p_elec", *(k for k in POWER_OUTPUTS if k.endswith(("_legs", "_wheels"))))
"""The outputs reported per training iteration (``Metrics/<name>``) and averaged by an evaluation task [W]: the
paper's p_cost, the electrical power the battery pays, and each measure split into legs and wheels."""


@dataclass(frozen=True)
class MotorArrays:
    """The motor model as the power kernel reads it (:meth:`build` from ``wqwarp.robot.motors.MotorModel``)."""

    copper: wp.array
    """(16,) float32 copper-loss coefficient 1 / (G k_m)^2 of each actuated joint [W / (N m)^2]."""
    coulomb: wp.array
    """(16,) float32 Coulomb friction whose loss the physics does not simulate [N m]."""
    viscous: wp.array
    """(16,) float32 viscous friction whose loss the physics does not simulate [N m s / rad]."""
    regeneration: float
    """Share of generated power the battery takes back, in [0, 1]."""
    shared_bus: bool
    """The joints share the robot's DC bus (only the robot's net power is settled with the battery)."""

    @staticmethod
    def build(copper, coulomb, viscous, regeneration: float, shared_bus: bool, device=None) -> MotorArrays:
        """From 16 values per coefficient (``wqwarp.robot.motors.MotorModel.kernel_inputs``) on ``device``."""
        arr = {
            k: wp.array(v, dtype=wp.float32, device=device)
            for k, v in (("copper", copper), ("coulomb", coulomb), ("viscous", viscous))
        }
        if any(a.shape != (NUM_ACTUATED,) for a in arr.values()):
            raise ValueError(f"the motor coefficients need {NUM_ACTUATED} values each")
        return MotorArrays(**arr, regeneration=float(regeneration), shared_bus=bool(shared_bus))


def launch_power(
    joint_torque: wp.array,
    joint_qd: wp.array,
    outputs: list,
    dof_index: wp.array,
    motor: MotorArrays,
    *,
    weight: float,
    device=None,
    record_cmd: bool = False,
):
    """Accumulate one substep's power into the per-robot sums (``+=``; zero them at each policy step's start).

    All arrays are float32; ``W`` = world_count.

    Args:
        joint_torque: (W, 16) actuated-joint torques [N m], project joint order.
        joint_qd: (W, dofs_per_world) joint velocities; actuated joint j at column ``dof_index[j]`` [rad/s].
        outputs: the (W,) arrays named by :data:`POWER_OUTPUTS`, in that order, accumulated.
        weight: scale of this substep's contribution, 1 / substeps [-].
        dof_index: (16,) int32 column of each actuated joint in a world's ``joint_qd`` row.
        motor: the motor model's per-joint coefficients and bus rule (electrical power).
        device: Warp device to launch on (default: the arrays' device).
        record_cmd: return the prepared launch instead of running it (replay it with ``.launch()``).
    """
    if len(outputs) != len(POWER_OUTPUTS):
        raise ValueError(f"launch_power needs {len(POWER_OUTPUTS)} output arrays ({', '.join(POWER_OUTPUTS)})")
    return wp.launch(
        accumulate_power,
        dim=joint_torque.shape[0],
        inputs=[
            joint_torque,
            joint_qd,
            dof_index,
            motor.copper,
            motor.coulomb,
            motor.viscous,
            float(motor.regeneration),
            int(motor.shared_bus),
            weight,
        ],
        outputs=list(outputs),
        record_cmd=record_cmd,
        device=device or joint_torque.device,
    )


@wp.kernel
def accumulate_p_cost_taped(
    joint_torque: wp.array2d(dtype=wp.float32),
    joint_qd: wp.array2d(dtype=wp.float32),
    dof_index: wp.array(dtype=wp.int32),
    weight: float,
    eps_tau: float,
    eps_qd: float,
    # outputs (accumulated with +=)
    p_cost_legs: wp.array(dtype=wp.float32),
    p_cost_wheels: wp.array(dtype=wp.float32),
    p_cost_smooth: wp.array(dtype=wp.float32),
):
    """One thread per robot: add weight * the exact p_cost of the legs and of the wheels, and weight * the smooth
    p_cost (:func:`p_cost_term_smooth`, all 16 joints) whose gradient a differentiable rollout follows. Only
    ``+=`` writes, so ``wp.Tape`` differentiates a sum over many substeps into one array correctly."""
    world = wp.tid()
    legs = float(0.0)
    wheels = float(0.0)
    smooth = float(0.0)
    for j in range(NUM_ACTUATED):
        tau = joint_torque[world, j]
        qd = joint_qd[world, dof_index[j]]
        if j < NUM_LEG_JOINTS:
            legs += p_cost_term(tau, qd)
        else:
            wheels += p_cost_term(tau, qd)
        smooth += p_cost_term_smooth(tau, qd, eps_tau, eps_qd)
    wp.atomic_add(p_cost_legs, world, weight * legs)
    wp.atomic_add(p_cost_wheels, world, weight * wheels)
    wp.atomic_add(p_cost_smooth, world, weight * smooth)
