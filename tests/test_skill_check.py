"""tools/studies/skill_check.py: issue 47's skill target read from evaluation results, each bound exclusive where the
issue says 'below' and inclusive where it says 'at least'."""

from __future__ import annotations

import json
import os
import sys

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "tools", "studies"))

import skill_check  # noqa: E402

from wqwarp.cli.args import UsageError  # noqa: E402


def _tracking(mse=(0.001, 0.01, 0.02), upright=(1.0, 1.0, 1.0, 1.0)):
    mses = dict(zip(("stand", "vx", "vy", "wz"), (0.0005, *mse), strict=True))
    ups = dict(zip(("stand", "vx", "vy", "wz"), upright, strict=True))
    return {"iteration": 4882, "results": [{"task": t, "mse": mses[t], "upright": ups[t]} for t in mses]}


def _lateral(ratio_neg=0.85, ratio_pos=0.9, wz=0.05, upright=1.0):
    runs = [
        {"command_vy": c, "ratio": r, "wz": wz, "upright": upright}
        for c, r in ((-0.6, ratio_neg), (-0.3, 0.2), (0.3, 0.9), (0.6, ratio_pos))
    ]
    return {"runs": {"selected": runs}}


def test_every_target_met():
    c = skill_check.check(_tracking(), _lateral())
    assert c["tracks"] and c["all_upright"] and c["lateral_edges"] and c["met"]
    assert c["lateral"]["-0.6"]["ratio"] == 0.85 and c["mse"]["vy"] == 0.01
    assert skill_check.check(_tracking())["met"] and skill_check.check(_tracking())["lateral_edges"] is None


@pytest.mark.parametrize(
    ("tracking", "lateral", "fails"),
    [
        (_tracking(mse=(0.001, 0.05, 0.01)), None, "tracks"),  # 'below 0.05': 0.05 is not
        (_tracking(upright=(1.0, 1.0, 0.99, 1.0)), None, "all_upright"),  # one robot of 100 fell
        (_tracking(), _lateral(ratio_neg=0.79), "lateral_edges"),  # -0.6 reaches 79 %
        (_tracking(), _lateral(wz=-0.1), "lateral_edges"),  # yaw drift at the bound
        (_tracking(), _lateral(upright=0.875), "lateral_edges"),  # a fall while holding the command
    ],
)
def test_each_target_can_fail(tracking, lateral, fails):
    c = skill_check.check(tracking, lateral)
    assert c[fails] is False and not c["met"]


def test_results_without_the_needed_tasks_or_commands_are_refused():
    t = _tracking()
    t["results"] = t["results"][1:]
    with pytest.raises(UsageError, match=r"lacks the tasks \['stand'\]"):
        skill_check.check(t)
    lat = _lateral()
    lat["runs"]["selected"] = lat["runs"]["selected"][:2]
    with pytest.raises(UsageError, match=r"no command \+0.6"):
        skill_check.check(_tracking(), lat)


def test_the_command_prints_a_row_and_writes_the_json(tmp_path, capsys):
    (tmp_path / "t.json").write_text(json.dumps(_tracking()))
    (tmp_path / "l.json").write_text(json.dumps(_lateral(ratio_pos=0.5)))
    out = tmp_path / "skill.json"
    assert skill_check.main([f"s3={tmp_path / 't.json'},{tmp_path / 'l.json'}", "--json", str(out)]) == 0
    assert "NOT met" in capsys.readouterr().out
    d = json.loads(out.read_text())
    assert d["checkpoints"]["s3"]["lateral_edges"] is False and d["targets"]["mse"] == 0.05 and d["git"]
    assert skill_check.main(["s3"]) == 2 and "expected LABEL=" in capsys.readouterr().err


def test_the_skill_curve_finds_the_first_checkpoint_meeting_each_axis_and_whether_it_is_kept(tmp_path, capsys):
    """tools/studies/skill_curve.py: checkpoint N holds N + 1 iterations of robots x steps samples; the wall time is
    the run's summed iteration times (a resumed run's repeated iteration counted once); an axis met at one checkpoint
    and lost at a later one is reported as not kept."""
    import skill_curve

    run = tmp_path / "run"
    run.mkdir()
    (run / "config.json").write_text(json.dumps({"env": {"sim": {"num_envs": 4}}, "train": {"num_steps_per_env": 5}}))
    rows = [{"iteration": i, "wall_s": 6.0} for i in range(1, 31)] + [{"iteration": 21, "wall_s": 12.0}]
    (run / "metrics.jsonl").write_text("\n".join(json.dumps(r) for r in rows) + "\n{cut")
    for it, mse, up in ((9, (0.001, 0.2, 0.06), 1.0), (19, (0.001, 0.04, 0.01), 1.0), (29, (0.06, 0.03, 0.01), 1.0)):
        (tmp_path / f"a_it{it}_tracking.json").write_text(json.dumps(_tracking(mse=mse, upright=(1.0, 1.0, up, 1.0))))
    r = skill_curve.analyse(str(run), str(tmp_path / "a"))
    assert [p["iteration"] for p in r["points"]] == [9, 19, 29] and r["points"][0]["samples"] == 10 * 20
    assert r["points"][0]["wall_min"] == pytest.approx(1.0) and r["points"][2]["wall_min"] == pytest.approx(3.1)
    f = r["first_met"]
    assert f["vx"]["iteration"] == 9 and not f["vx"]["kept"]  # lost at 29 (0.06)
    assert f["vy"]["iteration"] == 19 and f["vy"]["kept"] and f["wz"]["iteration"] == 19
    assert f["all"]["iteration"] == 19 and not f["all"]["kept"]
    assert skill_curve.main([f"a={run}:{tmp_path / 'none'}"]) == 2 and "no evaluations" in capsys.readouterr().err
