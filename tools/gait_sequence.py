"""The paper's Fig. 6 (the commanded-velocity experiment) for a trained checkpoint: one robot through a sequence of
commands, with the height of the front-right wheel, the requested and running gait, the measured power and the tracked
velocity over time.

Usage::

    python tools/gait_sequence.py --checkpoint runs/ours_X/model_1499.pt --json docs/gait_sequence.json \\
        --png docs/gait_sequence.png [--segments "0.5,0,0:4;0,0.3,0:4;0,0,0.5:4;0,0,0:4"] [--robots 8]

Each segment is ``v_x,v_y,w_z:seconds``. ``--robots`` runs that many robots (no domain randomisation, each with its
own random spawn yaw) and reports per segment the mean p_cost per joint group, the tracking error and the share of
each running gait over all of them; the figure shows robot 0. Nothing learns: the estimator and the power predictor
stay as saved.
"""

from __future__ import annotations

import argparse
import sys
import time

from wqwarp.cli.args import ArgumentParser
from wqwarp.eval.loading import parse_segments  # noqa: F401  (re-exported: the segment syntax of this tool)

DEFAULT_SEGMENTS = "0.6,0,0:4;0,0.4,0:4;0,0,0.6:4;0,0,0:4;-0.4,0,0:4"


def main(argv=None) -> int:
    ap = ArgumentParser(description=__doc__.split("\n\n")[0], epilog=__doc__.split("\n\n", 1)[1],
                        formatter_class=argparse.RawDescriptionHelpFormatter)  # fmt: skip
    ap.add_argument("--checkpoint", required=True, help="model_<it>.pt written by train/ppo_newton.py")
    ap.add_argument("--preset", default=None, help="preset of the checkpoint (default: from its run's config.json)")
    ap.add_argument("--segments", default=DEFAULT_SEGMENTS, help=f"command segments (default {DEFAULT_SEGMENTS!r})")
    ap.add_argument("--robots", type=int, default=8, help="robots run side by side (default 8; robot 0 is drawn)")
    ap.add_argument("--device", default="cpu", help="cpu or cuda:N (default cpu)")
    ap.add_argument("--seed", type=int, default=0, help="random seed (spawn yaws; default 0)")
    ap.add_argument("--json", default=None, help="write the time series and per-segment summary here")
    ap.add_argument("--png", default=None, help="draw the figure here (matplotlib)")
    args = ap.parse_args(argv)
    try:
        segments = parse_segments(args.segments)
    except ValueError as e:
        print(f"error: --segments: {e}", file=sys.stderr)
        return 2
    if args.robots < 1:
        print("error: --robots must be >= 1", file=sys.stderr)
        return 2

    import torch
    import warp as wp

    wp.config.quiet = True
    from wqwarp.control.gaits import GAIT_NAMES
    from wqwarp.eval.loading import make_policy_runner
    from wqwarp.eval.protocols import start_rollout
    from wqwarp.rl.config import to_dict
    from wqwarp.utils.provenance import write_result_json

    t0 = time.time()
    try:
        runner = make_policy_runner(args.checkpoint, args.preset, args.robots, args.device, seed=args.seed)
    except ValueError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    env = runner.env
    n = env.num_envs
    total = sum(s for _, s in segments)
    obs = start_rollout(env, torch.tensor([segments[0][0]] * n, dtype=torch.float32), total)
    fr_wheel = int(env.sim.layout.wheel_body[0])  # body index of the front-right wheel (legs FR, FL, RR, RL)
    series = {k: [] for k in ("t", "command", "v", "p_cost", "p_cost_legs", "p_cost_wheels", "gait_requested",
                              "gait_running", "wheel_fr_height")}  # fmt: skip
    summary = []
    fell = torch.zeros(n, dtype=torch.bool)
    k = 0
    with torch.no_grad():
        for cmd, sec in segments:
            c = torch.tensor([cmd] * n, dtype=torch.float32)
            steps = int(round(sec / env.dt))
            acc = {"p": 0.0, "legs": 0.0, "wheels": 0.0, "err": 0.0, "count": 0}
            usage = torch.zeros(len(GAIT_NAMES))
            env.hold_commands(c)
            for _ in range(steps):
                obs, _, dones, _ = env.step(runner.policy(obs))
                fell |= dones.bool().cpu()
                b = env.base_state()
                v = torch.stack([b["lin_vel"][:, 0], b["lin_vel"][:, 1], b["ang_vel"][:, 2]], 1).cpu()
                running = env.active_gait().cpu()
                usage += torch.bincount(running, minlength=len(GAIT_NAMES)).float()
                acc["p"] += float(env.tv["p_cost"].mean())
                acc["legs"] += float(env.tv["p_cost_legs"].mean())
                acc["wheels"] += float(env.tv["p_cost_wheels"].mean())
                acc["err"] += float(((v - c) ** 2).sum(1).mean())
                acc["count"] += 1
                wheel_z = env.tv["body_q"][0, fr_wheel, 2]  # wheel centre height above the ground [m]
                series["t"].append(round(k * env.dt, 4))
                series["command"].append(list(cmd))
                series["v"].append([round(float(x), 4) for x in v[0]])
                series["p_cost"].append(round(float(env.tv["p_cost"][0]), 3))
                series["p_cost_legs"].append(round(float(env.tv["p_cost_legs"][0]), 3))
                series["p_cost_wheels"].append(round(float(env.tv["p_cost_wheels"][0]), 3))
                series["gait_requested"].append(GAIT_NAMES[int(env.requested_gait()[0])])
                series["gait_running"].append(GAIT_NAMES[int(running[0])])
                series["wheel_fr_height"].append(round(float(wheel_z), 4))
                k += 1
            m = acc["count"]
            summary.append({
                "command": list(cmd), "seconds": sec, "mean_p_cost": acc["p"] / m, "mean_p_cost_legs": acc["legs"] / m,
                "mean_p_cost_wheels": acc["wheels"] / m, "mean_sq_velocity_error": acc["err"] / m,
                "gait_usage": {g: float(usage[i] / usage.sum()) for i, g in enumerate(GAIT_NAMES)},
            })  # fmt: skip
    print(f"{runner.preset} checkpoint (iteration {runner.iteration}), {n} robots; fell: {int(fell.sum())}")
    print(f"{'command':>18} {'p_cost':>7} {'legs':>6} {'wheels':>6} {'sq err':>7}  gaits (share of robot-steps)")
    for s in summary:
        gaits = " ".join(f"{g} {100 * v:.0f}%" for g, v in s["gait_usage"].items() if v > 0)
        print(f"{str(tuple(s['command'])):>18} {s['mean_p_cost']:7.1f} {s['mean_p_cost_legs']:6.1f} "
              f"{s['mean_p_cost_wheels']:6.1f} {s['mean_sq_velocity_error']:7.3f}  {gaits}")  # fmt: skip
    out = {"checkpoint": args.checkpoint, "preset": runner.preset, "iteration": runner.iteration, "robots": n,
           "seed": args.seed, "fell": int(fell.sum()), "segments": summary, "series_robot0": series,
           "wall_time_s": time.time() - t0, "config": to_dict(env.cfg)}  # fmt: skip
    if args.json:
        write_result_json(args.json, out, indent=None)  # the time series: compact
    if args.png:
        draw(out, args.png)
    return 0


def draw(out: dict, path: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    from wqwarp.control.gaits import GAIT_NAMES

    s = out["series_robot0"]
    t = np.array(s["t"])
    fig, ax = plt.subplots(4, 1, figsize=(9, 7.5), sharex=True)
    cmd, v = np.array(s["command"]), np.array(s["v"])
    for i, (name, col) in enumerate(zip(("$v_x$", "$v_y$", "$\\omega$"), ("C0", "C1", "C2"), strict=True)):
        ax[0].plot(t, cmd[:, i], "--", color=col, lw=1)
        ax[0].plot(t, v[:, i], color=col, lw=1, label=name)
    ax[0].set_ylabel("command / actual")
    ax[0].legend(loc="upper right", fontsize=8, ncol=3)
    ax[1].plot(t, s["wheel_fr_height"], color="k", lw=1)
    ax[1].set_ylabel("FR wheel z [m]")
    idx = {g: i for i, g in enumerate(GAIT_NAMES)}
    ax[2].step(t, [idx[g] for g in s["gait_running"]], where="post", label="running")
    ax[2].step(t, [idx[g] for g in s["gait_requested"]], where="post", ls=":", label="requested")
    ax[2].set_yticks(range(len(GAIT_NAMES)))
    ax[2].set_yticklabels(GAIT_NAMES)
    ax[2].legend(loc="upper right", fontsize=8)
    ax[3].plot(t, s["p_cost_legs"], lw=1, label="legs")
    ax[3].plot(t, s["p_cost_wheels"], lw=1, label="wheels")
    settled = t >= min(0.5, t[-1] / 2)  # robots spawn slightly above the ground: the first landing dwarfs the rest
    top = max(np.max(np.asarray(s["p_cost_legs"])[settled]), np.max(np.asarray(s["p_cost_wheels"])[settled]))
    ax[3].set_ylim(0, 1.15 * top + 1.0)
    ax[3].set_ylabel("p_cost [W]\n(spawn landing clipped)")
    ax[3].set_xlabel("time [s]")
    ax[3].legend(loc="upper right", fontsize=8)
    fig.suptitle(f"{out['preset']} (iteration {out['iteration']}), robot 0")
    fig.tight_layout()
    from wqwarp.utils.provenance import save_figure

    save_figure(fig, path, dpi=100)


if __name__ == "__main__":
    sys.exit(main())
