"""The omnidirectional-skill A/B table (issue 21): training curves and held-command evaluations of runs side by side.

Usage::

    python tools/studies/omni_ab.py RUN_DIR [RUN_DIR ...] [--eval-json NAME] [--lateral-json NAME] [--json PATH]
                                    [--plot PNG --labels a;b;...]

Per run: the levers that differ from the defaults (from its ``config.json``), samples and wall minutes until the
20-iteration mean of each training error first stays below 0.2 / 0.15 / 0.1 (``tools/time_to_skill.py``'s rule),
the last 50 iterations' mean errors, power and per-group policy std, and, where the run folder holds them, the MSE
per axis of ``train/evaluate.py --json RUN_DIR/<eval-json>`` and the pure-lateral probe of ``--protocol lateral
--json RUN_DIR/<lateral-json>``. Training errors are under each run's own command sampler: compare them only
between runs with the same sampler; the evaluation holds the paper's commands for every run. ``--plot`` draws the
20-iteration mean of each training error against samples, one line per run (runs with the same label share a colour,
seeds a line style), with the thresholds.
"""

from __future__ import annotations

import json
import os
import sys

from wqwarp.cli.args import UsageError, doc_parser, entry_point
from wqwarp.cli.time_to_skill import first_below

THRESHOLDS = (0.2, 0.15, 0.1)
LEVER_FIELDS = {
    "symmetry": ("train", "symmetry"),
    "init_std": ("train", "init_noise_std"),
    "std_groups": ("train", "init_noise_std_groups"),
    "entropy": ("train", "entropy_coef"),
    "phase_clip": ("env", "action", "phase_clip"),
    "clip_actions": ("env", "action", "clip_actions"),
    "axis_odds": ("env", "commands", "single_axis_weights"),
    "only_positive": ("env", "reward", "only_positive"),
    "lateral_gain": ("env", "gait", "lateral_gain"),
    "epochs": ("train", "num_learning_epochs"),
    "mini_batches": ("train", "num_mini_batches"),
    "explore": ("env", "predictor", "explore_fraction"),
    "reach": ("env", "predictor", "kinematic_reach"),
}


def _get(cfg: dict, path: tuple[str, ...]):
    for p in path:
        if not isinstance(cfg, dict) or p not in cfg:
            return None
        cfg = cfg[p]
    return cfg


def samples_per_iteration(cfg: dict) -> int:
    """Robot-steps per PPO iteration of a run's resolved ``config.json`` (any version): robots x ranks x steps."""
    robots = int(cfg["env"]["sim"]["num_envs"]) * int(cfg.get("world_size", 1))
    return robots * int(cfg["train"]["num_steps_per_env"])


def evaluation_curve(run: str, per_it: int) -> list[dict]:
    """MSE per task, upright share and power of every ``eval_<iterations>it.json`` in the run folder, by samples."""
    import re

    curve = []
    for name in os.listdir(run):
        m = re.fullmatch(r"eval_(\d+)it\.json", name)
        if not m:
            continue
        with open(os.path.join(run, name), encoding="utf-8") as f:
            res = json.load(f)
        it = int(m.group(1))
        curve.append(
            {
                "iterations": it,
                "samples": it * per_it,
                "file": name,
                "mse": {r["task"]: r["mse"] for r in res["results"]},
                "upright": {r["task"]: r["upright"] for r in res["results"]},
                "p_cost_w": {r["task"]: r["mean_p_cost"] for r in res["results"]},
            }
        )
    return sorted(curve, key=lambda c: c["iterations"])


def summarise(run: str, eval_json: str, lateral_json: str, tail: int = 50, upto: int | None = None) -> dict:
    from wqwarp.rl.progress import read_metrics

    with open(os.path.join(run, "config.json"), encoding="utf-8") as f:
        cfg = json.load(f)
    rows = read_metrics(run)[:upto]
    if not rows:
        raise ValueError(f"{run}: no metrics.jsonl rows")
    per_it = samples_per_iteration(cfg)
    out = {
        "run": run,
        "preset": cfg.get("task") or cfg["args"].get("preset"),
        "iterations": len(rows),
        "samples": len(rows) * per_it,
        "levers": {k: _get(cfg, p) for k, p in LEVER_FIELDS.items()},
        "to_threshold": {},
        "final": {},
    }
    wall = [float(r.get("collect_s") or 0) + float(r.get("learn_s") or 0) for r in rows]
    for axis in ("vx", "vy", "wz"):
        vals = [float(r.get(f"Metrics/{axis}_error") or 0.0) for r in rows]
        out["final"][f"{axis}_error"] = sum(vals[-tail:]) / min(tail, len(vals))
        cells = {}
        for th in THRESHOLDS:
            i = first_below(vals, th, 20)
            cells[str(th)] = (
                None
                if i is None
                else {"iteration": i + 1, "samples": (i + 1) * per_it, "wall_min": round(sum(wall[: i + 1]) / 60, 1)}
            )
        out["to_threshold"][axis] = cells
    for key in (
        "Metrics/p_cost",
        "Policy/std_phase",
        "Policy/std_foot",
        "Policy/std_wheel",
        "Actions/foot_abs",
        "Actions/phase_abs",
        "mean_reward",
    ):
        vals = [float(r[key]) for r in rows[-tail:] if r.get(key) is not None]
        if vals:
            out["final"][key] = sum(vals) / len(vals)
    out["wall_min"] = round(sum(wall) / 60, 1)
    out["evaluation_curve"] = evaluation_curve(run, per_it)
    out["learn_s_per_iteration"] = sum(float(r.get("learn_s") or 0) for r in rows) / len(rows)
    for name, key in ((eval_json, "evaluation"), (lateral_json, "lateral")):
        path = os.path.join(run, name)
        if os.path.isfile(path):
            with open(path, encoding="utf-8") as f:
                res = json.load(f)
            if key == "evaluation":
                out[key] = {
                    r["task"]: {
                        "mse": r.get("mse"),
                        "upright": r.get("upright"),
                        "p_cost_w": r.get("mean_p_cost"),
                        "gait_usage": r.get("gait_usage"),
                    }
                    for r in res["results"]
                }
            else:
                out[key] = [
                    {k: r[k] for k in ("command_vy", "vy", "wz", "upright", "tracked")} for r in res["runs"]["selected"]
                ]
    return out


def plot_curves(runs: list[str], labels: list[str], out: str, upto: int | None = None) -> None:
    """Training errors (20-iteration means) of each run against samples, one panel per axis (module docstring)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from wqwarp.rl.progress import read_metrics
    from wqwarp.utils.io import atomic_path

    arms = list(dict.fromkeys(labels))
    fig, axes = plt.subplots(1, 3, figsize=(13, 3.6), sharex=True)
    seen: dict[str, int] = {}
    for run, label in zip(runs, labels, strict=True):
        with open(os.path.join(run, "config.json"), encoding="utf-8") as f:
            cfg = json.load(f)
        per_it = samples_per_iteration(cfg)
        rows = read_metrics(run)[:upto]
        k = seen[label] = seen.get(label, -1) + 1
        for ax, axis in zip(axes, ("vx", "vy", "wz"), strict=True):
            vals = [float(r.get(f"Metrics/{axis}_error") or 0.0) for r in rows]
            mean = [sum(vals[max(0, i - 19) : i + 1]) / len(vals[max(0, i - 19) : i + 1]) for i in range(len(vals))]
            x = [(i + 1) * per_it / 1e6 for i in range(len(mean))]
            ax.plot(
                x,
                mean,
                color=f"C{arms.index(label)}",
                ls=("-", "--", ":", "-.")[k % 4],
                lw=1.0,
                label=f"{label} ({os.path.basename(run.rstrip('/'))})",
            )
    for ax, axis in zip(axes, ("v_x [m/s]", "v_y [m/s]", "w [rad/s]"), strict=True):
        for th in THRESHOLDS:
            ax.axhline(th, color="0.7", lw=0.6)
        ax.set_xlabel("samples [M]")
        ax.set_title(f"training |error| of {axis}, 20-it mean")
        ax.set_ylim(0, 1.0 if axis.startswith("w") else 0.5)
    axes[0].legend(fontsize=6)
    fig.tight_layout()
    with atomic_path(out) as tmp:
        fig.savefig(tmp, dpi=110, format="png")
    plt.close(fig)


ARCHIVE_DIGITS = 4
"""Significant digits of the archived training metrics: they are means over noisy rollouts, and full float precision
made the committed archives 2.5x larger gzipped."""


def compact_row(row: dict, digits: int = ARCHIVE_DIGITS) -> dict:
    """``row`` with every float rounded to ``digits`` significant digits (integers and strings as they are)."""
    return {k: float(f"{v:.{digits}g}") if isinstance(v, float) else v for k, v in row.items()}


def archive(run: str, dest: str, every: int = 10) -> None:
    """The committed record of a run: its configuration, its evaluation results (``eval*.json``, ``lateral*.json``,
    ``energymap*.json``) and every ``every``-th row of ``metrics.jsonl`` (and the last), floats to
    :data:`ARCHIVE_DIGITS` significant digits, gzipped (``metrics_every<every>.jsonl.gz``)."""
    import shutil

    from wqwarp.rl.progress import read_metrics
    from wqwarp.utils.io import write_text_gz_atomic

    os.makedirs(dest, exist_ok=True)
    for name in sorted(os.listdir(run)):
        if name == "config.json" or (name.endswith(".json") and name.startswith(("eval", "lateral", "energymap"))):
            shutil.copyfile(os.path.join(run, name), os.path.join(dest, name))
    rows = read_metrics(run)
    keep = [r for i, r in enumerate(rows) if (i + 1) % every == 0 or i + 1 == len(rows)]
    text = "".join(json.dumps(compact_row(r)) + "\n" for r in keep)
    write_text_gz_atomic(os.path.join(dest, f"metrics_every{every}.jsonl.gz"), text)


@entry_point
def main(argv=None) -> int:
    ap = doc_parser(__doc__)
    ap.add_argument("runs", nargs="+", help="run directories written by train/ppo_newton.py")
    ap.add_argument("--eval-json", default="eval.json", help="tracking result inside each run (default eval.json)")
    ap.add_argument(
        "--lateral-json", default="lateral.json", help="lateral probe inside each run (default lateral.json)"
    )
    ap.add_argument(
        "--upto", type=int, default=None, help="use the first UPTO iterations of each run (equal samples; default all)"
    )
    ap.add_argument("--json", default=None, help="also write the table to this JSON file")
    ap.add_argument("--plot", default=None, help="also draw the training errors against samples into this PNG")
    ap.add_argument(
        "--labels",
        default=None,
        help="semicolon-separated arm label per run for --plot (runs with one label share a colour; default: "
        "the run folder names)",
    )
    ap.add_argument(
        "--archive",
        default=None,
        help="copy each run's config.json, evaluation JSONs and every 10th "
        "row of metrics.jsonl (gzipped) into ARCHIVE/<run name>/ (what is committed; checkpoints never "
        "are)",
    )
    args = ap.parse_args(argv)
    ap.check_outputs(args.json)
    try:
        results = [summarise(r, args.eval_json, args.lateral_json, upto=args.upto) for r in args.runs]
    except (OSError, ValueError, KeyError) as e:
        raise UsageError(str(e)) from None
    if args.plot:
        labels = args.labels.split(";") if args.labels else [os.path.basename(r.rstrip("/")) for r in args.runs]
        if len(labels) != len(args.runs):
            raise UsageError(f"--labels names {len(labels)} arms for {len(args.runs)} runs")
        plot_curves(args.runs, labels, args.plot, args.upto)
    if args.archive:
        for run in args.runs:
            archive(run, os.path.join(args.archive, os.path.basename(run.rstrip("/"))))
    for r in results:
        lev = ", ".join(f"{k}={v}" for k, v in r["levers"].items())
        name = os.path.basename(r["run"].rstrip("/"))
        print(f"{name}: {r['samples'] / 1e6:.1f} M samples, {r['wall_min']} min; {lev}")
        for axis, cells in r["to_threshold"].items():
            txt = "  ".join(
                f"<{t}: " + ("never" if c is None else f"{c['samples'] / 1e6:.2f} M") for t, c in cells.items()
            )
            print(f"   train {axis}: final {r['final'][f'{axis}_error']:.3f}   {txt}")
        if "evaluation" in r:
            print(
                "   eval MSE: "
                + "  ".join(f"{t} {v['mse']:.4f} (up {v['upright']:.2f})" for t, v in r["evaluation"].items())
            )
        for c in r["evaluation_curve"]:
            print(
                f"   eval at {c['samples'] / 1e6:.1f} M: "
                + "  ".join(f"{t} {v:.4f}" for t, v in c["mse"].items())
                + "   upright "
                + " ".join(f"{v:.2f}" for v in c["upright"].values())
            )
        if "lateral" in r:
            print(
                "   lateral: "
                + "  ".join(f"{x['command_vy']:+.1f}->{x['vy']:+.2f} (wz {x['wz']:+.2f})" for x in r["lateral"])
            )
    if args.json:
        from wqwarp.utils.provenance import write_result_json

        command = " ".join(["tools/studies/omni_ab.py", *sys.argv[1:]])
        write_result_json(args.json, {"results": results}, command=command)
    return 0


if __name__ == "__main__":
    sys.exit(main())
