"""Train the residual PPO policy of the paper on the wheeled Go1 (rsl-rl OnPolicyRunner on the wqwarp env).

Examples::

    python train/ppo_newton.py                                   # ours: predictive gait selection (4000 iterations)
    python train/ppo_newton.py --preset no_predictor --max-iterations 1500 --temperature-iterations 1000
    python train/ppo_newton.py --preset pmtg --num-envs 256 --max-iterations 2000
    python train/ppo_newton.py --resume runs/ours_20261126-0900/model_500.pt
    python train/ppo_newton.py --device cuda:0 --num-envs 4096
    torchrun --nproc_per_node=K train/ppo_newton.py --device cuda:0 --num-envs 4096   # K GPUs, rsl-rl's DDP path

Writes to the log directory: TensorBoard events (rsl-rl's plus ``Gait/*`` usage shares per command type and
temperature, ``Predictor/*`` loss and held-out relative error per gait), ``model_<it>.pt`` checkpoints (policy,
critic, optimizer, estimator, power predictor and temperature position, observation layout, env config),
``config.json``, and at the end ``export/policy.pt`` (TorchScript), ``export/policy.onnx`` and ``export/policy.json``
(the onboard policy: observation history -> estimator -> o_t -> actor, and the power predictor with its argmin rule).
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

from wqwarp.cli.args import ArgumentParser, directory_problem


def parse_args(argv=None) -> argparse.Namespace:
    from wqwarp.rl.config import PRESETS

    p = ArgumentParser(
        prog="ppo_newton.py",
        description=__doc__.split("\n\n")[0],
        epilog=__doc__.split("\n\n", 1)[1],
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument(
        "--preset",
        default="ours",
        choices=sorted(PRESETS),
        help="method of the paper to train (default: ours = predictive gait selection with nominal wheel "
        "velocities; no_wheel_vel = predictive selection without them; no_predictor = fixed augmented trotting "
        "gait; pmtg = trotting without nominal wheel velocities; baseline = no nominal gait)",
    )
    p.add_argument("--num-envs", type=int, default=128, help="parallel robots (default 128; 4096 on a GPU)")
    p.add_argument(
        "--max-iterations",
        type=int,
        default=4000,
        help="PPO iterations of 24 steps per robot each (default 4000 as in the paper; 63 min with 128 "
        "robots on 2 CPU cores, docs/train_no_predictor_increment_4000.log)",
    )
    p.add_argument(
        "--device",
        default="cpu",
        help="cpu (mujoco.rollout on all cores) or cuda:N (Newton SolverMuJoCo with CUDA graphs); "
        "under torchrun each process uses cuda:<LOCAL_RANK>",
    )
    p.add_argument("--seed", type=int, default=1, help="random seed (offset by the rank under torchrun)")
    p.add_argument(
        "--log-dir",
        default=None,
        help="output directory (default runs/<preset>_<date-time>); must not hold checkpoints already, "
        "unless --resume points into it",
    )
    p.add_argument(
        "--resume", default=None, help="checkpoint (model_<it>.pt) to continue from; its layout must match --preset"
    )
    p.add_argument("--save-interval", type=int, default=50, help="iterations between checkpoints (default 50)")
    p.add_argument("--num-steps-per-env", type=int, default=24, help="rollout length per iteration (default 24)")
    p.add_argument("--dt", type=float, default=0.005, help="physics step [s] (default 0.005; the paper uses 0.001)")
    p.add_argument(
        "--decimation",
        type=int,
        default=4,
        help="physics steps per 50 Hz policy step (default 4; the paper's dt 0.001 needs 20)",
    )
    p.add_argument(
        "--threads",
        type=int,
        default=None,
        help="CPU threads of torch and of the physics together (default: torch 1 while collecting and half the "
        "cores in the PPO update, physics every core; cores are shared among torchrun's processes; measured within "
        "1.2x of the best setting idle and with a core busy, README 'Speed and threads'). More torch threads than "
        "free cores slows training ~2x (the PPO update 2-3x) when another process holds a core",
    )
    p.add_argument(
        "--torch-threads",
        type=int,
        default=None,
        help="torch intra-op threads during collection (policy and estimator inference; overrides --threads)",
    )
    p.add_argument(
        "--update-threads",
        type=int,
        default=None,
        help="torch intra-op threads during the PPO update and the estimator / predictor fits (default: half the "
        "cores, 1 on 2 cores; overrides --threads)",
    )
    p.add_argument(
        "--physics-threads", type=int, default=None, help="mujoco.rollout threads (CPU; overrides --threads)"
    )
    p.add_argument(
        "--true-state",
        action="store_true",
        help="debug: feed the true base velocity and height to the policy instead of the estimator's",
    )
    p.add_argument(
        "--phase-residual",
        choices=("increment", "offset"),
        default=None,
        help="how the policy's phase residual enters the gait phase: offset (an offset from the gait clock, as the "
        "authors' generator PMTG.py; the default) or increment (accumulated every policy step: the policy can stop "
        "the gait clock, see the README)",
    )
    p.add_argument(
        "--temperature",
        type=float,
        nargs=2,
        default=None,
        metavar=("START", "END"),
        help="predictive presets: softmax temperature tau at iteration 0 and at the end of the annealing "
        "(default 2 0.05, fractions of the mean predicted power; in W with --power-normalization watts)",
    )
    p.add_argument(
        "--power-normalization",
        choices=("mean", "watts"),
        default=None,
        help="predictive presets: softmax over p_est / mean(p_est) (mean, the default: tau is scale-free) or over "
        "p_est in W (watts: the paper's formula literally; collapses on driving early, see the README)",
    )
    p.add_argument(
        "--temperature-iterations",
        type=int,
        default=None,
        help="predictive presets: iterations over which tau is annealed, constant afterwards (default 2000)",
    )
    p.add_argument(
        "--temperature-shape",
        choices=("exponential", "linear", "cosine"),
        default=None,
        help="predictive presets: interpolation of tau between its ends (default exponential)",
    )
    p.add_argument(
        "--decision-interval",
        type=float,
        default=None,
        help="predictive presets: seconds a selected gait is held before the next selection (default 1.0, the "
        "prediction horizon)",
    )
    p.add_argument(
        "--reward",
        action="append",
        default=[],
        metavar="TERM=WEIGHT",
        help="override one weight of the paper's Table II, e.g. --reward energy=-1e-4 (repeatable; terms: "
        "track_vx, track_vy, track_wz, residual, orientation, lin_vel_z, ang_vel_xy, joint_acc, torques, "
        "action_smoothness, collision, energy)",
    )
    p.add_argument("--no-export", action="store_true", help="skip the TorchScript / ONNX export at the end")
    return p.parse_args(argv)


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


class Progress:
    """One status line per iteration instead of rsl-rl's block: progress bar, ETA and the key metrics."""

    def __init__(self, runner, total: int, start: int):
        self.runner, self.total, self.start, self.t0 = runner, total, start, time.time()
        self.metrics: dict = {}
        logger = runner.logger
        original = logger.log

        def log(**kw):
            if logger.writer is None:  # ranks other than 0 under torchrun: nothing to show
                return original(**kw)
            ep = {}
            for info in logger.ep_extras:
                for k, v in info.items():
                    ep.setdefault(k, []).append(float(v.mean()) if hasattr(v, "mean") else float(v))
            with contextlib.redirect_stdout(io.StringIO()):
                original(**kw)
            self.line(kw["it"], ep, kw["collect_time"], kw["learn_time"])

        logger.log = log

    def line(self, it: int, ep: dict, collect: float, learn: float) -> None:
        import statistics

        from wqwarp.rl.gait_selection import usage_from_scalars

        done = it + 1 - self.start
        frac = (it + 1) / max(self.total, 1)
        elapsed = time.time() - self.t0
        eta = elapsed / max(done, 1) * (self.total - it - 1)
        r = self.runner.logger.rewbuffer
        mean = lambda k: sum(ep[k]) / len(ep[k]) if ep.get(k) else float("nan")  # noqa: E731
        gait = self.runner.last_gait_scalars
        robots = self.runner.env.num_envs * self.runner.gpu_world_size  # all ranks under torchrun
        sps = robots * self.runner.cfg["num_steps_per_env"] / max(collect + learn, 1e-9)
        self.metrics = {
            "iteration": it + 1, "mean_reward": statistics.mean(r) if len(r) else float("nan"),
            "vx_error": mean("Metrics/vx_error"), "vy_error": mean("Metrics/vy_error"),
            "wz_error": mean("Metrics/wz_error"), "p_cost": mean("Metrics/p_cost"), "steps_per_s": sps,
            "p_cost_legs": mean("Metrics/p_cost_legs"), "p_cost_wheels": mean("Metrics/p_cost_wheels"),
        }  # fmt: skip
        bar = "#" * int(20 * frac) + "-" * (20 - int(20 * frac))
        m = self.metrics
        status = (f"[{bar}] {it + 1}/{self.total} ETA {datetime.timedelta(seconds=int(eta))} | "
                  f"reward {m['mean_reward']:7.2f} | err vx {m['vx_error']:.2f} vy {m['vy_error']:.2f} "
                  f"wz {m['wz_error']:.2f} | power {m['p_cost']:6.1f} W (legs {m['p_cost_legs']:5.1f}, wheels "
                  f"{m['p_cost_wheels']:5.1f}) | {sps:6.0f} steps/s")  # fmt: skip
        usage = usage_from_scalars(gait)
        if usage:
            shares = " ".join(f"{n[:5]} {100 * v:3.0f}%" for n, v in usage.items())
            status += f" | gaits {shares}"
            if "Gait/temperature" in gait:
                status += f" tau {gait['Gait/temperature']:.2g}"
        self.metrics.update({k: v for k, v in gait.items()})
        print("\r" + status, end="", flush=True)
        if (it + 1) % 10 == 0 or it + 1 == self.total:
            print(flush=True)


def main(argv=None) -> int:
    args = parse_args(argv)
    if args.num_envs < 1 or args.max_iterations < 1 or args.save_interval < 1 or args.num_steps_per_env < 1:
        fail("--num-envs, --max-iterations, --save-interval and --num-steps-per-env must be positive")
    if args.resume and not os.path.isfile(args.resume):
        fail(f"--resume: no such checkpoint {args.resume!r}")
    world = int(os.getenv("WORLD_SIZE", "1"))
    rank = int(os.getenv("RANK", "0"))
    device = args.device
    if world > 1 and device.startswith("cuda"):
        device = f"cuda:{int(os.getenv('LOCAL_RANK', '0'))}"  # one GPU per process
    if not (device == "cpu" or device.startswith("cuda")):
        fail(f"--device must be cpu or cuda:N, got {device!r}")

    import torch
    import warp as wp

    wp.config.quiet = True
    wp.init()
    if device.startswith("cuda") and not wp.is_cuda_available():
        fail(f"--device {device}: no CUDA device is available to Warp")
    torch.manual_seed(args.seed + rank)
    from wqwarp.utils.threads import configure_threads

    try:
        threads = configure_threads(args.threads, args.torch_threads, args.physics_threads, args.update_threads)
    except ValueError as e:
        fail(f"--{e}")

    from wqwarp.rl.config import TrainConfig, make_preset, to_dict
    from wqwarp.rl.env import WheeledGo1Env
    from wqwarp.rl.runner import WqRunner, export_onboard_policy

    log_dir = resolve_log_dir(args)
    cfg = make_preset(args.preset)
    cfg.sim.num_envs = args.num_envs
    cfg.sim.device = device
    cfg.sim.dt = args.dt
    cfg.sim.decimation = args.decimation
    cfg.sim.nthread = threads["physics"]
    cfg.seed = args.seed + rank
    cfg.estimator.use_true_state = args.true_state
    if args.phase_residual is not None:
        cfg.action.phase_residual_mode = args.phase_residual
    from wqwarp.rl.config import REWARD_TERMS

    for item in args.reward:
        term, _, value = item.partition("=")
        if term not in REWARD_TERMS:
            fail(f"--reward {item!r}: unknown term {term!r}; terms: {', '.join(REWARD_TERMS)}")
        try:
            setattr(cfg.reward, term, float(value))
        except ValueError:
            fail(f"--reward {item!r}: the weight must be a number")
    p = cfg.predictor
    if args.temperature is not None:
        p.temperature_start, p.temperature_end = args.temperature
    if args.power_normalization is not None:
        p.power_normalization = args.power_normalization
    if args.temperature_iterations is not None:
        p.temperature_iterations = args.temperature_iterations
    if args.temperature_shape is not None:
        p.temperature_shape = args.temperature_shape
    if args.decision_interval is not None:
        if args.decision_interval <= 0:
            fail(f"--decision-interval must be > 0 s, got {args.decision_interval}")
        p.decision_interval_s = args.decision_interval
    if args.temperature is not None and min(args.temperature) <= 0:
        fail(f"--temperature values must be > 0, got {args.temperature}")
    if args.temperature_iterations is not None and args.temperature_iterations < 0:
        fail(f"--temperature-iterations must be >= 0, got {args.temperature_iterations}")
    tcfg = TrainConfig(max_iterations=args.max_iterations, save_interval=args.save_interval,
                       num_steps_per_env=args.num_steps_per_env)  # fmt: skip
    say = print if rank == 0 else (lambda *a, **k: None)
    ranks = f" x {world} processes" if world > 1 else ""
    say(f"wqwarp: preset {args.preset}, {args.num_envs} robots{ranks} on {device} (threads: torch "
        f"{threads['torch']}, update {threads['update']}, physics {threads['physics']}), log dir {log_dir}",
        flush=True)  # fmt: skip
    t_setup = time.time()
    try:
        env = WheeledGo1Env(cfg)
    except ValueError as e:  # a configuration the simulator refuses, a missing or broken robot asset
        fail(str(e))
    say(f"environment ready in {time.time() - t_setup:.1f} s ({env.num_obs} actor observations, "
          f"{env.num_actions} actions)", flush=True)  # fmt: skip
    if rank == 0:
        os.makedirs(log_dir, exist_ok=True)
        with open(os.path.join(log_dir, "config.json"), "w", encoding="utf-8") as f:
            json.dump({"args": vars(args), "threads": threads, "world_size": world, "env": to_dict(cfg),
                       "train": to_dict(tcfg)}, f, indent=2)  # fmt: skip
    with contextlib.redirect_stdout(io.StringIO()):  # rsl-rl prints the full networks
        runner = WqRunner(env, tcfg.rsl_rl_dict(), log_dir=log_dir, device=device)
    runner.update_threads = threads["update"]
    if args.resume:
        try:
            runner.load(args.resume, restore_rng=True)
        except ValueError as e:
            fail(str(e))
        runner.current_learning_iteration += 1  # continue after the checkpoint; never rewrite it
        say(f"resumed from {args.resume} at iteration {runner.current_learning_iteration}", flush=True)
    start = runner.current_learning_iteration
    total = start + args.max_iterations if args.resume else args.max_iterations
    progress = Progress(runner, total, start)
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
        exported = export_onboard_policy(runner, os.path.join(log_dir, "export"))
    if rank == 0:
        m = progress.metrics
        print("\n" + "=" * 72)
        print(f" preset {args.preset} | {args.num_envs} robots on {device} | {total - start} iterations in "
              f"{datetime.timedelta(seconds=int(wall))}")  # fmt: skip
        print(f" mean episode reward {m.get('mean_reward', float('nan')):.2f} | |v_x error| "
              f"{m.get('vx_error', float('nan')):.3f} m/s | |v_y error| {m.get('vy_error', float('nan')):.3f} m/s | "
              f"|w_z error| {m.get('wz_error', float('nan')):.3f} rad/s")  # fmt: skip
        print(f" mean p_cost {m.get('p_cost', float('nan')):.1f} W | {m.get('steps_per_s', 0):.0f} env steps/s")
        print(f" checkpoint  {last}")
        for k, v in exported.items():
            print(f" export      {v} ({k})")
        print(f" tensorboard --logdir {log_dir}")
        print("=" * 72)
    return 0


if __name__ == "__main__":
    sys.exit(main())
