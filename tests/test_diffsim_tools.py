"""The differentiable-simulation tools end to end on tiny settings: their JSON holds numbers that could be wrong."""

from __future__ import annotations

import json
import os
import sys

import pytest

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))  # tools/ imports from the root

from tools.studies import compare_physics, gradient_study  # noqa: E402
from wqwarp.cli import optimize_gait  # noqa: E402


def test_gradient_study_short_horizon_agrees(tmp_path):
    out = tmp_path / "g.json"
    assert gradient_study.main(["--dts", "0.005", "--horizons", "0.02", "--warmup", "0.1", "--json", str(out)]) == 0
    p = json.loads(out.read_text())["points"][0]
    assert p["substeps"] == 4
    for key in ("p_cost_smooth", "vx_grad"):
        for group in ("gait", "legs", "wheels"):
            assert p[key][group]["cosine"] > 0.98, (key, group, p[key][group])
            assert p[key][group]["fd_consistency"] > 0.9
        assert len(p[key]["tape"]) == len(p[key]["fd"]) == 11


def test_optimize_gait_writes_its_iterations(tmp_path):
    out = tmp_path / "o.json"
    argv = [
        "--gait",
        "trotting",
        "--vx",
        "0.3",
        "--dt",
        "0.005",
        "--horizon",
        "0.04",
        "--warmup",
        "0.1",
        "--windows",
        "2",
        "--iterations",
        "1",
        "--no-eval",
        "--json",
        str(out),
    ]
    assert optimize_gait.main(argv) == 0
    rep = json.loads(out.read_text())
    hist = rep["tuning"]["history"]
    assert len(hist) == 2 and hist[0]["params"] != hist[1]["params"]
    assert rep["tuning"]["config"]["windows"] == 2 and rep["evaluations"] == []
    assert "commit" in rep["git"]


def test_compare_physics_on_a_short_run(tmp_path, capsys):
    out = tmp_path / "c.json"
    argv = ["--scenarios", "standing", "--seconds", "1.2", "--dt", "0.005", "--decimation", "4", "--json", str(out)]
    assert compare_physics.main(argv) == 0
    rep = json.loads(out.read_text())
    summary = rep["scenarios"]["standing"]["summary"]
    assert summary["height"]["mean_mujoco_cpu"] == pytest.approx(0.27, abs=0.01)
    assert summary["height"]["rms_featherstone_vs_mujoco_cpu"] < 0.01
    assert len(rep["scenarios"]["standing"]["traces"]["featherstone"]) == 60
    assert "| standing | height |" in capsys.readouterr().out
