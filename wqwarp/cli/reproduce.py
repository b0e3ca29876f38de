"""The command of ``train/reproduce.py``: its options, then the stages of ``wqwarp.eval.reproduce`` for every task and
seed (the module docstring there is the command's help)."""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from dataclasses import asdict

from wqwarp.cli.args import ArgumentParser, UsageError, entry_point, parse_seeds
from wqwarp.eval import reproduce as R
from wqwarp.eval.report import method_of, write_report
from wqwarp.rl.tasks import TASKS
from wqwarp.utils.io import repo_path, write_text_atomic

DEFAULT_TASKS = tuple(name for name, task in TASKS.items() if name == task.method)
"""The tasks a reproduction trains by default: each of the paper's five methods with its measured recipe."""


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    """The command line, with the budget's device, work and output folders filled in."""
    doc = R.__doc__
    p = ArgumentParser(
        prog="reproduce.py",
        description=doc.split("\n\n")[0],
        epilog=doc.split("\n\n", 1)[1],
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument(
        "--budget",
        choices=sorted(R.BUDGETS),
        default="smoke",
        help="smoke (minutes, plumbing only), cpu (~2.5 h on 2 cores: 128 robots x 3000 iterations = 9.2 M "
        "samples per task, the tasks' own budget; split it over sessions with --tasks and --import-from), "
        "gpu (the paper's 4096 x 4000; use --device cuda:0). Default smoke",
    )
    p.add_argument(
        "--seeds",
        default="1",
        help="training seeds of every task: a list or ranges, e.g. 11,12,13 or 11-13 (default 1); each seed is "
        "trained and evaluated (its evaluation seed is the same), and the page gives the mean and 95 %% confidence "
        "interval over seeds once there are two or more",
    )
    p.add_argument(
        "--tasks",
        "--presets",
        dest="tasks",
        default=",".join(DEFAULT_TASKS),
        help=f"comma-separated task ids (wqwarp/rl/tasks.py), one per method (default the five methods' "
        f"recipes: {','.join(DEFAULT_TASKS)}; the paper's methods as written: "
        f"{','.join(t + '-paper' for t in DEFAULT_TASKS)})",
    )
    p.add_argument(
        "--stages", default=",".join(R.STAGES), help=f"comma-separated stages (default all: {','.join(R.STAGES)})"
    )
    p.add_argument(
        "--out",
        default=None,
        help="folder for RESULTS.md, results.json and the figures (default: docs for the cpu and gpu "
        "budgets, <work>/report for smoke)",
    )
    p.add_argument(
        "--work",
        default=None,
        help="folder for training runs and raw evaluation files (default runs/reproduce_<budget>: a "
        "finished stage is never redone)",
    )
    p.add_argument(
        "--import-from",
        default=None,
        metavar="DIR",
        help="results folder of an earlier reproduction at this budget (e.g. docs/results/cpu, as its "
        "report wrote it): tasks and seeds recorded there with this budget's robots, steps and final "
        "iteration, trained as the same task, are taken as trained and evaluated instead of redone, so a "
        "reproduction longer than one session continues in the next without its checkpoints; other "
        "records are listed and left alone",
    )
    p.add_argument("--device", default=None, help="cpu or cuda:N (default: the budget's, cpu except gpu)")
    p.add_argument(
        "--torch-threads",
        type=int,
        default=1,
        help="torch CPU threads of each training process (default 1, as train/ppo_newton.py; physics uses all cores)",
    )
    args = p.parse_args(argv)
    budget = R.BUDGETS[args.budget]
    args.device = args.device or budget.device
    args.work = args.work or repo_path("runs", f"reproduce_{args.budget}")
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


@entry_point
def main(argv: list[str] | None = None) -> int:
    """Run the chosen stages for every task and seed; 0 when all are done, 1 when some failed, 2 for bad input."""
    args = parse_args(argv)
    budget = R.BUDGETS[args.budget]
    tasks = [x.strip() for x in args.tasks.split(",") if x.strip()]
    stages = [x.strip() for x in args.stages.split(",") if x.strip()]
    bad = [x for x in tasks if x not in TASKS] + [x for x in stages if x not in R.STAGES]
    if bad or not tasks or not stages or args.torch_threads < 1:
        raise UsageError(
            f"unknown task or stage {bad}, or --torch-threads < 1 (tasks: {', '.join(TASKS)}; "
            f"stages: {', '.join(R.STAGES)})"
        )
    try:
        seeds = parse_seeds(args.seeds)
    except ValueError as e:
        raise UsageError(f"--seeds: {e}") from None
    methods = [method_of(t) for t in tasks]
    if len(set(methods)) < len(methods):
        raise UsageError(f"--tasks {args.tasks}: one task per method (the page compares the methods)")
    if problem := _device_problem(args.device):
        raise UsageError(problem)
    if args.import_from and not os.path.isdir(args.import_from):
        raise UsageError(f"--import-from {args.import_from}: no such folder")
    os.makedirs(args.work, exist_ok=True)
    if args.import_from:
        for line in R.import_finished(args.import_from, args.work, budget, tasks, seeds):
            print(line)
    write_text_atomic(
        os.path.join(args.work, "budget.json"),
        json.dumps({"budget": args.budget, **asdict(budget), "device": args.device}, indent=2),
    )
    t0 = time.time()
    failed = []
    for task, seed, stage in R.plan(tasks, seeds, stages):
        ok = (
            R.stage_train(args, budget, task, seed)
            if stage == "train"
            else R.stage_eval(args, budget, task, seed, stage)
        )
        if not ok:
            failed.append(f"{stage} {task} seed {seed}")
    if "report" in stages:
        done = {(t, sd) for t in tasks for sd in seeds if R.trained(args.work, t, sd, budget)}
        write_report(args.work, args.out, args.budget, budget, tasks, seeds, wall_s=time.time() - t0, trained=done)
        print(f"wrote {os.path.join(args.out, 'RESULTS.md')}")
    if failed:
        print("not done: " + "; ".join(failed), file=sys.stderr)
        return 1
    return 0
