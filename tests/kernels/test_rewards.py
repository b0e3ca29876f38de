"""kernels/rewards.py against NumPy versions of the paper's Table II terms, plus hand values."""

from __future__ import annotations

import numpy as np
import pytest
import warp as wp

from wqwarp.kernels.rewards import compute_rewards
from wqwarp.rl.config import REWARD_TERMS, RewardConfig

DEVICES = ["cpu"] + (["cuda:0"] if wp.is_cuda_available() else [])


def _rot_inv(q, v):  # q xyzw
    x, y, z, w = q
    r = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                  [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                  [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])  # fmt: skip
    return r.T @ v


def np_terms(jq, jqd, cmd, a, a1, a2, qd, qd_prev, tau_sq, power_sq, coll, dt, sigma=4.0):
    out = []
    for i in range(len(jq)):
        q = jq[i, 3:7]
        v = _rot_inv(q, jqd[i, 0:3])
        w = _rot_inv(q, jqd[i, 3:6])
        g = _rot_inv(q, np.array([0.0, 0.0, -1.0]))
        out.append([
            np.exp(-sigma * (cmd[i, 0] - v[0]) ** 2), np.exp(-sigma * (cmd[i, 1] - v[1]) ** 2),
            np.exp(-sigma * (cmd[i, 2] - w[2]) ** 2), np.linalg.norm(a[i]), g[0] ** 2 + g[1] ** 2, v[2] ** 2,
            w[0] ** 2 + w[1] ** 2, np.sum(((qd[i] - qd_prev[i]) / dt) ** 2), tau_sq[i],
            np.sum((a[i] + a2[i] - 2 * a1[i]) ** 2), coll[i].sum(), power_sq[i],
        ])  # fmt: skip
    return np.asarray(out)


def _launch(device, jq, jqd, cmd, a, a1, a2, qd, qd_prev, tau_sq, power_sq, coll, weights, dt):
    n = len(jq)
    f = lambda x: wp.array(np.asarray(x, np.float32), dtype=wp.float32, device=device)  # noqa: E731
    reward = wp.zeros(n, dtype=wp.float32, device=device)
    term = wp.zeros((n, 12), dtype=wp.float32, device=device)
    ep = wp.zeros((n, 12), dtype=wp.float32, device=device)
    for _ in range(2):  # episode sums accumulate
        wp.launch(compute_rewards, dim=n,
                  inputs=[f(jq), f(jqd), f(cmd), f(a), f(a1), f(a2), f(qd), f(qd_prev), f(tau_sq), f(power_sq),
                          wp.array(coll.astype(np.int32), dtype=wp.int32, device=device), f(weights), 4.0, dt],
                  outputs=[reward, term, ep], device=device)  # fmt: skip
    return reward.numpy(), term.numpy(), ep.numpy()


@pytest.mark.parametrize("device", DEVICES)
def test_reward_terms_match_numpy(device):
    rng = np.random.default_rng(0)
    n, dt = 5, 0.02
    jq = rng.normal(size=(n, 23))
    quat = rng.normal(size=(n, 4))
    jq[:, 3:7] = quat / np.linalg.norm(quat, axis=1, keepdims=True)
    jqd = rng.normal(size=(n, 22))
    cmd = rng.uniform(-1, 1, (n, 3))
    a, a1, a2 = (rng.normal(size=(n, 20)) for _ in range(3))
    qd, qd_prev = rng.normal(size=(n, 16)) * 5, rng.normal(size=(n, 16)) * 5
    # substep averages (4 substeps) of sum tau^2 and sum (tau qd)^2, as the simulator's power kernel provides them
    tau, qd_sub = rng.normal(size=(4, n, 16)) * 10, rng.normal(size=(4, n, 16)) * 5
    tau_sq, power_sq = (tau**2).sum(2).mean(0), ((tau * qd_sub) ** 2).sum(2).mean(0)
    coll = rng.integers(0, 2, (n, 9))
    weights = np.asarray(RewardConfig().weights())
    reward, term, ep = _launch(device, jq, jqd, cmd, a, a1, a2, qd, qd_prev, tau_sq, power_sq, coll, weights, dt)
    expected = np_terms(jq, jqd, cmd, a, a1, a2, qd, qd_prev, tau_sq, power_sq, coll, dt) * weights * dt
    np.testing.assert_allclose(term, expected, rtol=2e-4, atol=1e-6)
    np.testing.assert_allclose(reward, expected.sum(1), rtol=2e-4, atol=1e-5)
    np.testing.assert_allclose(ep, 2 * expected, rtol=2e-4, atol=1e-6)


@pytest.mark.parametrize("device", DEVICES)
def test_hand_values_and_zero_weights(device):
    # Level robot moving at exactly the commanded (0.5, 0, 0.2): every tracking term is 1 -> weight * dt.
    jq = np.zeros((1, 23))
    jq[0, 6] = 1.0
    jqd = np.zeros((1, 22))
    jqd[0, 0], jqd[0, 5] = 0.5, 0.2
    cmd = np.array([[0.5, 0.0, 0.2]])
    a = np.zeros((1, 20))
    a[0, 0], a[0, 1] = 3.0, 4.0  # ||a|| = 5
    z16 = np.zeros((1, 16))
    coll = np.zeros((1, 9), int)
    coll[0, [0, 3]] = 1  # two bodies on the ground
    weights = np.asarray(RewardConfig().weights())
    weights[REWARD_TERMS.index("torques")] = 0.0
    dt = 0.02
    z20 = np.zeros((1, 20))
    tau_sq, power_sq = np.array([16 * 49.0]), np.array([100.0])
    _, term, _ = _launch(device, jq, jqd, cmd, a, z20, z20, z16, z16, tau_sq, power_sq, coll, weights, dt)
    t = dict(zip(REWARD_TERMS, term[0], strict=True))
    assert t["track_vx"] == pytest.approx(2.0 * dt) and t["track_wz"] == pytest.approx(3.0 * dt)
    assert t["residual"] == pytest.approx(-0.3 * 5.0 * dt)
    assert t["action_smoothness"] == pytest.approx(-0.01 * 25.0 * dt)  # (a_t + 0 - 0)^2
    assert t["collision"] == pytest.approx(-2.0 * 2 * dt)
    assert t["torques"] == 0.0  # zero weight: not evaluated
    assert t["energy"] == pytest.approx(-1e-5 * 100.0 * dt)  # reads the substep-averaged sum (tau qd)^2
    assert t["orientation"] == 0.0 and t["lin_vel_z"] == 0.0
