"""Train the residual PPO policy of the paper on the wheeled Go1 (rsl-rl OnPolicyRunner on the wqwarp env).

Examples::

    python train/ppo_newton.py                                   # ours + the omni levers, 15 M samples (4883 it)
    python train/ppo_newton.py --profile paper                   # the paper's method as written
    python train/ppo_newton.py --preset no_predictor --max-iterations 1500 --temperature-iterations 1000
    python train/ppo_newton.py --preset pmtg --num-envs 256 --max-iterations 2000
    python train/ppo_newton.py --resume runs/ours_20261126-0900/model_500.pt
    python train/ppo_newton.py --device cuda:0 --num-envs 4096
    python train/ppo_newton.py --env.reward.energy -2e-5 --env.sim.dt 0.001 --env.sim.decimation 20  # any field
    torchrun --nproc_per_node=K train/ppo_newton.py --device cuda:0 --num-envs 4096   # K GPUs, rsl-rl's DDP path

Writes to the log directory: TensorBoard events (rsl-rl's plus ``Gait/*`` usage shares per command type and
temperature, ``Predictor/*`` loss and held-out relative error per gait), ``model_<it>.pt`` checkpoints (policy,
critic, optimizer, estimator, power predictor and temperature position, observation layout, env config),
``config.json`` (the resolved configuration after preset and options, and the command line), ``metrics.jsonl`` (one
line of metrics per iteration), and at the end ``export/policy.onnx``, ``export/policy.pt2`` (``torch.export``) and
``export/policy.json`` (the onboard policy: observation history -> estimator -> o_t -> actor, and the power
predictor with its argmin rule).
An interrupted run (Ctrl-C or an error) saves ``model_<it>_interrupted.pt`` before exiting.
"""

from __future__ import annotations

import argparse
import contextlib
import datetime
import io
import json
import os
import sys
import time

from wqwarp.utils.io import directory_problem


def parse_args(argv=None) -> argparse.Namespace:
    """The command line: every config field (``--env.*``, ``--train.*``), their short aliases and the run's own
    flags (``wqwarp.cli.train_args``)."""
    from wqwarp.cli.train_args import parse_train_args

    return parse_train_args(__doc__, argv)


def fail(msg: str) -> None:
    print(f"error: {msg}", file=sys.stderr)
    sys.exit(2)


def check_writable_dir(d: str, what: str) -> None:
    """Fail (exit 2) unless ``d`` is, or can be created as, a writable directory; creates nothing."""
    problem = directory_problem(d)
    if problem:
        fail(f"{what} {d!r} {problem}")


def resolve_log_dir(args) -> str:
    if args.log_dir is None:
        stamp = datetime.datetime.now().strftime("%Y%m%d-%H%M%S")
        d = os.path.join("runs", f"{args.preset}_{stamp}")
        check_writable_dir(d, "log dir")
        return d
    d = args.log_dir
    check_writable_dir(d, "--log-dir")
    if os.path.isdir(d) and any(f.startswith("model_") for f in os.listdir(d)):
        if not (args.resume and os.path.abspath(os.path.dirname(args.resume)) == os.path.abspath(d)):
            fail(f"log dir {d!r} already holds checkpoints; choose another --log-dir or --resume from one of them")
    return d


def check_resumed_levers(path: str, cfg) -> None:
    """Fail (exit 2) when the checkpoint was trained with other levers (``wqwarp.rl.profiles``) than this command
    sets: resuming must not switch a lever on or off mid-run. An unreadable file is left to the runner's check."""
    import torch

    from wqwarp.rl.profiles import lever_differences

    try:
        ckpt = torch.load(path, weights_only=False, map_location="cpu")
    except Exception:  # noqa: BLE001 - reported by WqRunner.load with the reason
        return
    saved = (ckpt.get("infos") or {}).get("env_cfg") if isinstance(ckpt, dict) else None
    diffs = lever_differences(saved, cfg) if isinstance(saved, dict) else []
    if diffs:
        fail(f"--resume {path} was trained with other levers: {'; '.join(diffs)}; pass the --profile and options "
             "it was trained with (its config.json has the command)")


def main(argv=None) -> int:
    args = parse_args(argv)
    from wqwarp.cli.train_args import resolve_config, run_record

    try:
        cfg, tcfg = resolve_config(args)  # the preset, then the command line
    except ValueError as e:
        fail(str(e))
    if args.resume and not os.path.isfile(args.resume):
        fail(f"--resume: no such checkpoint {args.resume!r}")
    if args.resume:
        check_resumed_levers(args.resume, cfg)
    world = int(os.getenv("WORLD_SIZE", "1"))
    rank = int(os.getenv("RANK", "0"))
    device = cfg.sim.device
    if world > 1 and device.startswith("cuda"):
        device = f"cuda:{int(os.getenv('LOCAL_RANK', '0'))}"  # one GPU per process
    cfg.sim.device = device
    cfg.seed += rank

    import torch
    import warp as wp

    from wqwarp import quiet_warp

    quiet_warp()
    wp.init()
    if device.startswith("cuda") and not wp.is_cuda_available():
        fail(f"--device {device}: no CUDA device is available to Warp")
    torch.manual_seed(cfg.seed)
    from wqwarp.utils.threads import configure_threads

    physics_threads = args.physics_threads if args.physics_threads is not None else cfg.sim.nthread
    try:
        threads = configure_threads(args.threads, args.torch_threads, physics_threads, args.update_threads)
    except ValueError as e:
        fail(f"--{e}")
    cfg.sim.nthread = threads["physics"]

    from wqwarp.rl.config import to_dict
    from wqwarp.rl.env import WheeledGo1Env
    from wqwarp.rl.runner import WqRunner
    from wqwarp.utils.io import write_text_atomic

    log_dir = resolve_log_dir(args)
    say = print if rank == 0 else (lambda *a, **k: None)
    ranks = f" x {world} processes" if world > 1 else ""
    say(f"wqwarp: preset {args.preset}, {cfg.sim.num_envs} robots{ranks} on {device} (threads: torch "
        f"{threads['torch']}, update {threads['update']}, physics {threads['physics']}), log dir {log_dir}",
        flush=True)  # fmt: skip
    t_setup = time.time()
    try:
        env = WheeledGo1Env(cfg)
    except ValueError as e:  # a configuration the simulator refuses, a missing or broken robot asset
        fail(str(e))
    say(f"environment ready in {time.time() - t_setup:.1f} s ({env.num_obs} actor observations, "
          f"{env.num_actions} actions)", flush=True)  # fmt: skip
    if rank == 0:  # the resolved configuration (preset + command line) and the command line that produced it
        os.makedirs(log_dir, exist_ok=True)
        record = {**run_record(args), "threads": threads, "world_size": world, "env": to_dict(cfg),
                  "train": to_dict(tcfg)}  # fmt: skip
        write_text_atomic(os.path.join(log_dir, "config.json"), json.dumps(record, indent=2))
    with contextlib.redirect_stdout(io.StringIO()):  # rsl-rl prints the full networks
        runner = WqRunner(env, tcfg.rsl_rl_dict(), log_dir=log_dir, device=device)
    runner.alg.update_threads = threads["update"]
    if args.resume:
        try:
            runner.load(args.resume, restore_rng=True)
        except ValueError as e:
            fail(str(e))
        runner.current_learning_iteration += 1  # continue after the checkpoint; never rewrite it
        say(f"resumed from {args.resume} at iteration {runner.current_learning_iteration}", flush=True)
    start = runner.current_learning_iteration
    total = start + args.max_iterations if args.resume else args.max_iterations
    t0 = time.time()
    try:
        runner.learn(num_learning_iterations=total - start, init_at_random_ep_len=not args.resume)
    except (KeyboardInterrupt, Exception) as e:
        path = os.path.join(log_dir, f"model_{runner.current_learning_iteration}_interrupted.pt")
        if rank == 0:
            runner.save(path)
        print(f"\ninterrupted ({type(e).__name__}: {e}); saved {path}", file=sys.stderr)
        if isinstance(e, KeyboardInterrupt):
            return 130
        raise
    wall = time.time() - t0
    sync = runner.ranks_in_sync()  # under torchrun: every rank must end with the same networks
    if sync and rank == 0:
        print("\nranks in sync (largest parameter difference to rank 0): "
              + ", ".join(f"{k} {v:.1e}" for k, v in sync.items()), flush=True)  # fmt: skip
    if any(v > 1e-5 for v in sync.values()):
        print(f"error: the {world} ranks ended with different networks: {sync}", file=sys.stderr)
        return 1
    last = os.path.join(log_dir, f"model_{runner.current_learning_iteration}.pt")
    exported = {}
    if rank == 0 and not args.no_export:
        from wqwarp.rl.export import export_onboard_policy

        exported = export_onboard_policy(runner, os.path.join(log_dir, "export"))
    if rank == 0:
        row = runner.logger.metrics  # the last line of metrics.jsonl
        m = lambda k: float("nan") if row.get(k) is None else row[k]  # noqa: E731
        print("\n" + "=" * 72)
        print(f" preset {args.preset} | {args.num_envs} robots on {device} | {total - start} iterations in "
              f"{datetime.timedelta(seconds=int(wall))}")  # fmt: skip
        print(f" mean episode reward {m('mean_reward'):.2f} | |v_x error| {m('Metrics/vx_error'):.3f} m/s | |v_y "
              f"error| {m('Metrics/vy_error'):.3f} m/s | |w_z error| {m('Metrics/wz_error'):.3f} rad/s")  # fmt: skip
        print(f" mean p_cost {m('Metrics/p_cost'):.1f} W | {m('steps_per_s'):.0f} env steps/s")
        print(f" checkpoint  {last}")
        for k, v in exported.items():
            print(f" export      {v} ({k})")
        print(f" tensorboard --logdir {log_dir}")
        print("=" * 72)
    return 0


if __name__ == "__main__":
    sys.exit(main())
