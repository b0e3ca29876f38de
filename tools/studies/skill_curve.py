"""Time to skill from evaluated checkpoints: per seed and axis, the tracking MSE of ``train/evaluate.py`` at each
evaluated checkpoint against the samples and wall minutes of training that produced it, seeds overlaid.

Usage::

    python tools/studies/skill_curve.py LABEL=RUN_DIR:RESULT_PREFIX [...] [--json PATH] [--plot PATH]

Each argument names one training run (a ``train/ppo_newton.py`` log directory, for its ``config.json`` and
``metrics.jsonl``) and the prefix of its evaluations: every ``RESULT_PREFIX_it<N>_tracking.json`` (the
``train/evaluate.py --tasks stand,vx,vy,wz --json`` result of ``model_<N>.pt``) is one point. A checkpoint
``model_<N>.pt`` holds N + 1 iterations of robots x steps samples. Wall minutes are the run's own summed iteration
times up to it (``metrics.jsonl`` ``wall_s``: whatever else ran on the machine is in them; a resumed run's
repeated iterations count once). The target is issue 47's (``tools/studies/skill_check.py``): MSE below 0.05 on
v_x, v_y and w and every robot upright on the stand, v_x, v_y and w tasks. Per seed: the first evaluated checkpoint
meeting the target per axis and in all (an upper bound: the skill may come between two evaluated checkpoints) and
whether every later evaluated checkpoint keeps it.
"""

from __future__ import annotations

import glob
import os
import re
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))  # the sibling skill_check.py, as a script or a module
from skill_check import MSE_TARGET, check  # noqa: E402
from skill_check import _read as _load  # noqa: E402  (a JSON file, or a one-line usage error)

from wqwarp.cli.args import UsageError, add_result_options, doc_parser, entry_point  # noqa: E402

AXES = ("vx", "vy", "wz")


def wall_seconds(run: str) -> dict[int, float]:
    """Iteration -> the run's summed ``wall_s`` up to and including it (last row of each iteration wins)."""
    from wqwarp.rl.progress import read_metrics

    rows = read_metrics(run)
    if not rows:
        raise UsageError(f"{run}: no metrics.jsonl rows (not a train/ppo_newton.py run directory)")
    per_it = {int(r["iteration"]): float(r["wall_s"]) for r in rows}
    out, acc = {}, 0.0
    for it in sorted(per_it):
        acc += per_it[it]
        out[it] = acc
    return out


def first_met(points: list[dict], key: str) -> dict | None:
    """The first point whose ``key`` is true, and whether every later point keeps it; None if none."""
    for i, p in enumerate(points):
        if p[key]:
            return {
                "iteration": p["iteration"],
                "samples": p["samples"],
                "wall_min": p["wall_min"],
                "kept": all(q[key] for q in points[i:]),
            }
    return None


def analyse(run: str, prefix: str) -> dict:
    cfg = _load(os.path.join(run, "config.json"))
    per_it = int(cfg["env"]["sim"]["num_envs"]) * int(cfg.get("world_size", 1)) * int(cfg["train"]["num_steps_per_env"])
    wall = wall_seconds(run)
    files = glob.glob(f"{prefix}_it*_tracking.json")
    if not files:
        raise UsageError(f"no evaluations {prefix}_it<N>_tracking.json")
    points = []
    for path in files:
        m = re.search(r"_it(\d+)_tracking\.json$", path)
        it = int(m.group(1))
        c = check(_load(path))
        done = max((i for i in wall if i <= it + 1), default=None)  # metrics rows count iterations from 1
        p = {
            "iteration": it,
            "samples": (it + 1) * per_it,
            "wall_min": wall[done] / 60.0 if done is not None else None,
            "mse": c["mse"],
            "upright": c["upright"],
            "all_upright": c["all_upright"],
            "met": c["tracks"] and c["all_upright"],
            "json": path,
        }
        for a in AXES:
            p[f"met_{a}"] = c["mse"][a] < MSE_TARGET and c["upright"][a] >= 1.0
        points.append(p)
    points.sort(key=lambda p: p["iteration"])
    return {
        "run": run,
        "samples_per_iteration": per_it,
        "points": points,
        "first_met": {a: first_met(points, f"met_{a}") for a in AXES} | {"all": first_met(points, "met")},
    }


def plot(results: dict[str, dict], path: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axs = plt.subplots(1, 4, figsize=(15, 3.6))
    for label, r in results.items():
        xs = [p["samples"] / 1e6 for p in r["points"]]
        for ax, a in zip(axs[:3], AXES, strict=True):
            ax.plot(xs, [p["mse"][a] for p in r["points"]], "o-", label=label)
        axs[3].plot(xs, [100 * min(p["upright"].values()) for p in r["points"]], "o-", label=label)
    for ax, a in zip(axs[:3], AXES, strict=True):
        ax.axhline(MSE_TARGET, color="k", ls="--", lw=1)
        ax.set_yscale("log")
        ax.set_title(f"{a} tracking MSE (evaluation)")
        ax.set_xlabel("training samples [M]")
    axs[3].set_title("least upright share, 4 tasks [%]")
    axs[3].set_xlabel("training samples [M]")
    axs[3].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


@entry_point
def main(argv: list[str] | None = None) -> int:
    ap = doc_parser(__doc__)
    ap.add_argument("runs", nargs="+", metavar="LABEL=RUN_DIR:RESULT_PREFIX")
    add_result_options(ap, plot="a figure of MSE per axis and the least upright share against samples")
    args = ap.parse_args(argv)
    ap.check_outputs(args.json, args.plot)
    results = {}
    for spec in args.runs:
        label, eq, rest = spec.partition("=")
        run, colon, prefix = rest.partition(":")
        if not eq or not colon or not label or not run or not prefix:
            raise UsageError(f"{spec!r}: expected LABEL=RUN_DIR:RESULT_PREFIX")
        results[label] = analyse(run, prefix)
    print(f"{'seed':<12} {'it':>5} {'M':>6} {'min':>6} | MSE vx vy wz | min upright | target")
    for label, r in results.items():
        for p in r["points"]:
            mse = " ".join(f"{p['mse'][a]:.4f}" for a in AXES)
            wm = f"{p['wall_min']:6.1f}" if p["wall_min"] is not None else "     -"
            up = 100 * min(p["upright"].values())
            print(
                f"{label:<12} {p['iteration']:>5} {p['samples'] / 1e6:6.2f} {wm} | {mse} | {up:5.1f} % | "
                f"{'met' if p['met'] else '-'}"
            )
    print("first evaluated checkpoint meeting the target (samples M; * = not kept at every later checkpoint):")
    for label, r in results.items():
        cells = []
        for k, f in r["first_met"].items():
            cells.append(f"{k} " + (f"{f['samples'] / 1e6:.2f}{'' if f['kept'] else '*'}" if f else "never"))
        print(f"  {label:<12} " + ", ".join(cells))
    if args.plot:
        plot(results, args.plot)
    if args.json:
        from wqwarp.utils.provenance import write_result_json

        write_result_json(
            args.json, {"runs": results}, command=" ".join(["tools/studies/skill_curve.py", *(argv or sys.argv[1:])])
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
