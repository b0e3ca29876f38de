"""Reproduce the paper's evaluation in one command: train the five methods with identical budgets and seeds, evaluate
each, and write the results page with its JSON and figures.

Examples::

    python train/reproduce.py --budget smoke                      # plumbing check: minutes, meaningless numbers
    python train/reproduce.py --budget cpu                        # ~2 h on 2 CPU cores, writes docs/RESULTS.md
    python train/reproduce.py --budget gpu --device cuda:0        # the paper's 4096 robots x 4000 iterations
    python train/reproduce.py --budget cpu --stages report        # rebuild the page from finished stages

Stages, in order (``--stages`` picks some): ``train`` (``train/ppo_newton.py`` per preset and seed), then one stage
per evaluation protocol (``wqwarp.eval.protocols``): ``tracking`` (stand, v_x, v_y, w tasks, power per joint group,
cost of transport), ``push`` (Table III), ``sim2sim`` (the ``ours`` checkpoints under the paper's dt 0.001 x 20 and
under the authors' joint model, deltas against the training physics), ``timeline`` (the paper's Fig. 6: one robot,
stand -> forward -> rotate -> lateral), ``energymap`` (per gait measured and predicted power over a (v_x, v_y) and a
(v_x, w) grid, and the winning gait) and ``report`` (``RESULTS.md``, ``results.json``, PNGs).

Training runs ``train/ppo_newton.py`` in a child process (its progress on a terminal read from the run's
``metrics.jsonl``, never from its console); each evaluation calls its protocol in this process. Every
stage's output goes to a log next to its result, and its result is written atomically under ``--work`` with the
equivalent command line; a stage whose result is already there is skipped, and an interrupted training resumes from
its last checkpoint. Re-running the same command therefore continues where a crash or a time limit stopped it. A
stage that fails is reported and the others go on; the page lists what is missing.
"""

from __future__ import annotations

import argparse
import contextlib
import datetime
import glob
import json
import os
import re
import subprocess
import sys
import threading
import time
import traceback
from collections.abc import Callable, Iterator
from dataclasses import asdict, dataclass
from typing import TextIO

from wqwarp.cli.args import ArgumentParser, repo_path
from wqwarp.eval.timeline import fig6_segments
from wqwarp.rl.presets import PRESET_ORDER, PRESETS
from wqwarp.rl.profiles import DEFAULT_PROFILE, PROFILES, profile_help


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

EVAL_STAGES: dict[str, Callable[[Budget, str], dict]] = {
    "tracking": lambda b, preset: {"preset": preset, "tasks": "stand,vx,vy,wz", "num_envs": b.eval_envs,
                                   "seconds": b.eval_seconds},
    "push": lambda b, preset: {"preset": preset, "num_envs": b.push_envs, "seconds": b.push_seconds,
                               "push_interval": b.push_interval},
    "sim2sim": lambda b, preset: {"preset": preset, "tasks": "vx,vy,wz", "num_envs": b.sim2sim_envs,
                                  "seconds": b.eval_seconds},
    "timeline": lambda b, preset: {"segments": fig6_segments(b.timeline_seconds), "robots": 1},
    "energymap": lambda b, preset: {"seconds": b.map_seconds, "grid": b.map_grid},
}  # fmt: skip
"""Evaluation stage (a protocol of ``wqwarp.eval.protocols.PROTOCOLS``) -> its options at a budget for a preset."""
STAGES = ("train", *EVAL_STAGES, "report")

PREDICTIVE_ONLY = ("sim2sim", "timeline", "energymap")
"""Stages run only for presets with ``Preset.selection_studies`` (the sim-to-sim check, and the figures of the gait
selection)."""


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


ETA_ITERATIONS = 10
"""Iterations whose mean wall time gives a training stage's ETA."""


def training_progress(run: str, total: int) -> str | None:
    """``"iteration k/N, ETA h:mm:ss"`` of the training run in folder ``run`` from its ``metrics.jsonl``
    (``wqwarp.rl.progress.read_metrics``): k the last iteration written, the ETA the mean wall time of the last
    :data:`ETA_ITERATIONS` iterations [s] times the ``total - k`` left; None before the first iteration."""
    from wqwarp.rl.progress import read_metrics

    rows = read_metrics(run)
    if not rows:
        return None
    it = int(rows[-1]["iteration"])
    walls = [r["wall_s"] for r in rows[-ETA_ITERATIONS:] if r.get("wall_s") is not None]
    eta = sum(walls) / len(walls) * max(total - it, 0) if walls else 0.0
    return f"iteration {it}/{total}, ETA {datetime.timedelta(seconds=round(eta))}"


@contextlib.contextmanager
def stage_log(log: str, label: str, command: str, progress: Callable[[], str | None] | None = None) -> Iterator[TextIO]:
    """The log file of one stage (appended to, headed by ``$ python command``), with a start and an end line on the
    console; on a terminal, ``progress()`` (e.g. :func:`training_progress`) is echoed every 5 s while it runs when
    it has changed."""
    os.makedirs(os.path.dirname(os.path.abspath(log)), exist_ok=True)
    print(f"[{time.strftime('%H:%M:%S')}] {label}: python {command}", flush=True)
    stop = threading.Event()

    def echo() -> None:
        last = None
        while not stop.wait(5.0):
            now = progress()
            if now is not None and now != last:
                last = now
                print(f"\r  {label}: {now}   ", end="", flush=True)

    with open(log, "a", encoding="utf-8") as f:
        f.write(f"\n$ python {command}\n")
        f.flush()
        if progress is not None and sys.stdout.isatty():
            threading.Thread(target=echo, daemon=True).start()
        try:
            yield f
        finally:
            stop.set()


def _report_status(label: str, ok: bool, log: str, t0: float, code: object = 1) -> bool:
    status = "done" if ok else f"FAILED (exit {code}, see {log})"
    print(f"\r[{time.strftime('%H:%M:%S')}] {label}: {status} in {time.time() - t0:.0f} s", flush=True)
    return ok


def stage_train(args, budget: Budget, preset: str, seed: int) -> bool:
    """Train ``preset`` with ``seed`` (``train/ppo_newton.py`` in a child process, its output in ``<run>.log``),
    resuming an interrupted run; True when the final checkpoint is there."""
    d = run_dir(args.work, preset, seed)
    final = final_checkpoint(args.work, preset, seed, budget)
    if os.path.isfile(final):
        return True
    cmd = ["train/ppo_newton.py", "--preset", preset, "--profile", args.profile, "--seed", str(seed), "--num-envs",
           str(budget.num_envs), "--device", args.device, "--log-dir", d, "--no-export", "--num-steps-per-env",
           str(budget.steps_per_env), "--torch-threads", str(args.torch_threads)]  # fmt: skip
    if PRESETS[preset].predictive:
        cmd += ["--temperature-iterations", str(budget.temperature_iterations)]
    done = checkpoints(d)
    if done:  # continue an interrupted run after its last checkpoint
        it, path = done[-1]
        cmd += ["--resume", path, "--max-iterations", str(budget.iterations - 1 - it)]
    else:
        cmd += ["--max-iterations", str(budget.iterations)]
    cmd += ["--save-interval", str(max(1, min(50, budget.iterations // 4)))]
    t0, label, log = time.time(), f"train {preset} seed {seed}", d + ".log"
    with stage_log(log, label, " ".join(cmd), lambda: training_progress(d, budget.iterations)) as f:
        code = subprocess.run([sys.executable, repo_path(cmd[0]), *cmd[1:]], stdout=f, stderr=subprocess.STDOUT,
                              cwd=repo_path()).returncode  # fmt: skip
    return _report_status(label, code == 0, log, t0, code) and os.path.isfile(final)


def stage_eval(args, budget: Budget, preset: str, seed: int, name: str) -> bool:
    """Protocol ``name`` on the preset's final checkpoint (in this process, its output in ``<result>.log``) unless
    its result ``eval/<preset>_s<seed>_<name>.json`` (and ``.png`` where the protocol draws one) is there already;
    True when it is."""
    from wqwarp.eval.protocols import PROTOCOLS, equivalent_command, make_options, run_protocol

    if name in PREDICTIVE_ONLY and not PRESETS[preset].selection_studies:
        return True
    out = os.path.join(args.work, "eval", f"{preset}_s{seed}_{name}")
    outputs = {"json": out + ".json"} | ({"png": out + ".png"} if PROTOCOLS[name].draw else {})
    if all(os.path.isfile(f) for f in outputs.values()):  # all of them, or the stage runs again
        return True
    ckpt = final_checkpoint(args.work, preset, seed, budget)
    if not os.path.isfile(ckpt):
        print(f"  skip {name} of {preset} seed {seed}: no trained checkpoint {ckpt}")
        return False
    opts = make_options(name, checkpoint=ckpt, device=args.device, seed=seed, **outputs,
                        **EVAL_STAGES[name](budget, preset))  # fmt: skip
    t0, label, log, command = time.time(), f"{name} {preset} seed {seed}", out + ".log", equivalent_command(name, opts)
    with stage_log(log, label, command) as f:
        try:
            run_protocol(name, opts, log=f, command=command)
            ok = True
        except Exception:  # noqa: BLE001 - one failed stage must not stop the others; the log has the traceback
            f.write(traceback.format_exc())
            ok = False
    return _report_status(label, ok, log, t0)


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    """The command line, with the budget's device, work and output folders filled in."""
    p = ArgumentParser(description=__doc__.split("\n\n")[0], epilog=__doc__.split("\n\n", 1)[1],
                       formatter_class=argparse.RawDescriptionHelpFormatter)  # fmt: skip
    p.add_argument("--budget", choices=sorted(BUDGETS), default="smoke",
                   help="smoke (minutes, plumbing only), cpu (~2 h on 2 cores: 128 robots x 1000 iterations), gpu "
                   "(the paper's 4096 x 4000; use --device cuda:0). Default smoke")  # fmt: skip
    p.add_argument("--profile", default=DEFAULT_PROFILE, choices=sorted(PROFILES),
                   help=f"levers beyond the paper for every preset's training, as train/ppo_newton.py --profile "
                        f"(default {DEFAULT_PROFILE}; {profile_help()})")  # fmt: skip
    p.add_argument("--seeds", type=int, default=1, help="seeds 1..N per preset (default 1; bars show their spread)")
    p.add_argument("--presets", default=",".join(PRESET_ORDER),
                   help=f"comma-separated presets (default all five: {','.join(PRESET_ORDER)})")  # fmt: skip
    p.add_argument("--stages", default=",".join(STAGES),
                   help=f"comma-separated stages (default all: {','.join(STAGES)})")  # fmt: skip
    p.add_argument("--out", default=None,
                   help="folder for RESULTS.md, results.json and the figures (default: docs for the cpu and gpu "
                   "budgets, <work>/report for smoke)")  # fmt: skip
    p.add_argument("--work", default=None,
                   help="folder for training runs and raw evaluation files (default runs/reproduce_<budget>_<profile>: "
                   "a finished stage is never redone, so each profile has its own)")  # fmt: skip
    p.add_argument("--device", default=None, help="cpu or cuda:N (default: the budget's, cpu except gpu)")
    p.add_argument("--torch-threads", type=int, default=1,
                   help="torch CPU threads of each training process (default 1, as train/ppo_newton.py; physics uses "
                   "all cores)")  # fmt: skip
    args = p.parse_args(argv)
    budget = BUDGETS[args.budget]
    args.device = args.device or budget.device
    args.work = args.work or repo_path("runs", f"reproduce_{args.budget}_{args.profile}")
    args.out = args.out or (os.path.join(args.work, "report") if args.budget == "smoke" else repo_path("docs"))
    return args


def _device_problem(device: str) -> str | None:
    if not device.startswith("cuda"):
        return None
    try:
        import warp as wp

        from wqwarp import quiet_warp

        quiet_warp()
        wp.get_device(device)
    except Exception as e:  # noqa: BLE001
        return f"device {device!r} is not available: {e}"
    return None


def main(argv: list[str] | None = None) -> int:
    """Run the chosen stages for every preset and seed; 0 when all are done, 1 when some failed, 2 for bad input."""
    from wqwarp.utils.io import write_text_atomic

    args = parse_args(argv)
    budget = BUDGETS[args.budget]
    presets = [x.strip() for x in args.presets.split(",") if x.strip()]
    stages = [x.strip() for x in args.stages.split(",") if x.strip()]
    bad = [x for x in presets if x not in PRESET_ORDER] + [x for x in stages if x not in STAGES]
    if bad or not presets or not stages or args.seeds < 1 or args.torch_threads < 1:
        print(f"error: unknown preset or stage {bad}, or --seeds / --torch-threads < 1 (presets: "
              f"{', '.join(PRESET_ORDER)}; stages: {', '.join(STAGES)})", file=sys.stderr)  # fmt: skip
        return 2
    if problem := _device_problem(args.device):
        print(f"error: {problem}", file=sys.stderr)
        return 2
    os.makedirs(args.work, exist_ok=True)
    write_text_atomic(os.path.join(args.work, "budget.json"),
                      json.dumps({"budget": args.budget, **asdict(budget), "device": args.device,
                                  "profile": args.profile}, indent=2))  # fmt: skip
    t0 = time.time()
    seeds = list(range(1, args.seeds + 1))
    failed = []
    for stage in [s for s in stages if s != "report"]:
        for preset in presets:
            for seed in seeds:
                ok = stage_train(args, budget, preset, seed) if stage == "train" else \
                    stage_eval(args, budget, preset, seed, stage)  # fmt: skip
                if not ok:
                    failed.append(f"{stage} {preset} seed {seed}")
    if "report" in stages:
        from wqwarp.eval.report import write_report

        write_report(args.work, args.out, args.budget, budget, presets, seeds, wall_s=time.time() - t0)
        print(f"wrote {os.path.join(args.out, 'RESULTS.md')}")
    if failed:
        print("not done: " + "; ".join(failed), file=sys.stderr)
        return 1
    return 0
