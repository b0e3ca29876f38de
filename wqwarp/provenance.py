"""Provenance of a result file: the git commit of the source tree and whether it had uncommitted changes."""

from __future__ import annotations

import os
import subprocess

_ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def git_state() -> dict:
    """``{"commit": sha or None, "dirty": bool or None}`` of the checkout holding this package (None outside git)."""
    try:
        run = lambda *a: subprocess.run(["git", "-C", _ROOT, *a], capture_output=True, text=True, check=True)  # noqa: E731
        head, status = run("rev-parse", "HEAD"), run("status", "--porcelain")
    except (OSError, subprocess.CalledProcessError):
        return {"commit": None, "dirty": None}
    return {"commit": head.stdout.strip(), "dirty": bool(status.stdout.strip())}
