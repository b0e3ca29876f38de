"""Energy per metre along the line from a gait's start parameters to the tuned ones, measured on MuJoCo.

Usage::

    python tools/studies/gait_line.py --tuning docs/studies/diffsim/optimize_trotting_0.3.json
        [--alphas 0,0.25,0.5,0.75,1,1.25] [--backend mujoco_cpu] [--dt 0.001] [--decimation 20] [--seconds 3]
        [--json PATH]

Reads a ``tools/optimize_gait.py`` result and evaluates theta(alpha) = start + alpha (tuned - start) (clipped to the
gait's bounds) with ``wqwarp.diff.tuning.evaluate``: the closed-loop nominal gait, exact p_cost, 2 robots, 1 s warm-up,
then ``--seconds``. A monotone fall of the energy per metre along the line shows that the tuned point lies in a real
basin of the physics the tuning did not use, not in a pocket of the differentiable solver.

Output: a markdown table on stdout, the JSON (command, git commit, points) written atomically. Bad input: one
``error:`` line, exit code 2, nothing written.
"""

from __future__ import annotations

import json
import sys

import numpy as np

from wqwarp.cli.args import add_result_options, doc_parser


def main(argv: list[str] | None = None) -> int:
    ap = doc_parser(__doc__)
    ap.add_argument("--tuning", required=True, help="JSON written by tools/optimize_gait.py")
    ap.add_argument("--alphas", default="0,0.25,0.5,0.75,1,1.25", help="points on the line (0 start, 1 tuned)")
    ap.add_argument("--backend", default="mujoco_cpu", choices=("mujoco_cpu", "featherstone"), help="physics")
    ap.add_argument("--dt", type=float, default=0.001, help="physics step [s] (default 0.001)")
    ap.add_argument("--decimation", type=int, default=20, help="substeps per policy step (default 20)")
    ap.add_argument("--seconds", type=float, default=3.0, help="window after 1 s warm-up [s] (default 3)")
    add_result_options(ap, plot=None)
    args = ap.parse_args(argv)
    try:
        with open(args.tuning, encoding="utf-8") as f:
            rep = json.load(f)
        tuning = rep["tuning"]
        start, tuned = np.asarray(tuning["start"]["params"]), np.asarray(tuning["best"]["params"])
        bounds = np.asarray(tuning["bounds"])
        gait, vx = tuning["config"]["gait"], float(tuning["config"]["vx"])
    except (OSError, ValueError, KeyError, TypeError) as e:
        ap.error(f"--tuning {args.tuning}: not a readable tools/optimize_gait.py result ({type(e).__name__}: {e})")
    try:
        alphas = [float(a) for a in args.alphas.split(",") if a.strip()]
    except ValueError:
        ap.error(f"--alphas takes comma-separated numbers, got {args.alphas!r}")
    if not alphas or not (0 < args.dt <= 0.02) or args.decimation < 1 or args.seconds <= 0:
        ap.error("need --alphas, 0 < --dt <= 0.02, --decimation >= 1 and --seconds > 0")
    ap.check_outputs(args.json)

    from wqwarp import quiet_warp

    quiet_warp()
    from wqwarp.diff.tuning import evaluate

    points = []
    rows = [
        "| alpha | h_b | h_s | f | DF_swing | stance x | energy / m [J/m] | p_cost [W] | v_x [m/s] | height [m] |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for a in alphas:
        p = np.clip(start + a * (tuned - start), bounds[:, 0], bounds[:, 1])
        r = evaluate(p, gait, vx, args.backend, args.dt, args.decimation, 1.0, args.seconds)
        points.append({"alpha": a, **r})
        e = "-" if r["energy_per_m"] is None else f"{r['energy_per_m']:.1f}"
        rows.append(
            f"| {a:g} | " + " | ".join(f"{x:.4f}" for x in p) + f" | {e} | {r['p_cost']:.1f} | "
            f"{r['vx']:.3f} | {r['height']:.3f} |"
        )
        print(rows[-1], file=sys.stderr, flush=True)
    print("\n".join(rows))
    if args.json:
        from wqwarp.utils.provenance import write_result_json

        write_result_json(
            args.json,
            {
                "tuning": args.tuning,
                "gait": gait,
                "vx": vx,
                "start": start.tolist(),
                "tuned": tuned.tolist(),
                "points": points,
            },
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
