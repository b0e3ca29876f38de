"""Atomic writes: the target appears whole or not at all, and a failed write leaves what was there."""

import os

import pytest

from wqwarp.utils.io import atomic_path, write_text_atomic


def test_a_write_replaces_the_file_whole(tmp_path):
    p = tmp_path / "r.json"
    write_text_atomic(str(p), "old")
    write_text_atomic(str(p), "new")
    assert p.read_text() == "new"
    assert os.listdir(tmp_path) == ["r.json"]  # no temporary file left


def test_a_failed_write_keeps_the_old_file_and_leaves_no_temporary(tmp_path):
    p = tmp_path / "model.pt"
    p.write_text("checkpoint")
    with pytest.raises(RuntimeError), atomic_path(str(p)) as tmp:
        assert tmp.endswith(".pt") and os.path.dirname(tmp) == str(tmp_path)
        open(tmp, "w").write("half")
        raise RuntimeError("crash while writing")
    assert p.read_text() == "checkpoint"
    assert os.listdir(tmp_path) == ["model.pt"]


def test_the_written_file_has_the_permissions_of_a_plain_write(tmp_path):
    plain, atomic = tmp_path / "plain.txt", tmp_path / "atomic.txt"
    plain.write_text("x")
    write_text_atomic(str(atomic), "x")
    assert os.stat(atomic).st_mode & 0o777 == os.stat(plain).st_mode & 0o777
