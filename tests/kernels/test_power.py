"""Tests of kernels/power.py: each power term against NumPy and a hand value; substep averaging of the kernel."""

from __future__ import annotations

import numpy as np
import pytest
import warp as wp

from wqwarp.kernels.power import (
    POWER_OUTPUTS,
    joule_power_term,
    launch_power,
    p_cost_term,
    positive_mech_power_term,
)

NUM_ENVS = 4
DOFS, QD_START = 22, 6


@wp.kernel
def _eval_terms(tau: wp.array(dtype=wp.float32), qd: wp.array(dtype=wp.float32), out: wp.array(dtype=wp.vec3)):
    i = wp.tid()
    out[i] = wp.vec3(
        p_cost_term(tau[i], qd[i]), positive_mech_power_term(tau[i], qd[i]), joule_power_term(tau[i], qd[i])
    )


def np_terms(tau, qd):
    return np.stack([np.abs(tau) * np.abs(qd), np.maximum(tau * qd, 0), np.maximum(0.3 * tau**2 + tau * qd, 0)], -1)


def run_terms(tau, qd, device):
    tau_wp = wp.array(np.asarray(tau, dtype=np.float32), dtype=wp.float32, device=device)
    qd_wp = wp.array(np.asarray(qd, dtype=np.float32), dtype=wp.float32, device=device)
    out = wp.zeros(tau_wp.shape[0], dtype=wp.vec3, device=device)
    wp.launch(_eval_terms, dim=tau_wp.shape[0], inputs=[tau_wp, qd_wp], outputs=[out], device=device)
    return out.numpy()


def test_power_terms_match_numpy_and_hand_values(device):
    rng = np.random.default_rng(0)
    tau = rng.uniform(-30, 30, 128).astype(np.float32)
    qd = rng.uniform(-20, 20, 128).astype(np.float32)
    np.testing.assert_allclose(
        run_terms(tau, qd, device), np_terms(tau.astype(np.float64), qd.astype(np.float64)), rtol=1e-5, atol=1e-5
    )
    # tau=2, qd=-3: p_cost 6, p_mech 0, joule max(1.2 - 6, 0) = 0. tau=2, qd=3: 6, 6, 7.2.
    # tau=-2, qd=1: 2, 0, max(1.2 - 2, 0) = 0. tau=5, qd=-1: 5, 0, 7.5 - 5 = 2.5 (heating while braking).
    hand = run_terms([2.0, 2.0, -2.0, 5.0], [-3.0, 3.0, 1.0, -1.0], device)
    np.testing.assert_allclose(hand, [[6, 0, 0], [6, 6, 7.2], [2, 0, 0], [5, 0, 2.5]], rtol=1e-6, atol=1e-6)


def test_accumulate_power_averages_substeps(device):
    rng = np.random.default_rng(1)
    substeps = 4
    sums = [wp.zeros(NUM_ENVS, dtype=wp.float32, device=device) for _ in POWER_OUTPUTS]
    expected = np.zeros((NUM_ENVS, len(POWER_OUTPUTS)))
    for _ in range(substeps):
        tau = rng.uniform(-30, 30, (NUM_ENVS, 16)).astype(np.float32)
        qd = rng.uniform(-20, 20, (NUM_ENVS, DOFS)).astype(np.float32)
        qd[:, :QD_START] = 1e3  # base dofs and any trailing dofs must not count
        qd[:, QD_START + 16 :] = 1e3
        launch_power(
            wp.array(tau, dtype=wp.float32, device=device),
            wp.array(qd, dtype=wp.float32, device=device),
            sums,
            weight=1.0 / substeps,
            dof_index=wp.array(np.arange(QD_START, QD_START + 16), dtype=wp.int32, device=device),
            device=device,
        )
        t64, qd64 = tau.astype(np.float64), qd[:, QD_START : QD_START + 16].astype(np.float64)
        terms = np_terms(t64, qd64)  # (N, 16, 3): p_cost, p_mech, p_joule per joint
        legs, wheels = terms[:, :12].sum(1), terms[:, 12:].sum(1)
        expected += (
            np.concatenate(
                [
                    legs + wheels,
                    np.stack([legs[:, 0], wheels[:, 0], legs[:, 1], wheels[:, 1], legs[:, 2], wheels[:, 2]], 1),
                    (t64**2).sum(1, keepdims=True),
                    ((t64 * qd64) ** 2).sum(1, keepdims=True),
                ],
                1,
            )
            / substeps
        )
    got = np.stack([s.numpy() for s in sums], -1)
    np.testing.assert_allclose(got, expected, rtol=1e-5, atol=1e-2)


def test_accumulate_power_hand_value(device):
    # One robot, joint 0 only: tau=2, qd=3 every substep -> averages 6, 6, 7.2 over 2 substeps.
    tau = np.zeros((1, 16), dtype=np.float32)
    qd = np.zeros((1, DOFS), dtype=np.float32)
    tau[0, 0], qd[0, QD_START] = 2.0, 3.0
    tau[0, 13], qd[0, QD_START + 13] = -1.0, 4.0  # FL wheel: p_cost 4, p_mech 0, joule max(0.3 - 4, 0) = 0
    sums = [wp.zeros(1, dtype=wp.float32, device=device) for _ in POWER_OUTPUTS]
    for _ in range(2):
        launch_power(
            wp.array(tau, dtype=wp.float32, device=device),
            wp.array(qd, dtype=wp.float32, device=device),
            sums,
            dof_index=wp.array(np.arange(QD_START, QD_START + 16), dtype=wp.int32, device=device),
            weight=0.5,
            device=device,
        )
    got = dict(zip(POWER_OUTPUTS, [float(s.numpy()[0]) for s in sums], strict=True))
    expected = dict(
        p_cost=10.0,
        p_mech=6.0,
        p_joule=7.2,
        p_cost_legs=6.0,
        p_cost_wheels=4.0,
        p_mech_legs=6.0,
        p_mech_wheels=0.0,
        p_joule_legs=7.2,
        p_joule_wheels=0.0,
        torque_sq=5.0,
        power_sq=52.0,
    )
    assert got == pytest.approx(expected, rel=1e-6)
    with pytest.raises(ValueError, match="output arrays"):
        launch_power(wp.array(tau), wp.array(qd), sums[:3], dof_index=wp.zeros(16, dtype=wp.int32), weight=1.0)
