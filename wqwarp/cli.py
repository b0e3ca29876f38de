"""Command-line conventions shared by every script in ``train/`` and ``tools/``."""

from __future__ import annotations

import argparse


class ArgumentParser(argparse.ArgumentParser):
    """``argparse.ArgumentParser`` whose usage errors are one line naming the problem, exit code 2 (argparse prints the
    whole usage block first)."""

    def error(self, message: str):  # type: ignore[override]
        self.exit(2, f"{self.prog}: error: {message} (see --help)\n")


def output_problem(path: str) -> str | None:
    """Why a result file cannot be written at ``path`` (its folder missing, not a folder or not writable, or the path
    a folder), or None: checked before any work is done, so that a long run never ends in a failed write."""
    import os

    full = os.path.abspath(path)
    folder = os.path.dirname(full)
    if os.path.isdir(full):
        return "is a directory"
    if not os.path.exists(folder):
        return f"its directory {folder} does not exist"
    if not os.path.isdir(folder):
        return f"{folder} is not a directory"
    if not os.access(folder, os.W_OK | os.X_OK):
        return f"its directory {folder} is not writable"
    return None
