"""The command line of ``train/ppo_newton.py``: every field of the config tree (``--env.reward.energy -2e-5``,
``--env.sim.dt 0.001``, ``--train.max-iterations 10``) and the short flags that alias the most used ones
(``--num-envs`` = ``--env.sim.num-envs``). The preset is applied first, then the lever profile
(``--profile``, ``wqwarp.rl.profiles``), then :data:`TRAIN_DEFAULTS`, then the options in command-line order (a later
one wins), then the gaits tuned on the differentiable path (``--env.gait.tuned PATH``). No physics is imported here.
"""

from __future__ import annotations

import argparse
import json
import shlex
from collections.abc import Sequence
from dataclasses import dataclass

from wqwarp.cli.args import ArgumentParser
from wqwarp.cli.config_args import (
    add_config_arguments,
    apply_overrides,
    config_dest,
    config_overrides,
    normalize_options,
    option_kwargs,
    option_name,
    value_at,
)
from wqwarp.rl.config import EnvConfig, GaitConfig, TrainConfig, resolve_algorithm_class
from wqwarp.rl.presets import PRESETS, make_preset, preset_help
from wqwarp.rl.profiles import DEFAULT_PROFILE, PROFILES, profile_help, profile_overrides
from wqwarp.rl.rewards import REWARD_TERMS

TUNED_FLAG = "--env.gait.tuned"
"""Option that adds a gait tuned on the differentiable path to the run's library (the library itself is no flag)."""
TRAIN_DEFAULTS: dict[str, object] = {"env.sim.num_envs": 128, "train.max_iterations": 4883}
"""Where the training command's defaults differ from the config's own (dotted path -> value): 128 robots x 24 steps x
4883 iterations = 15.0 M samples, the budget at which the default main job met issue 21's target."""
DEFAULT_PRESET = "ours"


@dataclass(frozen=True)
class Alias:
    """A short flag for one config field; it parses like the field's own option and shares its destination."""

    flag: str
    path: str
    help: str


ALIASES: tuple[Alias, ...] = (
    Alias("--num-envs", "env.sim.num_envs", "parallel robots (4096 on a GPU)"),
    Alias("--max-iterations", "train.max_iterations", "PPO iterations of 24 steps per robot each (the paper: 4000 "
          "with 4096 robots; the default is 15 M samples with 128 robots, 44-85 min on 2 CPU cores, "
          "docs/studies/omnidirectional/README.md)"),
    Alias("--device", "env.sim.device", "cpu (mujoco.rollout on all cores) or cuda:N (Newton SolverMuJoCo with CUDA "
          "graphs); under torchrun each process uses cuda:<LOCAL_RANK>"),
    Alias("--seed", "env.seed", "random seed (offset by the rank under torchrun)"),
    Alias("--save-interval", "train.save_interval", "iterations between checkpoints"),
    Alias("--num-steps-per-env", "train.num_steps_per_env", "rollout length per iteration"),
    Alias("--dt", "env.sim.dt", "physics step [s] (the paper uses 0.001)"),
    Alias("--decimation", "env.sim.decimation", "physics steps per 50 Hz policy step (the paper's dt 0.001 needs 20)"),
    Alias("--true-state", "env.estimator.use_true_state",
          "debug: feed the true base velocity and height to the policy instead of the estimator's"),
    Alias("--phase-residual", "env.action.phase_residual_mode", "how the policy's phase residual enters the gait "
          "phase: offset (an offset from the gait clock, as the authors' generator PMTG.py) or increment (accumulated "
          "every policy step: the policy can stop the gait clock, see docs/method.md)"),
    Alias("--power-normalization", "env.predictor.power_normalization", "predictive presets: softmax over p_est / "
          "mean(p_est) (mean: tau is scale-free) or over p_est in W (watts: the paper's formula literally; collapses "
          "on driving early)"),
    Alias("--temperature-iterations", "env.predictor.temperature_iterations",
          "predictive presets: iterations over which tau is annealed, constant afterwards"),
    Alias("--temperature-shape", "env.predictor.temperature_shape",
          "predictive presets: interpolation of tau between its ends"),
    Alias("--decision-interval", "env.predictor.decision_interval_s",
          "predictive presets: seconds a selected gait is held before the next selection (the prediction horizon)"),
)  # fmt: skip
"""The short flags of ``train/ppo_newton.py`` and the config fields they set."""
POSITIVE = ("env.sim.num_envs", "train.max_iterations", "train.save_interval", "train.num_steps_per_env")
"""Fields whose non-positive value is refused with the short flags' names."""


class _Temperature(argparse.Action):
    """``--temperature START END`` sets ``env.predictor.temperature_start`` and ``temperature_end``."""

    def __call__(self, parser, namespace, values, option_string=None):
        setattr(namespace, config_dest("env.predictor.temperature_start"), values[0])
        setattr(namespace, config_dest("env.predictor.temperature_end"), values[1])


class _RewardWeight(argparse.Action):
    """``--reward TERM=WEIGHT`` sets ``env.reward.<TERM>`` (a term of ``wqwarp.rl.rewards.REWARD_TERMS``)."""

    def __call__(self, parser, namespace, value, option_string=None):
        term, _, weight = value.partition("=")
        if term not in REWARD_TERMS:
            parser.error(f"--reward {value!r}: unknown term {term!r}; terms: {', '.join(REWARD_TERMS)}")
        try:
            setattr(namespace, config_dest(f"env.reward.{term}"), float(weight))
        except ValueError:
            parser.error(f"--reward {value!r}: the weight must be a number")
        namespace.reward = [*getattr(namespace, "reward", []), value]


def tuned_gait_config(gait: GaitConfig, path: str) -> GaitConfig:
    """``gait`` with the gait tuned in ``path`` (``GaitConfig.with_tuned``); ValueError with one line naming
    :data:`TUNED_FLAG` and the path for a missing, unreadable or malformed file."""
    try:
        return gait.with_tuned(path)
    except OSError as e:
        raise ValueError(f"{TUNED_FLAG} {path!r}: {e.strerror or e}") from None
    except json.JSONDecodeError as e:
        raise ValueError(f"{TUNED_FLAG} {path!r}: not JSON ({e.msg}, line {e.lineno})") from None
    except (KeyError, TypeError, AttributeError) as e:
        what = f"no {e}" if isinstance(e, KeyError) else str(e)
        raise ValueError(f"{TUNED_FLAG} {path!r}: not a tuned gait (tools/optimize_gait.py JSON): {what}") from None
    except ValueError as e:  # a gait the library lacks, or tuned values no gait may have
        raise ValueError(f"{TUNED_FLAG} {path!r}: {e}") from None


def default_roots(preset: str = DEFAULT_PRESET, profile: str = DEFAULT_PROFILE) -> dict[str, object]:
    """The config trees of a run before its command-line options: ``preset``, then the levers of ``profile`` that
    apply to it, then :data:`TRAIN_DEFAULTS`."""
    env = make_preset(preset)
    roots: dict[str, object] = {"env": env, "train": TrainConfig()}
    apply_overrides(roots, profile_overrides(profile, env))
    apply_overrides(roots, TRAIN_DEFAULTS)
    return roots


def build_parser(doc: str, prog: str = "ppo_newton.py") -> ArgumentParser:
    """The training command's parser: ``doc``'s first paragraph as description and the rest as epilog, the
    non-config flags, the short aliases, then one group per config section."""
    shown = default_roots()
    p = ArgumentParser(prog=prog, usage=f"{prog} [--preset NAME] [--OPTION VALUE ...] (options below)",
                       description=doc.split("\n\n")[0], epilog=doc.split("\n\n", 1)[1],
                       formatter_class=argparse.RawDescriptionHelpFormatter)  # fmt: skip
    p.add_argument("--preset", default=DEFAULT_PRESET, choices=sorted(PRESETS),
                   help=f"method of the paper to train, applied before every other option (default: {DEFAULT_PRESET}; "
                        f"{preset_help()})")  # fmt: skip
    p.add_argument("--profile", default=DEFAULT_PROFILE, choices=sorted(PROFILES),
                   help=f"levers beyond the paper, applied after the preset and before every other option (default: "
                        f"{DEFAULT_PROFILE}; {profile_help()}; wqwarp/rl/profiles.py lists each lever and where it was "
                        "measured)")  # fmt: skip
    p.add_argument("--log-dir", default=None, help="output directory (default runs/<preset>_<date-time>); must not "
                   "hold checkpoints already, unless --resume points into it")  # fmt: skip
    p.add_argument("--resume", default=None,
                   help="checkpoint (model_<it>.pt) to continue from; its layout must match --preset")  # fmt: skip
    p.add_argument("--threads", type=int, default=None, help="CPU threads of torch and of the physics together "
                   "(default: torch 1 while collecting and half the cores in the PPO update, physics every core; cores "
                   "are shared among torchrun's processes; measured within 1.2x of the best setting idle and with a "
                   "core busy, docs/performance.md 'Speed and threads'). More torch threads than free cores slows "
                   "training ~2x (the PPO update 2-3x) when another process holds a core")  # fmt: skip
    p.add_argument("--torch-threads", type=int, default=None, help="torch intra-op threads during collection "
                   "(policy and estimator inference; overrides --threads)")  # fmt: skip
    p.add_argument("--update-threads", type=int, default=None, help="torch intra-op threads during the PPO update "
                   "and the estimator / predictor fits (default: half the cores, 1 on 2 cores; overrides --threads)")
    p.add_argument("--physics-threads", type=int, default=None,
                   help="mujoco.rollout threads (CPU; overrides --threads and --env.sim.nthread)")  # fmt: skip
    p.add_argument("--no-export", action="store_true", help="skip the onboard-policy export at the end "
                   "(export/policy.onnx, policy.pt2 through torch.export, policy.json)")  # fmt: skip
    short = p.add_argument_group("short flags", "aliases of the config options below (the same destination: the "
                                 "later one on the command line wins)")  # fmt: skip
    for a in ALIASES:
        default = value_at(shown, a.path)
        short.add_argument(a.flag, dest=config_dest(a.path), default=argparse.SUPPRESS,
                           help=f"{a.help} (default: {default}; = {option_name(a.path)})".replace("%", "%%"),
                           **option_kwargs(shown, a.path))  # fmt: skip
    short.add_argument("--temperature", type=float, nargs=2, metavar=("START", "END"), action=_Temperature,
                       default=argparse.SUPPRESS, help="predictive presets: softmax temperature tau at iteration 0 "
                       "and at the end of the annealing (fractions of the mean predicted power; in W with "
                       "--power-normalization watts; = --env.predictor.temperature-start / -end)")  # fmt: skip
    short.add_argument("--reward", metavar="TERM=WEIGHT", action=_RewardWeight, default=argparse.SUPPRESS,
                       help="override one weight of the paper's Table II, e.g. --reward energy=-1e-4 (repeatable; = "
                       f"--env.reward.TERM; terms: {', '.join(REWARD_TERMS)})")  # fmt: skip
    p.add_argument(TUNED_FLAG, dest="tuned_gaits", metavar="PATH", action="append", default=[],
                   help="a gait tuned on the differentiable path (tools/optimize_gait.py JSON, e.g. "
                   "docs/studies/diffsim/optimize_trotting_0.3.json): its frequency, DF_swing and stance x replace "
                   "those of the library gait it was tuned from (GaitConfig.with_tuned; repeatable, applied in order "
                   "after every other option; its h_b and h_s are not applied: set --env.gait.body-height / "
                   "--env.gait.swing-height)")  # fmt: skip
    add_config_arguments(p, shown, note=f"Defaults shown are the {DEFAULT_PRESET} preset's with the {DEFAULT_PROFILE} "
                         "profile and the training command's own; --preset and --profile replace them.")  # fmt: skip
    return p


def parse_train_args(doc: str, argv: Sequence[str] | None = None) -> argparse.Namespace:
    """Parse the training command line (``sys.argv[1:]`` when ``argv`` is None); ``args.argv`` keeps it."""
    import sys

    argv = list(sys.argv[1:] if argv is None else argv)
    args = build_parser(doc).parse_args(normalize_options(argv))
    args.argv = argv
    return args


def resolve_config(args: argparse.Namespace) -> tuple[EnvConfig, TrainConfig]:
    """The run's configuration: ``args.preset``, then ``args.profile``, then :data:`TRAIN_DEFAULTS`, then the command
    line's options; every section checked (ValueError naming the field). Sets each alias's resolved value on ``args``
    under its own name (``args.num_envs``, ``args.dt``, ...) so that ``args`` records what the run used."""
    roots = default_roots(args.preset, args.profile)
    overrides = config_overrides(args)
    apply_overrides(roots, overrides)
    if any(value_at(roots, path) < 1 for path in POSITIVE):
        raise ValueError("--num-envs, --max-iterations, --save-interval and --num-steps-per-env must be positive")
    env, train = roots["env"], roots["train"]
    for path in getattr(args, "tuned_gaits", []):
        env.gait = tuned_gait_config(env.gait, path)
    env.validate()
    train.validate()
    if train.algorithm_class != TrainConfig.algorithm_class:  # the default needs no import here
        resolve_algorithm_class(train.algorithm_class)
    for a in ALIASES:
        setattr(args, a.flag[2:].replace("-", "_"), value_at(roots, a.path))
    args.temperature = [env.predictor.temperature_start, env.predictor.temperature_end]
    args.reward = getattr(args, "reward", [])
    args.overrides = overrides
    return env, train


def run_record(args: argparse.Namespace) -> dict:
    """``config.json``'s command part: the command line as typed, the options it set (dotted path -> value) and the
    resolved flags (``args``)."""
    internal = ("argv", "overrides")
    plain = {k: v for k, v in vars(args).items() if not k.startswith(config_dest("")) and k not in internal}
    return {"command": shlex.join(["train/ppo_newton.py", *args.argv]), "overrides": dict(args.overrides),
            "args": plain}  # fmt: skip
