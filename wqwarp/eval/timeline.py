"""The paper's Fig. 6 (the commanded-velocity experiment): robots driven through a sequence of held commands, with
the height of the front-right wheel, the requested and running gait, the measured power and the tracked velocity
over time, and per segment the mean p_cost per joint group, the tracking error and the share of each running gait
over all robots (the series is robot 0's). Nothing learns: the estimator and the power predictor stay as saved.

Each segment is ``v_x,v_y,w_z:seconds`` (:func:`parse_segments`).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import TextIO

import torch

from wqwarp.eval.options import SelectionOptions, option
from wqwarp.eval.rollout import base_velocity, evaluation_session, start_rollout

Segments = list[tuple[tuple[float, float, float], float]]
DEFAULT_SEGMENTS = "0.6,0,0:4;0,0.4,0:4;0,0,0.6:4;0,0,0:4;-0.4,0,0:4"


def fig6_segments(seconds: float) -> str:
    """The paper's Fig. 6 sequence, ``seconds`` [s] per segment: stand, forward, rotate, lateral."""
    s = f"{seconds:g}"
    return f"0,0,0:{s};0.8,0,0:{s};0,0,0.6:{s};0,0.4,0:{s}"


def parse_segments(text: str) -> Segments:
    """``"vx,vy,wz:s;..."`` -> [((vx, vy, wz), seconds), ...]; ValueError naming the bad segment."""
    out = []
    for part in [p.strip() for p in text.split(";") if p.strip()]:
        try:
            cmd, sec = part.split(":")
            v = tuple(float(x) for x in cmd.split(","))
            s = float(sec)
        except ValueError:
            raise ValueError(f"bad segment {part!r}: expected 'vx,vy,wz:seconds'") from None
        if len(v) != 3 or not all(math.isfinite(x) for x in (*v, s)) or s <= 0:
            raise ValueError(f"bad segment {part!r}: expected three finite velocities and seconds > 0")
        out.append((v, s))
    if not out:
        raise ValueError("no segments given")
    return out


SERIES_KEYS = (
    "t",
    "command",
    "v",
    "p_cost",
    "p_cost_legs",
    "p_cost_wheels",
    "p_elec",
    "gait_requested",
    "gait_running",
    "wheel_fr_height",
)
"""Time series of robot 0, one entry per policy step."""


@torch.no_grad()
def run_timeline(runner, segments: Segments) -> tuple[list[dict], dict, torch.Tensor]:
    """Drive ``runner`` (``wqwarp.eval.loading.PolicyRunner``) through ``segments``: (per-segment summaries, robot 0's
    series of :data:`SERIES_KEYS`, which robots fell (N,) bool). The env is left as it was found."""
    with evaluation_session(runner.env):
        return _run_timeline(runner, segments)


def _run_timeline(runner, segments: Segments) -> tuple[list[dict], dict, torch.Tensor]:
    env = runner.env
    names = env.gait_names  # the run's library, also without a nominal gait (active_gait() is then 0)
    n = env.num_envs
    total = sum(s for _, s in segments)
    obs = start_rollout(env, torch.tensor([segments[0][0]] * n, dtype=torch.float32), total)
    fr_wheel = int(env.sim.layout.wheel_body[0])  # body index of the front-right wheel (legs FR, FL, RR, RL)
    series = {k: [] for k in SERIES_KEYS}
    summary = []
    fell = torch.zeros(n, dtype=torch.bool)
    k = 0
    for cmd, sec in segments:
        c = torch.tensor([cmd] * n, dtype=torch.float32)
        acc = {"p": 0.0, "legs": 0.0, "wheels": 0.0, "elec": 0.0, "err": 0.0, "count": 0}
        usage = torch.zeros(len(names))
        env.hold_commands(c)
        for _ in range(int(round(sec / env.dt))):
            obs, _, dones, _ = env.step(runner.policy(obs))
            fell |= dones.bool().cpu()
            v = base_velocity(env).cpu()
            running = env.active_gait().cpu()
            usage += torch.bincount(running, minlength=len(usage)).float()
            tv = env.tv
            acc["p"] += float(tv["p_cost"].mean())
            acc["legs"] += float(tv["p_cost_legs"].mean())
            acc["wheels"] += float(tv["p_cost_wheels"].mean())
            acc["elec"] += float(tv["p_elec"].mean())
            acc["err"] += float(((v - c) ** 2).sum(1).mean())
            acc["count"] += 1
            series["t"].append(round(k * env.dt, 4))
            series["command"].append(list(cmd))
            series["v"].append([round(float(x), 4) for x in v[0]])
            for key in ("p_cost", "p_cost_legs", "p_cost_wheels", "p_elec"):
                series[key].append(round(float(tv[key][0]), 3))
            series["gait_requested"].append(names[int(env.requested_gait()[0])])
            series["gait_running"].append(names[int(running[0])])
            series["wheel_fr_height"].append(round(float(tv["body_q"][0, fr_wheel, 2]), 4))  # wheel centre z [m]
            k += 1
        m = acc["count"]
        summary.append(
            {
                "command": list(cmd),
                "seconds": sec,
                "mean_p_cost": acc["p"] / m,
                "mean_p_cost_legs": acc["legs"] / m,
                "mean_p_cost_wheels": acc["wheels"] / m,
                "mean_p_elec": acc["elec"] / m,
                "mean_sq_velocity_error": acc["err"] / m,
                "gait_usage": {g: float(usage[i] / usage.sum()) for i, g in enumerate(names)},
            }
        )
    return summary, series, fell


@dataclass(kw_only=True)
class TimelineOptions(SelectionOptions):
    """Options of the timeline protocol (``tools/gait_sequence.py``)."""

    preset: str | None = option(None, help="preset of the checkpoint (default: from its run's config.json)")
    segments: str = option(DEFAULT_SEGMENTS, help=f"command segments (default {DEFAULT_SEGMENTS!r})")
    robots: int = option(8, help="robots run side by side (default 8; robot 0 is drawn)")
    png: str | None = option(None, help="draw the figure here (matplotlib)", output=True)

    def validate(self) -> None:
        try:
            parse_segments(self.segments)
        except ValueError as e:
            raise ValueError(f"--segments: {e}") from None
        if self.robots < 1:
            raise ValueError("--robots must be >= 1")


def timeline(opts: TimelineOptions, log: TextIO) -> dict:
    """Fig. 6: the checkpoint's robots through ``opts.segments``; the result holds the per-segment summaries and
    robot 0's series (``series_robot0``)."""
    from wqwarp.eval.loading import make_policy_runner
    from wqwarp.rl.config import to_dict

    opts.validate()
    t0 = time.time()
    runner = make_policy_runner(
        opts.checkpoint, opts.preset, opts.robots, opts.device, seed=opts.seed, criterion=opts.criterion
    )
    summary, series, fell = run_timeline(runner, parse_segments(opts.segments))
    print(
        f"{runner.preset} checkpoint (iteration {runner.iteration}), {opts.robots} robots; fell: {int(fell.sum())}",
        file=log,
    )
    print(
        f"{'command':>18} {'p_cost':>7} {'legs':>6} {'wheels':>6} {'p_elec':>7} {'sq err':>7}  "
        "gaits (share of robot-steps)",
        file=log,
    )
    for s in summary:
        gaits = " ".join(f"{g} {100 * v:.0f}%" for g, v in s["gait_usage"].items() if v > 0)
        print(
            f"{str(tuple(s['command'])):>18} {s['mean_p_cost']:7.1f} {s['mean_p_cost_legs']:6.1f} "
            f"{s['mean_p_cost_wheels']:6.1f} {s.get('mean_p_elec', float('nan')):7.1f} "
            f"{s['mean_sq_velocity_error']:7.3f}  {gaits}",
            file=log,
        )
    return {
        "checkpoint": opts.checkpoint,
        "preset": runner.preset,
        "iteration": runner.iteration,
        "robots": opts.robots,
        "seed": opts.seed,
        "fell": int(fell.sum()),
        "segments": summary,
        "gait_names": list(runner.env.gait_names),
        "series_robot0": series,
        "wall_time_s": time.time() - t0,
        "config": to_dict(runner.env.cfg),
    }


def draw_timeline(out: dict, path: str, command: str | None = None) -> None:
    """Fig. 6 of a :func:`timeline` result: velocities, FR wheel height, gaits, power over time (robot 0)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    from wqwarp.utils.provenance import save_figure

    s = out["series_robot0"]
    names = out["gait_names"]
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
    idx = {g: i for i, g in enumerate(names)}
    ax[2].step(t, [idx[g] for g in s["gait_running"]], where="post", label="running")
    ax[2].step(t, [idx[g] for g in s["gait_requested"]], where="post", ls=":", label="requested")
    ax[2].set_yticks(range(len(names)))
    ax[2].set_yticklabels(names)
    ax[2].legend(loc="upper right", fontsize=8)
    ax[3].plot(t, s["p_cost_legs"], lw=1, label="legs")
    ax[3].plot(t, s["p_cost_wheels"], lw=1, label="wheels")
    shown = ["p_cost_legs", "p_cost_wheels"]
    if "p_elec" in s:  # results before 2026-12-07 have no electrical series
        ax[3].plot(t, s["p_elec"], lw=1, color="k", ls="--", label="electrical (all)")
        shown.append("p_elec")
    settled = t >= min(0.5, t[-1] / 2)  # robots spawn slightly above the ground: the first landing dwarfs the rest
    top = max(np.max(np.asarray(s[k])[settled]) for k in shown)
    ax[3].set_ylim(0, 1.15 * top + 1.0)
    ax[3].set_ylabel("power [W]\n(spawn landing clipped)")
    ax[3].set_xlabel("time [s]")
    ax[3].legend(loc="upper right", fontsize=8)
    fig.suptitle(f"{out['preset']} (iteration {out['iteration']}), robot 0")
    fig.tight_layout()
    save_figure(fig, path, dpi=100, command=command)
