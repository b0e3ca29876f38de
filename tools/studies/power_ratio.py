"""One policy's power against another's, per task, under the mechanical and the electrical measure, and how the
electrical ratio moves over the leg motors' uncertain constant: the headline (``ours`` against the fixed trot) as the
battery would pay it, read from tracking records (``train/evaluate.py --json``) of any runs.

Usage::

    python tools/studies/power_ratio.py --a ours=docs/studies/electrical/mech_s5_it2999_tracking.json \\
        --b trot=docs/studies/electrical/trot_s5_it2999_tracking.json [--json PATH]

Per task of both records: MSE, p_cost and p_elec of each, their ratios a / b, and the p_elec ratio with the leg
copper loss rescaled to each leg motor constant of ``--leg-km`` (default the model's range, 0.147-0.22 N m /
sqrt(W); copper scales as (k_m0 / k_m)^2, the mechanical and the wheels' terms do not). Then the same over the
three moving tasks (v_x, v_y, w: the paper's "mean power"). Nothing is trained or evaluated here: the numbers are
the records'. Records written before the electrical model (no ``mean_p_elec``) are refused.
"""

from __future__ import annotations

import json
import os
import statistics
import sys

from wqwarp.cli.args import UsageError, add_result_options, doc_parser, entry_point

MOVING = ("vx", "vy", "wz")
"""The paper's three tracking tasks, over which its "mean power" is taken."""


def read_record(label_path: str, option: str) -> tuple[str, dict[str, dict]]:
    """``LABEL=FILE`` -> (label, {task: result row}); ValueError naming the problem."""
    label, sep, path = label_path.partition("=")
    if not sep or not label or not path:
        raise ValueError(f"{option} {label_path!r}: want LABEL=FILE")
    if not os.path.isfile(path):
        raise ValueError(f"{option} {label}: no such file: {path}")
    with open(path, encoding="utf-8") as f:
        rows = json.load(f).get("results", [])
    by_task = {r["task"]: r for r in rows}
    if not by_task or any(r.get("mean_p_elec") is None for r in rows):
        raise ValueError(f"{option} {label}: {path} has no tracking results with mean_p_elec (an older record?)")
    return label, by_task


def leg_motor_constant() -> tuple[float, tuple[float, float]]:
    """The model's leg k_m and its range (every leg actuator type has the same)."""
    from wqwarp.robot.motors import GO1_HIP_THIGH, GO1_KNEE

    if GO1_HIP_THIGH.motor_constant != GO1_KNEE.motor_constant:
        raise RuntimeError("the leg motors' constants differ: rescale each joint kind apart")
    return GO1_HIP_THIGH.motor_constant, GO1_HIP_THIGH.motor_constant_range


def p_elec_at(row: dict, km: float, km0: float) -> float:
    """The row's p_elec [W] with the leg copper loss rescaled from k_m0 to k_m."""
    copper = row["mean_p_copper_legs"]
    return row["mean_p_elec"] - copper + copper * (km0 / km) ** 2


def compare(a: dict[str, dict], b: dict[str, dict], kms: list[float]) -> dict:
    """Per common task and over the moving tasks: each side's MSE and powers, a / b under each measure and at each
    leg k_m."""
    km0, _ = leg_motor_constant()
    tasks = [t for t in ("stand", *MOVING) if t in a and t in b]
    out: dict = {"leg_km_model": km0, "leg_km": kms, "tasks": {}}
    for t in tasks:
        ra, rb = a[t], b[t]
        out["tasks"][t] = {
            "mse": [ra["mse"], rb["mse"]],
            "p_cost": [ra["mean_p_cost"], rb["mean_p_cost"]],
            "p_elec": [ra["mean_p_elec"], rb["mean_p_elec"]],
            "ratio_p_cost": ra["mean_p_cost"] / rb["mean_p_cost"],
            "ratio_p_elec": ra["mean_p_elec"] / rb["mean_p_elec"],
            "ratio_p_elec_at_km": [p_elec_at(ra, k, km0) / p_elec_at(rb, k, km0) for k in kms],
        }
    if all(t in out["tasks"] for t in MOVING):

        def mean(side: int, f) -> float:
            return statistics.fmean(f((a, b)[side][t]) for t in MOVING)

        out["moving"] = {
            "p_cost": [mean(s, lambda r: r["mean_p_cost"]) for s in (0, 1)],
            "p_elec": [mean(s, lambda r: r["mean_p_elec"]) for s in (0, 1)],
            "ratio_p_elec_at_km": [
                mean(0, lambda r, k=k: p_elec_at(r, k, km0)) / mean(1, lambda r, k=k: p_elec_at(r, k, km0)) for k in kms
            ],
        }
        m = out["moving"]
        m["ratio_p_cost"] = m["p_cost"][0] / m["p_cost"][1]
        m["ratio_p_elec"] = m["p_elec"][0] / m["p_elec"][1]
    return out


def table(result: dict, la: str, lb: str) -> str:
    kms = result["leg_km"]
    head = " ".join(f"k_m {k:g}" for k in kms)
    lines = [f"task   MSE {la} / {lb}   p_cost [W]   ratio   p_elec [W]   ratio   ratio p_elec at {head}"]
    rows = dict(result["tasks"]) | ({"3 tasks": result["moving"]} if "moving" in result else {})
    for t, r in rows.items():
        mse = f"{r['mse'][0]:.4f} / {r['mse'][1]:.4f}" if "mse" in r else "-"
        at = " ".join(f"{x:.2f}" for x in r["ratio_p_elec_at_km"])
        lines.append(
            f"{t:7s} {mse}  {r['p_cost'][0]:.1f} / {r['p_cost'][1]:.1f}  {r['ratio_p_cost']:.2f}  "
            f"{r['p_elec'][0]:.1f} / {r['p_elec'][1]:.1f}  {r['ratio_p_elec']:.2f}  {at}"
        )
    return "\n".join(lines)


@entry_point
def main(argv: list[str] | None = None) -> int:
    ap = doc_parser(__doc__)
    ap.add_argument("--a", required=True, metavar="LABEL=FILE", help="the tracking record of the policy compared")
    ap.add_argument("--b", required=True, metavar="LABEL=FILE", help="the tracking record it is compared against")
    ap.add_argument(
        "--leg-km",
        default=None,
        metavar="K[,K...]",
        help="leg motor constants [N m / sqrt(W)] to rescale the copper loss to (default: the model's range ends "
        "and its midpoint)",
    )
    add_result_options(ap, plot=None)
    args = ap.parse_args(argv)
    try:
        la, a = read_record(args.a, "--a")
        lb, b = read_record(args.b, "--b")
        km0, (lo, hi) = leg_motor_constant()
        if args.leg_km is None:
            kms = [lo, round((lo + hi) / 2, 4), hi]
        else:
            kms = [float(x) for x in args.leg_km.split(",") if x.strip()]
            if not kms or min(kms) <= 0:
                raise ValueError(f"--leg-km {args.leg_km!r}: need positive constants, e.g. 0.147,0.22")
    except ValueError as e:
        raise UsageError(str(e)) from None
    ap.check_outputs(args.json)
    result = compare(a, b, kms)
    if not result["tasks"]:
        raise UsageError(f"--a {la} and --b {lb} share no task")
    result["labels"] = [la, lb]
    result["inputs"] = [os.path.abspath(args.a.partition("=")[2]), os.path.abspath(args.b.partition("=")[2])]
    print(table(result, la, lb))
    if args.json:
        from wqwarp.utils.provenance import write_result_json

        write_result_json(args.json, result)
    return 0


if __name__ == "__main__":
    sys.exit(main())
