"""Benchmark and time-to-skill tools: the JSON they publish, its arithmetic, and clear errors on bad input."""

from __future__ import annotations

import json

import pytest

from wqwarp.cli import bench_train, time_to_skill


def test_bench_train_json_rates_and_breakdown(tmp_path):
    out = tmp_path / "bench.json"
    rc = bench_train.main(
        [
            "--sizes",
            "4",
            "--iterations",
            "2",
            "--steps-per-env",
            "4",
            "--seconds",
            "0.2",
            "--threads",
            "1",
            "--num-learning-epochs",
            "2",
            "--num-mini-batches",
            "1",
            "--json",
            str(out),
        ]
    )
    assert rc == 0
    data = json.loads(out.read_text())
    assert data["threads"] == {"torch": 1, "update": 1, "physics": 1} and data["busy_cores"] == 0
    assert data["git"]["commit"] and data["command"]
    (r,) = data["results"]
    assert r["n"] == 4 and set(r["breakdown_s"]) == set(bench_train.STAGES)
    assert (r["num_learning_epochs"], r["num_mini_batches"]) == (2, 1)  # the options, over the task's 5 x 4
    for k in ("sim_steps_per_s", "collect_steps_per_s", "train_steps_per_s"):
        assert r[k] > 0
    assert r["train_vs_sim"] == pytest.approx(r["train_steps_per_s"] / r["sim_steps_per_s"], abs=1e-3)
    # The training rate is the robot-steps of an iteration over its measured time.
    assert r["train_steps_per_s"] == pytest.approx(4 * 4 / r["iteration_s"], rel=0.01)
    assert r["breakdown_s"]["physics"] > 0 and r["breakdown_s"]["ppo_update"] > 0
    assert all(v >= -1e-3 for v in r["breakdown_s"].values())


@pytest.mark.parametrize(
    "argv",
    [
        ["--sizes", "0"],
        ["--sizes", "a"],
        ["--threads", "0"],
        ["--task", "nope"],
        ["--num-learning-epochs", "0"],
        ["--json", "/no/such/dir/x.json"],
    ],
)
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


def test_train_log_curves_average_the_progress_lines_of_a_console_log(tmp_path, capsys):
    """tools/studies/train_log_curves.py reads train/ppo_newton.py's progress lines (carriage returns included, a
    resumed run's repeated iteration: the last wins) and averages each window by hand: iterations 2-3 of window 2
    at iteration 3 give reward (20 + 40) / 2 = 30 and err vy (0.3 + 0.1) / 2 = 0.2; err vy first below 0.25 at 3."""
    import importlib

    tool = importlib.import_module("tools.studies.train_log_curves")

    def line(it, reward, vy, power):
        return (
            f"[#---] {it}/4 ETA 0:00:0{it} | reward {reward:7.2f} | err vx 0.10 vy {vy:.2f} wz 0.50 | power "
            f"{power:6.1f} W (legs {power - 10:5.1f}, wheels  10.0) |   1000 steps/s"
        )

    log = tmp_path / "run.log"
    text = "header\n" + "\r".join([line(1, 10.0, 0.5, 100.0), line(2, 99.0, 0.9, 1.0), line(2, 20.0, 0.3, 80.0)])
    log.write_text(text + "\n" + line(3, 40.0, 0.1, 60.0) + "\n" + line(4, -5.0, 0.1, 50.0) + "\n")
    rows = tool.read_log(str(log))
    assert sorted(rows) == [1, 2, 3, 4] and rows[2]["reward"] == 20.0 and rows[4]["reward"] == -5.0
    w = tool.windowed(rows, 3, 2)
    assert w["reward"] == pytest.approx(30.0) and w["err_vy"] == pytest.approx(0.2) and w["lines"] == 2
    assert w["power"] == pytest.approx(70.0) and w["power_legs"] == pytest.approx(60.0)
    assert tool.first_below(rows, "err_vy", 0.25, 2) == 3 and tool.first_below(rows, "err_vy", 0.05, 2) is None
    out = tmp_path / "curves.json"
    assert tool.main([str(log), "--at", "3,9", "--window", "2", "--skill", "vy=0.25", "--json", str(out)]) == 0
    data = json.loads(out.read_text())["logs"][str(log)]
    assert data["first_below"] == {"vy": 3} and data["points"]["9"] is None
    assert tool.main([str(log), "--skill", "roll=0.1"]) == 2 and "choose from vx" in capsys.readouterr().err
    rows = [
        {
            "iteration": k,
            "mean_reward": 10.0 * k,
            "Metrics/vx_error": 0.1,
            "Metrics/vy_error": 0.4 / k,
            "Metrics/wz_error": 0.5,
            "Metrics/p_cost": 100.0,
            "Metrics/p_cost_legs": 90.0,
            "Metrics/p_cost_wheels": 10.0,
        }
        for k in (10, 20)
    ]
    (tmp_path / "metrics.jsonl").write_text("".join(json.dumps(r) + "\n" for r in rows) + '{"iteration": 3')
    jl = tool.read_log(str(tmp_path / "metrics.jsonl"))
    assert sorted(jl) == [10, 20] and jl[20]["err_vy"] == pytest.approx(0.02) and jl[10]["power_wheels"] == 10.0
    assert tool.windowed(jl, 20, 20)["reward"] == pytest.approx(150.0)
    # records committed gzipped (docs/): read as X.gz, or by their plain name when only X.gz exists
    import gzip

    for plain in (log, tmp_path / "metrics.jsonl"):
        with gzip.open(f"{plain}.gz", "wt", encoding="utf-8") as f:
            f.write(plain.read_text())
        expected = tool.read_log(str(plain))
        assert tool.read_log(f"{plain}.gz") == expected
        plain.unlink()
        assert tool.read_log(str(plain)) == expected
    (tmp_path / "empty.log").write_text("nothing\n")
    assert tool.main([str(tmp_path / "empty.log")]) == 2 and "no progress lines" in capsys.readouterr().err


def test_headline_checks_read_records_of_any_runs_as_the_reproduction_page_does(tmp_path, capsys):
    """tools/studies/headline_checks.py: tracking records of runs outside the reproduction get the page's checks.
    Ours' two seeds (18 and 22 W, MSE 0.001 and 0.0012 on v_x) average to 20 W at 0.0011 against the fixed trot's
    40 W at 0.001: 0.50x at 1.10x, met; bad input is one line and exit 2."""
    import importlib

    tool = importlib.import_module("tools.studies.headline_checks")

    def record(path, vx, vy, wz):
        rows = [
            {"task": t, "mse": m, "mean_p_cost": p, "gait_usage": {"driving": 1.0}, "command": [0.0, 0.0, 0.0]}
            for t, (m, p) in (("vx", vx), ("vy", vy), ("wz", wz))
        ]
        path.write_text(json.dumps({"results": rows}))
        return str(path)

    o1 = record(tmp_path / "o1.json", (0.001, 18.0), (0.04, 30.0), (0.03, 25.0))
    o2 = record(tmp_path / "o2.json", (0.0012, 22.0), (0.04, 30.0), (0.03, 25.0))
    f1 = record(tmp_path / "f1.json", (0.001, 40.0), (0.01, 60.0), (0.01, 30.0))
    out = tmp_path / "h.json"
    assert tool.main(["--tracking", f"ours={o1},{o2}", "--tracking", f"no_predictor={f1}", "--json", str(out)]) == 0
    targets = json.loads(out.read_text())["targets"]
    line = next(x for x in targets if x.startswith("- headline"))
    assert "Ours 20.0 W = 0.50x the fixed trot's 40.0 W at 1.10x its MSE" in line and line.endswith("-> met")
    claims = json.loads(out.read_text())["fig5_claims"]
    assert "- lowest mean power over the three tasks: paper Ours; here Ours (25.0 W) -> agrees" in claims
    capsys.readouterr()
    for bad in (["--tracking", "walker=x.json"], ["--tracking", f"ours={tmp_path / 'missing.json'}"], []):
        assert tool.main(bad) == 2
        assert capsys.readouterr().err.count("\n") == 1


def test_power_ratio_compares_two_policies_under_both_measures_and_rescales_the_leg_copper(tmp_path, capsys):
    """tools/studies/power_ratio.py: a policy at 150 W of p_elec (140 W of it leg copper) against one at 100 W (90 W)
    is 1.50x; at the leg motor constant 0.22 instead of the model's 0.147 the copper is (0.147 / 0.22)^2 = 0.446x:
    (10 + 62.5) / (10 + 40.2) = 1.44x. p_cost 20 against 40 W is 0.50x. A record without p_elec is refused with one
    line and exit 2."""
    import importlib

    tool = importlib.import_module("tools.studies.power_ratio")

    def record(path, p_cost, p_elec, copper, elec=True):
        row = {"task": "vx", "mse": 0.001, "mean_p_cost": p_cost}
        if elec:
            row |= {"mean_p_elec": p_elec, "mean_p_copper_legs": copper}
        path.write_text(json.dumps({"results": [row]}))
        return str(path)

    a = record(tmp_path / "a.json", 20.0, 150.0, 140.0)
    b = record(tmp_path / "b.json", 40.0, 100.0, 90.0)
    out = tmp_path / "r.json"
    assert tool.main(["--a", f"ours={a}", "--b", f"trot={b}", "--leg-km", "0.147,0.22", "--json", str(out)]) == 0
    r = json.loads(out.read_text())["tasks"]["vx"]
    assert r["ratio_p_cost"] == pytest.approx(0.5) and r["ratio_p_elec"] == pytest.approx(1.5)
    s = (0.147 / 0.22) ** 2
    assert r["ratio_p_elec_at_km"] == pytest.approx([1.5, (10 + 140 * s) / (10 + 90 * s)])
    capsys.readouterr()
    old = record(tmp_path / "old.json", 20.0, 0.0, 0.0, elec=False)
    assert tool.main(["--a", f"ours={old}", "--b", f"trot={b}"]) == 2
    assert "no tracking results with mean_p_elec" in capsys.readouterr().err
