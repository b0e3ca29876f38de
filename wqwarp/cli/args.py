"""Command-line conventions shared by every script in ``train/`` and ``tools/``."""

from __future__ import annotations

import argparse
import math
import os
import re

from wqwarp.utils.io import output_problem

NEGATIVE_NUMBER = re.compile(r"^-(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?$")
"""A negative number, also in scientific notation (argparse's own pattern takes ``-2e-5`` for an option)."""


class ArgumentParser(argparse.ArgumentParser):
    """``argparse.ArgumentParser`` whose usage errors are one line naming the problem, exit code 2 (argparse prints the
    whole usage block first), and that reads ``-2e-5`` as a value."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self._negative_number_matcher = NEGATIVE_NUMBER

    def error(self, message: str):  # type: ignore[override]
        self.exit(2, f"{self.prog}: error: {message} (see --help)\n")

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


def repo_path(*parts: str) -> str:
    """Absolute path of ``parts`` inside the checkout holding this package (default result paths such as
    ``repo_path("docs", "studies", "x", "x.json")`` do not depend on the working directory)."""
    root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    return os.path.join(root, *parts)


def doc_parser(doc: str, epilog_from: int = 1, **kwargs) -> ArgumentParser:
    """The parser of a command whose module docstring ``doc`` is its help: the first paragraph the description, the
    paragraphs from ``epilog_from`` on the epilog, printed as written (``--help``)."""
    parts = doc.split("\n\n")
    return ArgumentParser(description=parts[0], epilog="\n\n".join(parts[epilog_from:]),
                          formatter_class=argparse.RawDescriptionHelpFormatter, **kwargs)  # fmt: skip


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
