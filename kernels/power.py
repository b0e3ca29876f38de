"""Power metrics per robot, averaged over the physics substeps of one policy step.

References:
    p_cost: the paper's power cost, sum over the 16 actuated joints of |tau_i| |qd_i|.
    Joule-heating model P = sum max(0.3 tau^2 + tau qd, 0) for Go1: the paper authors' lineage, see
    ``../shared/reference/SIMULATION_FACTS.md``.

Usage per policy step: zero ``p_cost``, ``p_mech``, ``p_joule``; after each of the ``substeps`` physics substeps call
:func:`launch_power` with ``weight = 1 / substeps``; the arrays then hold the substep-averaged power [W].
"""

from __future__ import annotations

import warp as wp

NUM_ACTUATED = wp.constant(16)
JOULE_COEFF = wp.constant(0.3)
"""Copper-loss coefficient of the Joule model [W/(N m)^2] (SIMULATION_FACTS.md)."""


@wp.func
def p_cost_term(tau: float, qd: float) -> float:
    """p = |tau| |qd| [W]: one joint's term of the paper's p_cost; tau [N m], qd [rad/s]."""
    return wp.abs(tau) * wp.abs(qd)


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
):
    """One thread per robot: add weight * sum over 16 joints of each power term."""
    world = wp.tid()
    cost = wp.float32(0.0)
    mech = wp.float32(0.0)
    joule = wp.float32(0.0)
    for j in range(NUM_ACTUATED):
        tau = joint_torque[world, j]
        qd = joint_qd[world, dof_index[j]]
        cost += p_cost_term(tau, qd)
        mech += positive_mech_power_term(tau, qd)
        joule += joule_power_term(tau, qd)
    p_cost[world] += weight * cost
    p_mech[world] += weight * mech
    p_joule[world] += weight * joule


def launch_power(
    joint_torque: wp.array,
    joint_qd: wp.array,
    p_cost: wp.array,
    p_mech: wp.array,
    p_joule: wp.array,
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
        p_cost: (W,) sum |tau| |qd| [W], accumulated.
        p_mech: (W,) sum max(tau qd, 0) [W], accumulated.
        p_joule: (W,) sum max(0.3 tau^2 + tau qd, 0) [W], accumulated.
        weight: scale of this substep's contribution, 1 / substeps [-].
        dof_index: (16,) int32 column of each actuated joint in a world's ``joint_qd`` row.
        device: Warp device to launch on (default: the arrays' device).
        record_cmd: return the prepared launch instead of running it (replay it with ``.launch()``).
    """
    return wp.launch(
        accumulate_power,
        dim=joint_torque.shape[0],
        inputs=[joint_torque, joint_qd, dof_index, weight],
        outputs=[p_cost, p_mech, p_joule],
        record_cmd=record_cmd,
        device=device or joint_torque.device,
    )
