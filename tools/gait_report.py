"""Summarise a training run's gait selection from its TensorBoard events: gait usage overall and per command type,
temperature, switch rate, falls after a switch, and the power predictor's loss and held-out relative error per gait.

Usage::

    python tools/gait_report.py RUN_DIR [--last 100] [--json gait_report.json]

Each value is the mean over the last ``--last`` logged iterations (the gait selector's ``Gait/*`` and ``Predictor/*``
scalars are written once per iteration by ``wqwarp.rl.progress.ProgressLogger``, after the predictor's fit in
``wqwarp.rl.algorithm.WqPPO``); a fixed-gait run reports its usage and switch counts too.
"""

from __future__ import annotations

import argparse
import os
import sys

from wqwarp.cli.args import ArgumentParser, UsageError, entry_point


def summarise(run_dir: str, last: int) -> dict:
    """tag -> mean over the last ``last`` iterations, for the ``Gait/*``, ``Predictor/*`` and ``Metrics/*`` tags."""
    from wqwarp.eval.report import load_scalars

    scalars = load_scalars(run_dir)
    out: dict = {"run": run_dir, "last_iterations": last, "scalars": {}}
    for tag, (steps, values, _) in sorted(scalars.items()):
        if not tag.startswith(("Gait/", "Predictor/", "Metrics/")) or not values:
            continue
        tail = values[-last:]
        out["scalars"][tag] = sum(tail) / len(tail)
        out["last_step"] = max(out.get("last_step", 0), steps[-1])
    return out


@entry_point
def main(argv=None) -> int:
    ap = ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("run", help="run directory written by train/ppo_newton.py")
    ap.add_argument("--last", type=int, default=100, help="iterations averaged at the end of the run (default 100)")
    ap.add_argument("--json", default=None, help="also write the summary to this JSON file")
    args = ap.parse_args(argv)
    if not os.path.isdir(args.run):
        raise UsageError(f"no such run directory {args.run!r}")
    if args.last < 1:
        raise UsageError("--last must be >= 1")
    rep = summarise(args.run, args.last)
    if not rep["scalars"]:
        raise UsageError(f"{args.run!r} holds no Gait/, Predictor/ or Metrics/ scalars")
    print(f"{args.run}: mean over the last {args.last} iterations (up to iteration {rep.get('last_step')})")
    for k, v in rep["scalars"].items():
        print(f"  {k:<45} {v:10.4f}")
    if args.json:
        from wqwarp.utils.provenance import write_result_json

        write_result_json(args.json, rep)
    return 0


if __name__ == "__main__":
    sys.exit(main())
