"""kernels/rewards.py against the registry's NumPy references of the paper's Table II terms, plus hand values."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import warp as wp

from wqwarp.kernels.rewards import RewardInputs, make_reward_kernel
from wqwarp.rl.config import REWARD_TERMS, RewardConfig
from wqwarp.rl.rewards import BEYOND_PAPER, TABLE_II, TERMS, RewardTerm, check_terms, soft_joint_limits

BASE = {"v": "base_lin_vel", "w": "base_ang_vel", "g": "projected_gravity"}
"""The references' names of the base-frame inputs -> the RewardInputs fields."""


def _inputs(device, x: dict) -> RewardInputs:
    inp = RewardInputs()
    for f in (
        "v",
        "w",
        "g",
        "command",
        "action",
        "prev_action",
        "prev2_action",
        "actuated_qd",
        "prev_actuated_qd",
        "torque_sq",
        "power_sq",
        "p_cost",
        "actuated_q",
        "joint_soft_low",
        "joint_soft_high",
    ):
        setattr(inp, BASE.get(f, f), wp.array(np.asarray(x[f], np.float32), dtype=wp.float32, device=device))
    inp.body_collision = wp.array(x["body_collision"].astype(np.int32), dtype=wp.int32, device=device)
    inp.sigma, inp.dt = x["sigma"], x["dt"]
    return inp


def _f32(x: dict) -> dict:
    """The references' inputs: the arrays rounded to float32, as the kernel reads them."""
    return {k: np.asarray(v, np.float32).astype(np.float64) if isinstance(v, np.ndarray) else v for k, v in x.items()}


def _random_inputs(n: int = 5, seed: int = 0) -> dict:
    rng = np.random.default_rng(seed)
    quat = rng.normal(size=(n, 4))
    g = -(quat / np.linalg.norm(quat, axis=1, keepdims=True))[:, :3]  # any vector of norm <= 1
    a, a1, a2 = (rng.normal(size=(n, 20)) for _ in range(3))
    # substep averages (4 substeps) of sum tau^2 and sum (tau qd)^2, as the simulator's power kernel provides them
    tau, qd_sub = rng.normal(size=(4, n, 16)) * 10, rng.normal(size=(4, n, 16)) * 5
    return {
        "v": rng.normal(size=(n, 3)),
        "w": rng.normal(size=(n, 3)),
        "g": g,
        "command": rng.uniform(-1, 1, (n, 3)),
        "action": a,
        "prev_action": a1,
        "prev2_action": a2,
        "actuated_qd": rng.normal(size=(n, 16)) * 5,
        "prev_actuated_qd": rng.normal(size=(n, 16)) * 5,
        "torque_sq": (tau**2).sum(2).mean(0),
        "power_sq": ((tau * qd_sub) ** 2).sum(2).mean(0),
        "p_cost": np.abs(tau * qd_sub).sum(2).mean(0),
        "body_collision": rng.integers(0, 2, (n, 9)),
        "actuated_q": rng.normal(size=(n, 16)) * 2,
        "joint_soft_low": soft_joint_limits(0.9)[0],
        "joint_soft_high": soft_joint_limits(0.9)[1],
        "sigma": 4.0,
        "dt": 0.02,
    }


def _launch(device, terms, x, weights, times: int = 1):
    n, k = len(x["v"]), len(terms)
    reward = wp.zeros(n, dtype=wp.float32, device=device)
    term = wp.zeros((n, k), dtype=wp.float32, device=device)
    ep = wp.zeros((n, k), dtype=wp.float32, device=device)
    kernel = make_reward_kernel(tuple(t.resolve() for t in terms))
    w = wp.array(np.asarray(weights, np.float32), dtype=wp.float32, device=device)
    for _ in range(times):  # episode sums accumulate
        wp.launch(kernel, dim=n, inputs=[_inputs(device, x), w], outputs=[reward, term, ep], device=device)
    return reward.numpy(), term.numpy(), ep.numpy()


def test_registry_derives_the_config_fields_and_every_term_has_a_formula_and_a_reference():
    assert REWARD_TERMS == tuple(t.name for t in TERMS) and len(TABLE_II) == 12
    assert all(t.weight == 0.0 for t in BEYOND_PAPER)  # every preset keeps the paper's reward
    fields = {f.name: f for f in dataclasses.fields(RewardConfig)}
    assert list(fields) == [
        *REWARD_TERMS,
        "tracking_sigma",
        "only_positive",
        "soft_joint_limit",
        "ramp_terms",
        "ramp_start",
        "ramp_iterations",
        "ramp_gate_vy_error",
        "ramp_gate_window",
        "power_measure",
    ]
    for t in TERMS:
        assert fields[t.name].default == t.weight and fields[t.name].metadata["doc"] == t.doc
        assert t.reference is not None and t.doc
        assert t.resolve().__doc__.split(":")[0].strip(), t.name  # the func's docstring starts with its formula
    assert RewardConfig().weights() == [t.weight for t in TERMS]
    with pytest.raises(ValueError, match="twice"):
        check_terms((*TABLE_II, RewardTerm("energy", 1.0, "again")))


@pytest.mark.parametrize("term", TERMS, ids=lambda t: t.name)
def test_each_term_matches_its_numpy_reference(device, term):
    x = _random_inputs()
    _, got, _ = _launch(device, (term,), {**x, "dt": 0.02}, [1.0])
    expected = term.reference(_f32(x)) * 0.02  # weight 1: the column is r_k dt
    np.testing.assert_allclose(got[:, 0], expected, rtol=2e-4, atol=1e-6)


def test_reward_terms_match_numpy(device):
    x = _random_inputs()
    weights = np.asarray(RewardConfig().weights())
    reward, term, ep = _launch(device, TERMS, x, weights, times=2)
    ref = _f32(x)
    expected = np.stack([t.reference(ref) for t in TERMS], 1) * weights * x["dt"]
    np.testing.assert_allclose(term, expected, rtol=2e-4, atol=1e-6)
    np.testing.assert_allclose(reward, expected.sum(1), rtol=2e-4, atol=1e-5)
    np.testing.assert_allclose(ep, 2 * expected, rtol=2e-4, atol=1e-6)


def test_hand_values_and_zero_weights(device):
    # Level robot moving at exactly the commanded (0.5, 0, 0.2): every tracking term is 1 -> weight * dt.
    g = np.array([[0.0, 0.0, -1.0]])
    a = np.zeros((1, 20))
    a[0, 0], a[0, 1] = 3.0, 4.0  # ||a|| = 5
    z16, z20 = np.zeros((1, 16)), np.zeros((1, 20))
    qd = z16.copy()
    qd[0, 0] = 0.1  # qdd = 0.1 / 0.02 = 5 rad/s^2 -> ||qdd||^2 = 25
    coll = np.zeros((1, 9), int)
    coll[0, [0, 3]] = 1  # two bodies on the ground
    weights = np.asarray(RewardConfig().weights())
    weights[REWARD_TERMS.index("torques")] = 0.0
    weights[REWARD_TERMS.index("p_cost")] = -0.02
    weights[REWARD_TERMS.index("joint_limits")] = -10.0
    dt = 0.02
    low, high = soft_joint_limits(0.9)
    q = np.zeros((1, 16))
    q[0, :12] = (low + high) / 2  # every leg joint mid-range, but the first hip 0.1 rad beyond its soft upper limit
    q[0, 0] = high[0] + 0.1  # (the hip range +-0.863 rad: soft limit 0.7767) and a wheel angle of no joint range
    q[0, 12] = 100.0
    x = {
        "v": np.array([[0.5, 0.0, 0.0]]),
        "w": np.array([[0.0, 0.0, 0.2]]),
        "g": g,
        "command": np.array([[0.5, 0.0, 0.2]]),
        "action": a,
        "prev_action": z20,
        "prev2_action": z20,
        "actuated_qd": qd,
        "prev_actuated_qd": z16,
        "torque_sq": np.array([16 * 49.0]),
        "power_sq": np.array([100.0]),
        "p_cost": np.array([25.0]),
        "body_collision": coll,
        "actuated_q": q,
        "joint_soft_low": low,
        "joint_soft_high": high,
        "sigma": 4.0,
        "dt": dt,
    }
    _, term, _ = _launch(device, TERMS, x, weights)
    t = dict(zip(REWARD_TERMS, term[0], strict=True))
    assert t["track_vx"] == pytest.approx(2.0 * dt) and t["track_wz"] == pytest.approx(3.0 * dt)
    assert t["track_vy"] == pytest.approx(2.0 * dt)
    assert t["residual"] == pytest.approx(-0.3 * 5.0 * dt)
    assert t["action_smoothness"] == pytest.approx(-0.01 * 25.0 * dt)  # (a_t + 0 - 0)^2
    assert t["joint_acc"] == pytest.approx(-2.5e-7 * 25.0 * dt)
    assert t["collision"] == pytest.approx(-2.0 * 2 * dt)
    assert t["torques"] == 0.0  # zero weight: not evaluated
    assert t["energy"] == pytest.approx(-1e-5 * 100.0 * dt)  # reads the substep-averaged sum (tau qd)^2
    assert t["p_cost"] == pytest.approx(-0.02 * 25.0 * dt)  # the substep-averaged sum |tau| |qd|, in W
    assert high[0] == pytest.approx(0.9 * 0.863) and t["joint_limits"] == pytest.approx(-10.0 * 0.1 * dt, rel=1e-4)
    assert t["orientation"] == 0.0 and t["lin_vel_z"] == 0.0 and t["ang_vel_xy"] == 0.0
    # Rolled 90 deg: gravity lies along the base y axis, ||g_xy||^2 = 1.
    x["g"] = np.array([[0.0, -1.0, 0.0]])
    _, term, _ = _launch(device, TERMS, x, weights)
    assert term[0, REWARD_TERMS.index("orientation")] == pytest.approx(-2.0 * dt, rel=1e-5)
