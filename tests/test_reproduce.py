"""train/reproduce.py --budget smoke (``wqwarp.eval.reproduce``): every artefact is written, its numbers are the
evaluation's, and a re-run continues instead of redoing."""

from __future__ import annotations

import dataclasses
import json
import os

import pytest

from wqwarp.cli import reproduce as command
from wqwarp.eval import reproduce
from wqwarp.eval.stats import per_seed_stat
from wqwarp.rl.tasks import TASKS


def _load(path):
    with open(path, encoding="utf-8") as f:
        return json.load(f)


def test_smoke_reproduction_writes_every_artefact_and_resumes(tmp_path, capsys):
    work, out = tmp_path / "work", tmp_path / "out"
    args = ["--budget", "smoke", "--tasks", "ours,pmtg", "--work", str(work), "--out", str(out)]
    assert command.main(args) == 0
    ev, res = work / "eval", out / "results" / "smoke"
    for name in (
        "RESULTS.md",
        "results/smoke/results.json",
        "results/smoke/tracking_power.png",
        "results/smoke/claims.png",
        "results/smoke/ours_s1_timeline.png",
        "results/smoke/ours_s1_energymap.png",
    ):
        assert (out / name).is_file(), name
    for name in ("ours_s1_tracking", "pmtg_s1_tracking", "ours_s1_push", "pmtg_s1_push", "ours_s1_sim2sim"):
        d = _load(ev / f"{name}.json")  # provenance of every evaluation
        assert "evaluate.py" in d["command"] and "--seed 1" in d["command"] and d["git"]["commit"]
        assert d["seed"] == 1 and d["config"]["sim"]["dt"] == 0.005 and d["wall_time_s"] > 0
        assert (res / f"{name}.json").is_file()
    summary, md = _load(res / "results.json"), (out / "RESULTS.md").read_text()
    from wqwarp.eval.report import regenerate_page

    assert regenerate_page(str(out), "smoke") == (md, md)  # the page is a function of its results.json
    assert summary["trained_as"] == ["ours", "pmtg"] and summary["tasks"] == ["ours", "pmtg"]  # the recipes, named
    assert "Written by `python train/reproduce.py --budget smoke --tasks ours,pmtg`" in md  # the command
    assert f"`ours` = {TASKS['ours'].summary}" in md and "`baseline` =" not in md  # ... and what they are
    train_cfg = _load(work / "train" / "ours_s1" / "config.json")
    assert train_cfg["command"].startswith("train/ppo_newton.py ours ") and train_cfg["task"] == "ours"
    assert train_cfg["env"]["gait"]["lateral_gain"] == 0.35 and train_cfg["env"]["sim"]["wheel_ki"] == 0.0

    # Tracking and energy: the page's numbers are the evaluation's.
    tracking = {r["task"]: r for r in _load(ev / "ours_s1_tracking.json")["results"]}
    assert set(tracking) == {"stand", "vx", "vy", "wz"}
    for task, r in tracking.items():
        s = summary["presets"]["ours"]["tracking"][task]
        assert s["mean_p_cost"]["mean"] == pytest.approx(r["mean_p_cost"]) and s["mse"]["n"] == 1
        assert f"| Ours | {task} | {r['mse']:.4f} | {r['mean_p_cost']:.1f} |" in md
    # Push recovery: Table III's layout with the paper's numbers beside ours; presets not run are dashes.
    push = {(r["max_push"], r["task"]): r for r in _load(ev / "pmtg_s1_push.json")["results"]}
    assert set(push) == {(lvl, t) for lvl in (0.5, 0.7) for t in ("stand", "vx", "vy", "wz")}
    r = push[(0.7, "vy")]
    assert r["command_range"] == [-1.0, 1.0] and r["outside_training_range"]
    row = next(line for line in md.splitlines() if line.startswith("| 0.7 m/s | v_y in [-1, 1] |"))
    assert f"{100 * r['upright']:.1f} / 56.8" in row and "- / 26.5" in row  # PMTG ours/paper; Baseline not run
    # Sim-to-sim: each physics as a named override, deltas = other - train.
    s2s = _load(ev / "ours_s1_sim2sim.json")
    assert set(s2s["sim2sim"]) == {"dt0.001", "authors", "authors_robot", "authors_robot_control"}
    assert s2s["sim2sim"]["authors_robot"]["config"]["sim"]["robot"].endswith("authors_wheeled_go1/wheeled_go1.xml")
    assert (ev / "pmtg_s1_sim2sim.json").is_file()  # every method on the authors' robot (issue 49)
    assert s2s["sim2sim"]["dt0.001"]["config"]["sim"]["decimation"] == 20
    assert s2s["sim2sim"]["authors"]["config"]["sim"]["joint_model"] == "authors"
    base = {r["task"]: r for r in s2s["results"]}
    for d, r in zip(s2s["sim2sim"]["authors"]["deltas"], s2s["sim2sim"]["authors"]["results"], strict=True):
        assert d["mean_p_cost"] == pytest.approx(r["mean_p_cost"] - base[d["task"]]["mean_p_cost"])
    # Timeline (Fig. 6: stand, forward, rotate, lateral) and the energy map.
    tl = _load(ev / "ours_s1_timeline.json")
    assert [s["command"] for s in tl["segments"]] == [[0, 0, 0], [0.8, 0, 0], [0, 0, 0.6], [0, 0.4, 0]]
    em = _load(ev / "ours_s1_energymap.json")
    assert len(em["cells"]) == 2 * 2 * 2  # two planes of 2 x 2 commands
    for c in em["cells"]:
        assert set(c["measured_p_cost"]) == {"driving", "trotting", "walking"}
        assert c["predicted_winner"] == min(c["predicted_p_cost"], key=c["predicted_p_cost"].get)
        # the rule the checkpoint runs (ours: kinematic_feasible): every cell has |v_y| or |w| = 0.7, never driving
        assert em["config"]["predictor"]["criterion"] == "kinematic_feasible"
        assert c["selected"] in ("trotting", "walking")
        assert max(c["share_not_in_forced_gait"].values()) < 0.5  # each robot ran the gait forced on it
    # The nominal gait with zero residual on stand and v_x (the energy targets' floor), for Ours only.
    nom = _load(ev / "ours_s1_nominal.json")
    assert nom["zero_residual"] and nom["forced_gait"] == "driving" and "--zero-residual" in nom["command"]
    assert [r["task"] for r in nom["results"]] == ["stand", "vx"] and not (ev / "pmtg_s1_nominal.json").exists()
    assert summary["presets"]["ours"]["nominal"]["vx"]["mean_p_cost"]["mean"] == pytest.approx(
        nom["results"][1]["mean_p_cost"]
    )
    assert "residual's energy, v_x task" in md and "| Ours, nominal gait alone | vx |" in md

    # A reproduction continued in another session without checkpoints: --import-from the results folder the report
    # wrote takes every task trained at this budget as the same task as done; the page has the same numbers.
    work2, out2 = tmp_path / "work2", tmp_path / "out2"
    capsys.readouterr()
    assert (
        command.main(
            [
                "--budget",
                "smoke",
                "--presets",
                "ours,pmtg",
                "--work",
                str(work2),
                "--out",
                str(out2),
                "--import-from",
                str(res),
            ]
        )
        == 0
    )
    assert "imported ours_s1" in capsys.readouterr().out
    assert not list(work2.glob("train/*/model_*.pt"))  # nothing trained again
    assert (work2 / "train" / "ours_s1" / reproduce.IMPORTED).is_file()
    summary2 = _load(out2 / "results" / "smoke" / "results.json")
    assert summary2["presets"] == summary["presets"] and summary2["trained_as"] == ["ours", "pmtg"]
    assert summary2["training"]["ours"]["1"]["wall_time_s"] == summary["training"]["ours"]["1"]["wall_time_s"]
    budget = reproduce.BUDGETS["smoke"]
    assert reproduce.import_mismatch(str(res), "ours_s1", budget) is None
    cfg = _load(res / "ours_s1_train_config.json")
    (res / "ours-paper_s1_train_config.json").write_text(json.dumps(cfg))  # the ours recipe under another task id
    assert "trained as ours," in reproduce.import_mismatch(str(res), "ours-paper_s1", budget)
    legacy = {k: v for k, v in cfg.items() if k != "task"} | {"args": {"preset": "ours", "profile": "select"}}
    (res / "ours-paper_s1_train_config.json").write_text(json.dumps(legacy))  # before the registry: select = ours
    assert "trained as ours," in reproduce.import_mismatch(str(res), "ours-paper_s1", budget)
    (res / "ours-paper_s1_train_config.json").unlink()
    earlier = json.loads(json.dumps(cfg))
    del earlier["env"]["predictor"]["label_command_cut"]  # a record from before the lever: an earlier recipe of ours
    (res / "ours_s1_train_config.json").write_text(json.dumps(earlier))
    why = reproduce.import_mismatch(str(res), "ours_s1", budget)
    assert why == "trained under an earlier recipe of ours (env.predictor.label_command_cut False (the task's True))"
    (res / "ours_s1_train_config.json").write_text(json.dumps(cfg))
    longer = dataclasses.replace(budget, iterations=5)
    assert "final is 4" in reproduce.import_mismatch(str(res), "ours_s1", longer)
    nominal = _load(res / "ours_s1_nominal.json")  # the nominal gait alone holds for any checkpoint of its config
    (res / "ours_s1_nominal.json").write_text(json.dumps({**nominal, "iteration": 0}))
    assert reproduce.import_mismatch(str(res), "ours_s1", budget) is None

    # A re-run redoes nothing that is there; a stage that cannot run is reported and the others go on.
    stamps = {p: p.stat().st_mtime_ns for p in ev.glob("*.json")}
    assert command.main([*args, "--stages", "train,tracking,push,report"]) == 0
    assert {p: p.stat().st_mtime_ns for p in ev.glob("*.json")} == stamps
    os.remove(ev / "pmtg_s1_push.json")
    os.remove(work / "train" / "pmtg_s1" / "model_1.pt")
    capsys.readouterr()
    assert command.main([*args, "--stages", "push,report"]) == 1
    assert "push pmtg seed 1" in capsys.readouterr().err
    page = (out / "RESULTS.md").read_text()
    assert "push pmtg seed 1" in page  # listed as not run, and its training without its final checkpoint as such
    assert "| PMTG | 1 | in progress: iteration 2 of 2 | - | - | - |" in page and "| Ours | 1 | " in page
    ours_row = next(line for line in page.splitlines() if line.startswith("| Ours | 1 | "))
    assert ours_row.endswith(f"| {summary['training']['ours']['1']['commit'][:12]} | no |")  # uninterrupted
    assert "in_progress" not in _load(res / "results.json")["training"]["ours"]["1"]
    assert command.main(["--presets", "nope"]) == 2


def test_a_reproduction_finishes_each_run_before_training_the_next():
    """Run by run, not stage by stage: a session that ends mid-reproduction leaves each finished training with all
    its evaluations (checkpoints do not outlive the machine); stages keep their own order whatever ``--stages`` says,
    and the report is no step."""
    steps = reproduce.plan(["ours", "pmtg"], [11, 12], ["push", "report", "tracking", "train"])
    assert steps[:3] == [("ours", 11, "train"), ("ours", 11, "tracking"), ("ours", 11, "push")]
    assert [(t, sd) for t, sd, _ in steps[::3]] == [("ours", 11), ("ours", 12), ("pmtg", 11), ("pmtg", 12)]
    assert len(steps) == 12 and all(st != "report" for *_, st in steps)


def test_training_progress_reads_the_runs_metrics_not_its_console(tmp_path):
    """The training stage's echo comes from ``metrics.jsonl`` (ProgressLogger's rows): the last iteration and an ETA
    from the mean wall time of the latest iterations; nothing before the first row, a line cut short is skipped."""
    assert reproduce.training_progress(str(tmp_path), 10) is None
    rows = [{"iteration": k, "wall_s": w} for k, w in ((1, 100.0), *((k, 2.0) for k in range(2, 12)))]
    (tmp_path / "metrics.jsonl").write_text("".join(json.dumps(r) + "\n" for r in rows) + '{"iteration": 1')
    assert reproduce.training_progress(str(tmp_path), 100) == "iteration 11/100, ETA 0:02:58"  # 89 x 2 s
    assert reproduce.training_progress(str(tmp_path), 11) == "iteration 11/11, ETA 0:00:00"


def test_report_checks_the_headline_targets_against_hand_numbers(tmp_path):
    """The page's target lines (issue 22) compute their ratios from the collected numbers: 20 W against the fixed
    trot's 40 W at 0.0011 against 0.001 MSE is 0.50x at 1.10x (met); 79 % legged on v_y misses 80 %; a forecast
    1.25x the realised power misses 20 %; 9.5 W standing against the zero-residual gait's 3 W is 3.2x (misses
    1.3x; against 0.02 W the page gives the difference), 20 W on v_x against its 16 W 1.25x (met); the energy map's
    driving cell at (1, 0, 0) with 30 W at squared error 0.02 misses the driving floor (|v_x - 1| 0.14 m/s), with
    0.005 meets it."""
    from wqwarp.eval.report import _target_checks

    def stat(v):
        return {"mean": v, "std": 0.0, "n": 1}

    ours = {
        "vx": {
            "mean_p_cost": stat(20.0),
            "mse": stat(0.0011),
            "predicted_power_running": stat(25.0),
            "gait_usage": {"driving": 0.9, "trotting": 0.1},
        },
        "vy": {
            "mean_p_cost": stat(30.0),
            "mse": stat(0.04),
            "predicted_power_running": stat(33.0),
            "gait_usage": {"driving": 0.21, "trotting": 0.39, "walking": 0.40},
        },
        "stand": {"mean_p_cost": stat(9.5)},
    }
    fixed = {"vx": {"mean_p_cost": stat(40.0), "mse": stat(0.001)}}
    nominal = {
        "stand": {"mean_p_cost": stat(3.0), "mse": stat(0.0001)},
        "vx": {"mean_p_cost": stat(16.0), "mse": stat(0.002)},
    }
    ours["vx"]["mse"], ours["stand"]["mse"] = stat(0.0011), stat(0.0002)
    summary = {
        "presets": {"ours": {"tracking": ours, "nominal": nominal}, "no_predictor": {"tracking": fixed}},
        "figures": {"energymap": "ours_s1_energymap.png"},
    }
    cells = [
        {"command": [0.5, 0.0, 0.0], "measured_p_cost": {"driving": 1.0}, "sq_velocity_error": {"driving": 0.0}},
        {
            "command": [1.0, 0.0, 0.0],
            "measured_p_cost": {"driving": 30.0, "walking": 90.0},
            "sq_velocity_error": {"driving": 0.02, "walking": 0.3},
        },
    ]
    (tmp_path / "ours_s1_energymap.json").write_text(json.dumps({"cells": cells}))
    lines = _target_checks(summary, str(tmp_path))
    by = {line.split(":")[0]: line for line in lines}
    assert "30.0 W at squared speed error 0.0200" in by["- driving floor"]
    assert by["- driving floor"].endswith("not met")
    assert "3.2x the nominal driving gait's 3.00 W" in by["- residual's energy, stand task"]
    assert by["- residual's energy, stand task"].endswith("not met")
    assert "1.2x the nominal driving gait's 16.00 W" in by["- residual's energy, v_x task"]
    assert by["- residual's energy, v_x task"].endswith("-> met")
    nominal["stand"]["mean_p_cost"] = stat(0.02)  # a floor of nearly nothing: the difference, not a ratio
    line = next(x for x in _target_checks(summary) if x.startswith("- residual's energy, stand task"))
    assert "9.5 W above the nominal driving gait's 0.02 W" in line and line.endswith("not met")
    nominal["stand"]["mean_p_cost"] = stat(3.0)
    cells[1]["sq_velocity_error"]["driving"] = 0.005
    (tmp_path / "ours_s1_energymap.json").write_text(json.dumps({"cells": cells}))
    assert _target_checks(summary, str(tmp_path))[-3].endswith("-> met")
    assert not any(x.startswith("- driving floor") for x in _target_checks(summary))  # no results folder given
    assert "0.50x the fixed trot's 40.0 W at 1.10x its MSE" in by["- headline, v_x task"]
    assert by["- headline, v_x task"].endswith("-> met")
    assert "legged gaits 79 %" in by["- gait pattern, v_y task"] and by["- gait pattern, v_y task"].endswith("not met")
    assert by["- gait pattern, v_x task"].endswith("-> met")
    assert "(1.25x)" in by["- predictor, v_x task"] and by["- predictor, v_x task"].endswith("not met")
    assert "(1.10x)" in by["- predictor, v_y task"] and by["- predictor, v_y task"].endswith("-> met")
    assert by["- energy floor"].endswith("-> met")


def test_report_compares_power_among_the_methods_that_track_every_task():
    """The Fig. 5 claim "lowest mean power: Ours" at comparable tracking: a baseline that stands still on v_y (MSE
    0.16 of a command variance 0.163, 98 %) has the lowest mean power (15 W against 20 and 25 W) and the page says
    so (differs), then names the cheapest of the methods whose MSE is below half the variance on every task (Ours,
    20 W; agrees). When the cheapest method tracks everything, no second line is written."""
    from wqwarp.eval.report import _ordering_checks

    def task(mse, power, var):
        return {"mse": {"mean": mse}, "mean_p_cost": {"mean": power}, "command_variance": var}

    def method(vx, vy, wz):
        return {"tracking": {"vx": task(*vx, 0.34), "vy": task(*vy, 0.163), "wz": task(*wz, 0.163)}}

    presets = {
        "ours": method((0.001, 15.0), (0.008, 30.0), (0.012, 15.0)),
        "no_predictor": method((0.004, 30.0), (0.010, 30.0), (0.011, 15.0)),
        "baseline": method((0.002, 20.0), (0.160, 10.0), (0.015, 15.0)),
    }
    lines = _ordering_checks({"presets": presets})
    assert "- lowest mean power over the three tasks: paper Ours; here Baseline (15.0 W) -> differs" in lines
    assert (
        "- ... among the methods that track all three tasks (MSE below half that of a robot that ignores the "
        "command): here Ours (20.0 W; Ours w/o switching 25.0 W) -> agrees"
    ) in lines
    assert any(x.startswith("- Baseline: v_y MSE 0.160, 98 %") and "not tracked" in x for x in lines)
    presets["baseline"]["tracking"]["vy"]["mse"]["mean"] = 0.05  # now it tracks: the cheapest outright
    lines = _ordering_checks({"presets": presets})
    assert "- lowest mean power over the three tasks: paper Ours; here Baseline (15.0 W) -> differs" in lines
    assert not any(x.startswith("- ... among") for x in lines)


def test_report_checks_the_claims_under_the_electrical_measure_too():
    """Records with p_elec (issue 48) get each power claim a second time by it, beside p_cost: Ours cheaper than the
    fixed trot mechanically (20 against 40 W on v_x) but dearer electrically (150 against 120 W) is "met" for the
    first headline and "not met" for the second; standing at 100 W against the nominal gait's 90 W of p_elec is 1.11x
    (met, target 1.2x), v_x at 120 against 94 W 1.28x (not met). Without p_elec (records before it) no electrical
    line is written."""
    from wqwarp.eval.report import _ordering_checks, _target_checks

    def stat(v):
        return {"mean": v, "std": 0.0, "n": 1}

    def task(mse, p_cost, p_elec, var=0.163):
        return {"mse": stat(mse), "mean_p_cost": stat(p_cost), "mean_p_elec": stat(p_elec), "command_variance": var}

    ours = {"vx": task(0.001, 20.0, 150.0), "vy": task(0.01, 30.0, 300.0), "wz": task(0.01, 25.0, 250.0)}
    ours["stand"] = {"mean_p_elec": stat(100.0)}
    fixed = {"vx": task(0.001, 40.0, 120.0), "vy": task(0.01, 32.0, 280.0), "wz": task(0.01, 26.0, 240.0)}
    nominal = {"stand": {"mean_p_elec": stat(90.0)}, "vx": {"mean_p_elec": stat(94.0)}}
    summary = {"presets": {"ours": {"tracking": ours, "nominal": nominal}, "no_predictor": {"tracking": fixed}}}
    by = {line.split(":")[0]: line for line in _target_checks(summary)}
    assert by["- headline, v_x task"].endswith("-> met")
    line = by["- headline under the electrical measure, v_x task"]
    assert "150.0 W = 1.25x the fixed trot's 120.0 W of p_elec at 1.00x its MSE" in line and line.endswith("not met")
    line = by["- residual's electrical energy, stand task"]
    assert "100.0 W = 1.11x the nominal driving gait's 90.0 W" in line and line.endswith("-> met")
    assert by["- residual's electrical energy, v_x task"].endswith("not met")
    lines = _ordering_checks(summary)
    assert "- lowest mean power over the three tasks: paper Ours; here Ours (25.0 W) -> agrees" in lines
    assert (
        "- lowest mean electrical power (p_elec) over the three tasks: paper Ours; here Ours w/o switching "
        "(213.3 W) -> differs"
    ) in lines
    for block in (ours, fixed):
        for r in block.values():
            r.pop("mean_p_elec", None)
    nominal["stand"].pop("mean_p_elec"), nominal["vx"].pop("mean_p_elec")
    assert not any("electrical" in x for x in _target_checks(summary) + _ordering_checks(summary))


def test_import_restores_the_training_log_the_report_committed_gzipped(tmp_path, monkeypatch):
    """The report writes ``<preset>_s<seed>_train.log.gz`` (docs/results is committed); ``--import-from`` puts it
    back as the run's plain ``<run>.log``; the older plain ``_train.log`` is taken likewise."""
    from wqwarp.utils.io import write_text_gz_atomic

    monkeypatch.setattr(reproduce, "import_mismatch", lambda *a: None)  # the records' budget is not under test here
    src, work = tmp_path / "res", tmp_path / "work"
    src.mkdir()
    for stem, log in (("ours_s1", "ours_s1_train.log.gz"), ("pmtg_s1", "pmtg_s1_train.log")):
        (src / f"{stem}_train_config.json").write_text("{}")
        if log.endswith(".gz"):
            write_text_gz_atomic(str(src / log), f"{stem} progress\n")
        else:
            (src / log).write_text(f"{stem} progress\n")
    budget = reproduce.BUDGETS["smoke"]
    lines = reproduce.import_finished(str(src), str(work), budget, ["ours", "pmtg"], [1])
    assert lines == [
        "imported ours_s1 from " + str(src) + ": 2 file(s)",
        "imported pmtg_s1 from " + str(src) + ": 2 file(s)",
    ]
    for stem in ("ours_s1", "pmtg_s1"):
        assert (work / "train" / f"{stem}.log").read_text() == f"{stem} progress\n"


def test_report_judges_the_papers_claims_from_intervals_over_seeds():
    """Claims are paired seed by seed: Ours at half the trot's power on v_x on all three seeds holds (interval
    [0.5, 0.5]); at 1, 1.2 and 1 times on v_y the interval straddles 1 (undecided at 3 seeds); twice on w does not
    hold. The three-task mean is each seed's mean first (ratios 0.82, 0.90, 0.86 here). A seed one method lacks is
    left out of the pair; one seed is always undecided. Push recovery compares shares by differences in points."""
    from wqwarp.eval.report import _claim_rows, paper_claims
    from wqwarp.eval.stats import ratio_ci

    def st(*values, seeds=(11, 12, 13)):
        return per_seed_stat(list(zip(seeds, values, strict=True)))

    ours = {
        "vx": {"mean_p_cost": st(10.0, 12.0, 11.0), "mse": st(0.001, 0.001, 0.001)},
        "vy": {"mean_p_cost": st(30.0, 36.0, 33.0), "mse": st(0.01, 0.01, 0.01), "legged_share": st(0.9, 0.8, 0.95)},
        "wz": {"mean_p_cost": st(40.0, 44.0, 42.0), "mse": st(0.01, 0.01, 0.01), "legged_share": st(0.2, 0.9, 0.5)},
        "stand": {"mean_p_cost": st(5.0, 5.0, 5.0)},
    }
    trot = {
        "vx": {"mean_p_cost": st(20.0, 24.0, 22.0), "mse": st(0.002, 0.002, 0.002)},
        "vy": {"mean_p_cost": st(30.0, 30.0, 33.0), "mse": st(0.01, 0.02, 0.01)},
        "wz": {"mean_p_cost": st(20.0, 22.0, 21.0, seeds=(11, 12, 14)), "mse": st(0.01, 0.01, 0.01)},
    }
    push = {str(lvl): {t: {"upright": st(1.0, 1.0, 0.98)} for t in ("stand", "vx", "vy", "wz")} for lvl in (0.5, 0.7)}
    push_trot = {
        str(lvl): {t: {"upright": st(0.9, 0.95, 0.9)} for t in ("stand", "vx", "vy", "wz")} for lvl in (0.5, 0.7)
    }
    summary = {
        "seeds": [11, 12, 13],
        "presets": {"ours": {"tracking": ours, "push": push}, "no_predictor": {"tracking": trot, "push": push_trot}},
    }
    claims = paper_claims(summary)
    headline = next(c for c in claims if c["measure"] == "Ours / fixed trot, p_cost")
    cells = {c["label"]: c for c in headline["cells"]}
    assert cells["v_x task"]["estimate"] == pytest.approx(0.5) and cells["v_x task"]["ci95"] == pytest.approx(
        [0.5, 0.5]
    )
    assert cells["v_x task"]["verdict"] == "holds" and cells["v_x task"]["n"] == 3
    assert cells["v_y task"]["verdict"] == "undecided" and cells["v_y task"]["per_seed"] == pytest.approx(
        {"11": 1.0, "12": 1.2, "13": 1.0}
    )
    assert cells["w task"]["verdict"] == "does not hold" and cells["w task"]["n"] == 2  # seed 13 / 14 unpaired
    three = cells["three moving tasks"]  # per seed: mean over the tasks the seed has all of (11, 12)
    want = ratio_ci([80 / 3, 92 / 3], [70 / 3, 76 / 3])
    assert three["estimate"] == pytest.approx(want["ratio"]) and three["ci95"] == pytest.approx(want["ci95"])
    legged = next(c for c in claims if c["measure"].startswith("Ours, share of robot-time"))
    assert [c["verdict"] for c in legged["cells"]] == ["holds", "undecided"]
    recover = [c for c in claims if "push recovery" in c["claim"]]
    assert len(recover) == 2 and recover[0]["cells"][0]["estimate"] == pytest.approx((0.1 + 0.05 + 0.08) / 3)
    assert recover[0]["cells"][0]["verdict"] == "holds"
    rows = _claim_rows(claims)
    assert "| v_x task | 0.50x [0.50x, 0.50x] | 3 | holds |" in "\n".join(rows)
    assert any("| w task |" in r and r.endswith("| 2 | does not hold |") for r in rows)
    assert any("+7.7 pt [" in r for r in rows)
    one = {"seeds": [1], "presets": {}}
    for p, block in summary["presets"].items():
        one["presets"][p] = {"tracking": {}}
        for t, b in block["tracking"].items():
            one["presets"][p]["tracking"][t] = {k: st(v["mean"], seeds=(1,)) for k, v in b.items()}
    assert {c["verdict"] for c in paper_claims(one)[0]["cells"]} == {"undecided"}


def test_the_sim2sim_table_pairs_each_physics_with_the_training_one_by_seed():
    """Each cell is the mean over the three tasks per seed, its change the paired difference: MSE 0.01 on every
    task under training physics, 0.02 on the authors' robot, on two seeds -> dMSE +0.0100 ± 0.0000."""
    from wqwarp.eval.report import _sim2sim_rows

    def block(mse, p):
        one = {
            "mse": per_seed_stat([(1, mse), (2, mse)]),
            "mean_p_cost": per_seed_stat([(1, p), (2, p + 2)]),
            "mean_p_elec": None,
        }
        return {t: {**one, "upright": per_seed_stat([(1, 1.0), (2, 1.0)])} for t in ("vx", "vy", "wz")}

    pres = {"ours": {"sim2sim": {"train": block(0.01, 20.0), "authors_robot": block(0.02, 25.0)}}}
    (row,) = _sim2sim_rows(pres)
    assert row == (
        "| Ours | authors_robot | 0.0200 ± 0.0000 | 0.0100 ± 0.0000 | 26.0 ± 12.7 | 5.0 ± 0.0 | - | - | "
        "100.0 ± 0.0 | 0.0 ± 0.0 |"
    )


def test_the_push_and_sim2sim_tables_say_which_seeds_each_method_rests_on():
    """A cell of one seed prints as a bare number, so the tables name each method's seeds: the union over its cells
    (here PMTG pushed on seed 13 at one level, 12 at the other), 'none' without a record."""
    from wqwarp.eval.report import _seeds_line

    def cell(*seeds):
        return {"upright": per_seed_stat([(s, 1.0) for s in seeds]), "falls": None}

    pres = {
        "ours": {"push": {}},
        "pmtg": {"push": {"0.5": {"vx": cell(13)}, "0.7": {"vy": cell(12, 13)}}},
    }
    assert _seeds_line(pres, "push", "upright") == "Seeds with a record: Ours none; PMTG 12, 13."


def test_the_readme_status_table_is_built_from_the_results_and_replaces_only_its_block(tmp_path):
    """The table quotes the page's numbers with their intervals and the claims' verdicts; a method not run reads
    "not run yet"; ``--write`` replaces only the block between the markers, ``--check`` fails on a stale table, and
    a results.json from before the claims is refused with exit 2."""
    from wqwarp.cli import readme_status
    from wqwarp.eval.report import paper_claims
    from wqwarp.eval.status import BEGIN, END, replace_block, status_table

    def st(*values):
        return per_seed_stat(list(zip((11, 12, 13), values, strict=True)))

    def block(p, mse):
        out = {t: {"mean_p_cost": st(p, p + 2, p + 1), "mse": st(mse, mse, mse)} for t in MOVING_TASKS}
        for t in MOVING_TASKS:
            out[t] |= {"upright": st(1.0, 1.0, 1.0), "legged_share": st(0.9, 0.8, 0.95)}
        out["vx"]["legged_share"] = st(0.1, 0.2, 0.0)
        return out

    summary = {
        "seeds": [11, 12, 13],
        "presets": {"ours": {"tracking": block(10.0, 0.001)}, "no_predictor": {"tracking": block(20.0, 0.002)}},
    }
    summary["claims"] = paper_claims(summary)
    table = status_table(summary)
    assert table.startswith(BEGIN) and table.endswith(END)
    assert "on training seeds 11, 12, 13, none of which chose a lever" in table
    assert "v_x task 0.50x [" in table and "**holds**" in table  # 10-12 W against 20-22 W, seed by seed
    assert "driving 90 ± 25 % of the v_x task" in table
    assert "| push recovery (Table III) | not run yet |" in table
    summary["presets"]["no_predictor"]["push"] = {"0.5": {"vy": {"upright": st(0.9, 0.8, 1.0)}}}
    with_push = status_table(summary)
    assert "| not run yet for Ours; seeds with a push record: Ours none; Ours w/o switching 11, 12, 13 |" in with_push
    assert "on training seeds 11, 12, 13, none of which" in with_push  # the others' push records are named, not hidden
    del summary["presets"]["no_predictor"]["push"]
    readme = tmp_path / "README.md"
    readme.write_text(f"# title\n\n{BEGIN}\nold\n{END}\n\nrest\n")
    assert replace_block(readme.read_text(), table) == f"# title\n\n{table}\n\nrest\n"
    res = tmp_path / "results.json"
    res.write_text(json.dumps(summary))
    argv = ["--results", str(res), "--readme", str(readme)]
    assert readme_status.main([*argv, "--check"]) == 1
    assert readme_status.main([*argv, "--write"]) == 0 and readme_status.main([*argv, "--check"]) == 0
    assert readme.read_text() == f"# title\n\n{table}\n\nrest\n"
    res.write_text(json.dumps({k: v for k, v in summary.items() if k != "claims"}))
    assert readme_status.main([*argv, "--check"]) == 2
    with pytest.raises(ValueError, match="no status block"):
        replace_block("no markers", table)


MOVING_TASKS = ("vx", "vy", "wz")


def test_a_missing_evaluation_of_an_imported_run_without_checkpoints_says_it_needs_training(tmp_path):
    from wqwarp.eval.report import IMPORTED, collect

    for run, marker in (("ours_s1", True), ("ours_s2", False)):
        (tmp_path / "train" / run).mkdir(parents=True)
        if marker:
            (tmp_path / "train" / run / IMPORTED).write_text("{}")
    missing = collect(str(tmp_path), ["ours"], [1, 2])["missing"]
    assert "push ours seed 1 (imported, no checkpoint)" in missing
    assert "push ours seed 2" in missing  # not imported: re-running the reproduction evaluates it
    (tmp_path / "train" / "ours_s1" / "model_9.pt").write_bytes(b"")
    assert "push ours seed 1" in collect(str(tmp_path), ["ours"], [1])["missing"]
