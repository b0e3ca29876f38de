"""Output paths checked before any work (:func:`output_problem`, :func:`directory_problem`: a long run never ends in a
failed write), and atomic writes: every file this project writes (checkpoints, exports, result JSON, figures, USD)
goes to a temporary file in the same folder and is renamed over its target, so a crash never leaves a truncated or
half-overwritten file and a failure never corrupts what exists. Text records that may be stored gzipped (the
per-run training logs and metrics rows committed under ``docs/``) are read through :func:`open_text` and written
by :func:`write_text_gz_atomic`."""

from __future__ import annotations

import contextlib
import gzip
import os
import tempfile
from collections.abc import Callable, Iterator
from typing import TextIO


@contextlib.contextmanager
def atomic_path(path: str) -> Iterator[str]:
    """A temporary path beside ``path`` (same folder, same extension: some writers pick the format by it) to write
    to inside the ``with`` block; renamed over ``path`` when the block ends without an exception, removed otherwise.

    Example::

        with atomic_path("runs/x/model_10.pt") as tmp:
            torch.save(state, tmp)
    """
    folder = os.path.dirname(os.path.abspath(path))
    base, ext = os.path.splitext(os.path.basename(path))
    fd, tmp = tempfile.mkstemp(dir=folder, prefix=f".{base}.", suffix=f".tmp{ext}")
    os.close(fd)
    try:
        yield tmp
        # mkstemp creates the file 0600; give the result the permissions a plain open() would (0666 less the umask)
        os.chmod(tmp, 0o666 & ~_umask())
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.remove(tmp)


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def write_atomic(path: str, write: Callable[[str], object]) -> None:
    """Call ``write(tmp)`` on a temporary path beside ``path``, then rename it over ``path`` (:func:`atomic_path`)."""
    with atomic_path(path) as tmp:
        write(tmp)


def write_text_atomic(path: str, text: str) -> None:
    """Write ``text`` (UTF-8) to ``path`` atomically."""
    with atomic_path(path) as tmp, open(tmp, "w", encoding="utf-8") as f:
        f.write(text)


def text_path(path: str) -> str:
    """``path``, or ``path + ".gz"`` when only that exists (a record committed gzipped, named by its plain name)."""
    if not path.endswith(".gz") and not os.path.exists(path) and os.path.exists(path + ".gz"):
        return path + ".gz"
    return path


def open_text(path: str, errors: str | None = None) -> TextIO:
    """A UTF-8 text handle on ``path`` for reading, gzip-decompressed when the file is gzipped: when ``path`` ends in
    ``.gz``, or when ``path`` does not exist and ``path + ".gz"`` does (:func:`text_path`). ``errors`` as for
    :func:`open`. A missing file raises :class:`FileNotFoundError` naming ``path``."""
    path = text_path(path)
    if path.endswith(".gz"):
        return gzip.open(path, "rt", encoding="utf-8", errors=errors)
    return open(path, encoding="utf-8", errors=errors)


def write_text_gz_atomic(path: str, text: str) -> None:
    """Write ``text`` (UTF-8) gzipped to ``path`` atomically, byte for byte the same for the same text (level 9, no
    name and no time in the header, as ``gzip -9n``)."""
    with atomic_path(path) as tmp, open(tmp, "wb") as raw:
        with gzip.GzipFile(filename="", mode="wb", compresslevel=9, fileobj=raw, mtime=0) as gz:
            gz.write(text.encode("utf-8"))


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


def repo_path(*parts: str) -> str:
    """Absolute path of ``parts`` inside the checkout holding this package (default result paths such as
    ``repo_path("docs", "studies", "x", "x.json")`` do not depend on the working directory)."""
    root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    return os.path.join(root, *parts)
