"""Options of an evaluation protocol as one dataclass: each field is a command-line flag (``--num-envs`` for
``num_envs``, through tyro: ``wqwarp.cli.evaluate``) with its help and choices from the field's metadata, and the same
object is what the protocol function takes when it
is called from code (``train/reproduce.py``). The equivalent command line is derived back from it for the result's
provenance (:func:`command_line`)."""

from __future__ import annotations

import shlex
from dataclasses import MISSING, dataclass, field, fields

from wqwarp.rl.config import SELECTION_CRITERIA


def option(default=MISSING, help: str = "", choices: tuple | None = None, output: bool = False):  # noqa: A002
    """A dataclass field that is also a command-line option: its ``help``, its ``choices`` (a closed set of values)
    and whether it names a result file (``output``: checked writable before any work) in its metadata. No default:
    a required option."""
    metadata = {"help": help, **({"choices": tuple(choices)} if choices else {}), "output": output}
    return field(metadata=metadata) if default is MISSING else field(default=default, metadata=metadata)


def flag(name: str) -> str:
    """``num_envs`` -> ``--num-envs``."""
    return "--" + name.replace("_", "-")


@dataclass(kw_only=True)
class ProtocolOptions:
    """Options every protocol has: the checkpoint, the device, the seed and the JSON result."""

    checkpoint: str = option(help="model_<it>.pt written by train/ppo_newton.py")
    device: str = option("cpu", help="cpu or cuda:N (default cpu)")
    seed: int = option(0, help="random seed of the evaluation (spawn yaws, pushes; default 0)")
    json: str | None = option(None, help="also write the results to this JSON file", output=True)

    def validate(self) -> None:
        """ValueError with a one-line message for an option out of range (before any work)."""

    def outputs(self) -> dict[str, str]:
        """Flag -> path of every result file this run writes (checked writable before any work)."""
        return {
            flag(f.name): getattr(self, f.name)
            for f in fields(self)
            if f.metadata.get("output") and getattr(self, f.name)
        }


@dataclass(kw_only=True)
class SelectionOptions(ProtocolOptions):
    """The options of a protocol that runs a predictive checkpoint's gait selection: ``--criterion`` runs the policy
    under another selection rule than the one it was trained with (a rule A/B with the network held fixed)."""

    criterion: str | None = option(
        None,
        choices=SELECTION_CRITERIA,
        help="predictive presets: select gaits by this criterion instead of the "
        "checkpoint's (a rule A/B on one policy; nothing learns); feasible and "
        "kinematic_feasible need a checkpoint with a tracking head",
    )


def command_line(prefix: str, opts: ProtocolOptions, defaults: dict | None = None) -> str:
    """``prefix`` and the flags of ``opts`` that differ from the defaults (``defaults`` over the dataclass's), quoted
    for a POSIX shell: the command a user would type to get the same result."""
    defaults = defaults or {}
    out = [prefix]
    for f in fields(opts):
        value, default = getattr(opts, f.name), defaults.get(f.name, f.default)
        if value == default and default is not MISSING:
            continue
        if isinstance(value, bool):
            out.append(flag(f.name))
        else:
            out += [flag(f.name), shlex.quote(f"{value:g}" if isinstance(value, float) else str(value))]
    return " ".join(out)
