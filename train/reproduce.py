"""Reproduce the paper's evaluation in one command: train the five methods with identical budgets and seeds, evaluate
each, and write the results page with its JSON and figures.

Examples::

    python train/reproduce.py --budget smoke                      # plumbing check: minutes, meaningless numbers
    python train/reproduce.py --budget cpu                        # ~2 h on 2 CPU cores, writes docs/RESULTS.md
    python train/reproduce.py --budget gpu --device cuda:0        # the paper's 4096 robots x 4000 iterations
    python train/reproduce.py --budget cpu --stages report        # rebuild the page from finished stages

Stages, in order (``--stages`` picks some): ``train`` (``train/ppo_newton.py`` per preset and seed), ``tracking``
(``train/evaluate.py``: stand, v_x, v_y, w tasks, power per joint group, cost of transport), ``push`` (Table III),
``sim2sim`` (the ``ours`` checkpoints under the paper's dt 0.001 x 20 and under the authors' joint model, deltas
against the training physics), ``timeline`` (the paper's Fig. 6: one robot, stand -> forward -> rotate -> lateral),
``energymap`` (per gait measured and predicted power over a (v_x, v_y, w) grid and the winning gait) and
``report`` (``RESULTS.md``, ``results.json``, PNGs).

Every stage runs the same script a user would (in this process, its output in a log next to its result) and writes
its result atomically under ``--work``; a stage whose result is
already there is skipped, and an interrupted training resumes from its last checkpoint. Re-running the same
command therefore continues where a crash or a time limit stopped it. A stage that fails is reported and the
others go on; the page lists what is missing.
"""

from __future__ import annotations

import argparse
import glob
import json
import os
import re
import sys
import time
from dataclasses import asdict, dataclass

from wqwarp.cli.args import ArgumentParser

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

PRESET_ORDER = ("ours", "no_predictor", "no_wheel_vel", "pmtg", "baseline")
"""Training order: the paper's method first, so a partial run has the rows that matter most."""
STAGES = ("train", "tracking", "push", "sim2sim", "timeline", "energymap", "report")


@dataclass(frozen=True)
class Budget:
    """Sizes of one reproduction. Training sizes are identical for every preset and seed."""

    num_envs: int
    """Robots in training."""
    iterations: int
    """PPO iterations (24 policy steps per robot each unless ``steps_per_env``)."""
    temperature_iterations: int
    """Predictive presets: iterations over which tau is annealed."""
    eval_envs: int
    """Robots per tracking task (the paper: 1000)."""
    eval_seconds: float
    """Length of each tracking task [s] (the paper: 60 for energy)."""
    push_envs: int
    """Robots per push run (the paper: 1000)."""
    push_seconds: float
    """Length of each push run [s] (the paper: 60, pushes every 15 s)."""
    push_interval: float
    """Seconds between pushes (the paper: 15)."""
    sim2sim_envs: int
    """Robots per sim-to-sim task."""
    map_seconds: float
    """Seconds per gait and grid cell of the energy map (the last half is measured)."""
    map_grid: int
    """Command values per axis of the energy map."""
    timeline_seconds: float
    """Seconds per segment of the timeline."""
    steps_per_env: int = 24
    device: str = "cpu"


BUDGETS = {
    "smoke": Budget(num_envs=8, iterations=2, temperature_iterations=2, eval_envs=4, eval_seconds=2.5, push_envs=4,
                    push_seconds=2.5, push_interval=1.0, sim2sim_envs=4, map_seconds=0.5, map_grid=2,
                    timeline_seconds=0.5, steps_per_env=8),
    "cpu": Budget(num_envs=128, iterations=1000, temperature_iterations=700, eval_envs=64, eval_seconds=20.0,
                  push_envs=32, push_seconds=31.0, push_interval=15.0, sim2sim_envs=32, map_seconds=4.0,
                  map_grid=5, timeline_seconds=4.0),
    "gpu": Budget(num_envs=4096, iterations=4000, temperature_iterations=2000, eval_envs=1000, eval_seconds=60.0,
                  push_envs=1000, push_seconds=60.0, push_interval=15.0, sim2sim_envs=1000, map_seconds=4.0,
                  map_grid=5, timeline_seconds=4.0, device="cuda:0"),
}  # fmt: skip
"""``smoke`` checks the plumbing in minutes; ``cpu`` fits a 2-core machine in about 2 hours (1000 iterations x 128
robots x 24 steps = 3.1 M samples per preset, 1/128 of the paper's 4096 x 24 x 4000); ``gpu`` is the paper's scale."""

SIM2SIM_PHYSICS = "dt0.001,authors"


def run_dir(work: str, preset: str, seed: int) -> str:
    return os.path.join(work, "train", f"{preset}_s{seed}")


def checkpoints(d: str) -> list[tuple[int, str]]:
    """``(iteration, path)`` of the regular checkpoints in a run folder, ascending."""
    out = []
    for p in glob.glob(os.path.join(d, "model_*.pt")):
        m = re.fullmatch(r"model_(\d+)\.pt", os.path.basename(p))
        if m:
            out.append((int(m.group(1)), p))
    return sorted(out)


def final_checkpoint(work: str, preset: str, seed: int, budget: Budget) -> str:
    return os.path.join(run_dir(work, preset, seed), f"model_{budget.iterations - 1}.pt")


_MODULES: dict = {}


def _script_main(path: str):
    """``main`` of a script file (``train/evaluate.py``, ``tools/gait_sequence.py``, ...), loaded once."""
    if path not in _MODULES:
        import importlib.util

        name = "_wq_" + os.path.splitext(os.path.basename(path))[0]
        spec = importlib.util.spec_from_file_location(name, path)
        mod = importlib.util.module_from_spec(spec)
        sys.modules[name] = mod
        spec.loader.exec_module(mod)
        _MODULES[path] = mod.main
    return _MODULES[path]


def _run(cmd: list[str], log: str, label: str, progress_pattern: str | None = None) -> bool:
    """Run the script ``cmd[0]`` with arguments ``cmd[1:]`` in this process (no interpreter and Warp start-up per
    stage), its output appended to ``log`` and ``sys.argv`` set to the equivalent command line (result files record
    it). Progress lines matching ``progress_pattern`` in the log are echoed on a terminal. True on exit code 0."""
    import contextlib
    import threading
    import traceback

    os.makedirs(os.path.dirname(os.path.abspath(log)), exist_ok=True)
    t0 = time.time()
    shown = " ".join(os.path.relpath(c, ROOT) if os.path.isabs(c) and c.startswith(ROOT) else c for c in cmd)
    print(f"[{time.strftime('%H:%M:%S')}] {label}: python {shown}", flush=True)
    stop = threading.Event()

    def echo():
        last = ""
        while not stop.wait(5.0):
            with open(log, encoding="utf-8", errors="replace") as r:
                r.seek(max(0, os.path.getsize(log) - 4000))
                hits = re.findall(progress_pattern, r.read())
            if hits and hits[-1] != last:
                last = hits[-1]
                print(f"\r  {label}: {last}   ", end="", flush=True)

    argv, real_out = sys.argv, sys.stdout
    with open(log, "a", encoding="utf-8") as f:
        f.write(f"\n$ python {shown}\n")
        f.flush()
        watcher = threading.Thread(target=echo, daemon=True) if progress_pattern and real_out.isatty() else None
        if watcher:
            watcher.start()
        try:
            sys.argv = [cmd[0], *cmd[1:]]
            with contextlib.redirect_stdout(f), contextlib.redirect_stderr(f):
                code = _script_main(cmd[0])(cmd[1:])
        except KeyboardInterrupt:
            raise
        except SystemExit as e:  # argparse errors
            code = e.code if isinstance(e.code, int) else 2
        except Exception:  # noqa: BLE001 - one failed stage must not stop the others; the log has the traceback
            f.write(traceback.format_exc())
            code = 1
        finally:
            sys.argv = argv
            stop.set()
    ok = code in (0, None)
    status = "done" if ok else f"FAILED (exit {code}, see {log})"
    print(f"\r[{time.strftime('%H:%M:%S')}] {label}: {status} in {time.time() - t0:.0f} s", flush=True)
    return ok


def stage_train(args, budget: Budget, preset: str, seed: int) -> bool:
    d = run_dir(args.work, preset, seed)
    final = final_checkpoint(args.work, preset, seed, budget)
    if os.path.isfile(final):
        return True
    cmd = [os.path.join(ROOT, "train", "ppo_newton.py"), "--preset", preset, "--seed", str(seed),
           "--num-envs", str(budget.num_envs), "--device", args.device, "--log-dir", d, "--no-export",
           "--num-steps-per-env", str(budget.steps_per_env), "--torch-threads", str(args.torch_threads)]  # fmt: skip
    if preset in ("ours", "no_wheel_vel"):
        cmd += ["--temperature-iterations", str(budget.temperature_iterations)]
    done = checkpoints(d)
    if done:  # continue an interrupted run after its last checkpoint
        it, path = done[-1]
        cmd += ["--resume", path, "--max-iterations", str(budget.iterations - 1 - it)]
    else:
        cmd += ["--max-iterations", str(budget.iterations)]
    cmd += ["--save-interval", str(max(1, min(50, budget.iterations // 4)))]
    return _run(cmd, d + ".log", f"train {preset} seed {seed}", r"\] (\d+/\d+ ETA [0-9:]+)") and os.path.isfile(final)


PREDICTIVE_ONLY = ("sim2sim", "timeline", "energymap")
"""Stages run for ``ours`` only (the sim-to-sim check, and the figures of the gait selection)."""


def _stage(args, budget: Budget, preset: str, seed: int, name: str, script: str, extra: list[str],
           png: bool = False) -> bool:  # fmt: skip
    """Run ``script`` (a path under the repository) on the preset's final checkpoint unless its result
    ``eval/<preset>_s<seed>_<name>.json`` (and ``.png`` with ``png``) is there already; True when it is."""
    if name in PREDICTIVE_ONLY and preset != "ours":
        return True
    out = os.path.join(args.work, "eval", f"{preset}_s{seed}_{name}")
    files = [out + ".json"] + ([out + ".png"] if png else [])
    if all(os.path.isfile(f) for f in files):  # all of them, or the stage runs again
        return True
    ckpt = final_checkpoint(args.work, preset, seed, budget)
    if not os.path.isfile(ckpt):
        print(f"  skip {name} of {preset} seed {seed}: no trained checkpoint {ckpt}")
        return False
    cmd = [os.path.join(ROOT, script), "--checkpoint", ckpt, "--device", args.device, "--seed", str(seed),
           "--json", out + ".json", *(["--png", out + ".png"] if png else []), *extra]  # fmt: skip
    return _run(cmd, out + ".log", f"{name} {preset} seed {seed}")


def stage_tracking(args, budget: Budget, preset: str, seed: int) -> bool:
    return _stage(args, budget, preset, seed, "tracking", "train/evaluate.py", [
        "--preset", preset, "--tasks", "stand,vx,vy,wz", "--num-envs", str(budget.eval_envs),
        "--seconds", str(budget.eval_seconds)])  # fmt: skip


def stage_push(args, budget: Budget, preset: str, seed: int) -> bool:
    return _stage(args, budget, preset, seed, "push", "train/evaluate.py", [
        "--preset", preset, "--protocol", "push", "--num-envs", str(budget.push_envs),
        "--seconds", str(budget.push_seconds), "--push-interval", str(budget.push_interval)])  # fmt: skip


def stage_sim2sim(args, budget: Budget, preset: str, seed: int) -> bool:
    return _stage(args, budget, preset, seed, "sim2sim", "train/evaluate.py", [
        "--preset", preset, "--tasks", "vx,vy,wz", "--num-envs", str(budget.sim2sim_envs),
        "--seconds", str(budget.eval_seconds), "--physics", SIM2SIM_PHYSICS])  # fmt: skip


def stage_timeline(args, budget: Budget, preset: str, seed: int) -> bool:
    s = budget.timeline_seconds
    segments = f"0,0,0:{s};0.8,0,0:{s};0,0,0.6:{s};0,0.4,0:{s}"  # the paper's Fig. 6: stand, forward, rotate, lateral
    return _stage(args, budget, preset, seed, "timeline", "tools/gait_sequence.py",
                  ["--segments", segments, "--robots", "1"], png=True)  # fmt: skip


def stage_energymap(args, budget: Budget, preset: str, seed: int) -> bool:
    return _stage(args, budget, preset, seed, "energymap", "tools/gait_energy_map.py",
                  ["--seconds", str(budget.map_seconds), "--grid", str(budget.map_grid)], png=True)  # fmt: skip


def main(argv=None) -> int:
    p = ArgumentParser(description=__doc__.split("\n\n")[0], epilog=__doc__.split("\n\n", 1)[1],
                       formatter_class=argparse.RawDescriptionHelpFormatter)  # fmt: skip
    p.add_argument("--budget", choices=sorted(BUDGETS), default="smoke",
                   help="smoke (minutes, plumbing only), cpu (~2 h on 2 cores: 128 robots x 1000 iterations), gpu "
                   "(the paper's 4096 x 4000; use --device cuda:0). Default smoke")  # fmt: skip
    p.add_argument("--seeds", type=int, default=1, help="seeds 1..N per preset (default 1; bars show their spread)")
    p.add_argument("--presets", default=",".join(PRESET_ORDER),
                   help=f"comma-separated presets (default all five: {','.join(PRESET_ORDER)})")  # fmt: skip
    p.add_argument("--stages", default=",".join(STAGES),
                   help=f"comma-separated stages (default all: {','.join(STAGES)})")  # fmt: skip
    p.add_argument("--out", default=None,
                   help="folder for RESULTS.md, results.json and the figures (default: docs for the cpu and gpu "
                   "budgets, <work>/report for smoke)")  # fmt: skip
    p.add_argument(
        "--work",
        default=None,
        help="folder for training runs and raw evaluation files (default runs/reproduce_<budget>)",
    )
    p.add_argument("--device", default=None, help="cpu or cuda:N (default: the budget's, cpu except gpu)")
    p.add_argument(
        "--torch-threads",
        type=int,
        default=1,
        help="torch CPU threads of each training process (default 1, as train/ppo_newton.py; physics uses all cores)",
    )
    args = p.parse_args(argv)
    budget = BUDGETS[args.budget]
    args.device = args.device or budget.device
    args.work = args.work or os.path.join(ROOT, "runs", f"reproduce_{args.budget}")
    args.out = args.out or (os.path.join(args.work, "report") if args.budget == "smoke" else os.path.join(ROOT, "docs"))
    presets = [x.strip() for x in args.presets.split(",") if x.strip()]
    stages = [x.strip() for x in args.stages.split(",") if x.strip()]
    bad = [x for x in presets if x not in PRESET_ORDER] + [x for x in stages if x not in STAGES]
    if bad or not presets or not stages or args.seeds < 1 or args.torch_threads < 1:
        print(f"error: unknown preset or stage {bad}, or --seeds / --torch-threads < 1 (presets: "
              f"{', '.join(PRESET_ORDER)}; stages: {', '.join(STAGES)})", file=sys.stderr)  # fmt: skip
        return 2
    if args.device.startswith("cuda"):
        try:
            import warp as wp

            wp.config.quiet = True
            wp.get_device(args.device)
        except Exception as e:  # noqa: BLE001
            print(f"error: device {args.device!r} is not available: {e}", file=sys.stderr)
            return 2
    os.makedirs(args.work, exist_ok=True)
    with open(os.path.join(args.work, "budget.json"), "w", encoding="utf-8") as f:
        json.dump({"budget": args.budget, **asdict(budget), "device": args.device}, f, indent=2)
    t0 = time.time()
    seeds = list(range(1, args.seeds + 1))
    failed = []
    funcs = {"train": stage_train, "tracking": stage_tracking, "push": stage_push, "sim2sim": stage_sim2sim,
             "timeline": stage_timeline, "energymap": stage_energymap}  # fmt: skip
    for stage in [s for s in stages if s != "report"]:
        for preset in presets:
            for seed in seeds:
                if not funcs[stage](args, budget, preset, seed):
                    failed.append(f"{stage} {preset} seed {seed}")
    if "report" in stages:
        from wqwarp.eval.report import write_report

        write_report(args.work, args.out, args.budget, budget, presets, seeds, wall_s=time.time() - t0)
        print(f"wrote {os.path.join(args.out, 'RESULTS.md')}")
    if failed:
        print("not done: " + "; ".join(failed), file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
