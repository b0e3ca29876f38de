"""Draw the paper's Fig. 4 from evaluation results: tracking MSE and mean power per task, one bar per method.

Usage::

    python tools/plot_eval.py eval_baseline.json eval_pmtg.json eval_no_predictor.json --out docs/fig4.png

Each JSON is written by ``python train/evaluate.py --json``; the legend uses the preset recorded in it.
"""

from __future__ import annotations

import argparse
import json
import os
import sys


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
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
            print(f"error: cannot read evaluation results {path!r}: {e}", file=sys.stderr)
            return 2
    tasks = [t for t in ("vx", "vy", "wz") if any(t in r for _, r in runs)]
    if not tasks:
        print("error: no vx / vy / wz results in the given files", file=sys.stderr)
        return 2
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    fig, axes = plt.subplots(1, 2, figsize=(10, 3.8))
    width = 0.8 / len(runs)
    x = np.arange(len(tasks))
    names = {"vx": "$v_x$ task", "vy": "$v_y$ task", "wz": "$\\omega$ task"}
    for k, (label, res) in enumerate(runs):
        mse = [res[t]["mse"] if t in res else np.nan for t in tasks]
        pw = [res[t]["mean_p_cost"] if t in res else np.nan for t in tasks]
        axes[0].bar(x + k * width, mse, width, label=label)
        axes[1].bar(x + k * width, pw, width, label=label)
    for ax, title in zip(axes, ("tracking MSE", "mean power p_cost [W]"), strict=True):
        ax.set_xticks(x + width * (len(runs) - 1) / 2)
        ax.set_xticklabels([names[t] for t in tasks])
        ax.set_title(title)
        ax.grid(axis="y", alpha=0.3)
    axes[0].legend(fontsize=8)
    fig.tight_layout()
    tmp = args.out + ".tmp.png"
    fig.savefig(tmp, dpi=100)
    os.replace(tmp, args.out)
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
