"""Config dataclasses that check their own values (no physics imported here).

A subclass of :class:`CheckedConfig` that is a ``@dataclass``:

- refuses a value outside a ``Literal[...]`` field's choices, at construction and on every later assignment, with
  one ValueError naming the class, the field, the value and the choices;
- runs its :meth:`CheckedConfig.check` (numeric sanity of its own fields: positive counts, ranges lo <= hi) at
  construction; :meth:`CheckedConfig.validate` runs ``check`` over a whole tree again after fields were set one by
  one (the command line, evaluation overrides).
"""

from __future__ import annotations

import dataclasses
import functools
import typing


@functools.cache
def field_types(cls: type) -> dict[str, object]:
    """The resolved type hints of dataclass ``cls`` (``from __future__ import annotations`` strings evaluated)."""
    return typing.get_type_hints(cls)


@functools.cache
def literal_choices(cls: type) -> dict[str, tuple]:
    """Field name -> its choices, for every ``Literal[...]`` field of dataclass ``cls``."""
    return {n: typing.get_args(t) for n, t in field_types(cls).items() if typing.get_origin(t) is typing.Literal}


def choice_error(owner: str, value: object, choices: tuple) -> str:
    """The one-line message for ``value`` outside ``choices`` of field ``owner`` (``"GaitConfig.selection"``)."""
    return f"{owner} {value!r} is not one of {', '.join(str(c) for c in choices)}"


class CheckedConfig:
    """Base of the config dataclasses: ``Literal`` choices checked on assignment, :meth:`check` at construction."""

    def __setattr__(self, name: str, value: object) -> None:
        choices = literal_choices(type(self)).get(name)
        if choices is not None and value not in choices:
            raise ValueError(choice_error(f"{type(self).__name__}.{name}", value, choices))
        object.__setattr__(self, name, value)

    def __post_init__(self) -> None:
        self.check()

    def check(self) -> None:
        """Numeric sanity of this section's own fields; ValueError naming the field. Overridden per section."""

    def validate(self) -> None:
        """:meth:`check` this section and every nested one (after fields were assigned one by one)."""
        self.check()
        for f in dataclasses.fields(self):  # type: ignore[arg-type]
            value = getattr(self, f.name)
            if isinstance(value, CheckedConfig):
                value.validate()


def require(ok: bool, owner: str, message: str) -> None:
    """ValueError ``"<owner> <message>"`` unless ``ok`` (``require(n >= 1, "SimConfig.num_envs", "must be >= 1")``)."""
    if not ok:
        raise ValueError(f"{owner} {message}")


def check_positive(cfg: object, *names: str, strict: bool = True) -> None:
    """Each named field of ``cfg`` must be > 0 (``strict``) or >= 0."""
    for n in names:
        v = getattr(cfg, n)
        bound = ">" if strict else ">="
        require(v > 0 if strict else v >= 0, f"{type(cfg).__name__}.{n}", f"must be {bound} 0, got {v}")


def check_ranges(cfg: object, *names: str) -> None:
    """Each named ``(lo, hi)`` field of ``cfg`` must have two values with lo <= hi."""
    for n in names:
        v = tuple(getattr(cfg, n))
        require(len(v) == 2 and v[0] <= v[1], f"{type(cfg).__name__}.{n}", f"must be (lo, hi) with lo <= hi, got {v}")
