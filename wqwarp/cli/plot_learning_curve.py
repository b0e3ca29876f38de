"""Plot the learning curve of a training run from its TensorBoard events.

Usage::

    python tools/plot_learning_curve.py RUN_DIR [RUN_DIR ...] --out curve.png [--labels a,b]

Panels: mean episode reward, |v_x| tracking error, and mean p_cost, against the iteration; the top axis of the
first panel gives the wall time of the first run.
"""

from __future__ import annotations

import os
import sys

from wqwarp.cli.args import UsageError, doc_parser, entry_point
from wqwarp.eval.report import load_scalars  # noqa: E402  (re-exported)


@entry_point
def main(argv=None) -> int:
    ap = doc_parser(__doc__)
    ap.add_argument("runs", nargs="+", help="run directories written by train/ppo_newton.py")
    ap.add_argument("--out", required=True, help="output PNG")
    ap.add_argument("--labels", default=None, help="semicolon-separated legend labels (default: directory names)")
    args = ap.parse_args(argv)
    ap.check_outputs(args.out)
    for r in args.runs:
        if not os.path.isdir(r):
            raise UsageError(f"no such run directory {r!r}")
    labels = args.labels.split(";") if args.labels else [os.path.basename(os.path.normpath(r)) for r in args.runs]
    if len(labels) != len(args.runs):
        raise UsageError("--labels needs one label per run")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    panels = [
        ("Train/mean_reward", "mean episode reward"),
        ("Metrics/vx_error", "|v_x error| [m/s]"),
        ("Metrics/p_cost", "mean p_cost [W]"),
    ]
    fig, axes = plt.subplots(len(panels), 1, figsize=(7, 8), sharex=True)
    for run, label in zip(args.runs, labels, strict=True):
        s = load_scalars(run)
        if "Train/mean_reward" not in s:
            raise UsageError(f"{run!r} has no training scalars (TensorBoard events)")
        for ax, (tag, name) in zip(axes, panels, strict=True):
            if tag in s:
                ax.plot(s[tag][0], s[tag][1], label=label)
            ax.set_ylabel(name)
            ax.grid(alpha=0.3)
        if run == args.runs[0]:
            steps, _, wall = s["Train/mean_reward"]
            if steps and wall[-1] > 0:
                axes[0].set_title(f"{label}: {steps[-1] + 1} iterations in {wall[-1] / 60:.0f} min")
    axes[-1].set_xlabel("PPO iteration")
    axes[0].legend()
    fig.tight_layout()
    from wqwarp.utils.provenance import save_figure

    save_figure(fig, args.out, dpi=100)
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
