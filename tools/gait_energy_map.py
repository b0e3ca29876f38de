"""Gait energy map of a predictive checkpoint: over a grid of commands, the measured power of each gait, the power
predictor's estimate of it, and the gait that wins.

Usage::

    python tools/gait_energy_map.py --checkpoint runs/ours_X/model_999.pt --json map.json --png map.png

Two command planes: (v_x, v_y) at w = 0 and (v_x, w) at v_y = 0, ``--grid`` values per axis over the paper's
evaluation ranges (v_x [-1, 1] m/s, v_y [-0.7, 0.7] m/s, w [-0.7, 0.7] rad/s). Every cell runs one robot per gait
(driving, trotting, walking), the gait forced for the whole rollout, all robots in one batch, commands held, no
randomisation. Measured per robot over the second half of ``--seconds``: mean p_cost (legs and wheels), the squared
velocity error, and whether the trunk touched the ground. Predicted: the mean over the same steps of the predictor's
output for that gait, from the observations of the cell's three robots. The measured winner is the cheapest gait
whose robot stayed up, the tracking winner the cheapest whose robot also tracked its command (squared velocity error
at most ``TRACKING_LIMIT``); the predicted winner is the argmin of the predictions (what the policy would select).
Energy alone can favour a gait that does not do the task (driving under a lateral command stands still, cheaply):
the figure marks such cells.

The policy was trained with the gaits its selector chose; a forced gait it rarely ran during training measures
that gait under this policy, not the gait's best possible power. Nothing learns.
"""

from __future__ import annotations

import argparse
import sys

from wqwarp.cli.args import ArgumentParser

RANGES = {"vx": (-1.0, 1.0), "vy": (-0.7, 0.7), "wz": (-0.7, 0.7)}
TRACKING_LIMIT = 0.05
"""Squared velocity error [(m/s)^2, (rad/s)^2 summed over v_x, v_y, w] up to which a gait counts as tracking its
command (0.05: an error of about 0.22 m/s)."""
PLANES = (("vx", "vy"), ("vx", "wz"))


def grid_commands(grid: int) -> list[tuple[str, tuple[float, float, float]]]:
    """``[(plane, (vx, vy, wz)), ...]``: ``grid`` x ``grid`` cells per plane of :data:`PLANES`."""
    import numpy as np

    axes = {"vx": 0, "vy": 1, "wz": 2}
    cells = []
    for a, b in PLANES:
        for u in np.linspace(*RANGES[a], grid):
            for v in np.linspace(*RANGES[b], grid):
                c = [0.0, 0.0, 0.0]
                c[axes[a]], c[axes[b]] = round(float(u), 4), round(float(v), 4)
                cells.append((f"{a}-{b}", tuple(c)))
    return cells


def main(argv=None) -> int:
    ap = ArgumentParser(description=__doc__.split("\n\n")[0], epilog=__doc__.split("\n\n", 1)[1],
                        formatter_class=argparse.RawDescriptionHelpFormatter)  # fmt: skip
    ap.add_argument("--checkpoint", required=True, help="model_<it>.pt of a predictive preset (ours, no_wheel_vel)")
    ap.add_argument("--grid", type=int, default=5, help="values per command axis (default 5: 2 x 25 cells)")
    ap.add_argument("--seconds", type=float, default=4.0, help="rollout length [s]; the second half is measured")
    ap.add_argument("--device", default="cpu", help="cpu or cuda:N (default cpu)")
    ap.add_argument("--seed", type=int, default=0, help="random seed (spawn yaws; default 0)")
    ap.add_argument("--json", default=None, help="write the cells here")
    ap.add_argument("--png", default=None, help="draw the map here (matplotlib)")
    args = ap.parse_args(argv)
    if args.grid < 2 or args.seconds < 0.2:
        print("error: need --grid >= 2 and --seconds >= 0.2", file=sys.stderr)
        return 2

    import time

    import torch
    import warp as wp

    wp.config.quiet = True
    from wqwarp.control.gaits import GAIT_NAMES
    from wqwarp.eval.loading import make_policy_runner
    from wqwarp.eval.protocols import start_rollout
    from wqwarp.rl.config import to_dict
    from wqwarp.utils.provenance import write_result_json

    t0 = time.time()
    cells = grid_commands(args.grid)
    gaits = list(GAIT_NAMES)
    g = len(gaits)
    n = len(cells) * g
    try:
        runner = make_policy_runner(args.checkpoint, None, n, args.device, seed=args.seed)
    except ValueError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    env = runner.env
    sel = env.gait_selector
    if sel.name != "predictive":
        print(f"error: the energy map needs a predictive preset (ours, no_wheel_vel), not {runner.preset}",
              file=sys.stderr)  # fmt: skip
        return 2
    dev = env.device
    cmd = torch.tensor([c for _, c in cells for _ in range(g)], dtype=torch.float32, device=dev)  # robot = cell*g+k
    sel.forced_gait = torch.arange(g, device=dev).repeat(len(cells))
    obs = start_rollout(env, cmd, args.seconds)
    steps = max(2, int(round(args.seconds / env.dt)))
    first = steps // 2
    z = lambda *s: torch.zeros(*s, device=dev)  # noqa: E732, E731
    p, legs, wheels, err, count, pred = z(n), z(n), z(n), z(n), z(n), z(n, g)
    fell = torch.zeros(n, dtype=torch.bool, device=dev)
    wrong_gait = z(n)
    with torch.no_grad():
        for k in range(steps):
            p_now = sel.predict(obs["policy"])
            obs, _, dones, _ = env.step(runner.policy(obs))
            fell |= dones.bool()
            if k >= first:
                b = env.base_state()
                v = torch.stack([b["lin_vel"][:, 0], b["lin_vel"][:, 1], b["ang_vel"][:, 2]], 1)
                err += ((v - cmd) ** 2).sum(1)
                p += env.tv["p_cost"]
                legs += env.tv["p_cost_legs"]
                wheels += env.tv["p_cost_wheels"]
                pred += p_now
                wrong_gait += (env.active_gait() != sel.forced_gait).float()
                count += 1
            if sys.stdout.isatty() and (k + 1) % max(1, steps // 20) == 0:
                print(f"\r  {100 * (k + 1) // steps:3d} %", end="", flush=True)
    c = count.clamp(min=1)
    p, legs, wheels, err, pred, wrong_gait = p / c, legs / c, wheels / c, err / c, pred / c[:, None], wrong_gait / c
    out_cells = []
    for i, (plane, command) in enumerate(cells):
        r = slice(i * g, (i + 1) * g)
        measured = {gaits[k]: float(p[r][k]) for k in range(g)}
        predicted = {gaits[k]: float(pred[r].mean(0)[k]) for k in range(g)}  # from all three robots' observations
        up = [k for k in range(g) if not bool(fell[r][k])]
        ok = [k for k in up if float(err[r][k]) <= TRACKING_LIMIT]
        out_cells.append({
            "plane": plane, "command": list(command), "measured_p_cost": measured,
            "measured_p_cost_legs": {gaits[k]: float(legs[r][k]) for k in range(g)},
            "measured_p_cost_wheels": {gaits[k]: float(wheels[r][k]) for k in range(g)},
            "sq_velocity_error": {gaits[k]: float(err[r][k]) for k in range(g)},
            "fell": {gaits[k]: bool(fell[r][k]) for k in range(g)},
            "share_not_in_forced_gait": {gaits[k]: float(wrong_gait[r][k]) for k in range(g)},
            "predicted_p_cost": predicted,
            "measured_winner": gaits[min(up, key=lambda k: float(p[r][k]))] if up else None,
            "measured_winner_tracking": gaits[min(ok, key=lambda k: float(p[r][k]))] if ok else None,
            "predicted_winner": min(predicted, key=predicted.get),
        })  # fmt: skip
    agree = [cl["measured_winner"] == cl["predicted_winner"] for cl in out_cells if cl["measured_winner"]]
    print(f"\r{runner.preset} checkpoint (iteration {runner.iteration}): {len(cells)} cells x {g} gaits, "
          f"{args.seconds:g} s; predicted winner = measured winner in {sum(agree)}/{len(agree)} cells")  # fmt: skip
    wins = {gt: sum(cl["measured_winner"] == gt for cl in out_cells) for gt in gaits}
    print("measured winners: " + ", ".join(f"{gt} {w}" for gt, w in wins.items()))
    untracked = sum(cl["measured_winner"] != cl["measured_winner_tracking"] for cl in out_cells)
    print(f"cells where the cheapest gait does not track its command (squared error > {TRACKING_LIMIT}): {untracked}")
    result = {"checkpoint": args.checkpoint, "preset": runner.preset, "iteration": runner.iteration,
              "seed": args.seed, "grid": args.grid, "seconds": args.seconds, "wall_time_s": time.time() - t0,
              "winner_agreement": sum(agree) / max(len(agree), 1), "tracking_limit": TRACKING_LIMIT,
              "cheapest_does_not_track": untracked, "cells": out_cells,
              "config": to_dict(env.cfg)}  # fmt: skip
    if args.json:
        write_result_json(args.json, result, indent=None)
    if args.png:
        draw(result, args.png)
    return 0


def draw(result: dict, path: str) -> None:
    """Per plane: the measured p_cost of each gait (the prediction printed under it) and the winners."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np
    from matplotlib.colors import ListedColormap

    cells = result["cells"]
    gaits = list(cells[0]["measured_p_cost"])
    axes_idx = {"vx": 0, "vy": 1, "wz": 2}
    labels = {"vx": "$v_x$ [m/s]", "vy": "$v_y$ [m/s]", "wz": "$\\omega$ [rad/s]"}
    fig, ax = plt.subplots(len(PLANES), len(gaits) + 1, figsize=(4.2 * (len(gaits) + 1), 3.8 * len(PLANES)))
    vmax = max(max(c["measured_p_cost"].values()) for c in cells)
    for row, (a, b) in enumerate(PLANES):
        sub = [c for c in cells if c["plane"] == f"{a}-{b}"]
        us = sorted({c["command"][axes_idx[a]] for c in sub})
        vs = sorted({c["command"][axes_idx[b]] for c in sub})
        at = {(c["command"][axes_idx[a]], c["command"][axes_idx[b]]): c for c in sub}
        for col, gait in enumerate(gaits):
            m = np.array([[at[(u, v)]["measured_p_cost"][gait] for u in us] for v in vs])
            im = ax[row, col].imshow(m, origin="lower", cmap="viridis", vmin=0, vmax=vmax, aspect="auto")
            for i, v in enumerate(vs):
                for j, u in enumerate(us):
                    c = at[(u, v)]
                    mark = " x" if c["fell"][gait] else ""
                    text = f"{c['measured_p_cost'][gait]:.0f}{mark}\n({c['predicted_p_cost'][gait]:.0f})"
                    ax[row, col].text(j, i, text, ha="center", va="center", fontsize=6, color="w")
            ax[row, col].set_title(f"{gait}: measured (predicted) W", fontsize=9)
            fig.colorbar(im, ax=ax[row, col], fraction=0.046)
        win = np.array([[gaits.index(at[(u, v)]["measured_winner"]) if at[(u, v)]["measured_winner"] else -1
                         for u in us] for v in vs])  # fmt: skip
        cmap = ListedColormap(["#dddddd", "#1f77b4", "#ff7f0e", "#2ca02c"][: len(gaits) + 1])
        ax[row, -1].imshow(win + 1, origin="lower", cmap=cmap, vmin=0, vmax=len(gaits), aspect="auto")
        for i, v in enumerate(vs):
            for j, u in enumerate(us):
                c = at[(u, v)]
                text = f"{(c['measured_winner'] or '-')[:5]}\npred {c['predicted_winner'][:5]}"
                if c["measured_winner_tracking"] != c["measured_winner"]:
                    text += f"\ntrack {(c['measured_winner_tracking'] or 'none')[:5]}"
                ax[row, -1].text(j, i, text, ha="center", va="center", fontsize=6)
        ax[row, -1].set_title("cheapest: measured (colour), predicted;\n'track': cheapest that tracks", fontsize=8)
        for axx in ax[row]:
            axx.set_xticks(range(len(us)), [f"{u:g}" for u in us], fontsize=7)
            axx.set_yticks(range(len(vs)), [f"{v:g}" for v in vs], fontsize=7)
            axx.set_xlabel(labels[a])
        ax[row, 0].set_ylabel(labels[b])
    fig.suptitle(f"gait energy map: {result['preset']} (iteration {result['iteration']}), "
                 f"x = the trunk touched the ground", fontsize=10)  # fmt: skip
    fig.tight_layout()
    from wqwarp.utils.provenance import save_figure

    save_figure(fig, path, dpi=90)


if __name__ == "__main__":
    sys.exit(main())
