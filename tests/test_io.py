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


def test_open_text_reads_a_plain_file_a_gzipped_one_and_falls_back_from_the_plain_name_to_the_gz(tmp_path):
    import gzip

    from wqwarp.utils.io import open_text, text_path

    plain, packed = tmp_path / "a_train.log", tmp_path / "b_metrics_every10.jsonl.gz"
    plain.write_text("plain \u00e9\n", encoding="utf-8")
    with gzip.open(packed, "wt", encoding="utf-8") as f:
        f.write('{"iteration": 1}\n')
    with open_text(str(plain)) as f:
        assert f.read() == "plain \u00e9\n"
    with open_text(str(packed)) as f:
        assert f.read() == '{"iteration": 1}\n'
    stem = str(packed)[: -len(".gz")]  # the plain name of a record committed gzipped
    assert text_path(stem) == str(packed)
    with open_text(stem) as f:
        assert f.read() == '{"iteration": 1}\n'
    plain_too = tmp_path / "b_metrics_every10.jsonl"  # when both exist, the plain file is read
    plain_too.write_text("newer\n")
    with open_text(stem) as f:
        assert f.read() == "newer\n"
    with pytest.raises(FileNotFoundError, match="missing.log"):
        open_text(str(tmp_path / "missing.log"))


def test_a_gzipped_write_is_deterministic_and_reads_back(tmp_path):
    from wqwarp.utils.io import open_text, write_text_gz_atomic

    a, b = tmp_path / "a.log.gz", tmp_path / "b.log.gz"
    write_text_gz_atomic(str(a), "line 1\nline 2\n")
    write_text_gz_atomic(str(b), "line 1\nline 2\n")
    assert a.read_bytes() == b.read_bytes() and a.read_bytes()[:2] == b"\x1f\x8b"
    with open_text(str(a)) as f:
        assert f.read() == "line 1\nline 2\n"
