"""Nominal gait (kernels/gait.py): Eqs. (1)-(3) against NumPy and hand values, the kernel, gait switching."""

import numpy as np
import pytest
import warp as wp

from wqwarp.control.gaits import GAIT_LIBRARY, gait_index, gait_library_arrays
from wqwarp.kernels import gait, kinematics
from wqwarp.robot import constants

H_B = constants.NOMINAL_BODY_HEIGHT
H_S = constants.NOMINAL_SWING_HEIGHT
R = constants.WHEEL_RADIUS
SIDES = np.array(constants.LEG_SIDE_SIGN)
DT = 0.02


@wp.kernel
def _eval_funcs(
    phi: wp.array(dtype=float),
    f: wp.array(dtype=float),
    dphi: wp.array(dtype=float),
    df: wp.array(dtype=float),
    psi: wp.array(dtype=float),
    vx: wp.array(dtype=float),
    wz: wp.array(dtype=float),
    d: wp.array(dtype=float),
    dt: float,
    h_b: float,
    h_s: float,
    # outputs
    phi_out: wp.array(dtype=float),
    psi_out: wp.array(dtype=float),
    height_out: wp.array(dtype=float),
    wheel_out: wp.array(dtype=float),
):
    i = wp.tid()
    phi_out[i] = gait.phase_update(phi[i], f[i], dt, dphi[i])
    psi_out[i] = gait.swing_progress(phi[i], df[i])
    height_out[i] = gait.swing_height(psi[i], h_b, h_s)
    wheel_out[i] = gait.nominal_wheel_velocity(vx[i], wz[i], d[i], gait.WHEEL_RADIUS, gait.WHEEL_FORWARD_SIGN)


def _funcs(device, phi=0.0, f=0.0, dphi=0.0, df=0.0, psi=0.0, vx=0.0, wz=0.0, d=0.0, dt=DT):
    args = np.broadcast_arrays(*(np.asarray(a, dtype=np.float32) for a in (phi, f, dphi, df, psi, vx, wz, d)))
    n = args[0].size
    ins = [wp.array(a.ravel().copy(), dtype=float, device=device) for a in args]
    outs = [wp.zeros(n, dtype=float, device=device) for _ in range(4)]
    wp.launch(_eval_funcs, dim=n, inputs=[*ins, dt, H_B, H_S], outputs=outs, device=device)
    return [o.numpy() for o in outs]


def _swing_height_np(psi):
    psi = np.asarray(psi, dtype=np.float64)
    first = -H_B + H_S * (-16 * psi**3 + 12 * psi**2)
    second = -H_B + H_S * (16 * psi**3 - 36 * psi**2 + 24 * psi - 4)
    return np.where(psi < 0, -H_B, np.where(psi <= 0.5, first, second))


# --- equations -----------------------------------------------------------------------------------------------------
def test_phase_update_eq1(device):
    rng = np.random.default_rng(0)
    phi, f, dphi = rng.uniform(0, 1, 200), rng.uniform(0, 2, 200), rng.uniform(-0.2, 0.2, 200)
    out = _funcs(device, phi=phi, f=f, dphi=dphi)[0]
    expected = np.mod(phi + f * DT + dphi, 1.0)
    np.testing.assert_allclose(np.minimum(np.abs(out - expected), 1 - np.abs(out - expected)), 0, atol=1e-6)
    assert np.all(out >= 0) and np.all(out < 1)
    # hand values: forward wrap, backward wrap through a negative residual, tiny negative rounds to 0 not 1
    out = _funcs(device, phi=[0.95, 0.01, 0.0], f=[1.2, 0.0, 0.0], dphi=[0.0, -0.03, -1e-9], dt=0.1)[0]
    np.testing.assert_allclose(out, [0.07, 0.98, 0.0], atol=1e-6)
    assert out[2] < 1.0


def test_swing_progress(device):
    psi = _funcs(device, phi=[0.0, 0.2, 0.39, 0.4, 0.9, 0.0, 0.5], df=[0.4, 0.4, 0.4, 0.4, 0.4, 0.0, 0.0])[1]
    np.testing.assert_allclose(psi, [0.0, 0.5, 0.975, -1, -1, -1, -1], atol=1e-6)


def test_swing_height_eq2(device):
    psi = np.linspace(0, 1, 101)
    np.testing.assert_allclose(_funcs(device, psi=psi)[2], _swing_height_np(psi), atol=1e-6)
    f0, f1, fh, stance = _funcs(device, psi=[0.0, 1.0, 0.5, -1.0])[2]
    np.testing.assert_allclose([f0, f1, fh, stance], [-H_B, -H_B, -H_B + H_S, -H_B], atol=1e-7)
    # C1 at 0.5 (and zero slope at lift-off / touch-down): second-order one-sided differences, error ~ h_s 96 e^2 / 3
    # against a slope scale of max |F'| = 3 h_s
    e = 1e-2

    def slope(psi0, direction):
        a, b, c = _funcs(device, psi=[psi0, psi0 + direction * e, psi0 + 2 * direction * e])[2]
        return direction * (-3 * a + 4 * b - c) / (2 * e)

    left, right = slope(0.5, -1), slope(0.5, 1)
    assert abs(left - right) < 2e-3 and abs(left) < 2e-3
    assert abs(slope(0.0, 1)) < 2e-3 and abs(slope(1.0, -1)) < 2e-3
    # the same analytically: dF/dpsi = h_s (-48 psi^2 + 24 psi) and h_s (48 psi^2 - 72 psi + 24) are both 0 at 0.5
    assert -48 * 0.25 + 24 * 0.5 == 0 and 48 * 0.25 - 72 * 0.5 + 24 == 0


def test_nominal_wheel_velocity_eq3(device):
    rng = np.random.default_rng(1)
    vx, wz, d = rng.uniform(-1, 1, 50), rng.uniform(-1, 1, 50), rng.uniform(-0.2, 0.2, 50)
    out = _funcs(device, vx=vx, wz=wz, d=d)[3]
    np.testing.assert_allclose(out, constants.WHEEL_FORWARD_SIGN * (vx - d * wz) / R, rtol=1e-5, atol=1e-5)
    # hand value: 1 m/s straight -> 1 / 0.075 rad/s; turning left, the left wheel (d > 0) rolls slower
    np.testing.assert_allclose(
        _funcs(device, vx=[1.0, 1.0], wz=[0.0, 1.0], d=[0.15, 0.15])[3], [13.3333, 11.3333], rtol=1e-5
    )


# --- kernel ----------------------------------------------------------------------------------------------------------
class _Sim:
    """Drives step_nominal_gait for a few worlds with constant command / contact / joint positions."""

    def __init__(self, device, world_count, gait_name, command=(0.0, 0.0, 0.0), contact=1, phase_mode="increment"):
        self.device, self.n, self.phase_mode = device, world_count, phase_mode
        self.gaits = gait_library_arrays(device)
        self.state = gait.NominalGaitState.allocate(world_count, device)
        self.gait_id = wp.array(np.full(world_count, gait_index(gait_name), np.int32), dtype=wp.int32, device=device)
        self.command = wp.array(np.tile(np.float32(command), (world_count, 1)), dtype=float, device=device)
        self.residual = wp.zeros((world_count, 4), dtype=float, device=device)
        q = np.tile(np.float32(constants.DEFAULT_JOINT_POS[:12]), (world_count, 1))
        self.joint_pos = wp.array(q, dtype=float, device=device)
        self.contact = wp.array(
            np.broadcast_to(np.int32(contact), (world_count, 4)).copy(), dtype=wp.int32, device=device
        )
        env_ids = wp.array(np.arange(world_count, dtype=np.int32), dtype=wp.int32, device=device)
        gait.reset_nominal_gait(self.state, env_ids, self.gait_id, self.gaits)

    def step(self, dt=DT):
        gait.step_nominal_gait(
            self.state,
            self.gaits,
            self.gait_id,
            self.command,
            self.residual,
            self.joint_pos,
            self.contact,
            dt,
            phase_mode=self.phase_mode,
        )


def test_reset_starts_in_stance(device):
    for g in GAIT_LIBRARY:
        sim = _Sim(device, 2, g.name)
        assert np.all(sim.state.active_gait_id.numpy() == gait_index(g.name))
        assert np.all(sim.state.phase.numpy() >= g.df_swing)


FOOT_XY = np.array(constants.NOMINAL_FOOT_XY)  # authors' generator: (0.0149 front / 0.0321 rear, +-0.09525)


def test_driving_targets_hold_the_authors_stance(device):
    sim = _Sim(device, 2, "driving")
    sim.step()
    target = sim.state.foot_target.numpy()
    # PMTG.py's driving branch: foot point x = nominal - 0.05, z = -h_b; hand values of the nominal (x, y)
    np.testing.assert_allclose(target[..., 0], np.tile([-0.0351, -0.0351, -0.0179, -0.0179], (2, 1)), atol=1e-6)
    np.testing.assert_allclose(target[..., 1], np.tile(SIDES * 0.09525, (2, 1)), atol=1e-7)
    np.testing.assert_allclose(target[..., 2], -H_B, atol=1e-7)
    # the joint targets put the calf end there (NumPy FK of the foot point)
    q = sim.state.leg_joint_target.numpy()[0].reshape(4, 3)
    for leg in range(4):
        p = kinematics.leg_fk_numpy(q[leg], SIDES[leg], constants.FOOT_IN_CALF)
        np.testing.assert_allclose(p, target[0, leg], atol=1e-5)
    assert np.all(sim.state.swing_psi.numpy() == -1.0)


def test_default_pose_is_the_authors_reset_stance():
    q = np.array(constants.DEFAULT_JOINT_POS[:12]).reshape(4, 3)
    np.testing.assert_allclose(q[:, 0], 0.1 * SIDES)  # config init_state: hip -0.1 right, +0.1 left
    np.testing.assert_allclose(q[:, 1:], np.tile([1.08, -2.16], (4, 1)))
    foot = np.array([kinematics.leg_fk_numpy(q[leg], SIDES[leg], constants.FOOT_IN_CALF) for leg in range(4)])
    np.testing.assert_allclose(-foot[:, 2], 0.192, atol=1e-3)  # 0.201 along the leg, abducted by 0.1 rad
    wheel = np.array([kinematics.leg_fk_numpy(q[leg], SIDES[leg]) for leg in range(4)])
    # base height of the default pose: hips above ground by the wheel centre depth plus the wheel radius
    np.testing.assert_allclose(constants.DEFAULT_BASE_HEIGHT, -wheel[0, 2] + R, atol=1e-9)


def test_swing_moves_the_foot_back_then_forward(device):
    sim = _Sim(device, 1, "trotting")
    seen_back = seen_fwd = False
    for _ in range(60):
        sim.step()
        psi = sim.state.swing_psi.numpy()[0]
        x = sim.state.foot_target.numpy()[0, :, 0]
        expected = FOOT_XY[:, 0] - np.where(psi >= 0, 0.05 * np.sin(2 * np.pi * np.maximum(psi, 0)), 0.0)
        np.testing.assert_allclose(x, expected, atol=1e-6)
        seen_back |= bool(np.any((psi > 0.1) & (psi < 0.4)))
        seen_fwd |= bool(np.any((psi > 0.6) & (psi < 0.9)))
    assert seen_back and seen_fwd


def test_phase_residual_readings(device):
    """increment: dphi accumulates every step; offset: phi = clock + dphi, the clock runs at f."""
    f, steps, dphi = GAIT_LIBRARY[gait_index("trotting")].frequency, 5, 0.01
    phases = {}
    for mode in ("increment", "offset"):
        sim = _Sim(device, 1, "trotting", phase_mode=mode)
        start = sim.state.phase.numpy()[0].copy()
        sim.residual.assign(np.full((1, 4), dphi, np.float32))
        for _ in range(steps):
            sim.step()
        phases[mode] = sim.state.phase.numpy()[0]
        clock = sim.state.clock.numpy()[0]
        advance = steps * (f * DT + (mode == "increment") * dphi)
        np.testing.assert_allclose(np.mod(clock - start, 1.0), np.mod(advance, 1.0), atol=1e-5)
    np.testing.assert_allclose(np.mod(phases["increment"] - phases["offset"], 1.0), (steps - 1) * dphi, atol=1e-5)
    with pytest.raises(ValueError, match="phase_mode"):
        _Sim(device, 1, "trotting", phase_mode="sideways").step()


def test_trot_diagonal_legs_in_phase(device):
    sim = _Sim(device, 2, "trotting")
    swung = np.zeros(4, bool)
    for _ in range(60):
        sim.step()
        phase, psi = sim.state.phase.numpy(), sim.state.swing_psi.numpy()
        np.testing.assert_allclose(phase[:, 0], phase[:, 3], atol=1e-6)  # FR, RL
        np.testing.assert_allclose(phase[:, 1], phase[:, 2], atol=1e-6)  # FL, RR
        np.testing.assert_allclose(np.mod(phase[:, 1] - phase[:, 0], 1.0), 0.5, atol=1e-5)
        np.testing.assert_array_equal(psi[:, 0], psi[:, 3])
        z = sim.state.foot_target.numpy()[..., 2]
        np.testing.assert_allclose(z, _swing_height_np(psi), atol=1e-6)
        swung |= (psi >= 0).any(axis=0)
    assert swung.all()


def test_walk_at_most_one_leg_in_swing(device):
    sim = _Sim(device, 1, "walking")
    dt = 0.002
    steps = int(round(1.0 / 0.8 / dt)) + 10  # one full cycle, finely sampled
    swung = np.zeros(4, bool)
    for _ in range(steps):
        sim.step(dt)
        in_swing = sim.state.swing_psi.numpy()[0] >= 0
        assert in_swing.sum() <= 1
        swung |= in_swing
    assert swung.all()


def test_wheel_velocity_pure_vx(device):
    sim = _Sim(device, 2, "driving", command=(0.6, 0.3, 0.0))  # v_y does not enter Eq. (3)
    sim.step()
    np.testing.assert_allclose(sim.state.wheel_velocity.numpy(), 0.6 / R, rtol=1e-5)


def test_wheel_velocity_pure_wz(device):
    wz = 0.5
    sim = _Sim(device, 2, "driving", command=(0.0, 0.0, wz))
    sim.step()
    v = sim.state.wheel_velocity.numpy()
    # |y| of the wheel centre in the base frame in the default pose (inboard of the calf; hip abducted 0.1 rad)
    q = np.array(constants.DEFAULT_JOINT_POS[:3])
    d = constants.HIP_OFFSET_Y + abs(kinematics.leg_fk_numpy(q, -1.0)[1])
    assert 0.10 < d < 0.13
    np.testing.assert_allclose(np.abs(v), d * wz / R, rtol=1e-5)
    left, right = SIDES > 0, SIDES < 0
    assert np.all(v[:, left] < 0) and np.all(v[:, right] > 0)  # turning left: the left wheels roll backwards
    np.testing.assert_allclose(v[:, left], -v[:, right], rtol=1e-6)


def test_wheel_in_air_keeps_previous_target(device):
    contact = np.array([1, 0, 1, 0], np.int32)  # FL, RL in the air
    sim = _Sim(device, 2, "driving", command=(1.0, 0.0, 0.0), contact=contact)
    sim.state.wheel_velocity.assign(np.full((2, 4), 3.0, np.float32))
    for _ in range(3):
        sim.step()
    v = sim.state.wheel_velocity.numpy()
    np.testing.assert_allclose(v[:, contact == 1], 1.0 / R, rtol=1e-5)
    np.testing.assert_allclose(v[:, contact == 0], 3.0)


# --- gait switching ---------------------------------------------------------------------------------------------------
def _switch_jump_bound(max_residual: float) -> float:
    """Largest per-step change of a wheel-centre z target without switches.

    |dF/dpsi| = h_s |-48 psi^2 + 24 psi| (and its mirror) peaks at 3 h_s (psi = 0.25, 0.75); psi advances by
    (f dt + |dphi|) / DF_swing per step; F(0) = F(1) = -h_b makes entering / leaving swing continuous; the switching
    rule only re-bases phases while every leg is in stance, so it adds no jump of its own.
    """
    rate = max((g.frequency * DT + max_residual) / g.df_swing for g in GAIT_LIBRARY if g.df_swing > 0)
    return 3.0 * H_S * rate


@pytest.mark.parametrize("max_residual", [0.0, 0.004])
def test_gait_switching_bounds_target_jump(device, max_residual):
    rng = np.random.default_rng(2)
    worlds, steps = 8, 1500
    sequence = [gait_index(n) for n in ("trotting", "driving", "walking")]  # trot -> drive -> walk -> trot ...
    sim = _Sim(device, worlds, "trotting")
    requested = np.zeros(worlds, np.int64)  # position in `sequence`
    switch_steps = np.sort(rng.integers(0, steps, size=(worlds, 40)), axis=1)  # ~ every 0.75 s at random times
    prev_z = sim.state.foot_target.numpy()[..., 2].copy()
    prev_z[:] = -H_B
    max_jump, pending_since, max_wait = 0.0, np.zeros(worlds, int), 0
    seen = np.zeros((worlds, 3), bool)
    for t in range(steps):
        change = (switch_steps == t).any(axis=1)
        requested[change] = (requested[change] + 1) % 3
        req_ids = np.array([sequence[i] for i in requested], np.int32)
        sim.gait_id.assign(req_ids)
        sim.residual.assign(rng.uniform(-max_residual, max_residual, (worlds, 4)).astype(np.float32))
        sim.step()
        z = sim.state.foot_target.numpy()[..., 2]
        max_jump = max(max_jump, float(np.abs(z - prev_z).max()))
        prev_z = z.copy()
        active = sim.state.active_gait_id.numpy()
        seen[np.arange(worlds), active] = True
        pending_since = np.where(active == req_ids, 0, pending_since + 1)
        max_wait = max(max_wait, int(pending_since.max()))
    bound = _switch_jump_bound(max_residual)
    assert max_jump <= bound + 1e-6, (max_jump, bound)
    assert max_jump > 0.5 * bound  # the bound is tight: the ordinary gait reaches it
    assert seen.all()  # every world ran every gait
    if max_residual == 0.0:
        # a request waits at most one cycle of the slowest stepping gait (walk: 1 / 0.8 s)
        assert max_wait * DT <= 1.0 / 0.8 + DT
