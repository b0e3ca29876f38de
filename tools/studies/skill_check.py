"""The skill target of issue 47, checked on evaluated checkpoints: tracking MSE below 0.05 on v_x, v_y and w, every
robot upright on the stand, v_x, v_y and w tasks, and held lateral commands of +-0.6 m/s reaching 80 % of the
command with |w| below 0.1 rad/s and no fall.

Usage::

    python tools/studies/skill_check.py LABEL=TRACKING_JSON[,LATERAL_JSON] [...] [--json PATH]

Each argument names one checkpoint: the ``train/evaluate.py --tasks stand,vx,vy,wz --json`` result of it and,
optionally, its ``train/evaluate.py --protocol lateral --json`` result. One row per checkpoint, each target met or
not, and the margins; the JSON holds the same with the input files named.
"""

from __future__ import annotations

import json
import os
import sys

from wqwarp.cli.args import UsageError, add_result_options, doc_parser, entry_point

MSE_TARGET = 0.05
"""Tracking MSE bound on each moving axis (issue 47)."""
LATERAL_COMMANDS = (-0.6, 0.6)
"""The held lateral commands of the range-edge target [m/s]."""
LATERAL_RATIO = 0.8
"""Share of the lateral command to reach."""
YAW_LIMIT = 0.1
"""|w| bound while holding a lateral command [rad/s]."""


def _read(path: str) -> dict:
    try:
        with open(path, encoding="utf-8") as f:
            return json.load(f)
    except (OSError, json.JSONDecodeError) as e:
        raise UsageError(f"{path}: cannot read a result ({e})") from None


def check(tracking: dict, lateral: dict | None = None) -> dict:
    """The issue 47 targets on one checkpoint's tracking result (and lateral result): the numbers and whether each
    target is met (``None`` where the lateral result is absent)."""
    rows = {r["task"]: r for r in tracking.get("results", [])}
    missing = [t for t in ("stand", "vx", "vy", "wz") if t not in rows]
    if missing:
        raise UsageError(f"the tracking result lacks the tasks {missing} (evaluate with --tasks stand,vx,vy,wz)")
    out = {
        "iteration": tracking.get("iteration"),
        "mse": {t: rows[t]["mse"] for t in ("vx", "vy", "wz")},
        "upright": {t: rows[t]["upright"] for t in ("stand", "vx", "vy", "wz")},
    }
    out["tracks"] = all(v < MSE_TARGET for v in out["mse"].values())
    out["all_upright"] = all(v >= 1.0 for v in out["upright"].values())
    out["lateral"], out["lateral_edges"] = {}, None
    if lateral is not None:
        runs = [r for rs in lateral.get("runs", {}).values() for r in rs]
        for cmd in LATERAL_COMMANDS:
            hit = [r for r in runs if abs(r["command_vy"] - cmd) < 1e-6]
            if not hit:
                raise UsageError(f"the lateral result holds no command {cmd:+g} m/s (--commands must include it)")
            r = hit[0]
            out["lateral"][f"{cmd:+g}"] = {"ratio": r["ratio"], "wz": r["wz"], "upright": r["upright"]}
        out["lateral_edges"] = all(
            v["ratio"] >= LATERAL_RATIO and abs(v["wz"]) < YAW_LIMIT and v["upright"] >= 1.0
            for v in out["lateral"].values()
        )
    out["met"] = out["tracks"] and out["all_upright"] and out["lateral_edges"] is not False
    return out


def _row(label: str, c: dict) -> str:
    mse = " ".join(f"{c['mse'][t]:.4f}" for t in ("vx", "vy", "wz"))
    up = " ".join(f"{100 * c['upright'][t]:.0f}" for t in ("stand", "vx", "vy", "wz"))
    lat = " ".join(f"{k} {v['ratio']:.2f} (w {v['wz']:+.2f})" for k, v in c["lateral"].items()) or "-"
    return f"{label:<24} {c['iteration']!s:>5} | {mse} | {up} | {lat} | {'met' if c['met'] else 'NOT met'}"


@entry_point
def main(argv: list[str] | None = None) -> int:
    ap = doc_parser(__doc__)
    ap.add_argument("checkpoints", nargs="+", metavar="LABEL=TRACKING_JSON[,LATERAL_JSON]")
    add_result_options(ap, plot=None)
    args = ap.parse_args(argv)
    ap.check_outputs(args.json)
    results = {}
    for spec in args.checkpoints:
        label, eq, files = spec.partition("=")
        paths = [p for p in files.split(",") if p]
        if not eq or not label or not 1 <= len(paths) <= 2:
            raise UsageError(f"{spec!r}: expected LABEL=TRACKING_JSON[,LATERAL_JSON]")
        for p in paths:
            if not os.path.isfile(p):
                raise UsageError(f"{spec!r}: no such file {p}")
        c = check(_read(paths[0]), _read(paths[1]) if len(paths) > 1 else None)
        results[label] = {**c, "tracking_json": paths[0], "lateral_json": paths[1] if len(paths) > 1 else None}
    print(f"{'checkpoint':<24} {'it':>5} | MSE vx vy wz | upright % stand vx vy wz | lateral +-0.6 | target")
    for label, c in results.items():
        print(_row(label, c))
    if args.json:
        from wqwarp.utils.provenance import write_result_json

        targets = {
            "mse": MSE_TARGET,
            "lateral_commands": LATERAL_COMMANDS,
            "lateral_ratio": LATERAL_RATIO,
            "yaw_limit": YAW_LIMIT,
        }
        write_result_json(
            args.json,
            {"targets": targets, "checkpoints": results},
            command=" ".join(["tools/studies/skill_check.py", *(argv or sys.argv[1:])]),
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
