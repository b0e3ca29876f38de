"""wqwarp.cli.energy_audit (tools/energy_audit.py): group powers add up, driving costs wheel power, airborne wheels
settle quietly, the JSON holds the documented fields, and bad input exits 2 without writing."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

from wqwarp.cli import energy_audit

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
TOOL = os.path.join(ROOT, "tools", "energy_audit.py")

SHORT = {"warmup": 0.3, "seconds": 0.5, "num_envs": 1}


@pytest.fixture(scope="module")
def audit_default_dt() -> dict:
    """Three scenarios at the default physics setting (dt 0.005 x 4), short window, one robot."""
    return energy_audit.audit(["standing", "drive_1.0", "air_wheels"], [(0.005, 4)], quiet=True, **SHORT)


def test_legs_plus_wheels_equal_the_total(audit_default_dt):
    for name, entry in audit_default_dt.items():
        r = entry["results"]["0.005x4"]
        for p in ("p_cost", "p_mech"):
            assert r[p + "_legs"] + r[p + "_wheels"] == pytest.approx(r[p], rel=1e-4, abs=1e-4), (name, p)
            assert r[p + "_legs"] >= 0 and r[p + "_wheels"] >= 0
        # the electrical total is the robot's net on the shared bus, never below zero without regeneration
        assert r["p_elec"] >= max(r["p_elec_legs"] + r["p_elec_wheels"], 0.0) - 1e-3, name


def test_standing_costs_the_battery_the_knees_copper_and_next_to_no_mechanical_power(audit_default_dt):
    """Standing, the nominal gait alone: p_cost is almost 0, but the battery pays the copper loss of the leg motors
    holding the trunk, most of it at the knees (hand check: 6 N m at the knee costs 0.513 x 36 = 18.5 W per knee
    with the Go1 knee's gear 9.495 and k_m 0.147), and the breakdown by joint kind adds up to the kernel's copper."""
    r = audit_default_dt["standing"]["results"]["0.005x4"]
    kinds = r["copper_by_joint_kind"]
    assert r["p_elec"] > 50.0 and r["p_cost"] < 0.05 * r["p_elec"]  # still settling in this short window
    assert r["p_elec"] == pytest.approx(r["p_copper_legs"] + r["p_copper_wheels"], rel=0.05)
    assert sum(k["copper_w"] for k in kinds.values()) == pytest.approx(
        r["p_copper_legs"] + r["p_copper_wheels"], rel=0.02
    )
    assert kinds["knee"]["copper_w"] > 0.7 * r["p_elec"] and 4.0 < kinds["knee"]["torque_rms"] < 8.0
    assert kinds["knee"]["copper_w"] == pytest.approx(4 * 0.5134 * kinds["knee"]["torque_rms"] ** 2, rel=1e-3)


def test_driving_costs_more_wheel_power_than_standing(audit_default_dt):
    standing = audit_default_dt["standing"]["results"]["0.005x4"]
    driving = audit_default_dt["drive_1.0"]["results"]["0.005x4"]
    assert driving["p_cost_wheels"] > standing["p_cost_wheels"] + 1.0
    assert driving["v_x"] > 0.5 and abs(standing["v_x"]) < 0.1
    assert not standing["trunk_touched"] and not driving["trunk_touched"]
    assert 0.2 < standing["height"] < 0.35


def test_airborne_wheels_hold_their_speed_without_chattering(audit_default_dt):
    """Acceptance criterion of the wheel-PID tuning: in free fall a wheel at constant speed needs ~no torque."""
    r = audit_default_dt["air_wheels"]["results"]["0.005x4"]
    assert r["start_height"] >= 50.0 and not r["trunk_touched"]
    assert sum(r["p_cost_per_wheel"]) == pytest.approx(r["p_cost_wheels"], rel=1e-3, abs=1e-3)
    assert r["wheel_torque_substep_pairs"] > 0
    assert max(r["p_cost_per_wheel"]) < 0.5, r["p_cost_per_wheel"]
    assert r["wheel_torque_sign_flips"] == 0
    assert r["wheel_speed"] == pytest.approx([5.0] * 4, abs=0.1)


def test_json_has_the_documented_fields(tmp_path, capsys):
    out = tmp_path / "audit.json"
    argv = [
        "--scenarios",
        "standing",
        "--settings",
        "0.005x4,0.001x20",
        "--warmup",
        "0.1",
        "--seconds",
        "0.2",
        "--num-envs",
        "1",
        "--json",
        str(out),
        "--quiet",
    ]
    assert energy_audit.main(argv) == 0
    captured = capsys.readouterr()
    assert captured.err == ""  # --quiet
    assert captured.out.startswith("| scenario | p_cost dt0.005 [W] (legs / wheels) | p_cost dt0.001 [W]")
    assert "| standing |" in captured.out
    data = json.loads(out.read_text())
    assert "--scenarios standing" in data["command"]
    assert set(data["git"]) == {"commit", "dirty", "tracked_changes"}
    assert [s["name"] for s in data["settings"]] == ["0.005x4", "0.001x20"]
    assert [s["policy_dt"] for s in data["settings"]] == pytest.approx([0.02, 0.02])
    entry = data["scenarios"]["standing"]
    fine, coarse = entry["results"]["0.001x20"], entry["results"]["0.005x4"]
    for r in (fine, coarse):
        assert r["window_steps"] == 10 and r["warmup_steps"] == 5
        for key in ("p_cost", "p_cost_legs", "p_cost_wheels", "p_mech", "p_elec", "v_x", "w_z", "height"):
            assert isinstance(r[key], float), key
        assert isinstance(r["trunk_touched"], bool)
    assert entry["ratio"]["p_cost"] == pytest.approx(coarse["p_cost"] / fine["p_cost"])
    assert entry["ratio"]["p_cost_legs"] == pytest.approx(coarse["p_cost_legs"] / fine["p_cost_legs"])
    assert [p for p in os.listdir(tmp_path)] == ["audit.json"]  # no temporary file left behind


@pytest.mark.parametrize(
    "argv, message",
    [
        (["--settings", "0.005y4"], "malformed setting"),
        (["--settings", "0.005x0"], "malformed setting"),
        (["--seconds", "0"], "--seconds"),
        (["--warmup", "-1"], "--warmup"),
        (["--num-envs", "0"], "--num-envs"),
    ],
)
def test_bad_input_exits_2_without_writing(tmp_path, capsys, argv, message):
    assert energy_audit.main([*argv, "--json", str(tmp_path / "a.json")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ") and message in err and err.count("\n") == 1
    assert not any(tmp_path.iterdir())


def test_command_line_rejects_unknown_scenario_and_missing_directory(tmp_path):
    r = subprocess.run(
        [sys.executable, TOOL, "--scenarios", "standing,nope", "--json", str(tmp_path / "a.json")],
        capture_output=True,
        text=True,
        cwd=ROOT,
    )
    assert r.returncode == 2 and r.stdout == ""
    assert [line for line in r.stderr.splitlines() if line.startswith("error: ")] == [
        "error: unknown scenario nope; choose from " + ", ".join(energy_audit.SCENARIOS)
    ]
    assert energy_audit.main(["--scenarios", "standing", "--json", str(tmp_path / "missing" / "a.json")]) == 2
    assert not any(tmp_path.iterdir())


@pytest.mark.slow
def test_default_timestep_keeps_the_energy_picture(tmp_path):
    """Acceptance: for every audit scenario p_cost at dt 0.005 x 4 is within 1.3x of the paper's dt 0.001 x 20."""
    out = tmp_path / "audit.json"
    assert energy_audit.main(["--json", str(out), "--quiet"]) == 0
    data = json.loads(out.read_text())
    for name, sc in data["scenarios"].items():
        if name == "air_wheels":  # ~0 W over ~0 W
            continue
        assert 1 / 1.3 <= sc["ratio"]["p_cost"] <= 1.3, (name, sc["ratio"])
    assert data["scenarios"]["standing"]["results"]["0.005x4"]["p_cost"] < 10.0


def test_authors_model_comparison_refuses_a_missing_model(tmp_path):
    tool = os.path.join(ROOT, "tools", "studies", "compare_authors_model.py")
    out = tmp_path / "x.json"
    r = subprocess.run(
        [sys.executable, tool, "--mjcf", str(tmp_path / "nope.xml"), "--json", str(out)], capture_output=True, text=True
    )
    assert r.returncode == 2 and "no such MJCF" in r.stderr and not out.exists()


def test_the_standing_posture_tool_reads_height_angles_and_copper_of_a_checkpoint(tmp_path, save_checkpoint):
    """tools/studies/standing_posture.py on an untrained ours checkpoint: the nominal driving gait alone stands at the
    default height with the knees carrying the trunk, each kind's copper is its coefficient times the torques'
    squares, and the JSON holds both rows."""
    sys.path.insert(0, os.path.join(ROOT, "tools", "studies"))
    import standing_posture

    from wqwarp.rl.presets import make_preset

    cfg = make_preset("ours")
    cfg.sim.num_envs = 2
    ckpt = save_checkpoint(str(tmp_path / "model_0.pt"), cfg)
    out = tmp_path / "posture.json"
    assert standing_posture.main(["--checkpoint", ckpt, "--robots", "2", "--seconds", "2.6", "--json", str(out)]) == 0
    d = json.loads(out.read_text())
    nominal = d["nominal_driving"]
    assert 0.25 < nominal["height"] < 0.29 and nominal["gait_usage"]["driving"] > 0.99
    knee = nominal["kinds"]["knee"]
    assert knee["copper_w"] == pytest.approx(4 * 0.5134 * knee["torque_rms"] ** 2, rel=1e-3)
    assert knee["copper_w"] > nominal["kinds"]["hip"]["copper_w"] and nominal["p_elec"] > knee["copper_w"]
    assert set(d["policy"]["kinds"]) == {"hip", "thigh", "knee"} and len(d["policy"]["hip_angles"]) == 4
    assert d["command"] == [0.0, 0.0, 0.0] and nominal["p_cost"] < 1.0 and nominal["wheels"]["copper_w"] < 1.0
    assert standing_posture.main(["--checkpoint", ckpt, "--seconds", "1"]) == 2
    assert standing_posture.main(["--checkpoint", ckpt, "--command", "0.5,0"]) == 2
    # held at 0.5 m/s forward: the wheels accelerate and roll the robot, torque the standing robot does not need
    drive = ["--checkpoint", ckpt, "--robots", "2", "--seconds", "2.6", "--command", "0.5,0,0", "--json", str(out)]
    assert standing_posture.main(drive) == 0
    moving = json.loads(out.read_text())
    assert moving["command"] == [0.5, 0.0, 0.0]
    assert moving["nominal_driving"]["wheels"]["torque_rms"] > nominal["wheels"]["torque_rms"]
    assert moving["nominal_driving"]["p_cost"] > nominal["p_cost"]
    fixed = make_preset("no_predictor")  # a fixed gait: its own nominal gait, trotting in place, with lifted feet
    fixed.sim.num_envs = 2
    ckpt = save_checkpoint(str(tmp_path / "trot_model_0.pt"), fixed)
    assert standing_posture.main(["--checkpoint", ckpt, "--robots", "2", "--seconds", "2.6", "--json", str(out)]) == 0
    trot = json.loads(out.read_text())["nominal_trotting"]
    assert trot["gait_usage"]["trotting"] > 0.99 and trot["p_elec"] > nominal["p_elec"]
    baseline = make_preset("baseline")
    baseline.sim.num_envs = 2
    ckpt = save_checkpoint(str(tmp_path / "base_model_0.pt"), baseline)
    assert standing_posture.main(["--checkpoint", ckpt, "--seconds", "2.6"]) == 2
