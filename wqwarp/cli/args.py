"""Command-line conventions shared by every script in ``train/`` and ``tools/``: one exception for bad input
(:class:`UsageError`, printed as one line with exit code 2 by :func:`entry_point`), tyro over config dataclasses
(:func:`tyro_cli`), and the argparse conventions of the smaller tools."""

from __future__ import annotations

import argparse
import contextlib
import functools
import io
import math
import re
import sys
from collections.abc import Callable, Sequence

from wqwarp.utils.io import output_problem, repo_path  # noqa: F401  (repo_path: re-exported for the tools)

USAGE_EXIT = 2
"""Exit code of a usage error (argparse's)."""


class UsageError(ValueError):
    """Bad input of a command (an option, a path, a checkpoint it cannot use): :func:`entry_point` prints it as one
    line ``error: <message>`` and exits with :data:`USAGE_EXIT`, before any work and without touching any output."""


def entry_point(main: Callable[..., int | None]) -> Callable[..., int]:
    """Decorator of a command's ``main(argv=None) -> exit code``: a :class:`UsageError` raised anywhere in it
    becomes one line on stderr and exit code 2; ``None`` returns 0."""

    @functools.wraps(main)
    def run(*args, **kwargs) -> int:
        try:
            code = main(*args, **kwargs)
        except UsageError as e:
            print(f"error: {' '.join(str(e).split())}", file=sys.stderr, flush=True)  # one line, whatever it holds
            return USAGE_EXIT
        return 0 if code is None else int(code)

    return run


_ANSI = re.compile(r"\x1b\[[0-9;]*m")
_RULE = set("─━-+╭╮╰╯ ")


def tyro_error_line(text: str) -> str:
    """tyro's boxed error message (UTF-8 or ASCII box) as one line: its sections joined with ``;``, and the first
    option it suggests for a misspelt one; the help pointers dropped."""
    rows = [_ANSI.sub("", line).strip() for line in text.splitlines()]
    segments: list[list[str]] = [[]]
    for row in rows:
        if row.startswith(("╭", "╰", "+-", "+=")) or (row and set(row) <= _RULE):  # the box's edges, a title line
            segments.append([])
            continue
        row = row.strip("│|").strip()
        if row and set(row) <= _RULE:  # an inner rule
            segments.append([])
        elif row:
            segments[-1].append(row)
    skip = ("For full helptext", "Perhaps you meant", "Argument helptext")
    segments = [s for s in segments if s]
    if len(segments) > 1 and len(segments[0]) == 1 and ":" not in segments[0][0]:  # the title of the ASCII form
        segments = segments[1:]
    kept = [" ".join(s) for s in segments if not s[0].startswith(skip)]
    suggest = next((s[1].split()[0] for s in segments if len(s) > 1 and s[0].startswith("Perhaps you meant")), "")
    message = re.sub(r"^Error parsing (?!-)[^:]*: ", "", "; ".join(kept) or "invalid command line")
    return message + (f" (did you mean {suggest}?)" if suggest else "") + " (see --help)"


def tyro_cli(cls: type, default: object, argv: Sequence[str], prog: str, description: str, config: tuple = ()):
    """``tyro.cli(cls, default=default, args=argv)``: an instance of the dataclass ``cls`` whose fields are options
    (``--env.sim.dt``), help from the fields' docstrings, choices from their ``Literal`` types. A bad option or value
    (including one a config's own checks refuse) is a :class:`UsageError` of one line; ``--help`` exits 0."""
    import tyro

    err = io.StringIO()
    try:
        with contextlib.redirect_stderr(err):
            out = tyro.cli(cls, default=default, args=list(argv), prog=prog, description=description, config=config)
    except SystemExit as e:
        if e.code not in (0, None):
            raise UsageError(tyro_error_line(err.getvalue())) from None
        raise
    except ValueError as e:  # a config check that tyro let through
        raise UsageError(str(e)) from None
    sys.stderr.write(err.getvalue())  # warnings of a successful parse
    return out


NEGATIVE_NUMBER = re.compile(r"^-(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?$")
"""A negative number, also in scientific notation (argparse's own pattern takes ``-2e-5`` for an option)."""


class ArgumentParser(argparse.ArgumentParser):
    """``argparse.ArgumentParser`` whose usage errors are one line naming the problem, exit code 2 (argparse prints the
    whole usage block first), and that reads ``-2e-5`` as a value."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self._negative_number_matcher = NEGATIVE_NUMBER

    def error(self, message: str):  # type: ignore[override]
        self.exit(USAGE_EXIT, f"{self.prog}: error: {message} (see --help)\n")

    def check_outputs(self, *paths: str | None) -> None:
        """Usage error unless every given result-file path can be written (:func:`output_problem`); None is skipped.
        Call it before any work, so that a long run never ends in a failed write."""
        for path in paths:
            if path and (problem := output_problem(path)):
                self.error(f"cannot write {path}: {problem}")


def parse_counts(text: str) -> list[int]:
    """``"64,128,256"`` -> [64, 128, 256]; ValueError unless at least one value and all positive integers."""
    try:
        values = [int(s) for s in text.split(",") if s.strip()]
    except ValueError:
        values = []
    if not values or min(values) < 1:
        raise ValueError(f"expected positive integers like 64,256, got {text!r}")
    return values


def parse_seeds(text: str) -> list[int]:
    """``"11,12,13"`` or ``"11-13"`` (ranges inclusive, mixed with single seeds) -> [11, 12, 13], in the order given;
    ValueError unless at least one seed, all non-negative integers, none twice."""
    seeds: list[int] = []
    try:
        for part in (s.strip() for s in text.split(",")):
            if not part:
                continue
            lo, sep, hi = part.partition("-")
            seeds += list(range(int(lo), int(hi) + 1)) if sep else [int(lo)]
    except ValueError:
        seeds = []
    if not seeds or min(seeds) < 0 or len(set(seeds)) < len(seeds):
        raise ValueError(f"expected seeds like 11,12,13 or 11-13 (non-negative, none twice), got {text!r}")
    return seeds


def doc_parser(doc: str, epilog_from: int = 1, **kwargs) -> ArgumentParser:
    """The parser of a command whose module docstring ``doc`` is its help: the first paragraph the description, the
    paragraphs from ``epilog_from`` on the epilog, printed as written (``--help``)."""
    parts = doc.split("\n\n")
    return ArgumentParser(
        description=parts[0],
        epilog="\n\n".join(parts[epilog_from:]),
        formatter_class=argparse.RawDescriptionHelpFormatter,
        **kwargs,
    )


def add_result_options(ap: argparse.ArgumentParser, plot: str | None = "the figure") -> None:
    """The result-file options of a measuring command: ``--json PATH`` (the results, written atomically with the
    command line and git state) and, unless ``plot`` is None, ``--plot PATH`` (``plot``, a PNG). Check both with
    :meth:`ArgumentParser.check_outputs` before any work."""
    ap.add_argument("--json", default=None, metavar="PATH", help="write the results here (JSON)")
    if plot is not None:
        ap.add_argument("--plot", default=None, metavar="PATH", help=f"write {plot} here (PNG)")


def parse_floats(text: str) -> list[float]:
    """``"0.3,0.25,0.2"`` -> [0.3, 0.25, 0.2]; ValueError unless at least one value and all finite numbers."""
    try:
        values = [float(s) for s in text.split(",") if s.strip()]
    except ValueError:
        values = []
    if not values or not all(math.isfinite(v) for v in values):
        raise ValueError(f"expected comma-separated numbers like 0.3,0.2, got {text!r}")
    return values


def parse_command(text: str, option: str = "--command") -> tuple[float, float, float]:
    """``"0.5,0,0.3"`` -> (0.5, 0.0, 0.3), a body command v_x, v_y, w; UsageError naming ``option`` unless three
    finite numbers."""
    parts = [p.strip() for p in text.split(",")]
    try:
        values = tuple(float(p) for p in parts)
    except ValueError:
        values = ()
    if len(values) != 3 or not all(math.isfinite(v) for v in values):
        raise UsageError(f"{option} {text!r}: expected three numbers vx,vy,wz (e.g. 0.5,0,0.3)")
    return values  # type: ignore[return-value]
