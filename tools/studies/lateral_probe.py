"""Why is lateral velocity not learned? Probe a trained policy, or the action space open loop.

Usage::

    python tools/studies/lateral_probe.py --checkpoint runs/X/model_999.pt [--json out.json]
    python tools/studies/lateral_probe.py --open-loop [--amplitudes 0,0.03,0.06] [--json out.json]

``--checkpoint``: 8 robots (no domain randomisation, estimator frozen), each holding one v_y command from -0.7 to
0.7 m/s (v_x = w = 0) for ``--seconds``; after 2 s prints per robot the achieved mean v_y, the mean phase action of
the policy (with the increment reading, -f dt / phase_scale = -0.12 stops the trotting clock) and the standard
deviation of the foot-y actions.

``--reach --checkpoint CKPT``: the nominal gaits alone (every action 0) with the checkpoint's lateral
feed-forward, each stepping gait forced, ``--robots`` robots per held v_y command from 0.1 to 0.7 m/s, for each stroke
bound in ``--limits`` [m] (``gait.lateral_limit``): the achieved v_y, the yaw rate and the upright share beside the
nominal reach 2 limit f / (1 - DF_swing) that ``predictor.kinematic_reach`` masks by
(``wqwarp.rl.gait_selection.lateral_reach``). The policy's weights are not used, only its environment.

``--open-loop``: one robot on the nominal trot (no policy) with a foot-y sawtooth added to every leg: in swing
the foot moves from -A to +A, in stance back from +A to -A (the stance legs push the body to +y); prints the
achieved mean v_y (base frame, after 1 s) per amplitude A [m]. Shows whether the action space (foot residuals,
0.2 m per action unit) can express lateral motion at all.
"""

from __future__ import annotations

import json
import os
import sys

import numpy as np

from wqwarp.cli.args import UsageError, doc_parser, entry_point
from wqwarp.utils.io import output_problem

COMMANDS = (-0.7, -0.5, -0.3, -0.1, 0.1, 0.3, 0.5, 0.7)


def probe_policy(checkpoint: str, seconds: float) -> dict:
    import torch

    from wqwarp.eval.loading import make_policy_runner
    from wqwarp.eval.rollout import start_rollout

    runner = make_policy_runner(checkpoint, None, num_envs=len(COMMANDS))
    env = runner.env
    cmd = torch.zeros(len(COMMANDS), 3)
    cmd[:, 1] = torch.tensor(COMMANDS)
    obs = start_rollout(env, cmd, seconds)  # commands held, also after a reset
    vy, actions = [], []
    settle = int(round(2.0 / env.dt))
    with torch.no_grad():
        for k in range(int(round(seconds / env.dt))):
            a = runner.policy(obs)
            obs, _, _, _ = env.step(a)
            if k >= settle:
                vy.append(env.base_state()["lin_vel"][:, 1].clone())
                actions.append(a.clone())
    a = torch.stack(actions)
    return {
        "checkpoint": checkpoint,
        "phase_residual_mode": env.cfg.action.phase_residual_mode,
        "command_vy": list(COMMANDS),
        "achieved_vy": torch.stack(vy).mean(0).tolist(),
        "mean_phase_action": a[:, :, :4].mean((0, 2)).tolist(),
        "foot_y_action_std": a[:, :, [5, 8, 11, 14]].std(0).mean(1).tolist(),
    }


REACH_COMMANDS = (0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7)


def probe_reach(
    checkpoint: str, limits: list[float], robots: int, seconds: float, frequency_scales: list[float] = (1.0,)
) -> dict:
    from dataclasses import replace

    from wqwarp.control.gaits import gait_library_arrays
    from wqwarp.eval.lateral import probe
    from wqwarp.eval.loading import make_policy_runner
    from wqwarp.eval.tracking import zero_policy
    from wqwarp.rl.gait_selection import lateral_reach

    runner = make_policy_runner(checkpoint, None, num_envs=len(REACH_COMMANDS) * robots)
    env = runner.env
    if env.nominal is None or env.gait_selector.name != "predictive":
        raise ValueError(f"--reach needs a checkpoint of a predictive preset with a nominal gait: {checkpoint}")
    runner.policy = zero_policy(env)
    ng, table = env.nominal, env.cfg.gait.library
    keep = ("command_vy", "vy", "wz", "upright", "foot_y_stroke_m")
    rows = []
    for gid, scale, limit in ((g, k, x) for g in range(len(table)) for k in frequency_scales for x in limits):
        if table[gid].df_swing == 0.0:
            continue
        # a study of the nominal pattern only: the library's gait at scale x its frequency (same size, same ids)
        library = tuple(replace(g, frequency=g.frequency * scale) if i == gid else g for i, g in enumerate(table))
        ng.library, ng.arrays, gait = library, gait_library_arrays(ng.device, library), library[gid]
        ng.lateral_limit = limit
        res = probe(runner, list(REACH_COMMANDS), robots, seconds, forced_gait=gid)
        rows.append(
            {
                "gait": gait.name,
                "frequency_hz": gait.frequency,
                "lateral_limit_m": limit,
                "nominal_reach_mps": lateral_reach(gait, limit),
                "commands": [{k: r[k] for k in keep} for r in res],
                "max_upright_vy": max((r["vy"] for r in res if r["upright"] == 1.0), default=None),
            }
        )
        print(
            f"{gait.name:10s} {gait.frequency:.2f} Hz limit {limit:.2f} m  reach {lateral_reach(gait, limit):.2f} m/s  "
            + "  ".join(f"{r['command_vy']:.1f}->{r['vy']:+.2f} (w {r['wz']:+.2f}, {r['upright']:.0%})" for r in res),
            file=sys.stderr,
            flush=True,
        )
    ng.library, ng.arrays = table, gait_library_arrays(ng.device, table)
    return {"checkpoint": checkpoint, "lateral_gain_s": ng.lateral_gain, "robots_per_command": robots, "reach": rows}


def probe_open_loop(amplitudes: list[float], seconds: float) -> dict:
    import warp as wp

    from wqwarp.control.nominal import NominalGait
    from wqwarp.kernels.kinematics import compute_leg_ik
    from wqwarp.robot import constants as C
    from wqwarp.sim.config import SimConfig
    from wqwarp.sim.simulator import Simulator

    out = []
    for amp in amplitudes:
        sim = Simulator(SimConfig(num_envs=1))
        ng = NominalGait(1, "cpu")
        ng.reset([0], ng.gait_ids("trotting"))
        df = ng.library[ng.gait_ids("trotting")].df_swing
        vy, p = [], []
        for k in range(int(round(seconds / sim.policy_dt))):
            ng.step(sim.actuated_q[:, :12], sim.wheel_contact, sim.policy_dt)
            target = ng.foot_target.numpy().copy()
            phi = ng.phase.numpy()[0]
            swing = phi < df
            target[0, :, 1] += np.where(swing, -amp + 2 * amp * phi / df, amp - 2 * amp * (phi - df) / (1 - df))
            q = compute_leg_ik(wp.array(target, dtype=wp.vec3), point=C.FOOT_IN_CALF)
            wp.copy(sim.leg_q_target, q)
            sim.wheel_qd_target.zero_()
            sim.step()
            if k * sim.policy_dt >= 1.0:
                v = sim.base_lin_vel.numpy()  # base frame
                vy.append(float(v[0, 1]))
                p.append(float(sim.p_cost.numpy()[0]))
        out.append(
            {
                "amplitude_m": amp,
                "action_units": amp / 0.2,
                "achieved_vy": float(np.mean(vy)),
                "p_cost": float(np.mean(p)),
            }
        )
    return {"open_loop": out}


@entry_point
def main(argv=None) -> int:
    ap = doc_parser(__doc__)
    ap.add_argument("--checkpoint", default=None, help="probe this policy (model_<it>.pt)")
    ap.add_argument("--open-loop", action="store_true", help="probe the nominal trot plus a foot-y sawtooth")
    ap.add_argument("--reach", action="store_true", help="with --checkpoint: each stepping gait's lateral reach")
    ap.add_argument("--limits", default="0.12,0.2", help="--reach: stroke bounds [m] (default 0.12,0.2)")
    ap.add_argument(
        "--frequency-scales", default="1", help="--reach: each stepping gait also at these multiples of its frequency"
    )
    ap.add_argument("--robots", type=int, default=4, help="--reach: robots per command (default 4)")
    ap.add_argument(
        "--amplitudes", default="0,0.03,0.06", help="open loop: sawtooth amplitudes [m] (default 0,0.03,0.06)"
    )
    ap.add_argument("--seconds", type=float, default=8.0, help="length of each rollout [s] (default 8)")
    ap.add_argument("--json", default=None, help="also write the results to this JSON file")
    args = ap.parse_args(argv)
    if (args.checkpoint is None) == (not args.open_loop) or args.seconds <= 2.0:
        raise UsageError("give exactly one of --checkpoint and --open-loop, and --seconds > 2")
    if args.checkpoint is not None and not os.path.isfile(args.checkpoint):
        raise UsageError(f"no such checkpoint: {args.checkpoint}")
    if args.json and (problem := output_problem(args.json)):
        raise UsageError(f"--json {args.json!r}: {problem}")
    if args.reach and (args.checkpoint is None or args.robots < 1):
        raise UsageError("--reach needs --checkpoint (the environment's configuration) and --robots >= 1")
    try:
        amps = [float(x) for x in args.amplitudes.split(",")]
        limits = [float(x) for x in args.limits.split(",")]
        scales = [float(x) for x in args.frequency_scales.split(",")]
    except ValueError:
        raise UsageError(
            "--amplitudes, --limits and --frequency-scales must be comma-separated numbers: "
            f"{args.amplitudes!r}, {args.limits!r}, {args.frequency_scales!r}"
        ) from None
    if any(x <= 0 for x in limits) or any(x <= 0 for x in scales):
        raise UsageError(
            f"--limits and --frequency-scales must be positive: {args.limits!r}, {args.frequency_scales!r}"
        )

    from wqwarp import quiet_warp

    quiet_warp()
    if args.reach:
        res = probe_reach(args.checkpoint, limits, args.robots, args.seconds, scales)
    elif args.checkpoint:
        res = probe_policy(args.checkpoint, args.seconds)
    else:
        res = probe_open_loop(amps, args.seconds)
    from wqwarp.utils.provenance import git_state, write_result_json

    res = {"command": " ".join(sys.argv), "git": git_state(), **res}
    print(json.dumps(res, indent=1))
    if args.json:
        write_result_json(args.json, res, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
