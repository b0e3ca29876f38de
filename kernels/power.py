"""Power metrics per robot, averaged over the physics substeps of one policy step.

References:
    p_cost: the paper's power cost, sum over the 16 actuated joints of |tau_i| |qd_i|.
    Joule-heating model P = sum max(0.3 tau^2 + tau qd, 0) for Go1: the paper authors' lineage, see
    ``../shared/reference/SIMULATION_FACTS.md``.

Usage per policy step: zero the output arrays; after each of the ``substeps`` physics substeps call
:func:`launch_power` with ``weight = 1 / substeps``; the arrays then hold substep averages. Outputs, each (W,):
``p_cost``, ``p_mech``, ``p_joule`` over all 16 joints [W]; the same split into legs (joints 0-11) and wheels
(12-15); ``torque_sq`` = sum tau_j^2 [(N m)^2] and ``power_sq`` = sum (tau_j qd_j)^2 [W^2], the substep averages
the reward's "joint torques" and "energy efficiency" terms read (the energy term is the squared norm of the vector
of joint powers, ||(tau_j qd_j)_j||^2, averaged over the substeps like p_cost).
"""

from __future__ import annotations

import warp as wp

NUM_ACTUATED = wp.constant(16)
NUM_LEG_JOINTS = wp.constant(12)
JOULE_COEFF = wp.constant(0.3)
"""Copper-loss coefficient of the Joule model [W/(N m)^2] (SIMULATION_FACTS.md)."""


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
def joule_power_term(tau: float, qd: float) -> float:
    """p = max(0.3 tau^2 + tau qd, 0) [W]: Joule heating plus mechanical power of one joint; tau [N m], qd [rad/s]."""
    # Coefficient 0.3 from the Go1 Joule model of the authors' lineage (SIMULATION_FACTS.md).
    return wp.max(JOULE_COEFF * tau * tau + tau * qd, 0.0)


@wp.kernel
def accumulate_power(
    joint_torque: wp.array2d(dtype=wp.float32),
    joint_qd: wp.array2d(dtype=wp.float32),
    dof_index: wp.array(dtype=wp.int32),
    weight: float,
    # outputs (accumulated with +=; the caller zeroes them at the start of each policy step)
    p_cost: wp.array(dtype=wp.float32),
    p_mech: wp.array(dtype=wp.float32),
    p_joule: wp.array(dtype=wp.float32),
    p_cost_legs: wp.array(dtype=wp.float32),
    p_cost_wheels: wp.array(dtype=wp.float32),
    p_mech_legs: wp.array(dtype=wp.float32),
    p_mech_wheels: wp.array(dtype=wp.float32),
    p_joule_legs: wp.array(dtype=wp.float32),
    p_joule_wheels: wp.array(dtype=wp.float32),
    torque_sq: wp.array(dtype=wp.float32),
    power_sq: wp.array(dtype=wp.float32),
):
    """One thread per robot: add weight * (sum over the legs' and the wheels' joints) of each term."""
    world = wp.tid()
    cost = wp.vec2(0.0, 0.0)
    mech = wp.vec2(0.0, 0.0)
    joule = wp.vec2(0.0, 0.0)
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
        joule[g] += joule_power_term(tau, qd)
        tsq += tau * tau
        psq += (tau * qd) * (tau * qd)
    p_cost[world] += weight * (cost[0] + cost[1])
    p_mech[world] += weight * (mech[0] + mech[1])
    p_joule[world] += weight * (joule[0] + joule[1])
    p_cost_legs[world] += weight * cost[0]
    p_cost_wheels[world] += weight * cost[1]
    p_mech_legs[world] += weight * mech[0]
    p_mech_wheels[world] += weight * mech[1]
    p_joule_legs[world] += weight * joule[0]
    p_joule_wheels[world] += weight * joule[1]
    torque_sq[world] += weight * tsq
    power_sq[world] += weight * psq


POWER_OUTPUTS = (
    "p_cost",
    "p_mech",
    "p_joule",
    "p_cost_legs",
    "p_cost_wheels",
    "p_mech_legs",
    "p_mech_wheels",
    "p_joule_legs",
    "p_joule_wheels",
    "torque_sq",
    "power_sq",
)
"""Names of :func:`accumulate_power`'s outputs, in order; each is a (W,) float32 array."""
REPORTED_POWER = ("p_cost", *(k for k in POWER_OUTPUTS if k.endswith(("_legs", "_wheels"))))
"""The outputs reported per training iteration (``Metrics/<name>``) and averaged by an evaluation task [W]: the
paper's p_cost and each measure split into legs and wheels."""


def launch_power(
    joint_torque: wp.array,
    joint_qd: wp.array,
    outputs: list,
    dof_index: wp.array,
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
        device: Warp device to launch on (default: the arrays' device).
        record_cmd: return the prepared launch instead of running it (replay it with ``.launch()``).
    """
    if len(outputs) != len(POWER_OUTPUTS):
        raise ValueError(f"launch_power needs {len(POWER_OUTPUTS)} output arrays ({', '.join(POWER_OUTPUTS)})")
    return wp.launch(
        accumulate_power,
        dim=joint_torque.shape[0],
        inputs=[joint_torque, joint_qd, dof_index, weight],
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
