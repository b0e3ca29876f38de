"""The pure-lateral probe: held v_y commands (v_x = w_z = 0), per gait, with what makes a lateral failure cheap to
explain: the achieved v_y and its ratio to the command, the yaw rate it drags along, the commanded foot-y stroke
(peak-to-peak of the nominal foot y plus the policy's foot-y residual, per leg, mean over legs), the posture (the
time-mean foot residual per leg and axis, after scale and clip: a residual held near the clip is a posture, not a
stroke), falls, and the distribution of the phase residuals and of the gait clock's swing share.

Targets it checks (issue 21): |v_y| within 30 % of the command and |w_z| < 0.2 rad/s, no falls. With predictive
selection it runs the selected gait and then each gait of the library forced (``--force-gait``'s mechanism).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TextIO

import torch
import warp as wp

from wqwarp.eval.options import SelectionOptions, option
from wqwarp.eval.rollout import base_velocity, evaluation_session, start_rollout

RATIO_TOLERANCE = 0.3
"""|v_y / v_y_cmd - 1| bound of a tracked lateral command (issue 21)."""
YAW_LIMIT = 0.2
"""|mean w_z| bound of a tracked lateral command [rad/s] (issue 21)."""


@dataclass(kw_only=True)
class LateralOptions(SelectionOptions):
    """Options of the pure-lateral probe (``train/evaluate.py --protocol lateral``)."""

    commands: str = option(
        "-0.6,-0.3,0.3,0.6", help="comma-separated held v_y commands [m/s] (default -0.6,-0.3,0.3,0.6)"
    )
    robots_per_command: int = option(8, help="robots holding each command (default 8)")
    seconds: float = option(10.0, help="rollout length [s]; metrics after 2 s (default 10)")
    per_gait: bool = option(False, help="predictive presets: also run every gait of the library forced")

    def command_list(self) -> list[float]:
        try:
            values = [float(x) for x in self.commands.split(",") if x.strip()]
        except ValueError:
            values = []
        if not values:
            raise ValueError(f"--commands {self.commands!r}: need comma-separated velocities, e.g. -0.3,0.3")
        return values

    def validate(self) -> None:
        self.command_list()
        if self.robots_per_command < 1 or self.seconds <= 2.0:
            raise ValueError("need --robots-per-command >= 1 and --seconds > 2 (the settling time)")


@torch.no_grad()
def probe(
    runner, commands: list[float], per_command: int, seconds: float, forced_gait: int | None = None, settle: float = 2.0
) -> list[dict]:
    """One row per command: the means over its robots after ``settle`` [s]."""
    env, sel = runner.env, runner.env.gait_selector
    n = env.num_envs
    with evaluation_session(env):
        if forced_gait is not None:
            sel.force(forced_gait)
        cmd = torch.zeros(n, 3, device=env.device)
        cmd[:, 1] = torch.tensor(commands, device=env.device).repeat_interleave(per_command)
        obs = start_rollout(env, cmd, seconds)
        vel, foot_y, dp, dphi, swing, gaits = [], [], [], [], [], []
        fell = torch.zeros(n, dtype=torch.bool, device=env.device)
        for k in range(int(round(seconds / env.dt))):
            obs, _, dones, _ = env.step(runner.policy(obs))
            fell |= dones.bool()
            if k * env.dt < settle:
                continue
            vel.append(base_velocity(env))
            if env.nominal is not None:
                ng = env.nominal
                residual = wp.to_torch(env.foot_residual_wp)
                foot_y.append(wp.to_torch(ng.foot_target)[:, :, 1] + residual[:, :, 1])
                dp.append(residual.clone())
                dphi.append(wp.to_torch(ng.phase_residual).clone())
                swing.append((wp.to_torch(ng.swing_psi) >= 0).float().mean(1))
            gaits.append(env.active_gait())
    v = torch.stack(vel)  # (T, N, 3)
    rows = []
    for i, c in enumerate(commands):
        r = slice(i * per_command, (i + 1) * per_command)
        vy = float(v[:, r, 1].mean())
        wz = float(v[:, r, 2].mean())
        row = {
            "command_vy": c,
            "vy": vy,
            "ratio": vy / c if c else None,
            "wz": wz,
            "vx": float(v[:, r, 0].mean()),
            "upright": float((~fell[r]).float().mean()),
        }
        if foot_y:
            fy = torch.stack(foot_y)[:, r]  # (T, k, 4)
            row["foot_y_stroke_m"] = float((fy.amax(0) - fy.amin(0)).mean())
            posture = torch.stack(dp)[:, r].mean((0, 1))  # (4 legs, x y z) [m]
            row["foot_residual_mean_m"] = posture.tolist()
            row["foot_residual_abs_mean_m"] = float(posture.abs().mean())
            d = torch.stack(dphi)[:, r].flatten()
            row["phase_residual"] = {
                "mean": float(d.mean()),
                "std": float(d.std()),
                "p05": float(d.quantile(0.05)),
                "p95": float(d.quantile(0.95)),
            }
            row["swing_share"] = float(torch.stack(swing)[:, r].mean())
        g = torch.stack(gaits)[:, r].flatten()
        row["gait_usage"] = {name: float((g == j).float().mean()) for j, name in enumerate(env.gait_names)}
        row["tracked"] = bool(
            c and abs(vy / c - 1.0) <= RATIO_TOLERANCE and abs(wz) < YAW_LIMIT and row["upright"] == 1.0
        )
        rows.append(row)
    return rows


def lateral(opts: LateralOptions, log: TextIO) -> dict:
    """Run the probe with the selected gait and, with ``--per-gait`` on a predictive preset, each gait forced."""
    from wqwarp.eval.loading import make_policy_runner

    opts.validate()
    commands = opts.command_list()
    runner = make_policy_runner(
        opts.checkpoint,
        None,
        len(commands) * opts.robots_per_command,
        opts.device,
        seed=opts.seed,
        criterion=opts.criterion,
    )
    env = runner.env
    runs = [("selected", None)]
    if opts.per_gait:
        if env.gait_selector.name != "predictive":
            raise ValueError(f"--per-gait needs a predictive preset, not {runner.preset}")
        runs += [(name, j) for j, name in enumerate(env.gait_names)]
    out = {}
    print(
        f"lateral probe of {opts.checkpoint} ({runner.preset}, iteration {runner.iteration}): held v_y, v_x = "
        f"w_z = 0, {opts.robots_per_command} robots each, {opts.seconds:g} s",
        file=log,
    )
    print(
        f"{'gait':<10} {'cmd':>6} {'v_y':>7} {'ratio':>6} {'w_z':>7} {'stroke':>7} {'posture':>7} {'dphi std':>8} "
        f"{'up':>5} tracked",
        file=log,
    )
    for label, forced in runs:
        rows = probe(runner, commands, opts.robots_per_command, opts.seconds, forced)
        out[label] = rows
        for r in rows:
            ratio = f"{r['ratio']:.2f}" if r["ratio"] is not None else "-"
            stroke = f"{100 * r.get('foot_y_stroke_m', 0.0):.1f}cm"
            posture = f"{100 * r.get('foot_residual_abs_mean_m', 0.0):.1f}cm"
            std = f"{r['phase_residual']['std']:.3f}" if "phase_residual" in r else "-"
            print(
                f"{label:<10} {r['command_vy']:>6.2f} {r['vy']:>7.3f} {ratio:>6} {r['wz']:>7.3f} {stroke:>7} "
                f"{posture:>7} {std:>8} {r['upright']:>5.2f} {'yes' if r['tracked'] else 'no'}",
                file=log,
            )
    return {
        "checkpoint": opts.checkpoint,
        "preset": runner.preset,
        "iteration": runner.iteration,
        "seconds": opts.seconds,
        "robots_per_command": opts.robots_per_command,
        "seed": opts.seed,
        "ratio_tolerance": RATIO_TOLERANCE,
        "yaw_limit": YAW_LIMIT,
        "runs": out,
        "all_tracked": all(r["tracked"] for r in out["selected"]),
    }
