"""Collection throughput of the residual-RL environment against the simulation core, in the same process.

Usage::

    python tools/bench_env.py [--sizes 64,256] [--preset no_predictor] [--seconds 3] [--json PATH]

For each N: ``sim_policy_steps_per_s`` = ``Simulator.step`` alone (actuation, power, physics, FK, contacts; fixed
targets), ``env_steps_per_s`` = ``WheeledGo1Env.step`` with random actions from a fixed-size MLP actor (nominal gait,
residual IK, rewards, resets, commands, pushes, estimator inference, gait selection (predictor inference with the
predictive presets), observations; training data collected as during learning) - what PPO collection costs without
the learning updates (PPO, estimator and predictor fits run in the runner). Both in robot-policy-steps per second.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time


def bench(n: int, preset: str, seconds: float) -> dict:
    import torch

    from wqwarp.config import make_preset
    from wqwarp.env import WheeledGo1Env

    cfg = make_preset(preset)
    cfg.sim.num_envs = n
    env = WheeledGo1Env(cfg)
    env.collect_training_data = True
    sim = env.sim
    actor = torch.nn.Sequential(torch.nn.Linear(env.num_obs, 256), torch.nn.ELU(), torch.nn.Linear(256, 128),
                                torch.nn.ELU(), torch.nn.Linear(128, env.num_actions))  # fmt: skip

    def timed(fn):
        fn()
        k, t0 = 0, time.perf_counter()
        while time.perf_counter() - t0 < seconds or k < 3:
            fn()
            k += 1
        return n * k / (time.perf_counter() - t0)

    def env_step():
        with torch.inference_mode():
            obs = env.get_observations()
            env.step(actor(obs["policy"]) * 0.1 + 0.3 * torch.randn(n, env.num_actions))
        env.estimator_trainer.clear()  # no fit here: keep the collected pairs from growing

    env_sps = timed(env_step)
    sim.reset(list(range(n)))
    sim_sps = timed(sim.step)
    return {"n": n, "preset": preset, "sim_policy_steps_per_s": round(sim_sps, 1),
            "env_steps_per_s": round(env_sps, 1), "ratio": round(env_sps / sim_sps, 3)}  # fmt: skip


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], epilog=__doc__.split("\n\n", 1)[1],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)  # fmt: skip
    ap.add_argument("--sizes", default="64,256", help="comma-separated robot counts (default 64,256)")
    ap.add_argument("--preset", default="no_predictor", help="environment preset (default no_predictor)")
    ap.add_argument("--seconds", type=float, default=3.0, help="minimum timed wall time per measurement (default 3)")
    ap.add_argument("--json", default=None, help="also write the results as JSON to this path")
    args = ap.parse_args(argv)
    try:
        sizes = [int(s) for s in args.sizes.split(",")]
        if min(sizes) < 1:
            raise ValueError
    except ValueError:
        print(f"error: --sizes must be positive integers, got {args.sizes!r}", file=sys.stderr)
        return 2
    print(f"{'N':>6} {'sim policy st/s':>16} {'env st/s':>10} {'ratio':>6}", flush=True)
    results = []
    for n in sizes:
        r = bench(n, args.preset, args.seconds)
        results.append(r)
        print(f"{n:>6} {r['sim_policy_steps_per_s']:>16.0f} {r['env_steps_per_s']:>10.0f} {r['ratio']:>6.2f}",
              flush=True)  # fmt: skip
    if args.json:
        with open(args.json + ".tmp", "w", encoding="utf-8") as f:
            json.dump({"device": f"cpu ({os.cpu_count()} cores)", "results": results}, f, indent=2)
        os.replace(args.json + ".tmp", args.json)
    return 0


if __name__ == "__main__":
    sys.exit(main())
