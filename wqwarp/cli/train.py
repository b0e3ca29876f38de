"""Train the residual PPO policy of the paper on the wheeled Go1 (rsl-rl OnPolicyRunner on the wqwarp env).

Examples::

    python train/ppo_newton.py                                   # task ours: the method with its measured levers
    python train/ppo_newton.py ours-paper                        # the paper's method as written
    python train/ppo_newton.py no_predictor --max-iterations 1500 --temperature-iterations 1000
    python train/ppo_newton.py pmtg --num-envs 256 --max-iterations 2000
    python train/ppo_newton.py --print-config                    # the resolved configuration, nothing built
    python train/ppo_newton.py --resume runs/ours_20261126-0900/model_500.pt    # its own configuration, to the end
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

import contextlib
import datetime
import io
import json
import os
import sys
import time

from wqwarp.cli.args import UsageError, entry_point
from wqwarp.utils.io import directory_problem


def check_writable_dir(d: str, what: str) -> None:
    """UsageError unless ``d`` is, or can be created as, a writable directory; creates nothing."""
    problem = directory_problem(d)
    if problem:
        raise UsageError(f"{what} {d!r} {problem}")


def later_checkpoints(path: str) -> list[str]:
    """The checkpoints beside ``path`` of a later iteration (a run resumed from ``path`` in its folder would write
    over them)."""
    it, d = checkpoint_iteration(path), os.path.dirname(os.path.abspath(path))
    if it is None:
        return []
    names = [f for f in os.listdir(d) if f.startswith("model_") and f.endswith(".pt")]
    return sorted(f for f in names if (k := checkpoint_iteration(f)) is not None and k > it)


def resolve_log_dir(args) -> str:
    run = args.command
    here = os.path.dirname(os.path.abspath(run.resume)) if run.resume is not None else None
    if here is not None and (run.log_dir is None or os.path.abspath(run.log_dir) == here):
        check_writable_dir(here, "the checkpoint's folder")  # continue where the checkpoint is
        if later := later_checkpoints(run.resume):
            raise UsageError(
                f"--resume {run.resume}: its folder holds later checkpoints ({', '.join(later[:3])}) that the run "
                "would write over; resume from the last one or pass another --log-dir"
            )
        return here
    if run.log_dir is None:
        stamp = datetime.datetime.now().strftime("%Y%m%d-%H%M%S")
        d = os.path.join("runs", f"{args.task}_{stamp}")
        check_writable_dir(d, "log dir")
        return d
    d = run.log_dir
    check_writable_dir(d, "--log-dir")
    if os.path.isdir(d) and any(f.startswith("model_") for f in os.listdir(d)):
        if not (run.resume and os.path.abspath(os.path.dirname(run.resume)) == os.path.abspath(d)):
            raise UsageError(
                f"log dir {d!r} already holds checkpoints; choose another --log-dir or --resume from one of them"
            )
    return d


def checkpoint_iteration(path: str) -> int | None:
    """The iteration in a checkpoint's name (``model_500.pt``, ``model_500_interrupted.pt``), None otherwise."""
    stem = os.path.basename(path).removesuffix(".pt").removeprefix("model_").removesuffix("_interrupted")
    return int(stem) if stem.isdigit() else None


@entry_point
def main(argv=None) -> int:
    from wqwarp.cli.train_args import parse_train_args, resolved_config

    args = parse_train_args(__doc__, argv)  # the task (or the checkpoint's configuration), then the options
    run, cfg, tcfg = args.command, args.env, args.train
    if run.print_config:
        print(json.dumps(resolved_config(args), indent=2))
        return 0
    if run.resume is not None:
        it = checkpoint_iteration(run.resume)
        if it is not None and it + 1 >= tcfg.max_iterations:
            raise UsageError(
                f"--resume {run.resume}: the run already reached its {tcfg.max_iterations} iterations; "
                "pass --max-iterations N (the new total) to train on"
            )
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
        raise UsageError(f"--device {device}: no CUDA device is available to Warp")
    torch.manual_seed(cfg.seed)
    from wqwarp.utils.threads import configure_threads

    physics_threads = run.physics_threads if run.physics_threads is not None else cfg.sim.nthread
    try:
        threads = configure_threads(run.threads, run.torch_threads, physics_threads, run.update_threads)
    except ValueError as e:
        raise UsageError(f"--{e}") from None
    cfg.sim.nthread = threads["physics"]

    from wqwarp.rl.config import to_dict
    from wqwarp.rl.env import WheeledGo1Env
    from wqwarp.rl.runner import WqRunner
    from wqwarp.utils.io import write_text_atomic
    from wqwarp.utils.provenance import git_state

    log_dir = resolve_log_dir(args)
    git = git_state()  # config.json and the log's first line name the code that trained
    say = print if rank == 0 else (lambda *a, **k: None)
    ranks = f" x {world} processes" if world > 1 else ""
    say(
        f"wqwarp: task {args.task}, {cfg.sim.num_envs} robots{ranks} on {device} (threads: torch "
        f"{threads['torch']}, update {threads['update']}, physics {threads['physics']}), log dir {log_dir}, "
        f"commit {git['commit']}{' (uncommitted changes)' if git['tracked_changes'] else ''}",
        flush=True,
    )
    t_setup = time.time()
    try:
        env = WheeledGo1Env(cfg)
    except ValueError as e:  # a configuration the simulator refuses, a missing or broken robot asset
        raise UsageError(str(e)) from None
    say(
        f"environment ready in {time.time() - t_setup:.1f} s ({env.num_obs} actor observations, "
        f"{env.num_actions} actions)",
        flush=True,
    )
    if rank == 0:  # the resolved configuration (preset + command line) and the command line that produced it
        os.makedirs(log_dir, exist_ok=True)
        record = {
            **resolved_config(args),
            "git": git,
            "threads": threads,
            "world_size": world,
            "env": to_dict(cfg),
        }
        name = "config.json"  # a resumed run keeps the first record and adds its own beside it
        if run.resume and os.path.isfile(os.path.join(log_dir, name)):
            name = f"config_resume_{checkpoint_iteration(run.resume)}.json"
        write_text_atomic(os.path.join(log_dir, name), json.dumps(record, indent=2))
    with contextlib.redirect_stdout(io.StringIO()):  # rsl-rl prints the full networks
        runner = WqRunner(env, tcfg.rsl_rl_dict(), log_dir=log_dir, device=device)
    runner.alg.update_threads = threads["update"]
    runner.train_config = to_dict(tcfg)
    if run.resume:
        try:
            runner.load(run.resume, restore_rng=True)
        except ValueError as e:
            raise UsageError(str(e)) from None
        runner.current_learning_iteration += 1  # continue after the checkpoint; never rewrite it
        changed = ", ".join(f"{k} {v!r}" for k, v in args.overrides.items()) or "none"
        say(
            f"resumed from {run.resume} at iteration {runner.current_learning_iteration} with its configuration; "
            f"options over it: {changed}",
            flush=True,
        )
        for note in args.migrated:
            say(f"  (older checkpoint) {note}", flush=True)
    start = runner.current_learning_iteration
    total = tcfg.max_iterations
    if start >= total:
        raise UsageError(f"--resume {run.resume}: iteration {start} is past --max-iterations {total} (the total)")
    t0 = time.time()
    try:
        runner.learn(num_learning_iterations=total - start, init_at_random_ep_len=not run.resume)
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
        print(
            "\nranks in sync (largest parameter difference to rank 0): "
            + ", ".join(f"{k} {v:.1e}" for k, v in sync.items()),
            flush=True,
        )
    if any(v > 1e-5 for v in sync.values()):
        print(f"error: the {world} ranks ended with different networks: {sync}", file=sys.stderr)
        return 1
    last = os.path.join(log_dir, f"model_{runner.current_learning_iteration}.pt")
    exported = {}
    if rank == 0 and not run.no_export:
        from wqwarp.rl.export import export_onboard_policy

        exported = export_onboard_policy(runner, os.path.join(log_dir, "export"))
    if rank == 0:
        row = runner.logger.metrics  # the last line of metrics.jsonl
        m = lambda k: float("nan") if row.get(k) is None else row[k]  # noqa: E731
        print("\n" + "=" * 72)
        print(
            f" task {args.task} | {cfg.sim.num_envs} robots on {device} | {total - start} iterations in "
            f"{datetime.timedelta(seconds=int(wall))}"
        )
        print(
            f" mean episode reward {m('mean_reward'):.2f} | |v_x error| {m('Metrics/vx_error'):.3f} m/s | |v_y "
            f"error| {m('Metrics/vy_error'):.3f} m/s | |w_z error| {m('Metrics/wz_error'):.3f} rad/s"
        )
        print(f" mean p_cost {m('Metrics/p_cost'):.1f} W | {m('steps_per_s'):.0f} env steps/s")
        print(f" checkpoint  {last}")
        for k, v in exported.items():
            print(f" export      {v} ({k})")
        print(f" tensorboard --logdir {log_dir}")
        print("=" * 72)
    return 0


if __name__ == "__main__":
    sys.exit(main())
