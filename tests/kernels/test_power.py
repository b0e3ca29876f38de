"""Tests of kernels/power.py: each power term against NumPy and a hand value; substep averaging of the kernel."""

from __future__ import annotations

import numpy as np
import pytest
import warp as wp

from wqwarp.kernels.power import joule_power_term, launch_power, p_cost_term, positive_mech_power_term

DEVICES = ["cpu"] + (["cuda:0"] if wp.is_cuda_available() else [])
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


@pytest.mark.parametrize("device", DEVICES)
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


@pytest.mark.parametrize("device", DEVICES)
def test_accumulate_power_averages_substeps(device):
    rng = np.random.default_rng(1)
    substeps = 4
    sums = [wp.zeros(NUM_ENVS, dtype=wp.float32, device=device) for _ in range(3)]
    expected = np.zeros((NUM_ENVS, 3))
    for _ in range(substeps):
        tau = rng.uniform(-30, 30, (NUM_ENVS, 16)).astype(np.float32)
        qd = rng.uniform(-20, 20, (NUM_ENVS, DOFS)).astype(np.float32)
        qd[:, :QD_START] = 1e3  # base dofs and any trailing dofs must not count
        qd[:, QD_START + 16 :] = 1e3
        launch_power(
            wp.array(tau, dtype=wp.float32, device=device),
            wp.array(qd, dtype=wp.float32, device=device),
            *sums,
            weight=1.0 / substeps,
            dof_index=wp.array(np.arange(QD_START, QD_START + 16), dtype=wp.int32, device=device),
            device=device,
        )
        expected += (
            np_terms(tau.astype(np.float64), qd[:, QD_START : QD_START + 16].astype(np.float64)).sum(1) / substeps
        )
    np.testing.assert_allclose(np.stack([s.numpy() for s in sums], -1), expected, rtol=1e-5, atol=1e-4)


@pytest.mark.parametrize("device", DEVICES)
def test_accumulate_power_hand_value(device):
    # One robot, joint 0 only: tau=2, qd=3 every substep -> averages 6, 6, 7.2 over 2 substeps.
    tau = np.zeros((1, 16), dtype=np.float32)
    qd = np.zeros((1, DOFS), dtype=np.float32)
    tau[0, 0], qd[0, QD_START] = 2.0, 3.0
    sums = [wp.zeros(1, dtype=wp.float32, device=device) for _ in range(3)]
    for _ in range(2):
        launch_power(
            wp.array(tau, dtype=wp.float32, device=device),
            wp.array(qd, dtype=wp.float32, device=device),
            *sums,
            dof_index=wp.array(np.arange(QD_START, QD_START + 16), dtype=wp.int32, device=device),
            weight=0.5,
            device=device,
        )
    np.testing.assert_allclose([s.numpy()[0] for s in sums], [6.0, 6.0, 7.2], rtol=1e-6)
