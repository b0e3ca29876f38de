"""Random extreme actions and commands against the divergence guard: how often does a robot's simulation diverge, and
does anything non-finite get through?

Usage::

    python tools/studies/stability_fuzz.py [--robot-steps 1000000] [--num-envs 256] [--preset ours] [--backend auto]
                                   [--dt 0.005 --decimation 4] [--seed 1] [--json PATH]

Every policy step draws actions uniformly over the whole clip range (+-``action.clip_actions``) and every second new
commands beyond the training ranges (v_x +-3 m/s, v_y +-1.5 m/s, w_z +-3 rad/s); pushes and domain randomisation
are on. Counts: robot-steps, episodes ended by a base contact, by a time-out and by a diverged simulation
(``Episode_Termination/unstable``), and non-finite values in observations, rewards and logs (must be 0: the guard
terminates a diverged robot before anything reads it). For every divergence: step, robot, command, and the largest
joint speed, base speed and base height of that robot in the step before.
"""

from __future__ import annotations

import math
import sys
import time

from wqwarp.cli.args import UsageError, doc_parser, entry_point
from wqwarp.utils.io import output_problem


def fuzz(
    robot_steps: int,
    num_envs: int,
    preset: str,
    backend: str,
    dt: float,
    decimation: int,
    seed: int,
    progress: bool = False,
) -> dict:
    import torch

    from wqwarp.rl.env import WheeledGo1Env
    from wqwarp.rl.presets import make_preset

    cfg = make_preset(preset)
    cfg.sim.num_envs = num_envs
    cfg.sim.backend = backend
    cfg.sim.dt = dt
    cfg.sim.decimation = decimation
    cfg.seed = seed
    env = WheeledGo1Env(cfg)
    env.collect_training_data = True  # as in training: the estimator and predictor data paths run too
    gen = torch.Generator().manual_seed(seed)
    clip = cfg.action.clip_actions
    steps = max(1, math.ceil(robot_steps / num_envs))
    per_second = max(1, int(round(1.0 / env.dt)))
    counts = {
        "robot_steps": 0,
        "contact_terminations": 0,
        "time_outs": 0,
        "unstable": 0,
        "nonfinite_obs": 0,
        "nonfinite_rewards": 0,
        "nonfinite_logs": 0,
    }
    events = []
    limits = torch.tensor([3.0, 1.5, 3.0])
    t0 = time.perf_counter()
    for step in range(steps):
        if step % per_second == 0:
            env.hold_commands((2 * torch.rand(num_envs, 3, generator=gen) - 1) * limits)
        qd_before = env.tv["joint_qd"].clone()
        height_before = env.tv["joint_q"][:, 2].clone()
        actions = (2 * torch.rand(num_envs, env.num_actions, generator=gen) - 1) * clip
        obs, rew, dones, extras = env.step(actions)
        unstable = env.last_unstable.clone()
        counts["robot_steps"] += num_envs
        counts["unstable"] += int(unstable.sum())
        counts["time_outs"] += int(extras["time_outs"].sum())
        counts["contact_terminations"] += int((dones.bool() & ~extras["time_outs"] & ~unstable).sum())
        counts["nonfinite_obs"] += sum(int((~torch.isfinite(obs[k])).sum()) for k in ("policy", "privileged"))
        counts["nonfinite_rewards"] += int((~torch.isfinite(rew)).sum())
        counts["nonfinite_logs"] += sum(
            int(not bool(torch.isfinite(torch.as_tensor(v)).all())) for v in extras["log"].values()
        )
        for r in unstable.nonzero().flatten().tolist():
            if len(events) < 50:
                events.append(
                    {
                        "step": step,
                        "robot": r,
                        "command": [round(float(x), 3) for x in env.commands[r]],
                        "max_joint_speed_before": round(float(qd_before[r, 6:].abs().max()), 2),
                        "base_speed_before": round(float(qd_before[r, :3].norm()), 3),
                        "base_height_before": round(float(height_before[r]), 3),
                    }
                )
        if step % 50 == 0:
            env.estimator_trainer.clear()  # nothing learns here; keep the collected pairs from growing
        if progress and (step + 1) % max(1, steps // 20) == 0:
            print(f"\r{step + 1}/{steps} policy steps, {counts['unstable']} diverged", end="", flush=True)
    if progress:
        print()
    wall = time.perf_counter() - t0
    return {
        "preset": preset,
        "backend": env.sim.backend,
        "num_envs": num_envs,
        "dt": dt,
        "decimation": decimation,
        "seed": seed,
        "wall_s": round(wall, 1),
        "counts": counts,
        "unstable_per_million_robot_steps": round(1e6 * counts["unstable"] / counts["robot_steps"], 2),
        "events": events,
    }


@entry_point
def main(argv=None) -> int:
    ap = doc_parser(__doc__)
    ap.add_argument("--robot-steps", type=int, default=1_000_000, help="robot policy steps in all (default 1e6)")
    ap.add_argument("--num-envs", type=int, default=256, help="robots stepped together (default 256)")
    ap.add_argument("--preset", default="ours", help="method preset (default ours)")
    ap.add_argument("--backend", default="auto", help="auto | mujoco_cpu | mujoco_warp (default auto)")
    ap.add_argument("--dt", type=float, default=0.005, help="physics step [s] (default 0.005; the paper's 0.001)")
    ap.add_argument("--decimation", type=int, default=4, help="physics steps per policy step (default 4)")
    ap.add_argument("--seed", type=int, default=1, help="seed of actions, commands and the env (default 1)")
    ap.add_argument("--json", default=None, help="write the counts and events to this JSON file (atomically)")
    args = ap.parse_args(argv)
    from wqwarp.rl.presets import PRESETS
    from wqwarp.sim.config import BACKENDS

    if args.robot_steps < 1 or args.num_envs < 1 or args.decimation < 1 or not args.dt > 0:
        raise UsageError("--robot-steps, --num-envs, --decimation and --dt must be positive")
    if args.preset not in PRESETS or args.backend not in BACKENDS:
        raise UsageError(
            f"unknown --preset {args.preset!r} or --backend {args.backend!r} (presets: "
            f"{', '.join(sorted(PRESETS))}; backends: {', '.join(BACKENDS)})"
        )

    if args.json and (problem := output_problem(args.json)):
        raise UsageError(f"--json {args.json!r}: {problem}")
    res = fuzz(
        args.robot_steps, args.num_envs, args.preset, args.backend, args.dt, args.decimation, args.seed, progress=True
    )
    c = res["counts"]
    print(
        f"{c['robot_steps']} robot-steps in {res['wall_s']} s: {c['unstable']} diverged "
        f"({res['unstable_per_million_robot_steps']} per million), {c['contact_terminations']} base contacts, "
        f"{c['time_outs']} time-outs; non-finite: obs {c['nonfinite_obs']}, rewards {c['nonfinite_rewards']}, "
        f"logs {c['nonfinite_logs']}"
    )
    for e in res["events"][:10]:
        print(f"  diverged: {e}")
    if args.json:
        from wqwarp.utils import provenance

        provenance.write_result_json(args.json, res)
        print(f"wrote {args.json}")
    bad = c["nonfinite_obs"] + c["nonfinite_rewards"] + c["nonfinite_logs"]
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
