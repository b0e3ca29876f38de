"""Gradient quality of the differentiable rollout (``wqwarp.diff.rollout``) against horizon and dt.

Usage::

    python tools/studies/gradient_study.py [--gait trotting] [--vx 0.3] [--dts 0.005,0.002,0.001]
                                   [--horizons 0.02,0.05,0.1,0.2,0.5] [--warmup 0.5] [--json PATH] [--plot PATH]

For every physics step dt and taped horizon T [s]: one robot warms up for ``--warmup`` seconds (untaped) in the
nominal gait at the command (v_x, 0, 0), then T seconds are taped. The tape's gradients of the horizon means of the
smooth p_cost [W] and of the base v_x [m/s] with respect to the five gait parameters (h_b, h_s, f, DF_swing,
stance x) are compared with central finite differences from the same start state (steps ``FD_FRACTION``, 1 % of each
parameter's scale). Reported per output: the cosine between the two gradient vectors (each parameter scaled by
``PARAM_SCALE`` so that the units compare), the relative error ||tape - fd|| / ||fd||, the cosine between the 1 %
and a 0.1 % finite difference (``fd_consistency``: below ~0.9 the output is not smooth on that scale, and finite
differences are no reference), and the norm of the scaled tape gradient. The policy rate is
kept at 50 Hz (decimation = 0.02 / dt).

Output: a progress line per setting on stderr, a markdown table on stdout, and, with ``--json`` / ``--plot``, the
results with the command, git commit and settings, and a figure of cosine and relative error against horizon.
Bad input: one ``error:`` line, exit code 2, nothing written.
"""

from __future__ import annotations

import sys
import time

import numpy as np

from wqwarp.cli.args import add_result_options, doc_parser

PARAM_SCALE = np.array([0.2, 0.1, 1.0, 0.4, 0.05])
"""Typical size of each gait parameter (h_b [m], h_s [m], f [Hz], DF_swing [-], stance x [m]): gradients are
multiplied by it before vectors are compared."""
FD_FRACTION = 0.01
"""Central-difference step per input: 1 % of its scale."""
FD_FRACTION_FINE = 0.001
"""A second, 10x smaller step: where the two finite differences disagree, the output is not smooth on that scale and
finite differences are no reference for the tape."""


PARAM_NAMES = ("h_b", "h_s", "frequency", "df_swing", "stance_x")
INPUTS = [("params", k, name, PARAM_SCALE[k]) for k, name in enumerate(PARAM_NAMES)]
INPUTS += [
    ("leg_offset", 0, "FR hip", 0.1),
    ("leg_offset", 1, "FR thigh", 0.1),
    ("leg_offset", 2, "FR calf", 0.1),
    ("leg_offset", 10, "RL thigh", 0.1),
    ("wheel_offset", 0, "FR wheel", 2.0),
    ("wheel_offset", 3, "RL wheel", 2.0),
]
"""Inputs whose gradients are checked: (DiffRollout input, column, name, scale). Leg-target offsets [rad] have scale
0.1 rad, wheel-speed offsets [rad/s] 2 rad/s."""
GROUPS = {"gait": slice(0, 5), "legs": slice(5, 9), "wheels": slice(9, 11)}


def study_point(gait: str, vx: float, dt: float, horizon_s: float, warmup_s: float) -> dict:
    from wqwarp.diff.rollout import DiffRollout, gait_params
    from wqwarp.sim.config import SimConfig

    decimation = max(1, round(0.02 / dt))
    policy_dt = dt * decimation
    cfg = SimConfig(num_envs=1, dt=dt, decimation=decimation, backend="featherstone")
    roll = DiffRollout(
        cfg, gait, (vx, 0.0, 0.0), horizon=max(1, round(horizon_s / policy_dt)), warmup=round(warmup_s / policy_dt)
    )
    zeros = np.zeros
    base = {"params": gait_params(gait), "leg_offset": zeros(12, np.float32), "wheel_offset": zeros(4, np.float32)}
    scale = np.array([x[3] for x in INPUTS])
    t0 = time.time()
    res = roll.run()
    gp = roll.gradients(p_cost_weight=np.ones(1))
    g_p = np.array([gp[key][0, k] for key, k, _, _ in INPUTS])
    gv = roll.gradients(velocity_weight=np.array([[1.0, 0.0, 0.0]]))
    g_v = np.array([gv[key][0, k] for key, k, _, _ in INPUTS])

    def central(fraction: float) -> tuple[np.ndarray, np.ndarray]:
        fd_p, fd_v = np.zeros(len(INPUTS)), np.zeros(len(INPUTS))
        for j, (key, k, _, sc) in enumerate(INPUTS):
            h = fraction * sc
            out = []
            for sgn in (1.0, -1.0):
                x = base[key].copy()
                x[k] += sgn * h
                roll.set_inputs(**{key: x})
                out.append(roll.run(record=False, warm_start=False))
            roll.set_inputs(**{key: base[key]})
            fd_p[j] = (out[0].p_cost_smooth[0] - out[1].p_cost_smooth[0]) / (2 * h)
            fd_v[j] = (out[0].base_velocity[0, 0] - out[1].base_velocity[0, 0]) / (2 * h)
        return fd_p, fd_v

    fd_p, fd_v = central(FD_FRACTION)
    fine_p, fine_v = central(FD_FRACTION_FINE)

    def cos_rel(x: np.ndarray, y: np.ndarray) -> tuple[float, float]:
        cos = float(x @ y / (np.linalg.norm(x) * np.linalg.norm(y) + 1e-30))
        return cos, float(np.linalg.norm(x - y) / (np.linalg.norm(y) + 1e-30))

    def compare(tape: np.ndarray, fd: np.ndarray, fine: np.ndarray) -> dict:
        a, b, c = tape * scale, fd * scale, fine * scale
        out = {}
        for name, sl in GROUPS.items():
            cos, rel = cos_rel(a[sl], b[sl])
            out[name] = {
                "cosine": cos,
                "rel_error": rel,
                "cosine_fine": cos_rel(a[sl], c[sl])[0],
                "fd_consistency": cos_rel(c[sl], b[sl])[0],
                "tape_norm": float(np.linalg.norm(a[sl])),
            }
        out.update(tape=tape.tolist(), fd=fd.tolist(), fd_fine=fine.tolist())
        return out

    return {
        "dt": dt,
        "decimation": decimation,
        "horizon_s": roll.horizon * policy_dt,
        "substeps": roll.horizon * decimation,
        "p_cost": float(res.p_cost[0]),
        "vx": float(res.base_velocity[0, 0]),
        "fell": bool(res.fell[0]),
        "p_cost_smooth": compare(g_p, fd_p, fine_p),
        "vx_grad": compare(g_v, fd_v, fine_v),
        "seconds": time.time() - t0,
    }


def table(points: list[dict]) -> str:
    rows = [
        "| dt [s] | horizon [s] | output | "
        + " | ".join(f"{g}: cos / rel err / fd 1 % vs 0.1 %" for g in GROUPS)
        + " |",
        "|---|---|---|" + "---|" * len(GROUPS),
    ]
    for p in points:
        for key, label in (("p_cost_smooth", "p_cost"), ("vx_grad", "v_x")):
            cells = [
                f"{p[key][g]['cosine']:.3f} / {p[key][g]['rel_error']:.2g} / {p[key][g]['fd_consistency']:.3f}"
                for g in GROUPS
            ]
            rows.append(f"| {p['dt']:g} | {p['horizon_s']:.2f} | {label} | " + " | ".join(cells) + " |")
    return "\n".join(rows)


def plot(points: list[dict], path: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(10, 3.8))
    for dt in sorted({p["dt"] for p in points}):
        pts = [p for p in points if p["dt"] == dt]
        h = [p["horizon_s"] for p in pts]
        for key, style in (("p_cost_smooth", "-o"), ("vx_grad", "--s")):
            label = f"dt {dt:g}, {'p_cost' if key == 'p_cost_smooth' else 'v_x'}"
            axes[0].plot(h, [p[key]["gait"]["cosine"] for p in pts], style, label=label)
            axes[1].loglog(h, [p[key]["gait"]["rel_error"] for p in pts], style, label=label)
    axes[0].set(
        xscale="log", xlabel="taped horizon [s]", ylabel="gait parameters: cosine(tape, fd)", ylim=(-1.05, 1.05)
    )
    axes[1].set(xlabel="taped horizon [s]", ylabel="||tape - fd|| / ||fd||")
    axes[0].legend(fontsize=7)
    fig.tight_layout()
    from wqwarp.utils.provenance import save_figure

    save_figure(fig, path, dpi=120)
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    ap = doc_parser(__doc__)
    ap.add_argument("--gait", default="trotting", help="Table I gait (default trotting)")
    ap.add_argument("--vx", type=float, default=0.3, help="commanded forward speed [m/s] (default 0.3)")
    ap.add_argument("--dts", default="0.005,0.002,0.001", help="physics steps [s], comma-separated")
    ap.add_argument("--horizons", default="0.02,0.05,0.1,0.2,0.5,1.0", help="taped horizons [s], comma-separated")
    ap.add_argument("--warmup", type=float, default=0.5, help="untaped warm-up before the horizon [s] (default 0.5)")
    add_result_options(ap)
    args = ap.parse_args(argv)
    try:
        dts = [float(x) for x in args.dts.split(",") if x.strip()]
        horizons = [float(x) for x in args.horizons.split(",") if x.strip()]
    except ValueError:
        ap.error(f"--dts and --horizons take comma-separated numbers, got {args.dts!r} and {args.horizons!r}")
    if not dts or min(dts) <= 0 or max(dts) > 0.02 or not horizons or min(horizons) <= 0 or args.warmup < 0:
        ap.error("need 0 < dt <= 0.02, horizons > 0 and warmup >= 0")
    from wqwarp.control.gaits import GAIT_NAMES

    if args.gait not in GAIT_NAMES:
        ap.error(f"unknown gait {args.gait!r}; choose one of {', '.join(GAIT_NAMES)}")
    ap.check_outputs(args.json, args.plot)

    from wqwarp import quiet_warp

    quiet_warp()
    points = []
    for dt in dts:
        for h in horizons:
            t0 = time.time()
            p = study_point(args.gait, args.vx, dt, h, args.warmup)
            points.append(p)
            print(
                f"dt {dt:g} horizon {p['horizon_s']:.2f} s: gait-parameter cos p_cost "
                f"{p['p_cost_smooth']['gait']['cosine']:.3f}, v_x {p['vx_grad']['gait']['cosine']:.3f} "
                f"({time.time() - t0:.1f} s)",
                file=sys.stderr,
                flush=True,
            )
    print(table(points))
    if args.json:
        from wqwarp.utils.provenance import write_result_json

        inputs = [{"input": a, "column": b, "name": c, "scale": float(d)} for a, b, c, d in INPUTS]
        write_result_json(
            args.json,
            {
                "gait": args.gait,
                "vx": args.vx,
                "warmup_s": args.warmup,
                "inputs": inputs,
                "fd_fractions": [FD_FRACTION, FD_FRACTION_FINE],
                "points": points,
            },
        )
    if args.plot:
        plot(points, args.plot)
    return 0


if __name__ == "__main__":
    sys.exit(main())
