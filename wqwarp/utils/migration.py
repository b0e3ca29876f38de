"""Settings added after checkpoints existed declare, on their own dataclass field, how the code behaved before them.

A checkpoint (``infos['env_cfg']``) or a run's ``config.json`` holds the whole configuration of the code that wrote
it. A field added since is missing there; reading it fills that key from the field's metadata and reports the fill::

    lateral_gain: float = field(default=0.0, metadata=migrate(0.0, "no lateral feed-forward before the setting"))
    # (the field's docstring, its --help, stays right after the field line)
    lateral_limit: float = field(default=0.12, metadata=since_default("its default (unused at gain 0)"))

- :func:`migrate` ``(value, why)``: old checkpoints behave as ``value`` (the dict form a checkpoint holds: lists,
  dicts). A literal, never a live constant: today's default may change, the old behaviour does not.
- :func:`since_default` ``(why)``: the old behaviour is whatever the field's default is (a value that the old
  configurations never read, e.g. a bound of a feature that was off).

A missing field without either is an error naming it (a configuration is read whole, never completed with today's
defaults): ``wqwarp.rl.config.from_dict``. :func:`migrations` lists the declarations of a config tree.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

from wqwarp.utils.checked_config import field_types

MIGRATION_KEY = "migration"
"""The key of a field's ``metadata`` that holds its :class:`Migration`."""


class _Default:
    def __repr__(self) -> str:
        return "DEFAULT"


DEFAULT = _Default()
"""The value of a :class:`Migration` that stands for the field's default (:func:`since_default`)."""


@dataclass(frozen=True)
class Migration:
    """How a configuration written before a field existed behaves: as ``value`` (or the field's default, for
    :data:`DEFAULT`), for the reason ``why`` (reported with the fill)."""

    value: object
    why: str

    def fill(self, f: dataclasses.Field) -> object:
        """The value filled in for the missing field ``f``, in a checkpoint's dict form (tuples as lists, dataclasses
        as dicts; a fresh copy each call)."""
        if self.value is not DEFAULT:
            return plain(self.value)
        if f.default is not dataclasses.MISSING:
            return plain(f.default)
        if f.default_factory is not dataclasses.MISSING:
            return plain(f.default_factory())
        raise TypeError(f"field {f.name!r}: since_default() needs a default")


def migrate(value: object, why: str, **metadata: object) -> dict[str, object]:
    """Field metadata: configurations without this field behave as ``value`` (a literal in dict form), because
    ``why``. Other metadata passes through: ``field(default=0.0, metadata=migrate(0.0, "...", doc="..."))``."""
    return {**metadata, MIGRATION_KEY: Migration(value, why)}


def since_default(why: str, **metadata: object) -> dict[str, object]:
    """Field metadata: configurations without this field behave as its default (whatever it is), because ``why``."""
    return migrate(DEFAULT, why, **metadata)


def migration_of(f: dataclasses.Field) -> Migration | None:
    """The :class:`Migration` declared on field ``f``; None where the field existed in every configuration."""
    m = f.metadata.get(MIGRATION_KEY)
    return m if isinstance(m, Migration) else None


def plain(value: object) -> object:
    """``value`` in the dict form of a stored configuration: dataclasses as dicts, tuples and lists as lists."""
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return plain(dataclasses.asdict(value))
    if isinstance(value, dict):
        return {k: plain(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [plain(v) for v in value]
    return value


def fill_missing(cls: type, data: dict, path: str, notes: list[str]) -> dict:
    """``data`` (one section of dataclass ``cls``, at dotted ``path``; '' at the root) with each missing key that
    declares a :class:`Migration` filled, a new dict; each fill appended to ``notes`` as ``"path = value (why)"``.
    Keys without one stay missing (the caller refuses them)."""
    out = dict(data)
    for f in dataclasses.fields(cls):
        m = migration_of(f)
        if f.name in out or m is None:
            continue
        out[f.name] = m.fill(f)
        notes.append(f"{path + '.' if path else ''}{f.name} = {out[f.name]!r} ({m.why})")
    return out


def migrations(cls: type, path: str = "") -> list[tuple[str, object, str]]:
    """Every declared migration of the config tree ``cls``, nested sections included, in field order:
    ``(dotted path, the value filled, why)``."""
    out: list[tuple[str, object, str]] = []
    hints = field_types(cls)
    for f in dataclasses.fields(cls):
        p = f"{path}.{f.name}" if path else f.name
        m = migration_of(f)
        if m is not None:
            out.append((p, m.fill(f), m.why))
        if dataclasses.is_dataclass(hints[f.name]):
            out += migrations(hints[f.name], p)
    return out
