"""Tune a nominal gait's parameters for energy per metre by gradient descent through the differentiable simulator.

Usage::

    python tools/optimize_gait.py --gait trotting --vx 0.3 [--iterations 30] [--lr 0.03] [--dt 0.002]
                                  [--horizon 0.1] [--windows 8] [--free h_b,h_s,frequency,df_swing,stance_x]
                                  [--eval-seconds 3] [--no-eval]
                                  [--json docs/studies/diffsim/optimize_trotting_0.3.json]

What runs: ``wqwarp.diff.tuning.optimize`` (Adam on J = P_smooth / v_c + w_v (v_x - v_c)^2 + w_h (z - z_0)^2 over
``--windows`` short taped windows of the Featherstone rollout; see that module), then ``wqwarp.diff.tuning.evaluate``
of the start (Table I) and of the best iterate with the closed-loop nominal gait and the exact p_cost on three
physics settings: MuJoCo at dt 0.005 x 4 and at the paper's 0.001 x 20, and Featherstone at the tuning dt, each 2
robots, 1 s warm-up, then ``--eval-seconds``. A gain that shows on Featherstone only is an artefact of that solver.

Output: a progress line per iteration on stderr; a before/after markdown table on stdout (energy per metre [J/m],
p_cost with its legs / wheels split [W], v_x [m/s], trunk height [m]); the JSON (command, git commit, settings,
every iteration, evaluations), written atomically. Bad input: one ``error:`` line, exit code 2, nothing written.
"""

from __future__ import annotations

import sys
import time

from wqwarp.cli.args import add_result_options, doc_parser

EVAL_SETTINGS = (("mujoco_cpu", 0.005, 4), ("mujoco_cpu", 0.001, 20))
"""MuJoCo settings (backend, dt, decimation) of the before/after evaluation; Featherstone at the tuning dt is added."""


def _fmt(x, spec=".1f"):
    return "-" if x is None else format(x, spec)


def table(report: dict) -> str:
    rows = [
        "| physics | params | energy / m [J/m] | p_cost [W] (legs / wheels) | v_x [m/s] | height [m] | trunk hit |",
        "|---|---|---|---|---|---|---|",
    ]
    for ev in report["evaluations"]:
        for which in ("start", "tuned"):
            r = ev[which]
            rows.append(
                f"| {ev['name']} | {which} | {_fmt(r['energy_per_m'])} | {r['p_cost']:.1f} "
                f"({r['p_cost_legs']:.1f} / {r['p_cost_wheels']:.1f}) | {r['vx']:.3f} | {r['height']:.3f} | "
                f"{'yes' if r['trunk_touched'] else 'no'} |"
            )
    return "\n".join(rows)


def main(argv: list[str] | None = None) -> int:
    from wqwarp.diff.tuning import TuneConfig

    d = TuneConfig()
    ap = doc_parser(__doc__)
    ap.add_argument("--gait", default=d.gait, help=f"Table I gait to tune (default {d.gait})")
    ap.add_argument("--vx", type=float, default=d.vx, help=f"commanded forward speed [m/s] (default {d.vx})")
    ap.add_argument("--iterations", type=int, default=d.iterations, help=f"Adam steps (default {d.iterations})")
    ap.add_argument(
        "--lr", type=float, default=d.lr, help=f"Adam step in units of the parameter scales (default {d.lr})"
    )
    ap.add_argument(
        "--dt",
        type=float,
        default=d.dt,
        help=f"physics step of the differentiable rollout [s] (default "
        f"{d.dt}; 0.005 makes the contact chatter, see docs/studies/diffsim)",
    )
    ap.add_argument("--horizon", type=float, default=d.horizon_s, help=f"taped window [s] (default {d.horizon_s})")
    ap.add_argument("--warmup", type=float, default=d.warmup_s, help=f"untaped warm-up [s] (default {d.warmup_s})")
    ap.add_argument(
        "--windows",
        type=int,
        default=d.windows,
        help=f"robots (phase-spread windows) per iteration (default {d.windows})",
    )
    ap.add_argument(
        "--accept-seconds",
        type=float,
        default=d.accept_seconds,
        help="untaped measurement after the "
        f"warm-up that picks the best iterate and triggers restarts [s]; 0: the taped windows' J (default "
        f"{d.accept_seconds})",
    )
    ap.add_argument(
        "--patience",
        type=int,
        default=d.patience,
        help=f"iterations without a better J before returning "
        f"to the best iterate with half the step (default {d.patience})",
    )
    ap.add_argument("--free", default=",".join(d.free), help="comma-separated parameters to tune (default: all five)")
    ap.add_argument("--w-speed", type=float, default=d.w_speed, help=f"speed penalty w_v (default {d.w_speed:g})")
    ap.add_argument("--w-height", type=float, default=d.w_height, help=f"height penalty w_h (default {d.w_height:g})")
    ap.add_argument(
        "--eval-seconds", type=float, default=3.0, help="evaluation window after 1 s warm-up [s] (default 3)"
    )
    ap.add_argument("--no-eval", action="store_true", help="skip the before/after evaluation")
    add_result_options(ap, plot=None)
    args = ap.parse_args(argv)
    from wqwarp.control.gaits import GAIT_NAMES
    from wqwarp.diff.rollout import PARAM_NAMES

    if args.gait not in GAIT_NAMES:
        ap.error(f"unknown gait {args.gait!r}; choose one of {', '.join(GAIT_NAMES)}")
    free = tuple(p.strip() for p in args.free.split(",") if p.strip())
    bad = [p for p in free if p not in PARAM_NAMES]
    if bad or not free:
        ap.error(f"unknown parameter {', '.join(bad) or '(none)'} in --free; choose from {', '.join(PARAM_NAMES)}")
    if not (0.05 <= args.vx <= 1.5):
        ap.error(f"--vx must lie in [0.05, 1.5] m/s, got {args.vx}")
    if args.iterations < 0 or args.windows < 1 or args.lr <= 0 or args.eval_seconds <= 0 or args.patience < 1:
        ap.error("need --iterations >= 0, --windows >= 1, --lr > 0, --patience >= 1 and --eval-seconds > 0")
    if not (0 < args.dt <= 0.02) or args.horizon <= 0 or args.warmup < 0 or args.accept_seconds < 0:
        ap.error("need 0 < --dt <= 0.02, --horizon > 0, --warmup >= 0 and --accept-seconds >= 0")
    ap.check_outputs(args.json)

    from wqwarp import quiet_warp

    quiet_warp()
    from wqwarp.diff.tuning import evaluate, optimize

    cfg = TuneConfig(
        gait=args.gait,
        vx=args.vx,
        dt=args.dt,
        horizon_s=args.horizon,
        warmup_s=args.warmup,
        windows=args.windows,
        iterations=args.iterations,
        lr=args.lr,
        w_speed=args.w_speed,
        w_height=args.w_height,
        free=free,
        patience=args.patience,
        accept_seconds=args.accept_seconds,
    )
    t0 = time.time()

    def progress(e):
        print(
            f"[{time.time() - t0:6.1f} s] it {e['iteration']:3d} J {e['J']:8.1f} (accept {e['J_accept']:7.1f}) "
            f"p_cost {e['p_cost']:6.1f} W v_x {e['vx']:.3f} z {e['height']:.3f} params "
            f"{' '.join(f'{x:.4f}' for x in e['params'])}",
            file=sys.stderr,
            flush=True,
        )

    result = optimize(cfg, progress)
    report = {"tuning": result, "evaluations": []}
    if not args.no_eval:
        settings = [*EVAL_SETTINGS, ("featherstone", cfg.dt, max(1, round(0.02 / cfg.dt)))]
        for backend, dt, dec in settings:
            name = f"{'MuJoCo' if backend.startswith('mujoco') else 'Featherstone'} dt {dt:g} x {dec}"
            ev = {"name": name, "backend": backend, "dt": dt, "decimation": dec}
            for which, params in (("start", result["start"]["params"]), ("tuned", result["best"]["params"])):
                ev[which] = evaluate(params, cfg.gait, cfg.vx, backend, dt, dec, 1.0, args.eval_seconds)
            s, t = ev["start"]["energy_per_m"], ev["tuned"]["energy_per_m"]
            ev["energy_ratio"] = t / s if s and t else None
            report["evaluations"].append(ev)
            print(
                f"[{time.time() - t0:6.1f} s] evaluated on {name}: {_fmt(s)} -> {_fmt(t)} J/m",
                file=sys.stderr,
                flush=True,
            )
        print(table(report))
    if args.json:
        from wqwarp.utils.provenance import write_result_json

        write_result_json(args.json, report)
    return 0


if __name__ == "__main__":
    sys.exit(main())
