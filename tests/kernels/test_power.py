"""Tests of kernels/power.py: each power term against NumPy and a hand value; substep averaging of the kernel; the
electrical power of the motor model (wqwarp.robot.motors) by hand, per joint and settled over the bus."""

from __future__ import annotations

import numpy as np
import pytest
import warp as wp

from wqwarp.kernels.power import (
    POWER_OUTPUTS,
    MotorArrays,
    battery_power,
    electrical_power_term,
    launch_power,
    p_cost_term,
    positive_mech_power_term,
)
from wqwarp.robot.motors import AK80_6, GO1_HIP_THIGH, GO1_KNEE, ActuatorType, MotorModel

NUM_ENVS = 4
DOFS, QD_START = 22, 6
COPPER, COULOMB, VISCOUS = 0.5, 0.2, 0.01  # one joint's coefficients for the term tests


@wp.kernel
def _eval_terms(tau: wp.array(dtype=wp.float32), qd: wp.array(dtype=wp.float32), out: wp.array(dtype=wp.vec4)):
    i = wp.tid()
    pe = electrical_power_term(tau[i], qd[i], COPPER, COULOMB, VISCOUS)
    out[i] = wp.vec4(p_cost_term(tau[i], qd[i]), positive_mech_power_term(tau[i], qd[i]), pe, battery_power(pe, 0.25))


def np_terms(tau, qd):
    pe = tau * qd + COPPER * tau**2 + (COULOMB + VISCOUS * np.abs(qd)) * np.abs(qd)
    return np.stack([np.abs(tau) * np.abs(qd), np.maximum(tau * qd, 0), pe, np.where(pe >= 0, pe, 0.25 * pe)], -1)


def run_terms(tau, qd, device):
    tau_wp = wp.array(np.asarray(tau, dtype=np.float32), dtype=wp.float32, device=device)
    qd_wp = wp.array(np.asarray(qd, dtype=np.float32), dtype=wp.float32, device=device)
    out = wp.zeros(tau_wp.shape[0], dtype=wp.vec4, device=device)
    wp.launch(_eval_terms, dim=tau_wp.shape[0], inputs=[tau_wp, qd_wp], outputs=[out], device=device)
    return out.numpy()


def test_power_terms_match_numpy_and_hand_values(device):
    rng = np.random.default_rng(0)
    tau = rng.uniform(-30, 30, 128).astype(np.float32)
    qd = rng.uniform(-20, 20, 128).astype(np.float32)
    np.testing.assert_allclose(
        run_terms(tau, qd, device), np_terms(tau.astype(np.float64), qd.astype(np.float64)), rtol=1e-5, atol=1e-4
    )
    # tau=2, qd=3: p_cost 6, p_mech 6, p_elec 6 + 0.5*4 + (0.2 + 0.03)*3 = 8.69.
    # tau=2, qd=-3: 6, 0, -6 + 2 + 0.69 = -3.31, battery 0.25 * -3.31 = -0.8275 (generating while braking).
    # tau=4, qd=0: 0, 0, 0.5*16 = 8 (holding torque at zero speed costs copper, not mechanical power).
    hand = run_terms([2.0, 2.0, 4.0], [3.0, -3.0, 0.0], device)
    np.testing.assert_allclose(hand, [[6, 6, 8.69, 8.69], [6, 0, -3.31, -0.8275], [0, 0, 8, 8]], rtol=1e-5, atol=1e-5)


def _model_arrays(model: MotorModel, device):
    return MotorArrays.build(**model.kernel_inputs(), device=device)


def _np_accumulate(model: MotorModel, tau, qd):
    """(N, outputs) of one substep, in POWER_OUTPUTS order, from the motor model's Python reference."""
    n = tau.shape[0]
    rows = []
    per = model.per_joint()
    for w in range(n):
        t, v = tau[w], qd[w]
        cost, mech = np.abs(t) * np.abs(v), np.maximum(t * v, 0)
        pe = np.array([model.joint_power(j, t[j], v[j]) for j in range(16)])
        settle = np.where(pe >= 0, pe, model.regeneration * pe)
        legs_e, wheels_e = (
            (pe[:12].sum(), pe[12:].sum()) if model.shared_bus else (settle[:12].sum(), settle[12:].sum())
        )
        cu = np.asarray(per["copper"]) * t**2
        rows.append(
            [
                cost.sum(),
                mech.sum(),
                model.battery_power(t, v),
                cost[:12].sum(),
                cost[12:].sum(),
                mech[:12].sum(),
                mech[12:].sum(),
                legs_e,
                wheels_e,
                cu[:12].sum(),
                cu[12:].sum(),
                (t**2).sum(),
                ((t * v) ** 2).sum(),
            ]
        )
    return np.asarray(rows)


@pytest.mark.parametrize(
    "model",
    [
        MotorModel(),
        MotorModel(shared_bus=False, regeneration=0.6),
        MotorModel(wheel_type=ActuatorType("w", 6.0, 0.2, (0.2, 0.3), coulomb_friction=0.1, viscous_friction=0.02)),
    ],
    ids=["shared_bus", "per_joint_regen", "wheel_friction"],
)
def test_accumulate_power_averages_substeps(device, model):
    rng = np.random.default_rng(1)
    substeps = 4
    sums = [wp.zeros(NUM_ENVS, dtype=wp.float32, device=device) for _ in POWER_OUTPUTS]
    expected = np.zeros((NUM_ENVS, len(POWER_OUTPUTS)))
    arrays = _model_arrays(model, device)
    for _ in range(substeps):
        tau = rng.uniform(-30, 30, (NUM_ENVS, 16)).astype(np.float32)
        qd = rng.uniform(-20, 20, (NUM_ENVS, DOFS)).astype(np.float32)
        qd[:, :QD_START] = 1e3  # base dofs and any trailing dofs must not count
        qd[:, QD_START + 16 :] = 1e3
        launch_power(
            wp.array(tau, dtype=wp.float32, device=device),
            wp.array(qd, dtype=wp.float32, device=device),
            sums,
            wp.array(np.arange(QD_START, QD_START + 16), dtype=wp.int32, device=device),
            arrays,
            weight=1.0 / substeps,
            device=device,
        )
        expected += _np_accumulate(model, tau.astype(np.float64), qd[:, QD_START : QD_START + 16].astype(np.float64))
    expected /= substeps
    got = np.stack([s.numpy() for s in sums], -1)
    np.testing.assert_allclose(got, expected, rtol=1e-5, atol=2e-2)


def test_one_joint_by_hand_and_the_bus_rule(device):
    """A hip motor holding 10 N m at rest pays only copper: (10 / (6.33 x 0.147))^2 = 115.5 W; a knee at the same
    torque (gear 9.495) 51.3 W; a wheel braking (-2 N m at 10 rad/s: -20 W mechanical, copper (2 / (6 x 0.2206))^2
    = 2.28 W) generates -17.7 W, which on a shared bus pays for part of the hip, and without a shared bus is lost."""
    assert GO1_HIP_THIGH.copper_coefficient * 100 == pytest.approx(115.5, rel=1e-3)
    assert GO1_KNEE.copper_coefficient * 100 == pytest.approx(51.34, rel=1e-3)
    assert AK80_6.copper_coefficient * 4 == pytest.approx(2.283, rel=1e-3)
    tau = np.zeros((1, 16), dtype=np.float32)
    qd = np.zeros((1, DOFS), dtype=np.float32)
    tau[0, 0] = 10.0  # FR hip holds at rest
    tau[0, 12], qd[0, QD_START + 12] = -2.0, 10.0  # FR wheel brakes
    hip, wheel = 115.5, -20.0 + 2.283
    for model, total, wheels in (
        (MotorModel(), hip + wheel, wheel),
        (MotorModel(shared_bus=False), hip, 0.0),
        (MotorModel(shared_bus=False, regeneration=0.5), hip + 0.5 * wheel, 0.5 * wheel),
    ):
        sums = [wp.zeros(1, dtype=wp.float32, device=device) for _ in POWER_OUTPUTS]
        for _ in range(2):
            launch_power(
                wp.array(tau, dtype=wp.float32, device=device),
                wp.array(qd, dtype=wp.float32, device=device),
                sums,
                wp.array(np.arange(QD_START, QD_START + 16), dtype=wp.int32, device=device),
                MotorArrays.build(**model.kernel_inputs(), device=device),
                weight=0.5,
                device=device,
            )
        got = dict(zip(POWER_OUTPUTS, [float(s.numpy()[0]) for s in sums], strict=True))
        assert got["p_elec"] == pytest.approx(total, rel=2e-3), model
        assert got["p_elec_legs"] == pytest.approx(hip, rel=2e-3) and got["p_elec_wheels"] == pytest.approx(
            wheels, abs=0.05
        )
        assert got["p_copper_legs"] == pytest.approx(hip, rel=2e-3) and got["p_copper_wheels"] == pytest.approx(
            2.283, rel=2e-3
        )
        assert got["p_cost"] == pytest.approx(20.0) and got["p_mech"] == pytest.approx(0.0)
    # a robot whose net is negative pays nothing without regeneration, a share with it
    assert MotorModel().battery_power([0.0] * 12 + [-2.0, 0, 0, 0], [0.0] * 12 + [10.0, 0, 0, 0]) == 0.0
    regen = MotorModel(regeneration=0.5).battery_power([0.0] * 12 + [-2.0, 0, 0, 0], [0.0] * 12 + [10.0, 0, 0, 0])
    assert regen == pytest.approx(0.5 * wheel, rel=1e-3)
    with pytest.raises(ValueError, match="output arrays"):
        launch_power(
            wp.array(tau),
            wp.array(qd),
            sums[:3],
            wp.zeros(16, dtype=wp.int32),
            MotorArrays.build(**MotorModel().kernel_inputs()),
            weight=1.0,
        )


@pytest.mark.parametrize(
    "bad",
    [
        dict(regeneration=1.5),
        dict(electronics_w=-1.0),
        dict(wheel_type=ActuatorType("w", 6.0, 0.2, (0.2, 0.3))),
    ],
    ids=["regeneration", "electronics", "valid_wheel"],
)
def test_the_motor_model_refuses_values_outside_their_meaning(bad):
    if "wheel_type" in bad:  # a valid type builds
        assert MotorModel(**bad).types[12].name == "w"
        with pytest.raises(ValueError, match="motor_constant"):
            ActuatorType("w", 6.0, 0.4, (0.2, 0.3))
        return
    with pytest.raises(ValueError):
        MotorModel(**bad)
