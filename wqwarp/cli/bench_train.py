"""Training throughput against the simulator's limit, in one process: simulator, collection and PPO training.

Usage::

    python tools/bench_train.py [--sizes 128,256,512] [--task ours] [--iterations 6] [--device cpu]
                                [--threads N | --torch-threads T --physics-threads P] [--busy K] [--json PATH]

For each robot count N (all in robot-policy-steps per second, one policy step = ``decimation`` physics substeps):

    sim_steps_per_s      ``Simulator.step`` alone with fixed targets (actuation, power, physics, FK, contacts)
    collect_steps_per_s  rsl-rl's rollout loop without the update: ``alg.act`` (policy inference) + ``env.step``
                         (nominal gait, IK, physics, rewards, resets, commands, pushes, estimator, gait selection,
                         observations) + ``alg.process_env_step`` + the logger's bookkeeping
    train_steps_per_s    ``WqRunner.learn``: collection + returns + PPO update + estimator and predictor fits,
                         N x num_steps_per_env x iterations / wall time (after one warm-up iteration)
    train_vs_sim         train_steps_per_s / sim_steps_per_s
    breakdown_s          seconds per training iteration by stage, from a second, instrumented run of the same
                         iterations (rates come from the plain run; the algorithm's stages are timed by a subclass
                         of the training algorithm, :class:`TimedPPO`, the env's and simulator's by wrapping their
                         methods):
                         physics (MuJoCo: ``mujoco.rollout`` / ``SolverMuJoCo.step``), sim_kernels (the rest of
                         ``Simulator.step``: actuation, power, state mirror, FK, contacts), env_kernels (nominal gait,
                         residual targets, rewards), env_resets (resets, pushes), estimator_inference,
                         gait_selection (predictor inference and sampling), env_torch (the rest of ``env.step``:
                         observations, bookkeeping), policy_inference (``alg.act``), storage (rsl-rl's
                         process_env_step), returns, ppo_update, estimator_fit, predictor_fit, other (the logger's
                         bookkeeping and logging among it).

``--busy K`` runs K processes that each spin one core for the whole measurement (a laptop is never idle).
Threads: ``--threads N`` sets torch's intra-op threads and the physics threads (``mujoco.rollout``) together, as
``train/ppo_newton.py --threads`` does; without it the training defaults are used (``wqwarp.utils.threads``).
"""

from __future__ import annotations

import contextlib
import io
import multiprocessing as mp
import os
import sys
import time

from wqwarp.cli.args import UsageError, doc_parser, entry_point
from wqwarp.cli.bench import add_bench_options, device_description, parse_bench_args
from wqwarp.rl.algorithm import WqPPO

STAGES = (
    "physics",
    "sim_kernels",
    "env_kernels",
    "env_resets",
    "estimator_inference",
    "gait_selection",
    "env_torch",
    "policy_inference",
    "storage",
    "returns",
    "ppo_update",
    "estimator_fit",
    "predictor_fit",
    "other",
)


def _spin(stop, parent: int) -> None:
    x = 0
    while not stop.is_set() and os.getppid() == parent:  # also ends when its parent is killed
        for _ in range(100000):
            x += 1


class Busy:
    """K processes, each spinning one core until the context exits."""

    def __init__(self, k: int):
        self.k = k
        self.procs: list = []

    def __enter__(self):
        ctx = mp.get_context("spawn")
        self.stop = ctx.Event()
        self.procs = [ctx.Process(target=_spin, args=(self.stop, os.getpid()), daemon=True) for _ in range(self.k)]
        for p in self.procs:
            p.start()
        time.sleep(0.5 if self.k else 0.0)
        return self

    def __exit__(self, *exc):
        self.stop.set()
        for p in self.procs:
            p.join(timeout=5)
            if p.is_alive():
                p.terminate()


class StageTimer:
    """Adds the wall time of calls to stages (time in nested timed calls is subtracted from the outer stage)."""

    def __init__(self, sync):
        self.sync = sync
        self.totals = dict.fromkeys(STAGES, 0.0)
        self._stack: list[list] = []
        self.enabled = False

    def call(self, stage: str, fn, *a, **kw):
        """``fn(*a, **kw)``, its time added to ``stage`` while :attr:`enabled`."""
        if not self.enabled:
            return fn(*a, **kw)
        self.sync()
        frame = [stage, 0.0]  # stage, time spent in nested timed calls
        self._stack.append(frame)
        t0 = time.perf_counter()
        try:
            return fn(*a, **kw)
        finally:
            self.sync()
            dt = time.perf_counter() - t0
            self._stack.pop()
            self.totals[stage] += dt - frame[1]
            if self._stack:
                self._stack[-1][1] += dt

    def wrap(self, obj, name: str, stage: str) -> None:
        """Time method ``name`` of this project's object ``obj`` (env, simulator, estimator, selector) as
        ``stage``."""
        fn = getattr(obj, name)
        setattr(obj, name, lambda *a, **kw: self.call(stage, fn, *a, **kw))


class TimedPPO(WqPPO):
    """The training algorithm with its stages timed by :attr:`timer` (None: not timed): policy inference, storage,
    returns, the PPO update, and the extensions' fits (``other`` around the two fits)."""

    def __init__(self, *args, **kwargs) -> None:
        super().__init__(*args, **kwargs)
        self.timer: StageTimer | None = None

    def _call(self, stage: str, fn, *a, **kw):
        return fn(*a, **kw) if self.timer is None else self.timer.call(stage, fn, *a, **kw)

    def act(self, obs):
        return self._call("policy_inference", super().act, obs)

    def process_env_step(self, *a, **kw):
        return self._call("storage", super().process_env_step, *a, **kw)

    def compute_returns(self, obs):
        return self._call("returns", super().compute_returns, obs)

    def update(self):
        return self._call("ppo_update", super().update)

    def fit_extensions(self):
        return self._call("other", super().fit_extensions)


class _TimedRollout:
    """Stand-in for ``mujoco.rollout.Rollout`` whose ``rollout`` call is timed as physics."""

    def __init__(self, inner, timer: StageTimer):
        self._inner = inner
        timer.wrap(self, "rollout", "physics")

    def rollout(self, *a, **kw):
        return self._inner.rollout(*a, **kw)


def instrument(runner, timer: StageTimer) -> None:
    """Time the stages of ``runner`` (built with ``algorithm.class_name`` naming :class:`TimedPPO`) in ``timer``."""
    env = runner.env
    sim = env.sim
    physics = sim.physics  # the backend (wqwarp.sim.backends): mujoco.rollout on the CPU, a Newton solver otherwise
    if hasattr(physics, "rollout"):
        physics.rollout = _TimedRollout(physics.rollout, timer)
    else:
        timer.wrap(physics.solver, "step", "physics")
    timer.wrap(sim, "step", "sim_kernels")
    timer.wrap(env, "_apply_actions", "env_kernels")
    timer.wrap(env, "_compute_rewards", "env_kernels")
    timer.wrap(env, "_reset_envs", "env_resets")
    timer.wrap(env, "_push_robots", "env_resets")
    timer.wrap(env.estimator, "forward", "estimator_inference")
    timer.wrap(env.gait_selector, "select", "gait_selection")
    timer.wrap(env, "step", "env_torch")
    timer.wrap(env.estimator_trainer, "fit", "estimator_fit")
    timer.wrap(env.gait_selector, "fit", "predictor_fit")
    runner.alg.timer = timer  # TimedPPO: act, process_env_step, compute_returns, update (around the fits)


def bench(n: int, args, threads: dict) -> dict:
    import torch
    import warp as wp

    from wqwarp.rl.env import WheeledGo1Env
    from wqwarp.rl.runner import WqRunner
    from wqwarp.rl.tasks import TASKS

    cfg, train = TASKS[args.task].make()
    cfg.sim.num_envs = n
    cfg.sim.device = args.device
    cfg.sim.nthread = threads["physics"]
    cfg.seed = args.seed
    torch.manual_seed(args.seed)
    env = WheeledGo1Env(cfg)
    train.num_steps_per_env = args.steps_per_env
    train.algorithm_class = f"{__name__}:TimedPPO"
    for name in ("num_learning_epochs", "num_mini_batches"):
        if getattr(args, name) is not None:
            setattr(train, name, getattr(args, name))
    train_cfg = train.rsl_rl_dict()
    with contextlib.redirect_stdout(io.StringIO()):
        runner = WqRunner(env, train_cfg, log_dir=None, device=env.device)
    runner.alg.update_threads = threads["update"]
    dev = wp.get_device(args.device)

    def sync():
        if dev.is_cuda:
            wp.synchronize_device(dev)
            torch.cuda.synchronize()

    sim = env.sim

    def timed(fn, seconds: float) -> float:
        fn()
        sync()
        k, t0 = 0, time.perf_counter()
        while time.perf_counter() - t0 < seconds or k < 3:
            fn()
            k += 1
        sync()
        return k / (time.perf_counter() - t0)

    def learn(iterations: int) -> float:
        sync()
        t0 = time.perf_counter()
        with contextlib.redirect_stdout(io.StringIO()):
            runner.learn(iterations)
        sync()
        return time.perf_counter() - t0

    def collect():
        obs = env.get_observations()
        with torch.inference_mode():
            for _ in range(args.steps_per_env):
                actions = runner.alg.act(obs)
                obs, rewards, dones, extras = env.step(actions)
                runner.alg.process_env_step(obs, rewards, dones, extras)
                runner.logger.process_env_step(rewards, dones, extras, None)
        runner.alg.storage.clear()
        env.estimator_trainer.clear()

    learn(1)  # warm-up: compiles kernels, fills the predictor's replay past its first fit
    wall = learn(args.iterations)
    train_sps = n * args.steps_per_env * args.iterations / wall
    timer = StageTimer(sync)
    instrument(runner, timer)
    timer.enabled = True
    wall_i = learn(args.iterations)
    timer.enabled = False
    breakdown = {k: v / args.iterations for k, v in timer.totals.items()}
    breakdown["other"] += wall_i / args.iterations - sum(timer.totals.values()) / args.iterations
    env.collect_training_data = True
    collect_sps = n * args.steps_per_env * timed(collect, args.seconds)
    env.collect_training_data = False
    sim.reset(list(range(n)))
    sim_sps = n * timed(sim.step, args.seconds)
    return {
        "n": n,
        "num_learning_epochs": train.num_learning_epochs,
        "num_mini_batches": train.num_mini_batches,
        "sim_steps_per_s": round(sim_sps, 1),
        "collect_steps_per_s": round(collect_sps, 1),
        "train_steps_per_s": round(train_sps, 1),
        "collect_vs_sim": round(collect_sps / sim_sps, 3),
        "train_vs_sim": round(train_sps / sim_sps, 3),
        "iteration_s": round(wall / args.iterations, 4),
        "breakdown_s": {k: round(v, 4) for k, v in breakdown.items()},
    }


@entry_point
def main(argv: list[str] | None = None) -> int:
    ap = doc_parser(__doc__)
    add_bench_options(ap, "128,256,512")
    ap.add_argument(
        "--task",
        default="ours",
        help="training task whose configuration is timed (wqwarp/rl/tasks.py; default ours: the most work per step)",
    )
    ap.add_argument("--iterations", type=int, default=6, help="timed training iterations per N (default 6)")
    ap.add_argument("--steps-per-env", type=int, default=24, help="rollout length per iteration (default 24)")
    ap.add_argument(
        "--seconds",
        type=float,
        default=3.0,
        help="minimum wall time of the simulator and collection measurements (default 3)",
    )
    ap.add_argument(
        "--threads",
        type=int,
        default=None,
        help="torch and physics threads together (default: the training defaults, wqwarp.utils.threads)",
    )
    ap.add_argument("--torch-threads", type=int, default=None, help="torch intra-op threads (overrides --threads)")
    ap.add_argument("--physics-threads", type=int, default=None, help="mujoco.rollout threads (overrides --threads)")
    ap.add_argument(
        "--update-threads",
        type=int,
        default=None,
        help="torch threads during the PPO update and fits (overrides --threads)",
    )
    ap.add_argument(
        "--num-learning-epochs",
        type=int,
        default=None,
        help="PPO epochs per update (default: the task's, --train.num-learning-epochs of train/ppo_newton.py)",
    )
    ap.add_argument(
        "--num-mini-batches",
        type=int,
        default=None,
        help="PPO minibatches per epoch (default: the task's, --train.num-mini-batches)",
    )
    ap.add_argument("--busy", type=int, default=0, help="processes spinning one core each while measuring (default 0)")
    ap.add_argument("--seed", type=int, default=1, help="seed of the env and the networks (default 1)")
    args, sizes = parse_bench_args(ap, argv)
    for name in ("iterations", "steps_per_env", "num_learning_epochs", "num_mini_batches"):
        v = getattr(args, name)
        if v is not None and v < 1:
            raise UsageError(f"--{name.replace('_', '-')} must be >= 1, got {v}")
    if args.busy < 0 or args.seconds <= 0:
        raise UsageError("--busy must be >= 0 and --seconds > 0")
    from wqwarp.rl.tasks import TASKS

    if args.task not in TASKS:
        raise UsageError(f"unknown --task {args.task!r}; choose one of {', '.join(TASKS)}")
    import warp as wp

    from wqwarp import quiet_warp
    from wqwarp.utils import provenance
    from wqwarp.utils.threads import configure_threads

    quiet_warp()
    wp.init()
    try:
        dev = wp.get_device(args.device)
    except Exception as e:  # noqa: BLE001 - Warp raises several types for unknown devices
        raise UsageError(f"--device {args.device!r}: {e}") from None
    try:
        threads = configure_threads(args.threads, args.torch_threads, args.physics_threads, args.update_threads)
    except ValueError as e:
        raise UsageError(f"--{e}") from None
    desc = device_description(dev)
    print(
        f"device: {desc}; task {args.task}; threads torch {threads['torch']} update {threads['update']} "
        f"physics {threads['physics']}; "
        f"{args.busy} busy core(s)",
        flush=True,
    )
    print(
        f"{'N':>6} {'sim st/s':>10} {'collect st/s':>13} {'train st/s':>11} {'train/sim':>9}  slowest stages",
        flush=True,
    )
    results = []
    with Busy(args.busy):
        for n in sizes:
            r = bench(n, args, threads)
            results.append(r)
            top = sorted(r["breakdown_s"].items(), key=lambda kv: -kv[1])[:4]
            stages = ", ".join(f"{k} {v * 1e3:.0f} ms" for k, v in top)
            print(
                f"{n:>6} {r['sim_steps_per_s']:>10.0f} {r['collect_steps_per_s']:>13.0f} "
                f"{r['train_steps_per_s']:>11.0f} {r['train_vs_sim']:>9.2f}  {stages}",
                flush=True,
            )
    if args.json:
        out = {
            "device": desc,
            "task": args.task,
            "threads": threads,
            "busy_cores": args.busy,
            "iterations": args.iterations,
            "steps_per_env": args.steps_per_env,
            "seed": args.seed,
            "results": results,
        }
        provenance.write_result_json(args.json, out)
        print(f"wrote {args.json}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
