"""The differentiable path: the Featherstone backend stands and drives, and the taped rollout's gradients match
central finite differences (float32; tolerances per test) from the same start state.

Tolerances come from ``tools/studies/gradient_study.py`` (docs/studies/diffsim/gradient_study.json): through contact
at dt 0.002 the tape and finite differences agree to a cosine > 0.99 and a relative error < ~0.1 up to 0.1 s; in free
fall (no contact) to ~1e-3 over 0.2 s."""

from __future__ import annotations

import numpy as np
import pytest
import warp as wp

from wqwarp.diff.rollout import DiffRollout, RolloutResult, gait_params
from wqwarp.diff.tuning import TuneConfig, objective_weights, param_bounds
from wqwarp.robot import constants as C
from wqwarp.sim.config import SimConfig
from wqwarp.sim.simulator import Simulator

STEPS = np.array([0.002, 0.001, 0.01, 0.004, 0.0005])
"""Central-difference steps for h_b [m], h_s [m], f [Hz], DF_swing [-], stance x [m]."""


def _fd_params(roll: DiffRollout, fn) -> np.ndarray:
    base = gait_params(roll.gait)
    out = np.zeros(5)
    for j in range(5):
        vals = []
        for sgn in (1.0, -1.0):
            p = base.copy()
            p[j] += sgn * STEPS[j]
            roll.set_inputs(p)
            vals.append(fn(roll.run(record=False, warm_start=False)))
        out[j] = (vals[0] - vals[1]) / (2 * STEPS[j])
    roll.set_inputs(base)
    return out


def _cos_rel(a: np.ndarray, b: np.ndarray) -> tuple[float, float]:
    return float(a @ b / (np.linalg.norm(a) * np.linalg.norm(b))), float(np.linalg.norm(a - b) / np.linalg.norm(b))


def test_featherstone_backend_stands_then_drives():
    sim = Simulator(SimConfig(num_envs=1, dt=0.002, decimation=10, backend="featherstone"))
    z, vx = [], []
    for k in range(100):  # 1 s standing, then 1 s with the wheels at 0.5 m/s
        if k == 50:
            sim.wheel_qd_target.fill_(0.5 / C.WHEEL_RADIUS * C.WHEEL_FORWARD_SIGN)
        sim.step()
        q, qd = sim.joint_q.numpy()[0], sim.joint_qd.numpy()[0]
        z.append(q[2])
        vx.append(qd[0])
        assert not sim.body_collision.numpy()[0, 0]
    z, vx = np.array(z), np.array(vx)
    assert 0.2 < z[25:50].mean() < 0.28 and np.ptp(z[40:50]) < 0.01  # settled at the standing height
    assert abs(vx[40:50].mean()) < 0.1  # the drop from the start pose leaves a slow sway, as on MuJoCo
    assert 0.4 < vx[80:].mean() < 0.65  # the wheels drive the robot at ~0.5 m/s
    assert sim.wheel_contact.numpy()[0].all() and (sim.wheel_force.numpy()[0] > 10).all()
    assert sim.p_cost.numpy()[0] > 0 and np.isfinite(sim.p_cost.numpy()).all()


def test_featherstone_backend_refuses_domain_randomisation():
    sim = Simulator(SimConfig(num_envs=1, dt=0.005, decimation=4, backend="featherstone"))
    with pytest.raises(ValueError, match="featherstone"):
        sim.set_dynamics(np.ones(1), np.zeros(1), np.zeros(1))


def test_taped_gradients_through_contact_match_finite_differences():
    roll = DiffRollout(
        SimConfig(num_envs=1, dt=0.002, decimation=10, backend="featherstone"),
        "trotting",
        (0.3, 0.0, 0.0),
        horizon=2,
        warmup=10,
    )
    res = roll.run()
    assert isinstance(res, RolloutResult) and not res.fell[0]
    assert 0.0 < res.p_cost_smooth[0] <= res.p_cost[0]
    g_p = roll.gradients(p_cost_weight=np.ones(1))
    g_v = roll.gradients(velocity_weight=np.array([[1.0, 0.0, 0.0]]))
    fd_p = _fd_params(roll, lambda r: r.p_cost_smooth[0])
    fd_v = _fd_params(roll, lambda r: r.base_velocity[0, 0])
    scale = np.array([0.2, 0.1, 1.0, 0.4, 0.05])
    for tape, fd in ((g_p["params"][0], fd_p), (g_v["params"][0], fd_v)):
        cos, rel = _cos_rel(tape * scale, fd * scale)
        assert cos > 0.99 and rel < 0.12, (tape, fd)
    _check_offset(roll, g_p, "leg_offset", 1, 0.005)  # the FR thigh target


def _check_offset(roll: DiffRollout, grads: dict, key: str, j: int, h: float) -> None:
    """d mean smooth p_cost / d offset ``key``[j] by the tape against central differences with step ``h``."""
    vals = []
    for sgn in (1.0, -1.0):
        off = np.zeros(12 if key == "leg_offset" else 4, np.float32)
        off[j] = sgn * h
        roll.set_inputs(**{key: off})
        vals.append(roll.run(record=False, warm_start=False).p_cost_smooth[0])
    roll.set_inputs(**{key: np.zeros_like(off)})
    fd = (vals[0] - vals[1]) / (2 * h)
    np.testing.assert_allclose(grads[key][0, j], fd, rtol=0.1, atol=0.05 * abs(fd) + 1e-3)


def test_anchored_contacts_keep_the_forces_and_fix_the_wheel_speed_gradient():
    """A wheel's contact point fixed on the wheel (Newton's own contact evaluation) turns with the wheel within a
    substep, which adds a spurious dependence on the spin angle: the tape's d p_cost / d (FR wheel-speed offset) is
    then ~30 % off finite differences (-0.42 against -0.61 W s/rad; steps 0.02 and 0.2 rad/s agree). Carried by the
    calf (``anchored_contacts``), the forward rollout is the same and the gradient is within 15 %."""
    out = {}
    for anchored in (False, True):
        roll = DiffRollout(
            SimConfig(num_envs=1, dt=0.002, decimation=10, backend="featherstone"),
            "trotting",
            (0.3, 0.0, 0.0),
            horizon=2,
            warmup=10,
            anchored_contacts=anchored,
        )
        res = roll.run()
        tape = roll.gradients(p_cost_weight=np.ones(1))["wheel_offset"][0, 0]
        vals = []
        for sgn in (1.0, -1.0):
            roll.set_inputs(wheel_offset=np.array([sgn * 0.02, 0, 0, 0], np.float32))
            vals.append(roll.run(record=False, warm_start=False).p_cost_smooth[0])
        out[anchored] = (res.p_cost_smooth[0], tape, (vals[0] - vals[1]) / 0.04)
    assert out[True][0] == pytest.approx(out[False][0], rel=1e-5)  # same forces forward
    p, tape, fd = out[True]
    assert abs(tape - fd) < 0.15 * abs(fd), out
    p, tape, fd = out[False]
    assert abs(tape - fd) > 0.2 * abs(fd), out  # the defect the anchoring removes


def test_taped_gradients_in_free_fall_match_over_a_long_horizon_and_need_per_step_matrices():
    """No contact (ke = kd = kf = 0): the dynamics is smooth, so 40 substeps of tape match finite differences to
    ~1e-3. Without the per-substep copies of Featherstone's mass matrix and Cholesky factor every step's adjoint
    reads the last step's, and the gradient is off by more than 10x."""
    cfg = SimConfig(
        num_envs=1, dt=0.005, decimation=4, backend="featherstone", contact_ke=0.0, contact_kd=0.0, contact_kf=0.0
    )
    errors = []
    for swap in (True, False):
        roll = DiffRollout(cfg, "trotting", (0.3, 0.0, 0.0), horizon=10, warmup=5, _swap_matrices=swap)
        roll.run()
        tape = roll.gradients(velocity_weight=np.array([[1.0, 0.0, 0.0]]))["params"][0]
        fd = _fd_params(roll, lambda r: r.base_velocity[0, 0])
        errors.append(_cos_rel(tape, fd)[1])
    assert errors[0] < 5e-3 and errors[1] > 1.0, errors


def test_gradients_need_a_recorded_rollout():
    roll = DiffRollout(
        SimConfig(num_envs=1, dt=0.005, decimation=4, backend="featherstone"), "driving", horizon=1, warmup=0
    )
    roll.run(record=False)
    with pytest.raises(RuntimeError, match="recorded"):
        roll.gradients(p_cost_weight=np.ones(1))


def test_param_bounds_keep_the_gaits_apart():
    trot, walk, drive = param_bounds("trotting"), param_bounds("walking"), param_bounds("driving")
    assert trot[3, 1] == pytest.approx(0.48) and walk[3, 1] == pytest.approx(0.23)  # offsets 0.5 and 0.25 apart
    assert (drive[2:4] == 0).all()  # no swing: f and DF_swing are not tuned
    for b, gait in ((trot, "trotting"), (walk, "walking")):
        p = gait_params(gait)
        assert ((p >= b[:, 0]) & (p <= b[:, 1])).all()  # Table I lies inside


def test_optimize_runs_inside_the_bounds_and_keeps_its_best_iterate():
    from wqwarp.diff.tuning import optimize

    cfg = TuneConfig(
        gait="trotting",
        vx=0.3,
        dt=0.005,
        horizon_s=0.04,
        warmup_s=0.1,
        windows=2,
        iterations=3,
        free=("h_s", "frequency"),
    )
    out = optimize(cfg)
    hist = out["history"]
    assert len(hist) == 4 and all(np.isfinite(h["J"]) for h in hist)
    b = np.asarray(out["bounds"])
    for h in hist:
        p = np.asarray(h["params"])
        assert ((p >= b[:, 0] - 1e-9) & (p <= b[:, 1] + 1e-9)).all()
        np.testing.assert_allclose(p[[0, 3, 4]], gait_params("trotting")[[0, 3, 4]], atol=1e-6)  # not free: fixed
    assert np.abs(np.diff([h["params"][2] for h in hist])).max() > 0  # the free ones move
    assert out["best"]["J_accept"] == min(h["J_accept"] for h in hist if h["fell"] == 0)


def test_measure_equals_the_taped_window_forward():
    """``measure`` (untaped, scratch states, Newton's contact evaluation) over the taped horizon gives the same means
    as the taped run (per-substep states, anchored contact evaluation): same physics, same weights."""
    roll = DiffRollout(
        SimConfig(num_envs=2, dt=0.005, decimation=4, backend="featherstone"),
        "walking",
        (0.3, 0.0, 0.0),
        horizon=5,
        warmup=10,
    )
    a = roll.run(record=False)
    b = roll.measure(5 * roll.policy_dt)
    for name in ("p_cost", "p_cost_legs", "p_cost_wheels", "p_cost_smooth", "base_height"):
        np.testing.assert_allclose(getattr(b, name), getattr(a, name), rtol=1e-3)  # contact evaluated two ways
    np.testing.assert_allclose(b.base_velocity, a.base_velocity, rtol=1e-2, atol=1e-3)


def test_objective_weights_are_the_gradient_of_j():
    cfg = TuneConfig(vx=0.3, w_speed=2e4, w_height=5e5)
    n = 3
    rng = np.random.default_rng(0)

    def result(p, v, z):
        vel = np.stack([v, 0 * v, 0 * v], 1)
        return RolloutResult(
            p_cost=p,
            p_cost_legs=p,
            p_cost_wheels=0 * p,
            p_cost_smooth=p,
            base_velocity=vel,
            base_height=z,
            fell=np.zeros(n, bool),
        )

    p, v, z = rng.uniform(50, 100, n), rng.uniform(0.2, 0.4, n), rng.uniform(0.2, 0.25, n)
    wpc, wv, wz, j = objective_weights(cfg, result(p, v, z), 0.22, n)
    h = 1e-6
    for i in range(n):
        for arr, w in ((p, wpc[i]), (v, wv[i, 0]), (z, wz[i])):
            a = arr.copy()
            a[i] += h
            args = {id(p): (a, v, z), id(v): (p, a, z), id(z): (p, v, a)}[id(arr)]
            j2 = objective_weights(cfg, result(*args), 0.22, n)[3]
            assert (j2 - j) / h == pytest.approx(w, rel=1e-3, abs=1e-6)


def test_energy_audit_runs_on_featherstone():
    from wqwarp.cli import energy_audit as audit

    r = audit.run_scenario("drive_0.5", 0.002, 10, 0.6, 0.4, 1, backend="featherstone")
    assert 0.35 < r["v_x"] < 0.7 and not r["trunk_touched"]
    assert r["p_cost"] == pytest.approx(r["p_cost_legs"] + r["p_cost_wheels"], rel=1e-5)
    wp.synchronize()
