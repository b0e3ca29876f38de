"""Draw the paper's Fig. 5 (fig:velocity_tracking) from evaluation results: tracking MSE and mean power per task,
one bar per method.

Usage::

    python tools/plot_eval.py eval_baseline.json eval_pmtg.json eval_no_predictor.json --out fig5.png

Each JSON is written by ``python train/evaluate.py --json``; the legend uses the preset recorded in it.
"""

from __future__ import annotations

import json
import os
import sys

from wqwarp.cli.args import ArgumentParser, UsageError, entry_point


@entry_point
def main(argv=None) -> int:
    ap = ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("results", nargs="+", help="JSON files from train/evaluate.py --json")
    ap.add_argument("--out", required=True, help="output PNG")
    args = ap.parse_args(argv)
    runs = []
    for path in args.results:
        try:
            with open(path, encoding="utf-8") as f:
                d = json.load(f)
            runs.append((d.get("preset", os.path.basename(path)), {r["task"]: r for r in d["results"]}))
        except (OSError, KeyError, json.JSONDecodeError) as e:
            raise UsageError(f"cannot read evaluation results {path!r}: {e}") from None
    tasks = [t for t in ("vx", "vy", "wz") if any(t in r for _, r in runs)]
    if not tasks:
        raise UsageError("no vx / vy / wz results in the given files")
    from wqwarp.eval.report import draw_tracking_power

    one = lambda v: {"mean": v, "std": 0.0, "n": 1}  # noqa: E731 - a single run: no spread
    stats = [
        (label, {t: {"mse": one(r["mse"]), "mean_p_cost": one(r["mean_p_cost"])} for t, r in res.items()})
        for label, res in runs
    ]
    draw_tracking_power(stats, args.out, tasks=tasks)
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
