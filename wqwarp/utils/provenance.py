"""Provenance of a result file: the git commit of the source tree and whether it had uncommitted changes."""

from __future__ import annotations

import json
import os
import subprocess
import sys

from wqwarp.utils.io import atomic_path

_ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def git_state() -> dict:
    """``{"commit": sha or None, "dirty": bool or None, "tracked_changes": bool or None}`` of the checkout holding
    this package (None outside git)."""
    try:
        run = lambda *a: subprocess.run(["git", "-C", _ROOT, *a], capture_output=True, text=True, check=True)  # noqa: E731
        head, status = run("rev-parse", "HEAD"), run("status", "--porcelain")
    except (OSError, subprocess.CalledProcessError):
        return {"commit": None, "dirty": None, "tracked_changes": None}
    lines = [ln for ln in status.stdout.splitlines() if ln.strip()]
    # "dirty": anything uncommitted, new files included; "tracked_changes": edits of committed files only (a run
    # that writes several result files into the tree makes the later ones "dirty" with its own output).
    return {
        "commit": head.stdout.strip(),
        "dirty": bool(lines),
        "tracked_changes": any(not ln.startswith("??") for ln in lines),
    }


def write_result_json(path: str, data: dict, indent: int | None = 2, command: str | None = None) -> None:
    """Write a result file atomically (``wqwarp.utils.io.atomic_path``: a crash never leaves a truncated or
    half-overwritten file), with the command line that made it (``command``; default this process's ``sys.argv``)
    and :func:`git_state` added unless ``data`` has them."""
    data = {"command": " ".join(sys.argv) if command is None else command, "git": git_state(), **data}
    with atomic_path(path) as tmp, open(tmp, "w", encoding="utf-8") as f:
        json.dump(data, f, indent=indent)
        f.write("\n")


def save_figure(fig, path: str, dpi: int = 100, command: str | None = None) -> None:
    """Save a matplotlib figure atomically (``wqwarp.utils.io.atomic_path``), with the command line (``command``;
    default this process's ``sys.argv``) and :func:`git_state` in the PNG's metadata (``Description`` and ``Source``;
    read them with any PNG tool or ``PIL.Image.open(path).info``)."""
    git = git_state()
    source = f"git {git['commit']}{' (dirty)' if git['dirty'] else ''}"
    description = " ".join(sys.argv) if command is None else command
    with atomic_path(path) as tmp:
        fig.savefig(
            tmp,
            dpi=dpi,
            format=os.path.splitext(path)[1][1:] or "png",
            metadata={"Description": description, "Source": source},
        )
