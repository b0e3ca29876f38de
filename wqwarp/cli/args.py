"""Command-line conventions shared by every script in ``train/`` and ``tools/``."""

from __future__ import annotations

import argparse
import os


class ArgumentParser(argparse.ArgumentParser):
    """``argparse.ArgumentParser`` whose usage errors are one line naming the problem, exit code 2 (argparse prints the
    whole usage block first)."""

    def error(self, message: str):  # type: ignore[override]
        self.exit(2, f"{self.prog}: error: {message} (see --help)\n")

    def check_outputs(self, *paths: str | None) -> None:
        """Usage error unless every given result-file path can be written (:func:`output_problem`); None is skipped.
        Call it before any work, so that a long run never ends in a failed write."""
        for path in paths:
            if path and (problem := output_problem(path)):
                self.error(f"cannot write {path}: {problem}")


def directory_problem(path: str) -> str | None:
    """Why ``path`` cannot be used as an output directory (a file there, or its nearest existing ancestor not a
    writable directory), or None. Creates nothing."""
    full = os.path.abspath(path)
    if os.path.exists(full) and not os.path.isdir(full):
        return "is a file, not a directory"
    parent = full
    while not os.path.exists(parent):
        parent = os.path.dirname(parent)
    if not os.path.isdir(parent) or not os.access(parent, os.W_OK | os.X_OK):
        return f"cannot be written ({parent} is not a writable directory)"
    return None


def output_problem(path: str) -> str | None:
    """Why a result file cannot be written at ``path`` (the path a folder, its folder missing, not a folder or not
    writable), or None: checked before any work is done, so that a long run never ends in a failed write."""
    full = os.path.abspath(path)
    folder = os.path.dirname(full)
    if os.path.isdir(full):
        return "is a directory"
    if not os.path.exists(folder):
        return f"its directory {folder} does not exist"
    problem = directory_problem(folder)
    return f"its directory {problem}" if problem else None


def parse_counts(text: str) -> list[int]:
    """``"64,128,256"`` -> [64, 128, 256]; ValueError unless at least one value and all positive integers."""
    try:
        values = [int(s) for s in text.split(",") if s.strip()]
    except ValueError:
        values = []
    if not values or min(values) < 1:
        raise ValueError(f"expected positive integers like 64,256, got {text!r}")
    return values
