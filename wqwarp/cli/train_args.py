"""The command line of ``train/ppo_newton.py``: ``ppo_newton.py [TASK] [--OPTION VALUE ...]``.

The task id (``wqwarp.rl.tasks``; default ``ours``) gives the whole configuration; every field of the config tree is
then an option through tyro (``--env.reward.energy -2e-5``, ``--env.sim.dt 0.001``, ``--train.max-iterations 10``;
help from the fields' docstrings, choices from their ``Literal`` types), and the short flags below stand for the
most used ones. With ``--resume CKPT`` the checkpoint's own configuration replaces the task's, and the options given
beside it override it. ``--print-config`` prints the resolved configuration and exits. No physics is imported here.
"""

from __future__ import annotations

import dataclasses
import json
import os
import shlex
from collections.abc import Sequence
from dataclasses import dataclass

import tyro

from wqwarp.cli.args import UsageError, tyro_cli
from wqwarp.rl.config import EnvConfig, GaitConfig, TrainConfig, env_config_from_dict, from_dict, to_dict
from wqwarp.rl.rewards import REWARD_TERMS
from wqwarp.rl.tasks import DEFAULT_TASK, TASKS, infer_task, task_help

PROG = "ppo_newton.py"
TUNED_FLAG = "--env.gait.tuned"
"""Option that adds a gait tuned on the differentiable path to the run's library (repeatable, applied last)."""

ALIASES: dict[str, str] = {
    "--num-envs": "env.sim.num_envs",
    "--max-iterations": "train.max_iterations",
    "--device": "env.sim.device",
    "--seed": "env.seed",
    "--save-interval": "train.save_interval",
    "--num-steps-per-env": "train.num_steps_per_env",
    "--dt": "env.sim.dt",
    "--decimation": "env.sim.decimation",
    "--true-state": "env.estimator.use_true_state",
    "--phase-residual": "env.action.phase_residual_mode",
    "--power-normalization": "env.predictor.power_normalization",
    "--temperature-iterations": "env.predictor.temperature_iterations",
    "--temperature-shape": "env.predictor.temperature_shape",
    "--decision-interval": "env.predictor.decision_interval_s",
}
"""The short flags and the config fields they set (``--num-envs 64`` = ``--env.sim.num-envs 64``)."""
REMOVED = {
    "--preset": "the method is the task id now: `ppo_newton.py no_predictor` (its recipe) or `no_predictor-paper`",
    "--profile": "the task id carries the recipe: `ppo_newton.py ours` (the former select levers) or `ours-paper` "
    "(the former paper profile); docs/training.md lists what the other profiles set",
}
"""Flags of earlier versions, refused with what replaced them."""


def option_name(path: str) -> str:
    """``"env.sim.num_envs"`` -> ``"--env.sim.num-envs"``."""
    return "--" + path.replace("_", "-")


@dataclass
class TrainCommand:
    """The main job's command: the run's configuration (``env``, ``train``) and the options of the run itself."""

    env: EnvConfig
    train: TrainConfig
    log_dir: str | None = None
    """Output directory (default runs/<task>_<date-time>, with --resume the checkpoint's folder); must not hold
    checkpoints already, unless --resume points into it."""
    resume: str | None = None
    """Checkpoint (model_<it>.pt) to continue from, with the configuration stored in it: options given beside it
    override it (listed when the run starts), a task id must be its own. The run goes on to its
    --train.max-iterations (the total, counted from iteration 0)."""
    threads: int | None = None
    """CPU threads of torch and of the physics together (default: torch 1 while collecting and half the cores in the
    PPO update, physics every core; cores are shared among torchrun's processes; docs/performance.md 'Speed and
    threads'). More torch threads than free cores slows training ~2x when another process holds a core."""
    torch_threads: int | None = None
    """torch intra-op threads during collection (policy and estimator inference; overrides --threads)."""
    update_threads: int | None = None
    """torch intra-op threads during the PPO update and the estimator / predictor fits (default: half the cores, 1 on
    2 cores; overrides --threads)."""
    physics_threads: int | None = None
    """mujoco.rollout threads (CPU; overrides --threads and --env.sim.nthread)."""
    no_export: tyro.conf.FlagCreatePairsOff[bool] = False
    """Skip the onboard-policy export at the end (export/policy.onnx, policy.pt2, policy.json)."""
    print_config: tyro.conf.FlagCreatePairsOff[bool] = False
    """Print the resolved configuration (JSON: task, env, train, run options) and exit without building an env."""


@dataclass
class TrainArgs:
    """A parsed training command line."""

    task: str
    """The task id the configuration came from (with --resume: the checkpoint's, inferred; ``custom`` if none)."""
    command: TrainCommand
    argv: list[str]
    """The command line as typed."""
    overrides: dict[str, object]
    """Dotted path -> value where the resolved configuration differs from its base (the task's, or the
    checkpoint's with --resume)."""
    tuned_gaits: list[str] = dataclasses.field(default_factory=list)
    migrated: list[str] = dataclasses.field(default_factory=list)
    """Fields filled for a checkpoint older than them (``--resume``)."""

    @property
    def env(self) -> EnvConfig:
        return self.command.env

    @property
    def train(self) -> TrainConfig:
        return self.command.train


def flatten(tree: dict, prefix: str = "") -> dict[str, object]:
    """``{"env": {"sim": {"dt": 0.005}}}`` -> ``{"env.sim.dt": 0.005}`` (lists as tuples)."""
    out: dict[str, object] = {}
    for k, v in tree.items():
        path = f"{prefix}{k}"
        if isinstance(v, dict):
            out.update(flatten(v, path + "."))
        else:
            out[path] = tuple(v) if isinstance(v, list) else v
    return out


def config_differences(base: dict[str, object], now: dict[str, object]) -> dict[str, object]:
    """Dotted path -> value of ``now`` (a :func:`flatten` dict) wherever it differs from ``base``."""
    return {k: v for k, v in now.items() if base.get(k, object()) != v}


def _description(doc: str) -> str:
    short = "\n".join(f"  {flag:<26} = {option_name(path)}" for flag, path in ALIASES.items())
    return (
        f"{doc.strip()}\n\nTasks (the first argument; default {DEFAULT_TASK}; --help after it shows its "
        f"defaults):\n{task_help()}\n\nShort flags:\n{short}\n  --temperature START END    = "
        "--env.predictor.temperature-start START --env.predictor.temperature-end END\n  --reward TERM=WEIGHT       "
        f"= --env.reward.TERM WEIGHT (terms: {', '.join(REWARD_TERMS)})\n  {TUNED_FLAG} PATH    a gait tuned "
        "on the differentiable path (tools/optimize_gait.py JSON): its frequency, DF_swing and stance x replace "
        "those of the library gait it was tuned from (repeatable, applied after every other option)"
    )


def _take_value(argv: list[str], i: int, flag: str, count: int = 1) -> tuple[list[str], int]:
    token = argv[i]
    if "=" in token and count == 1:
        return [token.partition("=")[2]], i + 1
    values = argv[i + 1 : i + 1 + count]
    if len(values) < count or any(v.startswith("--") for v in values):
        raise UsageError(f"{flag} expects {count} value{'s' if count > 1 else ''}")
    return values, i + 1 + count


def preprocess(argv: Sequence[str]) -> tuple[str | None, list[str], list[str]]:
    """The task id (first argument or ``--task ID``), the gaits of :data:`TUNED_FLAG`, and the rest of ``argv`` with
    the short flags written out as the config options they stand for (what tyro parses)."""
    argv, out, tuned, name = list(argv), [], [], None
    i = 0
    while i < len(argv):
        token = argv[i]
        flag = token.partition("=")[0].replace("_", "-") if token.startswith("--") else token
        if i == 0 and not token.startswith("-"):
            name, i = token, i + 1
        elif flag == "--task":
            (name,), i = _take_value(argv, i, flag)
        elif flag in REMOVED:
            raise UsageError(f"{flag} was removed: {REMOVED[flag]}")
        elif flag == TUNED_FLAG:
            (path,), i = _take_value(argv, i, flag)
            tuned.append(path)
        elif flag == "--reward":
            (spec,), i = _take_value(argv, i, flag)
            term, _, weight = spec.partition("=")
            if term not in REWARD_TERMS:
                raise UsageError(f"--reward {spec!r}: unknown term {term!r}; terms: {', '.join(REWARD_TERMS)}")
            out += [f"--env.reward.{term.replace('_', '-')}", weight]
        elif flag == "--temperature":
            (start, end), i = _take_value(argv, i, flag, 2)
            out += ["--env.predictor.temperature-start", start, "--env.predictor.temperature-end", end]
        elif flag in ALIASES or flag == "--no-true-state":
            path = ALIASES.get(flag, "env.estimator.use_true_state")
            full = option_name(path)
            if flag == "--no-true-state":
                head, _, leaf = full.rpartition(".")
                full = f"{head}.no-{leaf}"
            out.append(full + (token[len(token.partition("=")[0]) :] if "=" in token else ""))
            i += 1
        else:
            out.append(token)
            i += 1
    return name, tuned, out


def _resume_value(argv: Sequence[str]) -> str | None:
    for i, token in enumerate(argv):
        if token == "--resume" and i + 1 < len(argv):
            return argv[i + 1]
        if token.startswith("--resume="):
            return token.partition("=")[2]
    return None


def checkpoint_config(path: str) -> tuple[EnvConfig, TrainConfig, list[str]]:
    """The env and PPO configuration a checkpoint was trained with (its ``infos``; for a checkpoint written before
    the PPO settings were stored there: its run's ``config.json``), and the migration notes (fields filled for a
    checkpoint older than them). UsageError naming the file when it has none."""
    from wqwarp.eval.loading import checkpoint_infos

    if not os.path.isfile(path):
        raise UsageError(f"--resume: no such checkpoint {path!r}")
    notes: list[str] = []
    try:
        infos = checkpoint_infos(path)
        env = env_config_from_dict(infos["env_cfg"], notes)
        train_dict = infos.get("train_cfg")
        if train_dict is None:
            run_cfg = os.path.join(os.path.dirname(os.path.abspath(path)), "config.json")
            with open(run_cfg) as f:
                train_dict = json.load(f)["train"]
            notes.append(f"train = {run_cfg}'s (the checkpoint predates stored PPO settings)")
        train = from_dict(TrainConfig, train_dict, migrated=notes)
    except (OSError, KeyError, json.JSONDecodeError) as e:
        raise UsageError(f"--resume {path}: no PPO settings in it nor a readable config.json beside it ({e})") from None
    except ValueError as e:
        raise UsageError(f"--resume: {e}" if path in str(e) else f"--resume {path}: {e}") from None
    return env, train, notes


def tuned_gait_config(gait: GaitConfig, path: str) -> GaitConfig:
    """``gait`` with the gait tuned in ``path`` (``GaitConfig.with_tuned``); UsageError with one line naming
    :data:`TUNED_FLAG` and the path for a missing, unreadable or malformed file."""
    try:
        return gait.with_tuned(path)
    except OSError as e:
        raise UsageError(f"{TUNED_FLAG} {path!r}: {e.strerror or e}") from None
    except json.JSONDecodeError as e:
        raise UsageError(f"{TUNED_FLAG} {path!r}: not JSON ({e.msg}, line {e.lineno})") from None
    except (KeyError, TypeError, AttributeError) as e:
        what = f"no {e}" if isinstance(e, KeyError) else str(e)
        raise UsageError(f"{TUNED_FLAG} {path!r}: not a tuned gait (tools/optimize_gait.py JSON): {what}") from None
    except ValueError as e:  # a gait the library lacks, or tuned values no gait may have
        raise UsageError(f"{TUNED_FLAG} {path!r}: {e}") from None


def parse_train_args(doc: str, argv: Sequence[str] | None = None) -> TrainArgs:
    """Parse and resolve a training command line (``sys.argv[1:]`` when ``argv`` is None): the task's configuration
    (or the checkpoint's with ``--resume``), then the options, then the tuned gaits; every section checked.
    UsageError (one line) for anything it refuses; ``--help`` exits 0."""
    import sys

    typed = list(sys.argv[1:] if argv is None else argv)
    name, tuned, rest = preprocess(typed)
    if name is not None and name not in TASKS:
        raise UsageError(f"unknown task {name!r}; tasks: {', '.join(TASKS)}")
    resume = _resume_value(rest)
    if resume is not None and not {"-h", "--help"} & set(rest):
        env, train, notes = checkpoint_config(resume)
        own = infer_task(env, train)
        if name is not None and name != own:
            raise UsageError(
                f"--resume {resume} was trained as {own or 'a custom configuration'}, not as task "
                f"{name}; drop the task id (the checkpoint's configuration is used)"
            )
        name = own or name or "custom"
    else:
        name, notes = name or DEFAULT_TASK, []
        env, train = TASKS[name].make()
    base = {"env": to_dict(env), "train": to_dict(train)}
    command = tyro_cli(
        TrainCommand, TrainCommand(env=env, train=train), rest, prog=f"{PROG} {name}", description=_description(doc)
    )
    cfg = command.env
    for path in tuned:
        cfg.gait = tuned_gait_config(cfg.gait, path)
    try:
        cfg.validate()
        command.train.validate()
        if command.train.algorithm_class != TrainConfig.algorithm_class:  # the default needs no import here
            from wqwarp.rl.algorithm import resolve_algorithm_class

            resolve_algorithm_class(command.train.algorithm_class)
    except ValueError as e:
        raise UsageError(str(e)) from None
    now = {"env": to_dict(cfg), "train": to_dict(command.train)}
    overrides = config_differences(flatten(base), flatten(now))
    return TrainArgs(task=name, command=command, argv=typed, overrides=overrides, tuned_gaits=tuned, migrated=notes)


def resolved_config(args: TrainArgs) -> dict:
    """What ``--print-config`` prints and ``config.json`` records: the task, the command line, the options that
    changed its configuration, the run's own options and the whole configuration."""
    run = {
        f.name: getattr(args.command, f.name)
        for f in dataclasses.fields(TrainCommand)
        if f.name not in ("env", "train")
    }
    return {
        "task": args.task,
        "command": shlex.join([f"train/{PROG}", *args.argv]),
        "overrides": args.overrides,
        "tuned_gaits": list(args.tuned_gaits),
        "args": run,
        "env": to_dict(args.env),
        "train": to_dict(args.train),
    }
