"""Benchmark and time-to-skill tools: the JSON they publish, its arithmetic, and clear errors on bad input."""

from __future__ import annotations

import json

import pytest

from wqwarp.cli import bench_train, time_to_skill


def test_bench_train_json_rates_and_breakdown(tmp_path):
    out = tmp_path / "bench.json"
    rc = bench_train.main(["--sizes", "4", "--iterations", "2", "--steps-per-env", "4", "--seconds", "0.2",
                           "--threads", "1", "--json", str(out)])  # fmt: skip
    assert rc == 0
    data = json.loads(out.read_text())
    assert data["threads"] == {"torch": 1, "update": 1, "physics": 1} and data["busy_cores"] == 0
    assert data["git"]["commit"] and data["command"]
    (r,) = data["results"]
    assert r["n"] == 4 and set(r["breakdown_s"]) == set(bench_train.STAGES)
    for k in ("sim_steps_per_s", "collect_steps_per_s", "train_steps_per_s"):
        assert r[k] > 0
    assert r["train_vs_sim"] == pytest.approx(r["train_steps_per_s"] / r["sim_steps_per_s"], abs=1e-3)
    # The training rate is the robot-steps of an iteration over its measured time.
    assert r["train_steps_per_s"] == pytest.approx(4 * 4 / r["iteration_s"], rel=0.01)
    assert r["breakdown_s"]["physics"] > 0 and r["breakdown_s"]["ppo_update"] > 0
    assert all(v >= -1e-3 for v in r["breakdown_s"].values())


@pytest.mark.parametrize("argv", [["--sizes", "0"], ["--sizes", "a"], ["--threads", "0"], ["--preset", "nope"],
                                  ["--json", "/no/such/dir/x.json"]])  # fmt: skip
def test_bench_train_bad_input_exits_2(argv, capsys):
    assert bench_train.main(argv) == 2
    assert "error:" in capsys.readouterr().err


def test_first_below_uses_the_trailing_mean():
    values = [1.0, 0.5, 0.3, 0.1, 0.1, 0.1]
    assert time_to_skill.first_below(values, 0.2, window=1) == 3
    assert time_to_skill.first_below(values, 0.2, window=2) == 4  # (0.1 + 0.3) / 2 = 0.2 is not below
    assert time_to_skill.first_below(values, 0.2, window=3) == 4  # (0.3 + 0.1 + 0.1) / 3 = 0.167
    assert time_to_skill.first_below(values, 0.05, window=1) is None


def test_time_to_skill_rejects_a_folder_that_is_not_a_run(tmp_path, capsys):
    assert time_to_skill.main([str(tmp_path)]) == 2
    assert "config.json" in capsys.readouterr().err
