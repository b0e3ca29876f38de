"""The paper's tracking, push-recovery and sim-to-sim protocols (Sec. IV-A, Table III) of a trained checkpoint.

Tracking: robots get commands of one axis spread evenly over the task's range (``wqwarp.eval.metrics.TASKS``) and
hold them for the whole run; the metrics (``wqwarp.eval.metrics``) are taken after a settling time. Push recovery
(Table III): random velocity impulses up to ``max_push`` along the trunk's x and y every ``push_interval`` seconds; a
robot recovers if its trunk never touches the ground. Sim-to-sim: the same tasks under other physics
(``wqwarp.eval.physics``), with each metric's change against the training physics.
"""

from __future__ import annotations

import dataclasses
import os
import time
from dataclasses import dataclass
from typing import TextIO

import torch

from wqwarp.control.gaits import gait_index
from wqwarp.eval.metrics import PUSH_TASKS, TASKS, EvalResult, TaskMetrics, check_task, physics_delta
from wqwarp.eval.options import SelectionOptions, option
from wqwarp.eval.physics import PHYSICS_VARIANTS, physics_variant
from wqwarp.eval.rollout import base_velocity, evaluation_session, start_rollout
from wqwarp.rl.gait_selection import usage_from_scalars
from wqwarp.rl.presets import PRESETS


def spread_commands(task: str, n: int, command_range: tuple[float, float] | None = None) -> torch.Tensor:
    """(n, 3) commands with only the task's axis set, evenly spread over its range (default: ``TASKS``)."""
    axis, (lo, hi) = TASKS[task]
    if command_range is not None:
        lo, hi = command_range
    cmd = torch.zeros(n, 3)
    cmd[:, axis] = torch.linspace(lo, hi, n) if n > 1 else torch.tensor([(lo + hi) / 2])
    return cmd


@torch.no_grad()
def run_task(
    runner,
    task: str,
    seconds: float,
    settle: float = 2.0,
    max_push: float = 0.0,
    push_interval: float = 15.0,
    progress=None,
    command_range: tuple[float, float] | None = None,
    forced_gait: int | None = None,
) -> EvalResult:
    """Roll out ``runner.policy`` (``wqwarp.eval.loading.PolicyRunner``) on ``task`` for ``seconds`` [s], measuring
    after ``settle`` [s]; ``command_range`` replaces the task's range (e.g. ``PUSH_TASKS``); ``forced_gait``
    (predictive selection only) runs that gait instead of the selected one. The env is left as it was found
    (``evaluation_session``)."""
    check_task(task)
    env = runner.env
    with evaluation_session(env):
        return _run_task(runner, task, seconds, settle, max_push, push_interval, progress, command_range, forced_gait)


def _run_task(
    runner, task, seconds, settle, max_push, push_interval, progress, command_range, forced_gait
) -> EvalResult:
    env, sel = runner.env, runner.env.gait_selector
    axis, rng = TASKS[task]
    rng = tuple(command_range) if command_range is not None else rng
    c = env.cfg.commands
    train_rng = (c.vx_range, c.vy_range, c.wz_range)[axis]
    outside = rng[0] < train_rng[0] - 1e-9 or rng[1] > train_rng[1] + 1e-9
    n = env.num_envs
    predictive = sel.name == "predictive"
    if forced_gait is not None:
        if not predictive:
            raise ValueError(f"a forced gait needs the predictive gait selection, not {sel.name!r}")
        sel.force(forced_gait)
    cmd = spread_commands(task, n, rng).to(env.device)
    obs = start_rollout(env, cmd, seconds)  # every observation, also after a reset, carries the task's command
    steps = int(round(seconds / env.dt))
    settle_steps = int(round(settle / env.dt))
    push_steps = int(round(push_interval / env.dt)) if max_push > 0 else 0
    fell = torch.zeros(n, dtype=torch.bool, device=env.device)
    falls = 0
    sel.log_scalars()  # restart the selector's usage counters
    pred_sum = torch.zeros(n, max(sel.num_gaits, 1), device=env.device)
    pred_run = torch.zeros(n, device=env.device)
    metrics = TaskMetrics(task, cmd)
    for k in range(steps):
        if push_steps and k > 0 and k % push_steps == 0:
            env._push_robots(max_push)
        if predictive:
            p_now = sel.predict(obs["policy"])
        obs, _, dones, _ = env.step(runner.policy(obs))
        running_now = env.active_gait()
        fell |= dones.bool()
        falls += int(dones.sum())
        if k >= settle_steps:
            if predictive:  # the prediction made from the o_t this step started from
                pred_sum += p_now
                pred_run += p_now.gather(1, running_now[:, None]).squeeze(1)
            metrics.add(base_velocity(env), env.tv)
        if progress is not None:
            progress(k + 1, steps)
    gait = sel.log_scalars()
    c = max(metrics.steps, 1)
    predicted = predicted_running = None
    if predictive:  # over all robots, as every metric; falls are reported beside them
        mean_pred = (pred_sum / c).mean(0)
        predicted = {g: float(mean_pred[i]) for i, g in enumerate(sel.gait_names)}
        predicted_running = float((pred_run / c).mean())
    return EvalResult(
        task=task,
        num_robots=n,
        seconds=seconds,
        **metrics.summary(env.sim.robot_mass, env.sim.motor_model.electronics_w),
        upright=float((~fell).float().mean()),
        falls=falls,
        max_push=max_push,
        command_range=list(rng),
        outside_training_range=outside,
        gait_usage=usage_from_scalars(gait) or None,
        gait_switches_per_robot_minute=gait.get("Gait/switches_per_robot_minute", 0.0),
        falls_within_1s_of_switch=int(gait.get("Gait/falls_within_1s_of_switch", 0)),
        predicted_power=predicted,
        predicted_power_running=predicted_running,
        fallen_commands=sorted(round(float(v), 4) for v in cmd[fell, axis].cpu()),
    )


SIM2SIM_CHOICES = tuple(k for k in PHYSICS_VARIANTS if k != "train")


@dataclass(kw_only=True)
class TrackingOptions(SelectionOptions):
    """Options of the tracking, push and sim-to-sim protocols (``train/evaluate.py``)."""

    preset: str | None = option(
        None,
        choices=tuple(PRESETS),
        help="label of the results; must be the method the "
        "checkpoint was trained as (default: the preset in the run's config.json). The "
        "environment is always built from the configuration stored in the checkpoint",
    )
    tasks: str = option("vx,vy,wz", help=f"comma-separated tasks from {', '.join(TASKS)} (default vx,vy,wz)")
    num_envs: int | None = option(None, help="robots per task (default 100; the paper uses 1000)")
    seconds: float | None = option(None, help="length of each rollout [s] (default 20; 60 push)")
    paper_scale: bool = option(
        False,
        help="the paper's scale: 1000 robots and 60 s per task (unless --num-envs / "
        "--seconds say otherwise); about 30x the default's cost",
    )
    push: float = option(0.0, help="max push velocity [m/s]; 0 disables pushes (default)")
    push_interval: float = option(15.0, help="seconds between pushes (default 15, as the paper)")
    push_levels: str = option("0.5,0.7", help="push protocol: comma-separated max push velocities [m/s]")
    physics: str = option(
        "",
        help="sim-to-sim: comma-separated physics to evaluate after the training physics, from "
        f"{', '.join(SIM2SIM_CHOICES)}; deltas against the training physics are printed",
    )
    robot: str | None = option(
        None,
        help="sim-to-sim: the robot description (USD or MJCF) that the physics authors_robot and "
        "authors_robot_control build, e.g. the paper authors' tests/data/authors_wheeled_go1/wheeled_go1.xml "
        "(github xu-yang16/wheeled-quadruped-sim2sim, resources/wheeled_go1/xml/, MIT)",
    )
    dt: float | None = option(
        None,
        help="physics step [s] (default: the training value 0.005); the "
        "policy keeps its 50 Hz step, e.g. --dt 0.001 checks that a power figure is not an "
        "artefact of the time step (the paper trains at 0.001)",
    )
    sample_gaits: bool = option(
        False,
        help="predictive presets: sample gaits from softmax(-p/tau) at the "
        "checkpoint's tau instead of the argmin (the default, tau -> 0)",
    )
    force_gait: str | None = option(
        None,
        help="predictive presets, diagnostics: run this gait of the checkpoint's "
        "library instead of the selected one; the predictor's forecast for it is "
        "reported beside the realised power",
    )
    zero_residual: bool = option(
        False,
        help="diagnostics, presets with a nominal gait: every action 0 instead of "
        "the policy's (the nominal gait with no residual); with --tasks stand,vx "
        "--force-gait driving it measures the floor the learned residual's power is "
        "compared with (train/reproduce.py stage nominal)",
    )

    def __post_init__(self) -> None:
        if self.seconds is None:
            self.seconds = 60.0 if self.paper_scale else 20.0
        if self.num_envs is None:
            self.num_envs = 1000 if self.paper_scale else 100

    def physics_list(self) -> list[str]:
        return [x.strip() for x in self.physics.split(",") if x.strip()]

    def task_list(self) -> list[str]:
        return [t.strip() for t in self.tasks.split(",") if t.strip()]

    def levels(self) -> list[float]:
        try:
            levels = [float(x) for x in self.push_levels.split(",") if x.strip()]
        except ValueError:
            levels = []
        if not levels or min(levels) <= 0:
            raise ValueError(f"--push-levels {self.push_levels!r}: need positive velocities, e.g. 0.5,0.7")
        return levels

    def validate(self) -> None:
        bad_physics = [x for x in self.physics_list() if x not in SIM2SIM_CHOICES]
        if bad_physics:
            raise ValueError(f"--physics {bad_physics}: choose from {', '.join(SIM2SIM_CHOICES)}")
        needs_robot = [x for x in self.physics_list() if PHYSICS_VARIANTS[x].robot]
        if needs_robot and not self.robot:
            raise ValueError(f"--physics {','.join(needs_robot)} builds the robot from --robot PATH; none given")
        if self.robot and not os.path.isfile(self.robot):
            raise ValueError(f"--robot {self.robot}: no such file")
        if self.push_interval <= 0:
            raise ValueError(f"--push-interval must be > 0 s, got {self.push_interval}")
        self.levels()
        bad = [t for t in self.task_list() if t not in TASKS]
        if bad or not self.task_list():
            raise ValueError(f"unknown task(s) {bad}; choose from {', '.join(TASKS)}")
        if self.num_envs < 1 or self.seconds <= 2.0:
            raise ValueError("need --num-envs >= 1 and --seconds > 2 (the settling time)")


def tracking(opts: TrackingOptions, log: TextIO) -> dict:
    """Tracking error and power per task over the paper's command ranges (``--push`` adds pushes)."""
    return _evaluate(opts, log, "tracking")


def push(opts: TrackingOptions, log: TextIO) -> dict:
    """Table III: pushes up to each of ``push_levels`` during the tasks stand, v_x, v_y, w in [-1, 1]."""
    return _evaluate(opts, log, "push")


def sim2sim(opts: TrackingOptions, log: TextIO) -> dict:
    """Tracking under the training physics and under each of ``physics``, with the deltas."""
    return _evaluate(opts, log, "sim2sim")


def zero_policy(env):
    """A policy whose every action is 0: with a residual action space, the nominal gait alone (no phase, foot or
    wheel residual)."""
    zeros = torch.zeros(env.num_envs, env.num_actions, device=env.device)

    def policy(obs):
        return zeros

    return policy


def _load(opts: TrackingOptions, phys: str):
    from wqwarp.eval.loading import make_policy_runner

    runner = make_policy_runner(
        opts.checkpoint,
        opts.preset,
        opts.num_envs,
        opts.device,
        dt=opts.dt,
        evaluation_selection="sample" if opts.sample_gaits else None,
        physics=phys,
        seed=opts.seed,
        criterion=opts.criterion,
        robot=opts.robot,
    )
    if opts.zero_residual:
        if not runner.env.residual_mode:
            raise ValueError(
                f"--zero-residual needs a preset with a nominal gait (a residual policy), not {runner.preset}"
            )
        runner = dataclasses.replace(runner, policy=zero_policy(runner.env))
    predictive = runner.env.gait_selector.name == "predictive"
    for name, wanted in (("--sample-gaits", opts.sample_gaits), ("--force-gait", opts.force_gait)):
        if wanted and not predictive:
            raise ValueError(f"{name} needs a predictive preset, not {runner.preset}")
    if not opts.force_gait:
        return runner, None
    try:
        return runner, gait_index(opts.force_gait, runner.env.cfg.gait.library)
    except ValueError as e:
        raise ValueError(f"--force-gait: {e}") from None


def _evaluate(opts: TrackingOptions, log: TextIO, protocol: str) -> dict:
    """Every task (at every push level for ``push``) under the training physics and each of ``opts.physics``."""
    from wqwarp.rl.config import to_dict

    opts.validate()
    t_start = time.time()
    pushing = protocol == "push"
    tasks = opts.task_list()
    runs = [(lvl, t) for lvl in opts.levels() for t in tasks] if pushing else [(opts.push, t) for t in tasks]
    by_physics = {}
    for phys in ["train", *opts.physics_list()]:
        t_phys = time.time()
        runner, forced = _load(opts, phys)
        cfg = runner.env.cfg
        _print_header(log, runner, opts, phys)
        results = []
        for max_push, t in runs:
            r = run_task(
                runner,
                t,
                opts.seconds,
                max_push=max_push,
                push_interval=opts.push_interval,
                progress=_progress(log, t),
                command_range=PUSH_TASKS[t][1] if pushing else None,
                forced_gait=forced,
            )
            results.append(dataclasses.asdict(r))
            _print_row(log, r, f"{t}@{max_push:g}" if pushing else t)
        by_physics[phys] = {
            "physics": phys,
            "overrides": physics_variant(phys).overrides(),
            "config": to_dict(cfg),
            "wall_time_s": time.time() - t_phys,
            "results": results,
        }
        preset, iteration = runner.preset, runner.iteration
        del runner
    results = by_physics["train"]["results"]
    deltas = {
        p: [physics_delta(a, b) for a, b in zip(results, by_physics[p]["results"], strict=True)]
        for p in opts.physics_list()
    }
    for phys, d in deltas.items():
        _print_deltas(log, phys, d)
    if pushing:
        _print_table3(log, results, tasks, opts.levels())
    train = by_physics["train"]
    return {
        "checkpoint": opts.checkpoint,
        "preset": preset,
        "iteration": iteration,
        "protocol": protocol,
        "forced_gait": opts.force_gait,
        "zero_residual": opts.zero_residual,
        "seed": opts.seed,
        "num_envs": opts.num_envs,
        "seconds": opts.seconds,
        "push_interval": opts.push_interval,
        "dt": train["config"]["sim"]["dt"],
        "decimation": train["config"]["sim"]["decimation"],
        "wall_time_s": time.time() - t_start,
        "config": train["config"],
        "results": results,
        "sim2sim": {p: {**by_physics[p], "deltas": deltas[p]} for p in opts.physics_list()},
    }


def _progress(log: TextIO, task: str):
    def show(k: int, n: int) -> None:
        if log.isatty() and (k == n or k % max(1, n // 20) == 0):
            print(f"\r  {task}: {100 * k // n:3d} %", end="", flush=True, file=log)

    return show


def _print_header(log: TextIO, runner, opts: TrackingOptions, phys: str) -> None:
    cfg = runner.env.cfg
    scale = "" if opts.num_envs >= 1000 else " (the paper: 1000 robots; --paper-scale)"
    what = "zero residual (the nominal gait alone), configuration of the " if opts.zero_residual else ""
    print(
        f"\n{runner.preset} {what}checkpoint (iteration {runner.iteration}), {opts.num_envs} robots{scale}, "
        f"{opts.seconds:g} s, physics {phys}: dt {cfg.sim.dt:g} s x {cfg.sim.decimation}, joints "
        f"{cfg.sim.joint_model}, friction {cfg.domain_rand.nominal_friction:g}, seed {opts.seed}",
        file=log,
    )
    print(
        f"{'task':>9} {'MSE':>8} {'|err|':>8} {'p_cost [W]':>11} {'legs':>7} {'wheels':>7} {'CoT':>6} "
        f"{'p_elec [W]':>11} {'legs':>7} {'wheels':>7} {'CoT_el':>6} {'upright':>8}  gaits",
        file=log,
    )


def _print_row(log: TextIO, r: EvalResult, label: str) -> None:
    cot = f"{r.cost_of_transport:6.2f}" if r.cost_of_transport is not None else f"{'-':>6}"
    cot_el = f"{r.cost_of_transport_elec:6.2f}" if r.cost_of_transport_elec is not None else f"{'-':>6}"
    print(
        f"\r{label:>9} {r.mse:8.4f} {r.mean_abs_error:8.3f} {r.mean_p_cost:11.1f} {r.mean_p_cost_legs:7.1f} "
        f"{r.mean_p_cost_wheels:7.1f} {cot} {r.mean_p_elec:11.1f} {r.mean_p_elec_legs:7.1f} "
        f"{r.mean_p_elec_wheels:7.1f} {cot_el} {100 * r.upright:7.1f}%  "
        + " ".join(f"{g} {100 * v:.0f}%" for g, v in (r.gait_usage or {}).items() if v > 0)
        + ("  (commands outside the training range)" if r.outside_training_range else ""),
        file=log,
    )


def _print_deltas(log: TextIO, phys: str, deltas: list[dict]) -> None:
    print(f"\nsim-to-sim: {phys} minus train", file=log)
    print(
        f"{'task':>9} {'dMSE':>8} {'dp_cost [W]':>12} {'(%)':>7} {'dlegs':>7} {'dwheels':>8} {'dupright':>9}", file=log
    )
    for d in deltas:
        print(
            f"{d['label']:>9} {d['mse']:8.4f} {d['mean_p_cost']:12.1f} {d['mean_p_cost_rel']:7.1%} "
            f"{d['mean_p_cost_legs']:7.1f} {d['mean_p_cost_wheels']:8.1f} {100 * d['upright']:8.1f}%",
            file=log,
        )


def _print_table3(log: TextIO, results: list[dict], tasks: list[str], levels: list[float]) -> None:
    print("\nTable III: share of robots that recovered (trunk never touched the ground) [%]", file=log)
    print(f"{'max push':>9} " + " ".join(f"{t:>8}" for t in tasks), file=log)
    for lvl in levels:
        row = [r for r in results if r["max_push"] == lvl]
        print(f"{lvl:>7g} m/s " + " ".join(f"{100 * r['upright']:8.1f}" for r in row), file=log)
    for r in results:
        if r.get("fallen_commands"):
            lo, hi = r["command_range"]
            fallen = ", ".join(f"{v:g}" for v in r["fallen_commands"])
            print(
                f"{r['task']} at {r['max_push']:g} m/s: fell at commands {fallen} (task range [{lo:g}, {hi:g}])",
                file=log,
            )
