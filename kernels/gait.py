"""Augmented nominal gait: leg phases, swing trajectory, nominal leg targets and nominal wheel velocities.

References:
    Paper, "Augmented Nominal Gait Design": Eq. (1) phase update, Eq. (2) swing height F(psi), Eq. (3) nominal
    wheel velocity, Table I gait library (``wqwarp.control.gaits``). Where the paper is silent, the conventions of the
    authors' public trajectory generator (xu-yang16/wheeled-quadruped-sim2sim ``sim/policy_manager/PMTG.py``,
    config ``sim/policy_manager/policy_config/my_legged_robot_config.py``), cited in ``wqwarp.robot.constants``.

Per leg i (FR, FL, RR, RL) and policy step, with the gait clock c_i and the policy's phase residual dphi_i::

    increment mode:  c_i <- (c_i + f dt + dphi_i) mod 1,  phi_i = c_i        Eq. (1), residual accumulated
    offset mode:     c_i <- (c_i + f dt) mod 1,  phi_i = (c_i + dphi_i) mod 1   PMTG.py: phi = phi0 + f t + dphi
    swing  while phi_i < DF_swing, psi = phi_i / DF_swing in [0, 1); stance otherwise
    p_n,i = (x_i + x_gait + x_swing(psi), y_i, F(psi))  foot point (calf end) in the hip frame, Eq. (2) for z
    q_n,i = foot IK(p_n,i)
    v_n,i = (v_x - d_i w_z) / R  if the wheel touches the ground, else the previous v_n,i     Eq. (3)

Nominal placement (PMTG.py): the foot point is the calf end, h_b is measured there; (x_i, y_i) =
``constants.NOMINAL_FOOT_XY``; x_gait = the gait's ``stance_x`` (driving: -0.05 m, PMTG.py's driving branch);
x_swing = -0.05 sin(2 pi psi) during swing (0 in stance). d_i in Eq. (3) is the measured wheel-centre y in the base
frame (the wheel sits inboard of the calf, ``constants.WHEEL_CENTER_IN_CALF``).

Gait switching (the requested gait ``gait_id`` may change at any policy step): each world keeps an
``active_gait_id``. A request that differs from it is applied at the first step at which no leg of the active gait
is in swing (all phases >= DF_swing; immediately for driving, whose legs never swing). The clocks are then re-based
to the new gait's offsets at the start of one of its all-stance windows: c_i = (r + offset_i) mod 1 with
r = DF_swing - offset_k for the first leg k for which every leg is then in stance (leg k has just landed). Before
and after the re-base every leg is in stance at z = -h_b, so the foot height target stays continuous (in increment
mode; in offset mode a nonzero residual is added after the re-base); the stance x moves by the difference of the two
gaits' ``stance_x`` (0.05 m between driving and the legged gaits). A pending request waits at most about one cycle
of the active gait; requesting the active gait again cancels it. Every Table I gait has an all-stance window
(tested); a gait without one is re-based at r = DF - offset_0 and its other legs may jump. Observations (f,
DF_swing) should read the active gait, not the requested one.
"""

from __future__ import annotations

from dataclasses import dataclass

import warp as wp

from wqwarp.robot import constants

from .kinematics import LEG_SIDE, foot_ik, leg_fk

NOMINAL_FOOT_X = wp.constant(wp.vec4(*[float(xy[0]) for xy in constants.NOMINAL_FOOT_XY]))
"""x of each leg's nominal stance foot point in its hip frame [m], legs FR, FL, RR, RL (PMTG.py)."""
NOMINAL_FOOT_Y = wp.constant(wp.vec4(*[float(xy[1]) for xy in constants.NOMINAL_FOOT_XY]))
"""y of each leg's nominal foot point in its hip frame [m] (signed; PMTG.py)."""
PHASE_INCREMENT = wp.constant(0)
PHASE_OFFSET = wp.constant(1)
"""Phase-residual readings: accumulated into the clock every step, or an offset from the gait clock."""
HIP_OFFSET_Y = wp.constant(float(constants.HIP_OFFSET_Y))
"""|y| of the hip joint in the base (trunk) frame [m]."""
WHEEL_RADIUS = wp.constant(float(constants.WHEEL_RADIUS))
"""Wheel radius R [m]."""
WHEEL_FORWARD_SIGN = wp.constant(float(constants.WHEEL_FORWARD_SIGN))
"""+1: a positive wheel speed rolls the robot forward."""
REBASE_EPS = wp.constant(1.0e-4)
"""Margin [cycles] past a leg's touch-down at a re-base, so float rounding cannot leave it at psi ~ 1 in swing."""


# --- paper equations ---------------------------------------------------------------------------------------------
@wp.func
def wrap_phase(x: float) -> float:
    """x mod 1 in [0, 1) [cycles]; negative x wraps up."""
    r = x - wp.floor(x)
    if r >= 1.0:  # x - floor(x) rounds to 1 for tiny negative x in float32
        r = 0.0
    return r


@wp.func
def phase_update(phi: float, f: float, dt: float, dphi: float) -> float:
    """Eq. (1) phase update phi' = (phi + f dt + dphi) mod 1, in [0, 1).

    phi [cycles], f gait frequency [Hz], dt policy step [s], dphi the policy's phase residual Delta phi_i [cycles]
    (the paper's action adds it to each leg's phase; dphi = 0 gives the paper's Eq. (1)). Negative values wrap.
    """
    return wrap_phase(phi + f * dt + dphi)


@wp.func
def swing_progress(phi: float, df_swing: float) -> float:
    """Swing progress psi = phi / DF_swing in [0, 1) while phi < DF_swing; -1 in stance (always for DF_swing = 0).

    phi leg phase [cycles], df_swing swing duty factor DF_swing [-].
    """
    if phi < df_swing:
        return phi / df_swing
    return -1.0


@wp.func
def swing_height(psi: float, h_b: float, h_s: float) -> float:
    """Eq. (2) swing height F(psi): foot-point (calf end) z in the hip frame [m].

    F = -h_b + h_s (-16 psi^3 + 12 psi^2) for psi in [0, 0.5], -h_b + h_s (16 psi^3 - 36 psi^2 + 24 psi - 4) for
    psi in (0.5, 1]; -h_b in stance (psi < 0). h_b body height [m], h_s swing height [m]. F(0) = F(1) = -h_b,
    F(0.5) = -h_b + h_s, F is C1 with zero slope at 0, 0.5 and 1.
    """
    if psi < 0.0:
        return -h_b
    if psi <= 0.5:
        return -h_b + h_s * (-16.0 * psi * psi * psi + 12.0 * psi * psi)
    return -h_b + h_s * (16.0 * psi * psi * psi - 36.0 * psi * psi + 24.0 * psi - 4.0)


@wp.func
def swing_x(psi: float, amplitude: float) -> float:
    """Horizontal swing offset of the foot point [m]: -amplitude sin(2 pi psi) in swing (psi in [0, 1)), 0 in stance.

    PMTG.py (authors' generator): the foot moves back at lift-off and forward before touch-down, amplitude
    ``max_horizontal_offset`` 0.05 m; the paper's Eq. (2) only gives z.
    """
    if psi < 0.0:
        return 0.0
    return -amplitude * wp.sin(2.0 * wp.pi * psi)


@wp.func
def lateral_stroke(phi: float, df_swing: float, amplitude: float) -> float:
    """Lateral feed-forward of a stepping leg's foot point [m] (an option, not in the paper): a sawtooth locked to
    the leg phase, from -A to +A over swing (psi = phi / DF_swing) and back from +A to -A over stance, so the stance
    legs push the body toward +A. Continuous at lift-off and touch-down; 0 without swing (DF_swing = 0, driving).

    phi leg phase [cycles], df_swing DF_swing [-], amplitude A [m] (``GaitConfig.lateral_gain`` x v_y, clipped).
    """
    if df_swing <= 0.0:
        return 0.0
    if phi < df_swing:
        return amplitude * (2.0 * phi / df_swing - 1.0)
    return amplitude * (1.0 - 2.0 * (phi - df_swing) / (1.0 - df_swing))


@wp.func
def nominal_wheel_velocity(vx: float, wz: float, d: float, radius: float, forward_sign: float) -> float:
    """Eq. (3) nominal wheel velocity v_n = forward_sign (v_x - d w_z) / R [rad/s].

    vx commanded forward velocity [m/s], wz commanded yaw rate [rad/s], d signed lateral (y) position of the wheel
    centre in the base frame [m], radius R [m]. The paper's leading minus is forward_sign = -1 for its wheel axes;
    ours point +y, so forward_sign = constants.WHEEL_FORWARD_SIGN = +1. The lateral command v_y does not enter
    Eq. (3): wheels cannot roll sideways, the legs produce v_y.
    """
    return forward_sign * (vx - d * wz) / radius


# --- gait switching ------------------------------------------------------------------------------------------------
@wp.func
def stance_reference_phase(offsets: wp.vec4, df_swing: float) -> float:
    """Reference phase r [cycles] at which every leg (r + offset_i) mod 1 of a gait is in stance, just after a
    touch-down: r = DF_swing - offset_k (+ margin) for the first leg k that gives an all-stance configuration;
    the k = 0 candidate when the gait has no all-stance window."""
    for k in range(4):
        r = wrap_phase(df_swing - offsets[k] + REBASE_EPS)
        ok = True
        for i in range(4):
            if wrap_phase(r + offsets[i]) < df_swing:
                ok = False
        if ok:
            return r
    return wrap_phase(df_swing - offsets[0] + REBASE_EPS)


@wp.kernel
def apply_gait_switch(
    gait_id: wp.array(dtype=wp.int32),
    phase_offsets: wp.array2d(dtype=float),
    df_swing: wp.array(dtype=float),
    # outputs
    clock: wp.array2d(dtype=float),
    phase: wp.array2d(dtype=float),
    active_gait_id: wp.array(dtype=wp.int32),
):
    """Per world: apply a requested gait once no leg of the active gait is in swing, re-basing the clocks."""
    world = wp.tid()
    new = gait_id[world]
    old = active_gait_id[world]
    if new == old:
        return
    for leg in range(4):
        if phase[world, leg] < df_swing[old]:
            return  # a leg is in swing: keep the request pending
    offsets = wp.vec4(phase_offsets[new, 0], phase_offsets[new, 1], phase_offsets[new, 2], phase_offsets[new, 3])
    r = stance_reference_phase(offsets, df_swing[new])
    for leg in range(4):
        clock[world, leg] = wrap_phase(r + offsets[leg])
        phase[world, leg] = clock[world, leg]
    active_gait_id[world] = new


@wp.kernel
def reset_gait_phases(
    env_ids: wp.array(dtype=wp.int32),
    gait_id: wp.array(dtype=wp.int32),
    phase_offsets: wp.array2d(dtype=float),
    df_swing: wp.array(dtype=float),
    # outputs
    clock: wp.array2d(dtype=float),
    phase: wp.array2d(dtype=float),
    active_gait_id: wp.array(dtype=wp.int32),
    wheel_velocity: wp.array2d(dtype=float),
):
    """For each world in env_ids: make gait_id active, clocks and phases at an all-stance point of it, wheels 0."""
    world = env_ids[wp.tid()]
    g = gait_id[world]
    offsets = wp.vec4(phase_offsets[g, 0], phase_offsets[g, 1], phase_offsets[g, 2], phase_offsets[g, 3])
    r = stance_reference_phase(offsets, df_swing[g])
    for leg in range(4):
        clock[world, leg] = wrap_phase(r + offsets[leg])
        phase[world, leg] = clock[world, leg]
        wheel_velocity[world, leg] = 0.0
    active_gait_id[world] = g


# --- nominal gait --------------------------------------------------------------------------------------------------
@wp.kernel
def compute_nominal_gait(
    active_gait_id: wp.array(dtype=wp.int32),
    df_swing: wp.array(dtype=float),
    frequency: wp.array(dtype=float),
    stance_x: wp.array(dtype=float),
    command: wp.array2d(dtype=float),
    phase_residual: wp.array2d(dtype=float),
    leg_joint_pos: wp.array2d(dtype=float),
    contact: wp.array2d(dtype=wp.int32),
    dt: float,
    h_b: float,
    h_s: float,
    swing_x_amplitude: float,
    phase_mode: int,
    lateral_gain: float,
    lateral_limit: float,
    # outputs
    clock: wp.array2d(dtype=float),
    phase: wp.array2d(dtype=float),
    swing_psi: wp.array2d(dtype=float),
    foot_target: wp.array2d(dtype=wp.vec3),
    leg_joint_target: wp.array2d(dtype=float),
    wheel_velocity: wp.array2d(dtype=float),
):
    """Per (world, leg): Eq. (1) clock and phase, swing progress, Eq. (2) foot target and its IK, Eq. (3) wheel
    speed. ``phase_mode``: PHASE_INCREMENT (0) or PHASE_OFFSET (1), see the module docstring."""
    world, leg = wp.tid()
    g = active_gait_id[world]
    side = LEG_SIDE[leg]

    dphi = phase_residual[world, leg]
    phi = float(0.0)
    if phase_mode == PHASE_OFFSET:
        c = phase_update(clock[world, leg], frequency[g], dt, 0.0)
        clock[world, leg] = c
        phi = wrap_phase(c + dphi)
    else:
        phi = phase_update(clock[world, leg], frequency[g], dt, dphi)
        clock[world, leg] = phi
    psi = swing_progress(phi, df_swing[g])
    x = NOMINAL_FOOT_X[leg] + stance_x[g] + swing_x(psi, swing_x_amplitude)
    amplitude = wp.clamp(lateral_gain * command[world, 1], -lateral_limit, lateral_limit)
    y = NOMINAL_FOOT_Y[leg] + lateral_stroke(phi, df_swing[g], amplitude)
    p_n = wp.vec3(x, y, swing_height(psi, h_b, h_s))
    q_n = foot_ik(p_n, side)

    phase[world, leg] = phi
    swing_psi[world, leg] = psi
    foot_target[world, leg] = p_n
    for j in range(3):
        leg_joint_target[world, 3 * leg + j] = q_n[j]

    if contact[world, leg] != 0:
        q = wp.vec3(leg_joint_pos[world, 3 * leg], leg_joint_pos[world, 3 * leg + 1], leg_joint_pos[world, 3 * leg + 2])
        d = side * HIP_OFFSET_Y + leg_fk(q, side)[1]  # wheel-centre y in the base frame
        wheel_velocity[world, leg] = nominal_wheel_velocity(
            command[world, 0], command[world, 2], d, WHEEL_RADIUS, WHEEL_FORWARD_SIGN
        )
    # else: in the air, keep the previous nominal wheel velocity (paper: "preserved from the previous moment")


# --- open-loop gait with its parameters as inputs (differentiable) ---------------------------------------------
GAIT_PARAM_NAMES = ("h_b", "h_s", "frequency", "df_swing", "stance_x")
"""Columns of the ``params`` input of :func:`open_loop_gait_targets`: body height h_b [m], swing height h_s [m],
gait frequency f [Hz], swing duty factor DF_swing [-], stance x offset of the foot points [m]."""


@wp.kernel
def open_loop_gait_targets(
    params: wp.array2d(dtype=float),
    phase_offsets: wp.array2d(dtype=float),
    command: wp.array2d(dtype=float),
    t: float,
    swing_x_amplitude: float,
    # outputs
    leg_joint_target: wp.array2d(dtype=float),
    wheel_velocity: wp.array2d(dtype=float),
):
    """Per (world, leg): the nominal leg targets and wheel speed at time ``t`` [s] of a gait run from t = 0 with
    constant parameters, no phase residual and no state, so that every output is a function of ``params``
    ((W, 5), columns ``GAIT_PARAM_NAMES``) that ``wp.Tape`` can differentiate.

    Eq. (1) integrated: phi_i = (offset_i + f t) mod 1, the same phases as :func:`compute_nominal_gait` from a reset
    at the offsets; then Eq. (2) and the swing x offset, foot IK, and Eq. (3) with d_i read from the nominal target
    (not the measured legs) for every wheel (no hold in the air: the command is constant, so the held value would be
    the same up to the small change of d_i). Gradients are exact away from the phase wrap and the swing/stance switch.
    At the switch (touch-down) F and its slope are continuous, and so is x_swing, but x_swing's slope jumps from
    -2 pi A / DF_swing to 0: d/df and d/dDF_swing stay finite but jump there (tests/kernels/test_gait_gradients.py)."""
    world, leg = wp.tid()
    side = LEG_SIDE[leg]
    h_b = params[world, 0]
    h_s = params[world, 1]
    f = params[world, 2]
    df = params[world, 3]
    phi = wrap_phase(phase_offsets[world, leg] + f * t)
    psi = swing_progress(phi, df)
    x = NOMINAL_FOOT_X[leg] + params[world, 4] + swing_x(psi, swing_x_amplitude)
    p_n = wp.vec3(x, NOMINAL_FOOT_Y[leg], swing_height(psi, h_b, h_s))
    q_n = foot_ik(p_n, side)
    for j in range(3):
        leg_joint_target[world, 3 * leg + j] = q_n[j]
    d = side * HIP_OFFSET_Y + leg_fk(q_n, side)[1]
    wheel_velocity[world, leg] = nominal_wheel_velocity(
        command[world, 0], command[world, 2], d, WHEEL_RADIUS, WHEEL_FORWARD_SIGN
    )


# --- Python side ---------------------------------------------------------------------------------------------------
PHASE_MODES = ("increment", "offset")
"""Names of the phase-residual readings, index = the kernel's ``phase_mode``."""


@dataclass
class NominalGaitState:
    """Buffers of the nominal gait for world_count worlds, allocated once (legs FR, FL, RR, RL)."""

    clock: wp.array2d
    """(world_count, 4) float32 gait clocks c in [0, 1) [cycles] (state; equal to ``phase`` in increment mode)."""
    phase: wp.array2d
    """(world_count, 4) float32 leg phases phi in [0, 1) [cycles]."""
    active_gait_id: wp.array
    """(world_count,) int32 gait id in effect; lags the requested gait until a switch is applied (state)."""
    wheel_velocity: wp.array2d
    """(world_count, 4) float32 nominal wheel velocities v_n [rad/s] (state: kept while a wheel is in the air)."""
    swing_psi: wp.array2d
    """(world_count, 4) float32 swing progress psi in [0, 1), -1 in stance [-]."""
    foot_target: wp.array2d
    """(world_count, 4) vec3 nominal foot-point (calf end) targets p_n in each hip frame [m]."""
    leg_joint_target: wp.array2d
    """(world_count, 12) float32 nominal leg joint targets IK(p_n) [rad]."""

    @classmethod
    def allocate(cls, world_count: int, device: wp.context.Devicelike = None) -> NominalGaitState:
        """Zeroed buffers; call :func:`reset_nominal_gait` before the first step."""
        n, legs = world_count, constants.NUM_LEGS
        return cls(
            clock=wp.zeros((n, legs), dtype=float, device=device),
            phase=wp.zeros((n, legs), dtype=float, device=device),
            active_gait_id=wp.zeros(n, dtype=wp.int32, device=device),
            wheel_velocity=wp.zeros((n, legs), dtype=float, device=device),
            swing_psi=wp.zeros((n, legs), dtype=float, device=device),
            foot_target=wp.zeros((n, legs), dtype=wp.vec3, device=device),
            leg_joint_target=wp.zeros((n, constants.NUM_LEG_JOINTS), dtype=float, device=device),
        )


def reset_nominal_gait(state: NominalGaitState, env_ids: wp.array, gait_id: wp.array, gaits) -> None:
    """Reset the worlds in ``env_ids`` ((n,) int32) to gait ``gait_id[world]`` ((world_count,) int32).

    ``gaits`` holds ``phase_offsets`` (num_gaits, 4), ``df_swing`` (num_gaits,) and ``frequency`` (num_gaits,)
    float32 arrays (``wqwarp.control.gaits.gait_library_arrays``). Phases start just after a touch-down with every leg
    in stance; nominal wheel velocities start at 0.
    """
    wp.launch(
        reset_gait_phases,
        dim=env_ids.shape[0],
        inputs=[env_ids, gait_id, gaits.phase_offsets, gaits.df_swing],
        outputs=[state.clock, state.phase, state.active_gait_id, state.wheel_velocity],
        device=state.phase.device,
    )


def step_nominal_gait(
    state: NominalGaitState,
    gaits,
    gait_id: wp.array,
    command: wp.array2d,
    phase_residual: wp.array2d,
    leg_joint_pos: wp.array2d,
    contact: wp.array2d,
    dt: float,
    h_b: float = constants.NOMINAL_BODY_HEIGHT,
    h_s: float = constants.NOMINAL_SWING_HEIGHT,
    swing_x_amplitude: float = constants.MAX_HORIZONTAL_OFFSET,
    phase_mode: str = "increment",
    lateral_gain: float = 0.0,
    lateral_limit: float = 0.0,
) -> None:
    """Advance the nominal gait by one policy step (gait switch, then :func:`compute_nominal_gait`), in place.

    Args:
        state: buffers from :meth:`NominalGaitState.allocate`, updated in place.
        gaits: gait library arrays (``wqwarp.control.gaits.GaitArrays``).
        gait_id: (world_count,) int32 requested gait per world (applied as described in the module docstring).
        command: (world_count, 3) float32 (v_x [m/s], v_y [m/s], w_z [rad/s]) in the base frame.
        phase_residual: (world_count, 4) float32 policy phase residuals dphi [cycles].
        leg_joint_pos: (world_count, 12) float32 measured leg joint positions [rad] (for d in Eq. (3)).
        contact: (world_count, 4) int32 wheel ground contact, nonzero = in contact.
        dt: policy step [s].
        h_b: nominal body height, foot point below the hip [m].
        h_s: swing height [m].
        swing_x_amplitude: horizontal swing amplitude [m] (authors' generator: 0.05).
        phase_mode: ``"increment"`` (residual accumulated into the clock) or ``"offset"`` (offset from the clock).
        lateral_gain, lateral_limit: the lateral feed-forward (:func:`lateral_stroke`), A = clip(gain v_y, +-limit)
            [s, m]; 0 = off (the paper).
    """
    if phase_mode not in PHASE_MODES:
        raise ValueError(f"unknown phase_mode {phase_mode!r}; choose one of {', '.join(PHASE_MODES)}")
    world_count = state.phase.shape[0]
    device = state.phase.device
    wp.launch(
        apply_gait_switch,
        dim=world_count,
        inputs=[gait_id, gaits.phase_offsets, gaits.df_swing],
        outputs=[state.clock, state.phase, state.active_gait_id],
        device=device,
    )
    wp.launch(
        compute_nominal_gait,
        dim=(world_count, constants.NUM_LEGS),
        inputs=[
            state.active_gait_id,
            gaits.df_swing,
            gaits.frequency,
            gaits.stance_x,
            command,
            phase_residual,
            leg_joint_pos,
            contact,
            float(dt),
            float(h_b),
            float(h_s),
            float(swing_x_amplitude),
            PHASE_MODES.index(phase_mode),
            float(lateral_gain),
            float(lateral_limit),
        ],
        outputs=[
            state.clock,
            state.phase,
            state.swing_psi,
            state.foot_target,
            state.leg_joint_target,
            state.wheel_velocity,
        ],
        device=device,
    )
