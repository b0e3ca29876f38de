"""Time to skill of training runs: iterations, robot-steps and seconds until a tracking error first stays low.

Usage::

    python tools/time_to_skill.py RUN_DIR [RUN_DIR ...] [--metric Metrics/vx_error] [--thresholds 0.3,0.25,0.2]
                                  [--window 20] [--bench docs/studies/bench/bench_train_busy0.json] [--json PATH]

For each run (a ``train/ppo_newton.py`` log directory) and threshold: the first iteration at which the moving mean
of ``--metric`` over ``--window`` iterations is below the threshold, the robot-steps collected by then
(robots x steps per iteration x iterations, all ranks), and two times: ``wall_s``, the run's own summed iteration
times (rsl-rl's ``Perf/collection_time`` + ``Perf/learning_time``; they include whatever else ran on the machine),
and, with ``--bench``, ``bench_s`` = iterations x the idle seconds per iteration that ``tools/bench_train.py``
measured for the run's robot count (a like-for-like comparison of robot counts on a quiet machine).
"""

from __future__ import annotations

import json
import os
import sys

from wqwarp.cli.args import UsageError, doc_parser, entry_point, parse_floats


def first_below(values: list[float], threshold: float, window: int) -> int | None:
    """Index of the first element whose trailing mean over ``window`` values (fewer at the start) is below
    ``threshold``; None if never."""
    acc = 0.0
    for i, v in enumerate(values):
        acc += v
        if i >= window:
            acc -= values[i - window]
        if i + 1 >= window and acc / window < threshold:
            return i
    return None


def analyse(run: str, metric: str, thresholds: list[float], window: int, bench: dict[int, float]) -> dict:
    from wqwarp.eval.report import load_scalars

    cfg_path = os.path.join(run, "config.json")
    if not os.path.isfile(cfg_path):
        raise ValueError(f"{run}: no config.json (not a train/ppo_newton.py run directory)")
    with open(cfg_path, encoding="utf-8") as f:
        cfg = json.load(f)
    robots = int(cfg["env"]["sim"]["num_envs"]) * int(cfg.get("world_size", 1))  # the resolved config (any version)
    steps_per_it = robots * int(cfg["train"]["num_steps_per_env"])
    sc = load_scalars(run)
    if metric not in sc:
        raise ValueError(f"{run}: no scalar {metric!r} (have {', '.join(sorted(sc)[:8])}, ...)")
    its, vals, _ = sc[metric]
    times = [a + b for a, b in zip(sc["Perf/collection_time"][1], sc["Perf/learning_time"][1], strict=False)]
    out = {
        "run": run,
        "robots": robots,
        "iterations": len(vals),
        "final": sum(vals[-window:]) / min(window, len(vals)),
        "seconds_per_iteration": sum(times) / max(len(times), 1),
        "thresholds": {},
    }
    for th in thresholds:
        i = first_below(vals, th, window)
        if i is None:
            out["thresholds"][str(th)] = None
            continue
        row = {"iteration": its[i] + 1, "robot_steps": (i + 1) * steps_per_it, "wall_s": round(sum(times[: i + 1]), 1)}
        if cfg["env"]["sim"]["num_envs"] in bench:
            row["bench_s"] = round((i + 1) * bench[cfg["env"]["sim"]["num_envs"]], 1)
        out["thresholds"][str(th)] = row
    return out


@entry_point
def main(argv=None) -> int:
    ap = doc_parser(__doc__)
    ap.add_argument("runs", nargs="+", help="run directories written by train/ppo_newton.py")
    ap.add_argument("--metric", default="Metrics/vx_error", help="scalar to threshold (default Metrics/vx_error)")
    ap.add_argument("--thresholds", default="0.3,0.25,0.2", help="comma-separated thresholds (default 0.3,0.25,0.2)")
    ap.add_argument("--window", type=int, default=20, help="moving-mean window in iterations (default 20)")
    ap.add_argument("--bench", default=None, help="tools/bench_train.py JSON giving idle seconds per iteration by N")
    ap.add_argument("--json", default=None, help="also write the results to this JSON file (atomically)")
    args = ap.parse_args(argv)
    try:
        thresholds = parse_floats(args.thresholds)
    except ValueError as e:
        ap.error(f"--thresholds: {e}")
    if args.window < 1:
        ap.error(f"--window must be >= 1, got {args.window}")
    ap.check_outputs(args.json)
    bench: dict[int, float] = {}
    if args.bench:
        try:
            with open(args.bench, encoding="utf-8") as f:
                bench = {int(r["n"]): float(r["iteration_s"]) for r in json.load(f)["results"]}
        except (OSError, ValueError, KeyError) as e:
            raise UsageError(f"--bench {args.bench!r}: {e}") from None
    try:
        results = [analyse(r, args.metric, thresholds, args.window, bench) for r in args.runs]
    except ValueError as e:
        raise UsageError(str(e)) from None
    print(
        f"{'run':<28} {'robots':>6} {'s/it':>6} {'final':>6}  "
        + "  ".join(f"< {t:g}: it / Msteps / wall s" for t in thresholds)
    )
    for r in results:
        cells = []
        for t in thresholds:
            row = r["thresholds"][str(t)]
            cells.append(
                "never"
                if row is None
                else f"{row['iteration']} / {row['robot_steps'] / 1e6:.2f} / "
                f"{row['wall_s']:.0f}" + (f" (bench {row['bench_s']:.0f})" if "bench_s" in row else "")
            )
        print(
            f"{os.path.basename(r['run'].rstrip('/')):<28} {r['robots']:>6} {r['seconds_per_iteration']:>6.2f} "
            f"{r['final']:>6.3f}  " + "  ".join(cells)
        )
    if args.json:
        from wqwarp.utils import provenance

        provenance.write_result_json(
            args.json, {"metric": args.metric, "window": args.window, "thresholds": thresholds, "results": results}
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
