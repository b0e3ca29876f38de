"""Run a rollout of N wheeled Go1 robots and write it as a time-sampled USD stage for usdview or Omniverse.

Usage::

    python tools/export_usd.py --out FILE.usda|FILE.usdc|FILE.usd [--checkpoint PATH] [--preset NAME]
        [--gait NAME] [--num-envs 4] [--seconds 10] [--command vx,vy,wz | --command-script FILE] [--fps 50]
        [--device cpu]

Without --checkpoint the robots play the nominal gait alone, open loop: legs track the nominal leg targets (PD),
wheels the nominal wheel speeds; so the gait library can be inspected before any training. With --checkpoint a
trained policy drives them, in the environment the checkpoint's configuration describes.

The stage: Z up, metres, /World/ground (top face at z = 0), /World/robot_{i} side by side along y (1 m apart, more
if their paths would overlap sideways), one Xform per rigid body /World/robot_{i}/{body} with the asset's shapes and
its pose sampled every frame, and the per-frame attributes wqwarp:gait, wqwarp:activeGait, wqwarp:phase,
wqwarp:command, wqwarp:baseVelocity, wqwarp:pCost, wqwarp:wheelContact on each /World/robot_{i} (see
wqwarp/viz/usd.py). Open it with ``usdview FILE`` and scrub the timeline.

Command script (--command-script): one ``t,vx,vy,wz`` line per change (commas or spaces), t in seconds from which
that command applies, times increasing; before the first line the command is zero. Blank lines, lines starting with
'#' and a header line ``t,vx,vy,wz`` are skipped.

Exit status: 0 on success, 2 on bad input (unknown extension, missing or unwritable output directory, malformed
command, checkpoint that does not fit); no partial output file is left behind.
"""

from __future__ import annotations

import argparse
import math
import os
import shlex
import sys
import time

import numpy as np

from wqwarp.cli.args import ArgumentParser, UsageError, entry_point, parse_command
from wqwarp.control.gaits import GAIT_NAMES
from wqwarp.viz.usd import USD_EXTENSIONS, RolloutRecorder, check_output_path


class CommandSchedule:
    """Piecewise-constant velocity command: ``times`` (K,) increasing [s], ``commands`` (K, 3) (v_x, v_y, w_z)."""

    def __init__(self, times, commands):
        self.times = np.asarray(times, np.float64).reshape(-1)
        self.commands = np.asarray(commands, np.float32).reshape(-1, 3)

    @classmethod
    def constant(cls, command) -> CommandSchedule:
        return cls([0.0], [command])

    def at(self, t: float) -> np.ndarray:
        """Command in force at time ``t`` [s]: that of the last entry with time <= t (zero before the first)."""
        k = int(np.searchsorted(self.times, t + 1e-9, side="right")) - 1
        return self.commands[k] if k >= 0 else np.zeros(3, np.float32)


def parse_command_script(path: str) -> CommandSchedule:
    """Read a ``t,vx,vy,wz`` file; UsageError naming the file and line for anything malformed."""
    try:
        with open(path, encoding="utf-8") as f:
            lines = f.read().splitlines()
    except (OSError, UnicodeDecodeError) as e:
        raise UsageError(f"cannot read --command-script {path!r}: {e}") from None
    times, commands = [], []
    for lineno, raw in enumerate(lines, 1):
        line = raw.strip()
        if not line or line.startswith("#"):
            continue
        fields = [p for p in line.replace(",", " ").split()]
        if [p.lower() for p in fields] == ["t", "vx", "vy", "wz"]:
            continue
        where = f"{path}:{lineno}: {raw.strip()!r}"
        try:
            values = [float(p) for p in fields]
        except ValueError:
            raise UsageError(f"malformed command script line {where}: expected numbers t,vx,vy,wz") from None
        if len(values) != 4:
            raise UsageError(f"malformed command script line {where}: expected 4 values t,vx,vy,wz, got {len(values)}")
        if not all(math.isfinite(v) for v in values):
            raise UsageError(f"malformed command script line {where}: values must be finite")
        if values[0] < 0 or (times and values[0] <= times[-1]):
            raise UsageError(f"malformed command script line {where}: times must be >= 0 and increasing")
        times.append(values[0])
        commands.append(values[1:])
    if not times:
        raise UsageError(f"command script {path!r} holds no command lines (t,vx,vy,wz)")
    return CommandSchedule(times, commands)


def build_parser() -> argparse.ArgumentParser:
    doc = __doc__.split("\n\n")
    ap = ArgumentParser(
        prog="tools/export_usd.py",
        description=doc[0],
        epilog="\n\n".join(doc[3:]),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    exts = ", ".join(USD_EXTENSIONS)
    add = ap.add_argument
    add(
        "--out",
        required=True,
        metavar="FILE",
        help=f"output USD file, extension one of {exts} (.usda text, .usdc / .usd binary crate); its directory must "
        "exist and be writable",
    )
    add(
        "--checkpoint",
        default=None,
        metavar="PATH",
        help="trained policy checkpoint to play (default: none, the nominal gait alone, open loop)",
    )
    add(
        "--preset",
        default=None,
        metavar="NAME",
        help="config preset the checkpoint was trained with (a wqwarp.rl.config preset, e.g. ours); only with "
        "--checkpoint",
    )
    add(
        "--gait",
        default="trotting",
        choices=GAIT_NAMES,
        help="nominal gait played without a checkpoint (default trotting)",
    )
    add("--num-envs", type=int, default=4, metavar="N", help="number of robots, laid out side by side (default 4)")
    add("--seconds", type=float, default=10.0, metavar="S", help="simulated time [s] (default 10)")
    cmd = ap.add_mutually_exclusive_group()
    cmd.add_argument(
        "--command",
        default=None,
        metavar="VX,VY,WZ",
        help="constant velocity command in the base frame [m/s, m/s, rad/s] for every robot (default "
        "0,0,0); write a negative first value as --command=-0.5,0,0",
    )
    cmd.add_argument(
        "--command-script",
        default=None,
        metavar="FILE",
        help="file of 't,vx,vy,wz' lines: the command from time t [s] on (see below)",
    )
    add(
        "--fps",
        type=float,
        default=50.0,
        metavar="FPS",
        help="frames per second of the stage (default 50 = every "
        "policy step; other rates show the nearest policy step)",
    )
    add("--device", default="cpu", metavar="DEVICE", help="Warp device for the simulation: cpu (default) or cuda:N")
    return ap


def validate(args) -> CommandSchedule:
    problem = check_output_path(args.out)
    if problem:
        raise UsageError(problem)
    if args.num_envs < 1:
        raise UsageError(f"--num-envs must be a positive integer, got {args.num_envs}")
    for name in ("seconds", "fps"):
        v = getattr(args, name)
        if not (math.isfinite(v) and v > 0):
            raise UsageError(f"--{name} must be a positive number, got {v}")
    if args.preset is not None and args.checkpoint is None:
        raise UsageError("--preset only applies with --checkpoint")
    if args.checkpoint is not None and not os.path.isfile(args.checkpoint):
        raise UsageError(f"checkpoint {args.checkpoint!r} does not exist")
    if args.command_script is not None:
        return parse_command_script(args.command_script)
    return CommandSchedule.constant(parse_command(args.command) if args.command is not None else (0.0, 0.0, 0.0))


class Progress:
    """One line per simulated second (at most ~20 lines), with the wall time so far."""

    def __init__(self, steps: int, policy_dt: float):
        self.steps, self.dt, self.t0 = steps, policy_dt, time.perf_counter()
        self.wall = 0.0
        """Wall time of the rollout loop so far [s]."""
        seconds = steps * policy_dt
        self.every = max(1, int(round(max(1.0, seconds / 20) / policy_dt)))

    def __call__(self, step: int) -> None:
        if step % self.every == 0 or step == self.steps:
            pct = 100.0 * step / self.steps
            self.wall = time.perf_counter() - self.t0
            print(f"  t = {step * self.dt:6.2f} s  ({pct:5.1f} %)  wall {self.wall:6.1f} s", flush=True)


def run_nominal(args, schedule: CommandSchedule) -> tuple[RolloutRecorder, dict, float]:
    """The nominal gait alone, open loop, for ``args.seconds``; returns the filled recorder, metadata and the wall
    time of the rollout loop [s]."""
    from wqwarp.control.driver import OpenLoopDriver
    from wqwarp.sim.config import SimConfig
    from wqwarp.sim.simulator import Simulator

    n, device = args.num_envs, args.device
    sim = Simulator(SimConfig(num_envs=n, device=device))
    driver = OpenLoopDriver(sim, args.gait, schedule.at(0.0), contact="sim")
    rec = RolloutRecorder.for_simulator(sim, args.seconds, args.fps)
    dt = sim.policy_dt
    current = schedule.at(0.0)
    rec.capture(0, sim, driver.nominal)
    progress = Progress(rec.num_steps, dt)
    for step in range(1, rec.num_steps + 1):
        c = schedule.at((step - 1) * dt)  # the command in force during this step
        if not np.array_equal(c, current):
            driver.set_command(c)
            current = c
        driver.step()
        rec.capture(step, sim, driver.nominal)
        progress(step)
    return rec, {"mode": "nominal", "gait": args.gait, "device": str(device)}, progress.wall


def run_policy(args, schedule: CommandSchedule) -> tuple[RolloutRecorder, dict, float]:
    """A trained policy (``wqwarp.eval.loading.make_policy_runner``: the env as the checkpoint's configuration says, no
    randomisation) for ``args.seconds`` with the scheduled commands held; returns the filled recorder, metadata and
    the rollout wall time [s]. Recorded after every step from ``env.sim`` and ``env.nominal``."""
    import torch

    from wqwarp.eval.loading import make_policy_runner
    from wqwarp.eval.rollout import start_rollout

    try:
        runner = make_policy_runner(args.checkpoint, args.preset, args.num_envs, args.device)
    except (ValueError, KeyError, RuntimeError) as e:  # RuntimeError: torch's state_dict size mismatch
        raise UsageError(f"cannot play checkpoint {args.checkpoint!r}: {e}") from None
    env = runner.env
    sim = env.sim
    n = sim.num_envs
    rec = RolloutRecorder.for_simulator(sim, args.seconds, args.fps)
    dt = sim.policy_dt

    def command(t: float) -> torch.Tensor:
        return torch.tensor(np.tile(schedule.at(t), (n, 1)), dtype=torch.float32, device=env.device)

    obs = start_rollout(env, command(0.0), args.seconds)
    rec.capture(0, sim, env.nominal)
    progress = Progress(rec.num_steps, dt)
    with torch.no_grad():
        for step in range(1, rec.num_steps + 1):
            env.hold_commands(command((step - 1) * dt))  # the command in force during this step
            obs, *_ = env.step(runner.policy(obs))
            rec.capture(step, sim, env.nominal)
            progress(step)
    env.hold_commands(None)
    meta = {
        "mode": "policy",
        "checkpoint": os.path.abspath(args.checkpoint),
        "preset": runner.preset,
        "iteration": runner.iteration,
        "device": str(args.device),
    }
    return rec, meta, progress.wall


@entry_point
def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    args = build_parser().parse_args(argv)
    try:
        schedule = validate(args)

        from wqwarp import quiet_warp

        quiet_warp()
        t0 = time.perf_counter()
        mode = "policy " + args.checkpoint if args.checkpoint else f"nominal {args.gait} gait, open loop"
        print(f"rollout: {args.num_envs} robots, {args.seconds:g} s, {mode}, device {args.device}", flush=True)
        rec, meta, t_loop = (run_policy if args.checkpoint else run_nominal)(args, schedule)
        t_sim = time.perf_counter() - t0
        t_write = time.perf_counter()
        meta["commandLine"] = shlex.join(["python", "tools/export_usd.py", *argv])
        meta["commandSchedule"] = "; ".join(
            f"t={t:g}: {c[0]:g},{c[1]:g},{c[2]:g}" for t, c in zip(schedule.times, schedule.commands, strict=True)
        )
        size = rec.write(args.out, meta)
    except UsageError:
        raise
    except ValueError as e:  # e.g. the output path became invalid while simulating
        raise UsageError(str(e)) from None
    except OSError as e:
        raise UsageError(f"cannot write {args.out!r}: {e}") from None
    now = time.perf_counter()
    print(
        f"wrote {args.out}: {rec.num_frames} frames x {rec.num_envs} robots, {size / 1e6:.2f} MB; wall time: set-up "
        f"{t_sim - t_loop:.1f} s, rollout {t_loop:.1f} s, writing {now - t_write:.1f} s, total {now - t0:.1f} s"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
