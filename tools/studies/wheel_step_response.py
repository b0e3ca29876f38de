"""Step response of the wheel velocity PID, loaded (robot standing on its wheels) and airborne (free fall), used to
choose ``SimConfig.wheel_*`` gains.

Usage::

    python tools/studies/wheel_step_response.py [--speed 0.5] [--air-target 5] [--seconds 2]
                                        [--gains "kp,ki,kd;..."] [--settings "0.005x4,0.001x20"] [--json PATH]

For each gain set and physics setting (dt x decimation, both 50 Hz policy steps) two runs:

* ``loaded``: all four wheels commanded ``speed / R`` [rad/s] from rest on flat ground, legs held at the default
  pose (the wheels carry the 15.6 kg robot: large effective inertia);
* ``airborne``: the robot in free fall from 50 m (no ground load), wheels commanded ``--air-target`` rad/s from rest.
  Only the wheel's axial inertia and its armature resist: I = 5.7e-4 + 2.19e-3 kg m^2. An explicit velocity loop
  is stable there only for kp dt / I < 2 (``SimConfig.validate``).

Printed per run: 10-90 % rise time, overshoot, settling time (last time outside a +-5 % band), steady error over the
last 0.5 s, torque sign flips after settling (between consecutive substeps, both torques above 0.06 N m, 1 % of the
limit; a chattering loop flips every substep), mean wheel p_cost over the
last 0.5 s per wheel [W], and (loaded) the base forward speed reached. Wheel speeds are sampled every physics
substep (``Simulator.step`` of one substep each).
"""

from __future__ import annotations

import sys

import numpy as np

from wqwarp.cli.args import UsageError, doc_parser, entry_point
from wqwarp.utils.io import output_problem

FLIP_TORQUE = 0.06
"""Torques below 1 % of the 6 N m limit [N m] do not count as a sign flip."""


def run(kp, ki, kd, i_limit, dt, decimation, mode, target, seconds) -> dict:

    from wqwarp import quiet_warp
    from wqwarp.robot import asset as robot
    from wqwarp.sim.config import SimConfig
    from wqwarp.sim.simulator import Simulator

    quiet_warp()
    cfg = SimConfig(
        num_envs=1,
        dt=dt,
        decimation=1,
        wheel_kp=kp,
        wheel_ki=ki,
        wheel_kd=kd,
        wheel_i_limit=i_limit,
        check_wheel_stability=False,
    )
    sim = Simulator(cfg)
    if mode == "airborne":
        q = robot.default_joint_q(sim.layout, base_height=50.0)[None]
        sim.reset([0], q, np.zeros((1, sim.layout.dofs_per_world), np.float32))
    sim.wheel_qd_target.fill_(target)
    wheel_dof = sim.layout.actuated_dof[12:]
    steps = int(round(seconds / dt))
    w, tau, pw, vx = [], [], [], []
    for _ in range(steps):
        sim.step()
        w.append(sim.joint_qd.numpy()[0, wheel_dof].copy())
        tau.append(sim.joint_torque.numpy()[0, 12:].copy())
        pw.append(float(sim.p_cost_wheels.numpy()[0]))
        vx.append(float(sim.joint_qd.numpy()[0, 0]))
    w, tau, pw = np.asarray(w), np.asarray(tau), np.asarray(pw)
    t = np.arange(1, steps + 1) * dt
    wm = w.mean(1)
    rise = t[np.argmax(wm >= 0.9 * target)] - t[np.argmax(wm >= 0.1 * target)] if (wm >= 0.9 * target).any() else None
    outside = np.nonzero(np.abs(w - target).max(1) > 0.05 * abs(target))[0]
    settle = float(t[outside[-1]]) if outside.size else 0.0
    after = t > settle + dt
    sig = tau[after] * (np.abs(tau[after]) > FLIP_TORQUE)  # ignore sign changes of negligible torques
    flips = int(np.sum((sig[1:] * sig[:-1]) < 0))
    tail = t > seconds - 0.5
    return {
        "mode": mode,
        "kp": kp,
        "ki": ki,
        "kd": kd,
        "dt": dt,
        "decimation": decimation,
        "target_rad_s": target,
        "rise_s": None if rise is None else float(rise),
        "overshoot_pct": float(100 * (w.max() / target - 1)),
        "settle_s": settle if settle < seconds - 0.5 else None,
        "steady_err_pct": float(100 * abs(wm[tail].mean() / target - 1)),
        "sign_flips_after_settle": flips,
        "p_cost_per_wheel_w": float(pw[tail].mean() / 4),
        "base_vx": float(np.mean(vx[-int(0.5 / dt) :])),
    }


def _fmt(x, spec):
    return "   -" if x is None else format(x, spec)


@entry_point
def main(argv=None) -> int:
    ap = doc_parser(__doc__)
    ap.add_argument("--speed", type=float, default=0.5, help="loaded run: commanded rolling speed [m/s] (default 0.5)")
    ap.add_argument("--air-target", type=float, default=5.0, help="airborne run: wheel target [rad/s] (default 5)")
    ap.add_argument("--seconds", type=float, default=2.0, help="length of each run [s] (default 2)")
    ap.add_argument("--i-limit", type=float, default=2.5, help="integral bound [rad] (default 2.5, as SimConfig)")
    ap.add_argument(
        "--gains",
        default="2,5,0;1,5,0;0.5,5,0;0.5,0,0;0.5,2,0;0.5,1,0",
        help='semicolon-separated "kp,ki,kd" sets (default: a small sweep around the chosen 0.5,2,0)',
    )
    ap.add_argument(
        "--settings",
        default="0.005x4,0.001x20",
        help='comma-separated physics settings "dt x decimation" (default "0.005x4,0.001x20")',
    )
    ap.add_argument("--modes", default="loaded,airborne", help="comma-separated: loaded, airborne (default both)")
    ap.add_argument("--json", default=None, help="also write the results to this JSON file")
    args = ap.parse_args(argv)
    try:
        sets = [tuple(float(x) for x in g.split(",")) for g in args.gains.split(";")]
        if any(len(s) != 3 for s in sets):
            raise ValueError
    except ValueError:
        raise UsageError(f"--gains must look like '2,10,0;4,10,0', got {args.gains!r}") from None
    try:
        settings = [(float(a), int(b)) for a, b in (s.split("x") for s in args.settings.split(","))]
        if any(dt <= 0 or dec < 1 for dt, dec in settings):
            raise ValueError
    except ValueError:
        raise UsageError(f"--settings must look like '0.005x4,0.001x20', got {args.settings!r}") from None
    modes = args.modes.split(",")
    if not modes or any(m not in ("loaded", "airborne") for m in modes) or args.seconds <= 0.6:
        raise UsageError("--modes takes loaded and/or airborne, and --seconds must exceed 0.6")
    if args.json and (problem := output_problem(args.json)):
        raise UsageError(f"--json {args.json!r}: {problem}")
    from wqwarp.robot import constants as C

    print(
        f"{'mode':>8} {'dt':>6} {'kp':>5} {'ki':>5} {'kd':>5} {'rise[s]':>8} {'overshoot%':>10} {'settle[s]':>9} "
        f"{'steady err%':>11} {'flips':>6} {'W/wheel':>8} {'base vx':>8}"
    )
    results = []
    for mode in modes:
        target = C.WHEEL_FORWARD_SIGN * args.speed / C.WHEEL_RADIUS if mode == "loaded" else args.air_target
        for dt, dec in settings:
            for kp, ki, kd in sets:
                r = run(kp, ki, kd, args.i_limit, dt, dec, mode, target, args.seconds)
                results.append(r)
                print(
                    f"{mode:>8} {dt:6.3f} {kp:5.2f} {ki:5.2f} {kd:5.2f} {_fmt(r['rise_s'], '8.3f')} "
                    f"{r['overshoot_pct']:10.1f} {_fmt(r['settle_s'], '9.3f')} {r['steady_err_pct']:11.2f} "
                    f"{r['sign_flips_after_settle']:6d} {r['p_cost_per_wheel_w']:8.3f} {r['base_vx']:8.3f}",
                    flush=True,
                )
    if args.json:
        from wqwarp.utils.provenance import write_result_json

        write_result_json(args.json, {"results": results}, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
