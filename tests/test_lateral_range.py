"""tools/studies/lateral_range.py: falls split at the training range and the paired B - A share, from records."""

import json

import pytest

from tools.studies import lateral_range


def _record(path, upright_05, upright_07, fallen):
    rows = [
        {"task": "vy", "max_push": lvl, "upright": up, "falls": len(f), "fallen_commands": f}
        for lvl, up, f in ((0.5, upright_05, fallen[0]), (0.7, upright_07, fallen[1]))
    ]
    rows.append({"task": "vx", "max_push": 0.5, "upright": 1.0, "falls": 0, "fallen_commands": []})
    path.write_text(json.dumps({"results": rows}))
    return str(path)


def test_falls_are_split_at_the_limit_and_arms_paired_by_seed(tmp_path, capsys):
    a11 = _record(tmp_path / "a11.json", 0.9, 0.8, ([-1.0, 0.95, 0.5], [-1.0, 0.8, 0.72, 0.7, 0.1]))
    a12 = _record(tmp_path / "a12.json", 0.95, 0.9, ([1.0], [1.0, -0.9]))
    b11 = _record(tmp_path / "b11.json", 1.0, 0.9, ([], [0.3]))
    b12 = _record(tmp_path / "b12.json", 0.97, 1.0, ([0.9], []))
    out = tmp_path / "ab.json"
    argv = ["--a", f"11={a11},12={a12}", "--b", f"11={b11},12={b12},13={b12}", "--json", str(out)]
    assert lateral_range.main(argv) == 0
    r = json.loads(out.read_text())
    assert r["seeds"] == ["11", "12"]  # 13 has no A record
    s11 = r["levels"]["0.7"]["per_seed"]["11"]["A"]
    assert (s11["fallen_within"], s11["fallen_past"]) == (2, 3)  # 0.7 itself is within; 0.72 past
    d = r["levels"]["0.5"]["upright_B_minus_A"]
    assert d["per_seed"] == pytest.approx([0.1, 0.02]) and d["mean"] == pytest.approx(0.06)
    assert "B - A upright: +6.0 pt [" in capsys.readouterr().out
    assert lateral_range.main(["--a", f"11={a11}", "--b", f"12={b12}"]) == 2  # no shared seed
    (tmp_path / "tracking.json").write_text(json.dumps({"results": [{"task": "vy", "max_push": 0.0}]}))
    assert lateral_range.main(["--a", f"11={tmp_path / 'tracking.json'}", "--b", f"11={b11}"]) == 2


def test_arm_a_alone_splits_its_falls_on_every_seed(tmp_path, capsys):
    a11 = _record(tmp_path / "a11.json", 0.9, 0.8, ([-1.0, 0.95, 0.5], [-1.0, 0.8, 0.72, 0.7, 0.1]))
    a12 = _record(tmp_path / "a12.json", 0.95, 0.9, ([1.0], [1.0, -0.9]))
    out = tmp_path / "a.json"
    assert lateral_range.main(["--a", f"11={a11},12={a12}", "--json", str(out)]) == 0
    r = json.loads(out.read_text())
    assert r["seeds"] == ["11", "12"]
    lvl = r["levels"]["0.7"]
    assert set(lvl["per_seed"]["12"]) == {"A"} and lvl["upright_B_minus_A"] is None
    assert lvl["falls_total"] == {"A": {"falls": 7, "fallen_within": 2, "fallen_past": 5}}
    assert "A, all seeds: falls 2 within / 5 past 0.7 m/s" in capsys.readouterr().out
