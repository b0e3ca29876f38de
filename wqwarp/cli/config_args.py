"""Every field of a tree of config dataclasses as a command-line option, with its docstring as help.

``add_config_arguments(parser, {"env": EnvConfig(), "train": TrainConfig()})`` adds ``--env.sim.dt``,
``--env.reward.energy``, ``--train.max-iterations``, ... (one argument group per config section); after parsing,
:func:`config_overrides` gives the options given, as ``{"env.sim.dt": 0.001, ...}`` in command-line order, and
:func:`apply_overrides` sets them on the tree. Field help is the string literal right after each field in the class
body (read with :mod:`ast`) or, for a generated dataclass, ``field.metadata["doc"]``. Dashes and underscores are
both accepted in option names (:func:`normalize_options`).

Types: ``bool`` (``--x``, ``--no-x``, ``--x true``), ``int``, ``float``, ``str``, ``Literal[...]`` (choices),
``tuple[float, float]`` (two values), ``tuple[int, ...]`` (one or more), ``X | None`` (``none`` for None) and nested
dataclasses; fields of any other type are not options.
"""

from __future__ import annotations

import argparse
import ast
import dataclasses
import functools
import inspect
import textwrap
import types
import typing
from collections.abc import Callable, Iterator, Sequence

from wqwarp.utils.checked_config import field_types

DEST_PREFIX = "@"
"""argparse ``dest`` of a config option: ``"@" + dotted path`` (never a valid Python name, so never a clash)."""
TRUE_WORDS = ("true", "1", "yes", "on")
FALSE_WORDS = ("false", "0", "no", "off")


def config_dest(path: str) -> str:
    """The argparse ``dest`` of the config field at dotted ``path`` (``"env.sim.dt"``); aliases use it too."""
    return DEST_PREFIX + path


def option_name(path: str) -> str:
    """``"env.sim.num_envs"`` -> ``"--env.sim.num-envs"``."""
    return "--" + path.replace("_", "-")


@functools.cache
def field_docs(cls: type) -> dict[str, str]:
    """Field name -> its docstring: the string literal right after the field in the class body of ``cls`` or a base,
    else ``field.metadata["doc"]``; fields without either are absent."""
    docs: dict[str, str] = {}
    for klass in reversed(cls.__mro__):
        try:
            tree = ast.parse(textwrap.dedent(inspect.getsource(klass)))
        except (OSError, TypeError, SyntaxError):  # builtins, generated classes: no source
            continue
        body = tree.body[0].body if tree.body and isinstance(tree.body[0], ast.ClassDef) else []
        for node, after in zip(body, body[1:], strict=False):
            if (isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name) and isinstance(after, ast.Expr)
                    and isinstance(after.value, ast.Constant) and isinstance(after.value.value, str)):  # fmt: skip
                docs[node.target.id] = inspect.cleandoc(after.value.value)
    for f in dataclasses.fields(cls):
        if "doc" in f.metadata:
            docs.setdefault(f.name, str(f.metadata["doc"]))
    return docs


def parse_bool(text: str) -> bool:
    """``true/1/yes/on`` -> True, ``false/0/no/off`` -> False (any case); ArgumentTypeError otherwise."""
    if text.lower() in TRUE_WORDS:
        return True
    if text.lower() in FALSE_WORDS:
        return False
    raise argparse.ArgumentTypeError(f"expected true or false, got {text!r}")


def _optional(convert: Callable[[str], object]) -> Callable[[str], object]:
    def parse(text: str) -> object:
        return None if text.lower() == "none" else convert(text)

    parse.__name__ = f"{getattr(convert, '__name__', 'value')} or none"
    return parse


def _negative(option: str) -> str:
    """``--env.obs.noise`` -> ``--env.obs.no-noise``; ``--true-state`` -> ``--no-true-state``."""
    head, dot, leaf = option[2:].rpartition(".")
    return f"--{head}{dot}no-{leaf}"


class BoolAction(argparse.Action):
    """``--x`` -> True, ``--x false`` -> False, ``--no-x`` -> False."""

    def __init__(self, option_strings: list[str], dest: str, **kw):
        self.negative = tuple(_negative(s) for s in option_strings)
        super().__init__(list(option_strings) + list(self.negative), dest, nargs="?", metavar="BOOL", **kw)

    def __call__(self, parser, namespace, values, option_string=None):
        if option_string in self.negative:
            if values is not None:
                parser.error(f"{option_string} takes no value")
            value = False
        else:
            try:
                value = True if values is None else parse_bool(values)
            except argparse.ArgumentTypeError as e:
                parser.error(f"argument {option_string}: {e}")
        setattr(namespace, self.dest, value)


@dataclasses.dataclass(frozen=True)
class ConfigOption:
    """One settable leaf of a config tree."""

    path: str
    """Dotted path from the root name (``"env.sim.dt"``)."""
    hint: object
    """The field's resolved type."""
    default: object
    """The value in the tree the parser was built from."""
    doc: str
    """The field's docstring ('' if none)."""


def config_options(root: str, cfg: object) -> Iterator[tuple[str, type, list[ConfigOption]]]:
    """(section path, section class, its settable leaves) for ``cfg`` and every nested config dataclass, depth first."""
    cls = type(cfg)
    hints, docs = field_types(cls), field_docs(cls)
    leaves, nested = [], []
    for f in dataclasses.fields(cfg):
        value, path = getattr(cfg, f.name), f"{root}.{f.name}"
        if dataclasses.is_dataclass(value):
            nested.append((path, value))
        elif _argparse_kwargs(hints[f.name]) is not None:
            leaves.append(ConfigOption(path, hints[f.name], value, docs.get(f.name, "")))
    yield root, cls, leaves
    for path, value in nested:
        yield from config_options(path, value)


def _argparse_kwargs(hint: object) -> dict | None:
    """The ``add_argument`` keywords that parse a value of type ``hint``, or None where it is not an option."""
    origin, args = typing.get_origin(hint), typing.get_args(hint)
    if hint is bool:
        return {"action": BoolAction}
    if hint in (int, float, str):
        return {"type": hint, "metavar": hint.__name__.upper()}
    if origin is typing.Literal:
        return {"type": type(args[0]), "choices": args}
    if origin in (typing.Union, types.UnionType) and len(args) == 2 and type(None) in args:
        inner = next(a for a in args if a is not type(None))
        if inner in (int, float, str):
            return {"type": _optional(inner), "metavar": f"{inner.__name__.upper()}|none"}
        return None
    if origin is tuple and args and all(a in (int, float, str) for a in args if a is not Ellipsis):
        if len(args) == 2 and args[1] is Ellipsis:
            return {"type": args[0], "nargs": "+", "metavar": args[0].__name__.upper()}
        if len(set(args)) == 1:
            names = ("LO", "HI") if len(args) == 2 else tuple(f"V{i}" for i in range(len(args)))
            return {"type": args[0], "nargs": len(args), "metavar": names}
    return None


def value_at(roots: dict[str, object], path: str) -> object:
    """The value at dotted ``path`` (``"env.sim.dt"``) of the tree named by its first part."""
    head, *rest = path.split(".")
    node = roots[head]
    for part in rest:
        node = getattr(node, part)
    return node


def option_kwargs(roots: dict[str, object], path: str) -> dict:
    """The ``add_argument`` keywords that parse the field at ``path`` (for an alias of it); KeyError if none."""
    owner, leaf = value_at(roots, path.rpartition(".")[0]), path.rpartition(".")[2]
    kwargs = _argparse_kwargs(field_types(type(owner))[leaf])
    if kwargs is None:
        raise KeyError(f"{path} cannot be set from the command line")
    return kwargs


def _help(option: ConfigOption) -> str:
    doc = " ".join(option.doc.split())
    default = option.default
    shown = " ".join(str(v) for v in default) if isinstance(default, tuple) else str(default)
    return f"{doc} (default: {shown})".replace("%", "%%").strip()


def add_config_arguments(parser: argparse.ArgumentParser, roots: dict[str, object], note: str = "") -> None:
    """One option per settable field of each tree in ``roots`` (name -> config instance whose values are shown as
    the defaults), one argument group per section titled by its path and class docstring (``note`` is appended to
    each root's description). Unset options leave no attribute on the namespace."""
    for name, cfg in roots.items():
        for section, cls, leaves in config_options(name, cfg):
            if not leaves:
                continue
            summary = (inspect.getdoc(cls) or "").split("\n\n")[0].replace("\n", " ").replace("%", "%%")
            group = parser.add_argument_group(f"--{section}.*", summary + (f" {note}" if section == name and note
                                                                             else ""))  # fmt: skip
            for option in leaves:
                kwargs = _argparse_kwargs(option.hint) or {}
                group.add_argument(option_name(option.path), dest=config_dest(option.path), default=argparse.SUPPRESS,
                                   help=_help(option), **kwargs)  # fmt: skip


def config_overrides(args: argparse.Namespace) -> dict[str, object]:
    """The config options given on the command line: dotted path -> value (tuples for multi-value options)."""
    return {k[len(DEST_PREFIX):]: tuple(v) if isinstance(v, list) else v
            for k, v in vars(args).items() if k.startswith(DEST_PREFIX)}  # fmt: skip


def apply_overrides(roots: dict[str, object], overrides: dict[str, object]) -> None:
    """Set each ``path -> value`` of ``overrides`` on the tree named by the path's first part (a ValueError from a
    config's own checks propagates)."""
    for path, value in overrides.items():
        owner, _, leaf = path.rpartition(".")
        setattr(value_at(roots, owner), leaf, value)


def normalize_options(argv: Sequence[str]) -> list[str]:
    """Option names with underscores written with dashes (``--env.sim.num_envs=4`` -> ``--env.sim.num-envs=4``);
    values are left alone."""
    out = []
    for token in argv:
        if token.startswith("--") and len(token) > 2:
            name, eq, value = token.partition("=")
            token = name.replace("_", "-") + eq + value
        out.append(token)
    return out
