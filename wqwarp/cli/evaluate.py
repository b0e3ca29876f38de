"""The command line of the evaluation protocols (``train/evaluate.py``, ``tools/gait_sequence.py``,
``tools/gait_energy_map.py``): a protocol's options dataclass (``wqwarp.eval.protocols``) through tyro, each field an
option (``--num-envs`` for ``num_envs``) with its help and choices from the field, the protocol's own defaults shown.
Bad options, an unwritable output or a checkpoint that cannot be evaluated: one line, exit code 2."""

from __future__ import annotations

import dataclasses
import sys
import textwrap
import typing
from typing import Annotated, Literal

import tyro
from typing_extensions import Doc

from wqwarp.cli.args import UsageError, entry_point, tyro_cli
from wqwarp.eval.protocols import PROTOCOLS, protocol, run_protocol


def tyro_options(cls: type, defaults: dict) -> type:
    """A dataclass with the fields of the protocol options ``cls`` as tyro reads them: the help of ``option()`` as a
    PEP 727 ``Doc``, its ``choices`` as a ``Literal``, a flag for a bool, ``defaults`` over the field defaults (a
    field without one is a required option)."""
    hints = typing.get_type_hints(cls)
    fields = []
    for f in dataclasses.fields(cls):
        hint = hints[f.name]
        if choices := f.metadata.get("choices"):
            optional = type(None) in typing.get_args(hint)
            hint = Literal[tuple(choices)] | None if optional else Literal[tuple(choices)]
        if hint is bool:
            hint = tyro.conf.FlagCreatePairsOff[bool]
        default = defaults.get(f.name, f.default)
        spec = dataclasses.field() if default is dataclasses.MISSING else dataclasses.field(default=default)
        fields.append((f.name, Annotated[hint, Doc(f.metadata.get("help", ""))], spec))
    return dataclasses.make_dataclass(cls.__name__, fields, kw_only=True)


def parse_options(name: str, argv: list[str], prog: str, description: str):
    """The options of protocol ``name`` from ``argv`` (UsageError for a bad one)."""
    p = protocol(name)
    parsed = tyro_cli(tyro_options(p.options, p.defaults), None, argv, prog=prog, description=description)
    try:
        return p.options(**{f.name: getattr(parsed, f.name) for f in dataclasses.fields(p.options)})
    except ValueError as e:
        raise UsageError(str(e)) from None


def _take_protocol(argv: list[str]) -> tuple[str | None, list[str]]:
    for i, token in enumerate(argv):
        if token == "--protocol":
            if i + 1 >= len(argv):
                raise UsageError("--protocol expects a name")
            return argv[i + 1], argv[:i] + argv[i + 2 :]
        if token.startswith("--protocol="):
            return token.partition("=")[2], argv[:i] + argv[i + 1 :]
    return None, argv


@entry_point
def main(argv: list[str] | None = None, name: str | None = None, doc: str = "") -> int:
    """Command-line entry: protocol ``name``, or the one ``--protocol`` names (default tracking) when None. ``doc``:
    the script's docstring (the help's description)."""
    argv = sys.argv[1:] if argv is None else list(argv)
    command = " ".join([sys.argv[0], *argv])
    description = doc.strip()
    if name is None:
        chosen, argv = _take_protocol(argv)
        name = chosen or "tracking"
        if name not in PROTOCOLS:
            raise UsageError(f"unknown protocol {name!r}; choose from {', '.join(PROTOCOLS)}")
        description += "\n\nProtocols (--protocol NAME --help lists its options; default tracking):\n" + "\n".join(
            textwrap.fill(q.doc, 116, initial_indent=f"  {q.name:<10} ", subsequent_indent=" " * 13)
            for q in PROTOCOLS.values()
        )
        prog = f"evaluate.py --protocol {name}"
    else:
        prog = sys.argv[0].rpartition("/")[2]
    opts = parse_options(name, argv, prog, description)
    from wqwarp import quiet_warp

    quiet_warp()
    try:
        run_protocol(name, opts, command=command)
    except ValueError as e:
        raise UsageError(str(e)) from None
    return 0
