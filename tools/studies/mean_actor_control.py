"""Control for ``--env.predictor.label-source mean``: which of its two parts changes how the policy learns?

The option does two things: every 8th robot acts with the actor's mean and alone labels the power predictor (what
the predictor learns, and so which gaits the robots are given), and PPO leaves those robots' transitions out of its
losses (advantage 0, return = value). This study trains the first part without the second: the mean-acting robots'
transitions stay in PPO as rsl-rl computes them (:class:`KeptMeanActorsPPO`; biased, since a mean is not a sample
of the Gaussian, so it is a diagnostic, not an option). Compare its ``Actions/foot_abs`` and ``Policy/std_foot``
with runs of the option and of the paper's labels at the same iterations (tools/studies/omni_ab.py).

Usage::

    python tools/studies/mean_actor_control.py --seed 1 --iterations 600 --log-dir runs/ab22/ours_ff_kin_meankept_s1

The configuration is that of docs/studies/omnidirectional's mean-label runs: preset ``ours``, 128 robots,
``--env.gait.lateral-gain 0.35 --env.predictor.criterion kinematic --env.predictor.label-source mean``; a
``config.json`` and ``metrics.jsonl`` are written to the log dir (and checkpoints every 50 iterations).
"""

from __future__ import annotations

import contextlib
import io
import json
import os
import sys

from wqwarp.cli.args import doc_parser
from wqwarp.rl.algorithm import WqPPO


class KeptMeanActorsPPO(WqPPO):
    """WqPPO whose mean-acting robots still act with the mean, but whose returns and advantages are rsl-rl's for
    every robot (the mean actors' transitions train PPO like the others')."""

    def compute_returns(self, obs) -> None:
        super(WqPPO, self).compute_returns(obs)


def main(argv=None) -> int:
    ap = doc_parser(__doc__)
    ap.add_argument("--seed", type=int, default=1, help="random seed (default 1)")
    ap.add_argument("--iterations", type=int, default=600, help="PPO iterations (default 600)")
    ap.add_argument("--log-dir", required=True, help="run folder (must not exist yet)")
    ap.add_argument("--threads", type=int, default=None, help="torch and physics threads (default: as torch has it)")
    args = ap.parse_args(argv)
    if args.iterations < 1:
        print("error: --iterations must be >= 1", file=sys.stderr)
        return 2
    if os.path.exists(args.log_dir):
        print(f"error: {args.log_dir} exists; choose a new run folder", file=sys.stderr)
        return 2

    import torch

    from wqwarp import quiet_warp

    quiet_warp()
    from wqwarp.rl.config import TrainConfig, to_dict
    from wqwarp.rl.env import WheeledGo1Env
    from wqwarp.rl.presets import make_preset
    from wqwarp.rl.runner import WqRunner
    from wqwarp.utils.io import write_text_atomic

    if args.threads:
        torch.set_num_threads(args.threads)
    cfg = make_preset("ours")
    cfg.seed = args.seed
    cfg.sim.num_envs = 128  # the main job's default (EnvConfig's own is 64)
    cfg.gait.lateral_gain = 0.35
    cfg.predictor.criterion = "kinematic"
    cfg.predictor.label_source = "mean"
    if args.threads:
        cfg.sim.nthread = args.threads
    torch.manual_seed(args.seed)
    env = WheeledGo1Env(cfg)
    tcfg = TrainConfig(max_iterations=args.iterations)
    train_cfg = tcfg.rsl_rl_dict()
    train_cfg["algorithm"]["class_name"] = f"{KeptMeanActorsPPO.__module__}:KeptMeanActorsPPO"
    os.makedirs(args.log_dir)
    record = {"command": " ".join(sys.argv), "study": "mean_actor_control", "seed": args.seed,
              "algorithm": "KeptMeanActorsPPO", "env": to_dict(cfg), "train": to_dict(tcfg),
              "args": {"preset": "ours", "num_envs": cfg.sim.num_envs, "num_steps_per_env": tcfg.num_steps_per_env,
                       "seed": args.seed, "max_iterations": args.iterations}}  # fmt: skip
    write_text_atomic(os.path.join(args.log_dir, "config.json"), json.dumps(record, indent=2))
    with contextlib.redirect_stdout(io.StringIO()):
        runner = WqRunner(env, train_cfg, log_dir=args.log_dir, device=env.device)
    runner.learn(args.iterations)
    return 0


if __name__ == "__main__":
    sys.exit(main())
