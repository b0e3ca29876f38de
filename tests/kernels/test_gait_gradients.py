"""Gradients of the gait kernels recorded on ``wp.Tape``, against hand values and central finite differences.

Covered: the Eq. (1) phase update away from and across its wrap, the swing progress psi = phi / DF_swing, and the
open-loop gait (``open_loop_gait_targets``): the Jacobians of the leg joint targets and the wheel speeds w.r.t. the
five gait parameters (``GAIT_PARAM_NAMES``) for the trotting and walking gaits, and their behaviour at the
swing/stance switch.

float32 only: the kernels are typed ``float`` (float32). Central differences with h = ``EPS`` = 1e-3 then carry
about ulp(value) / (2 h) of rounding noise, ~1e-4 relative (6e-5 on a 1 rad joint target, ~5e-4 on a 7 rad/s wheel
speed), so finite differences are compared with rtol 1e-2 and atol 1e-3 (the gait Jacobian's largest entries are
~10, its worst observed error ~4e-3), and hand values of the tape's gradients with rtol 1e-5.
Across the phase wrap and the swing/stance switch the functions are not differentiable; what the tape does there
is pinned down by the tests below (local slope at the wrap, one-sided slopes at the switch)."""

from __future__ import annotations

import math

import numpy as np
import pytest
import warp as wp

from wqwarp.control.gaits import GAIT_LIBRARY, gait_index
from wqwarp.kernels.gait import GAIT_PARAM_NAMES, open_loop_gait_targets, phase_update, swing_progress

EPS = 1e-3  # finite-difference step; float32 noise ~1e-4 relative
RTOL, ATOL = 1e-2, 1e-3
HAND = 1e-5  # rtol of tape gradients against closed forms
COMMAND = (0.5, 0.0, 0.3)  # (v_x, v_y, w_z): a turn, so Eq. (3)'s d_i matters
AMPLITUDE = 0.05  # swing x amplitude [m] (constants.MAX_HORIZONTAL_OFFSET)
H_B, H_S, STANCE_X = 0.2, 0.1, 0.0
COL = {name: i for i, name in enumerate(GAIT_PARAM_NAMES)}


def _jacobian(fn, x: np.ndarray, device: str, fd: bool = True) -> tuple[np.ndarray, np.ndarray | None]:
    """Full Jacobian of the concatenated (flattened) outputs of ``fn(xa) -> tuple of arrays`` w.r.t. x, by the tape
    (one backward pass per output entry) and, if ``fd``, by central differences (else None); each (n_out, x.size)."""
    xa = wp.array(x.astype(np.float32), dtype=float, device=device, requires_grad=True)
    tape = wp.Tape()
    with tape:
        outs = fn(xa)
    rows = []
    for out in outs:
        for idx in np.ndindex(*out.shape):
            seed = np.zeros(out.shape, np.float32)
            seed[idx] = 1.0
            tape.backward(grads={out: wp.array(seed, dtype=float, device=device)})
            rows.append(xa.grad.numpy().reshape(-1).copy())
            tape.zero()
    if not fd:
        return np.asarray(rows), None
    flat = x.reshape(-1).astype(np.float64)
    num = np.zeros((len(rows), flat.size))
    for i in range(flat.size):
        for sgn in (1, -1):
            xp = flat.copy()
            xp[i] += sgn * EPS
            o = fn(wp.array(xp.reshape(x.shape).astype(np.float32), dtype=float, device=device))
            num[:, i] += sgn * np.concatenate([a.numpy().reshape(-1) for a in o]) / (2 * EPS)
    return np.asarray(rows), num


# --- Eq. (1) phase update and swing progress -------------------------------------------------------------------
@wp.kernel
def _phase(x: wp.array2d(dtype=float), out: wp.array(dtype=float)):
    i = wp.tid()
    out[i] = phase_update(x[i, 0], x[i, 1], x[i, 2], x[i, 3])


def _phase_fn(xa):
    out = wp.zeros(xa.shape[0], dtype=float, device=xa.device, requires_grad=True)
    wp.launch(_phase, dim=xa.shape[0], inputs=[xa], outputs=[out], device=xa.device)
    return (out,)


def test_phase_update_gradient_away_from_the_wrap(device):
    # rows (phi, f, dt, dphi); phi + f dt + dphi in 0.374, 0.816, 0.074 and 0.52 (wrapped from 1.52): > 1e-2 from 0, 1
    x = np.array([[0.3, 1.2, 0.02, 0.05], [0.9, 0.8, 0.02, -0.1], [0.1, 1.2, 0.02, -0.05], [0.7, 1.0, 0.02, 0.8]])
    tape, num = _jacobian(_phase_fn, x, device)
    np.testing.assert_allclose(tape, num, rtol=RTOL, atol=2e-4)
    # d phi' / d(phi, f, dt, dphi) = (1, dt, f, 1) on each row's own inputs, 0 on the other rows'
    hand = np.zeros((4, 4, 4))
    for i, (_, f, dt, _) in enumerate(x):
        hand[i, i] = (1.0, dt, f, 1.0)
    np.testing.assert_allclose(tape, hand.reshape(4, 16), rtol=HAND, atol=0)


def test_phase_update_across_the_wrap_keeps_the_local_slope(device):
    """phi + f dt + dphi = 1.0005: the value wraps to 5e-4, and a step of -EPS in phi or dphi lands before the wrap
    at 0.9995, a jump of -1. The tape differentiates ``x - floor(x)`` with floor's derivative 0, i.e. it returns the
    local slope (1, dt, f, 1) on both sides; central differences straddling the wrap see the jump instead,
    slope - 1 / (2 EPS) = -499. (A rollout through the wrap is differentiable; a phase difference is not.)"""
    x = np.array([[0.9755, 1.2, 0.02, 0.001]])
    value = lambda xs: _phase_fn(wp.array(xs, dtype=float, device=device))[0].numpy()[0]  # noqa: E731
    before, after = value(x - [[EPS, 0, 0, 0]]), value(x)
    assert after == pytest.approx(5e-4, abs=1e-6) and before == pytest.approx(0.9995, abs=1e-6)
    tape, num = _jacobian(_phase_fn, x, device)
    np.testing.assert_allclose(tape[0], [1.0, 0.02, 1.2, 1.0], rtol=HAND)
    # an f step moves the sum by dt EPS = 2e-5 < 5e-4: no straddle, FD = tape; a dt step moves it by f EPS = 1.2e-3
    np.testing.assert_allclose(num[0, 1], 0.02, atol=2e-4)
    for k, slope in ((0, 1.0), (2, 1.2), (3, 1.0)):
        np.testing.assert_allclose(num[0, k], slope - 1.0 / (2 * EPS), rtol=1e-3)  # straddles: the jump dominates


@wp.kernel
def _psi(x: wp.array2d(dtype=float), out: wp.array(dtype=float)):
    i = wp.tid()
    out[i] = swing_progress(x[i, 0], x[i, 1])


def test_swing_progress_gradient(device):
    # rows (phi, DF_swing): three in swing (psi 0.25, 0.75, 0.889), two in stance; > 1e-2 from the switch phi = DF
    x = np.array([[0.1, 0.4], [0.3, 0.4], [0.2, 0.225], [0.6, 0.4], [0.25, 0.225]])

    def fn(xa):
        out = wp.zeros(xa.shape[0], dtype=float, device=xa.device, requires_grad=True)
        wp.launch(_psi, dim=xa.shape[0], inputs=[xa], outputs=[out], device=xa.device)
        return (out,)

    tape, num = _jacobian(fn, x, device)
    np.testing.assert_allclose(tape, num, rtol=RTOL, atol=ATOL)
    hand = np.zeros((5, 5, 2))
    for i, (phi, df) in enumerate(x[:3]):
        hand[i, i] = (1.0 / df, -phi / df**2)  # d psi / d phi, d psi / d DF_swing; 0 in stance (psi = -1)
    np.testing.assert_allclose(tape, hand.reshape(5, 10), rtol=HAND, atol=0)


# --- open-loop gait: leg targets and wheel speeds w.r.t. the gait parameters ------------------------------------
GAITS = [GAIT_LIBRARY[gait_index("trotting")], GAIT_LIBRARY[gait_index("walking")]]


def _params(gaits) -> np.ndarray:
    """(W, 5) params per ``GAIT_PARAM_NAMES``: h_b 0.2, h_s 0.1, each gait's Table I frequency and DF_swing,
    stance_x 0."""
    return np.array([[H_B, H_S, g.frequency, g.df_swing, STANCE_X] for g in gaits])


def _gait_fn(gaits, t: float, amplitude: float = AMPLITUDE):
    offsets = np.array([g.phase_offsets for g in gaits], np.float32)
    command = np.tile(np.asarray(COMMAND, np.float32), (len(gaits), 1))

    def fn(pa):
        dev, n = pa.device, pa.shape[0]
        leg = wp.zeros((n, 12), dtype=float, device=dev, requires_grad=True)
        wheel = wp.zeros((n, 4), dtype=float, device=dev, requires_grad=True)
        wp.launch(
            open_loop_gait_targets,
            dim=(n, 4),
            inputs=[
                pa,
                wp.array(offsets, dtype=float, device=dev),
                wp.array(command, dtype=float, device=dev),
                float(t),
                float(amplitude),
            ],
            outputs=[leg, wheel],
            device=dev,
        )
        return leg, wheel

    return fn


def _phases(gaits, t: float) -> np.ndarray:
    return (np.array([g.phase_offsets for g in gaits]) + np.array([g.frequency for g in gaits])[:, None] * t) % 1.0


@pytest.mark.parametrize("t", [0.1, 0.7, 1.75])
def test_open_loop_gait_jacobian_away_from_the_switches(device, t):
    """d(leg_joint_target, wheel_velocity) / d(h_b, h_s, f, DF_swing, stance_x), trotting and walking, at times where
    every leg's phase is > 3e-2 from the wrap (0), the switch (DF_swing) and the cubic's branch point (DF_swing / 2),
    so the FD steps (phase moves <= 2e-3) stay on one smooth piece; at each t some legs swing, some stand."""
    phi = _phases(GAITS, t)
    df = np.array([g.df_swing for g in GAITS])[:, None]
    marks = np.stack([0.0 * df, df, 0.5 * df, 1.0 + 0.0 * df], -1)
    assert np.min(np.abs(phi[..., None] - marks)) > 3e-2  # the test's own premise
    swing = phi < df
    assert swing.any() and (~swing).any()

    params = _params(GAITS)
    tape, num = _jacobian(_gait_fn(GAITS, t), params, device)
    np.testing.assert_allclose(tape, num, rtol=RTOL, atol=ATOL)

    # structure: rows (world, 12 leg targets) then (world, 4 wheels); columns (world, 5 params)
    w = len(GAITS)
    leg = tape[: 12 * w].reshape(w, 4, 3, w, 5)
    wheel = tape[12 * w :].reshape(w, 4, w, 5)
    for a in range(w):
        for b in range(w):
            if a != b:  # worlds are independent
                assert not leg[a, :, :, b].any() and not wheel[a, :, b].any()
        lg, wh = leg[a, :, :, a], wheel[a, :, a]
        assert np.all(np.abs(lg[:, 1:, COL["h_b"]]) > 0.1)  # thigh and calf follow the body height on every leg
        assert np.all(np.abs(lg[:, 1:, COL["stance_x"]]) > 0.1)
        for k in range(4):
            moving = ("h_s", "frequency", "df_swing")
            if swing[a, k]:  # a swinging leg moves with h_s, f and DF_swing
                assert all(np.abs(lg[k, 1:, COL[p]]).max() > 1e-3 for p in moving)
            else:  # a standing leg is at (x_i + stance_x, y_i, -h_b): independent of them
                assert not lg[k][:, [COL[p] for p in moving]].any() and not wh[k, [COL[p] for p in moving]].any()
        # Eq. (3) through d_i: the wheel centre's y moves with the leg (inboard offset), only while turning
        assert np.abs(wh[:, COL["h_b"]]).max() > 1e-3


def _switch_jacobians(device, amplitude: float, delta: float = 1e-4) -> tuple[np.ndarray, np.ndarray, float, float]:
    """Tape Jacobians of the trotting gait (world 0 only) at phase DF_swing - delta and DF_swing + delta of its FR and
    RL legs (just before and just after touch-down), reshaped (4 legs, 4 rows: 3 joints and the wheel, 5 params)."""
    gait = GAITS[0]
    out = []
    for d in (-delta, delta):
        t = (gait.df_swing + d) / gait.frequency
        tape, _ = _jacobian(_gait_fn([gait], t, amplitude), _params([gait]), device, fd=False)
        out.append(np.concatenate([tape[:12].reshape(4, 3, 5), tape[12:].reshape(4, 1, 5)], 1))
    return out[0], out[1], (gait.df_swing - delta) / gait.frequency, gait.df_swing - delta


def test_open_loop_gait_gradient_at_the_touch_down_switch(device):
    """At touch-down (phi = DF_swing) the value is continuous, and so is the Eq. (2) height's slope (F'(1) = 0):
    without the swing x offset the tape's gradients just before and just after agree. The swing x offset
    -A sin(2 pi psi) has slope -2 pi A / DF_swing at psi = 1 but 0 in stance, so the gradients w.r.t. f and DF_swing
    jump there (finite on both sides): just before, d/df = (dq/dx) (-2 pi A / DF_swing) t and
    d/dDF_swing = (dq/dx) (2 pi A phi / DF_swing^2), with dq/dx = the stance_x column; just after, 0. Documented
    here, not smoothed: the x offset is the authors' generator's (PMTG.py)."""
    before, after, t, phi = _switch_jacobians(device, amplitude=0.0)
    assert np.all(np.isfinite(before)) and np.all(np.isfinite(after))
    np.testing.assert_allclose(before, after, rtol=1e-2, atol=1e-2)  # continuous (left - right ~ 24 (1 - psi) h_s)

    before, after, t, phi = _switch_jacobians(device, amplitude=AMPLITUDE)
    assert np.all(np.isfinite(before)) and np.all(np.isfinite(after))
    df = GAITS[0].df_swing
    cont = [COL["h_b"], COL["h_s"], COL["stance_x"]]
    np.testing.assert_allclose(before[..., cont], after[..., cont], rtol=1e-2, atol=1e-2)
    landing = [0, 3]  # FR and RL touch down; FL and RR (phase DF + 0.5) stand on both sides
    np.testing.assert_allclose(before[[1, 2]], after[[1, 2]], rtol=1e-2, atol=1e-2)
    assert not after[landing][..., [COL["frequency"], COL["df_swing"]]].any()
    dq_dx = after[landing][..., COL["stance_x"]]
    slope = -2.0 * math.pi * AMPLITUDE / df  # d x_swing / d phi at psi -> 1
    np.testing.assert_allclose(before[landing][..., COL["frequency"]], dq_dx * slope * t, rtol=1e-2, atol=1e-2)
    np.testing.assert_allclose(before[landing][..., COL["df_swing"]], dq_dx * slope * (-phi / df), rtol=1e-2, atol=1e-2)
    assert np.abs(before[landing][..., COL["frequency"]]).max() > 0.5  # a jump of ~1 rad/Hz, not rounding
