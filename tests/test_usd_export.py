"""wqwarp.cli.export_usd (tools/export_usd.py) and wqwarp.viz.usd: the stage's prims, time samples, per-frame
attributes and metadata; bad input exits 2 and leaves no file behind."""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import pytest

pxr = pytest.importorskip("pxr")
from pxr import Usd, UsdGeom  # noqa: E402

import wqwarp  # noqa: E402
from wqwarp.viz.usd import export_atomic, frame_steps  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
TOOL = os.path.join(ROOT, "tools", "export_usd.py")
N_ENVS, SECONDS = 2, 1.5
FRAMES = int(round(SECONDS * 50)) + 1  # frame 0 = the state after reset


def _run(*args):
    return subprocess.run([sys.executable, TOOL, *args], capture_output=True, text=True, cwd=ROOT)


@pytest.fixture(scope="module")
def tool():
    from wqwarp.cli import export_usd

    return export_usd


@pytest.fixture(scope="module")
def trot_stage(tool, tmp_path_factory):
    out = tmp_path_factory.mktemp("usd") / "trot.usdc"
    argv = ["--out", str(out), "--num-envs", str(N_ENVS), "--seconds", str(SECONDS), "--command", "0.3,0,0.2"]
    assert tool.main(argv) == 0
    assert sorted(os.listdir(out.parent)) == ["trot.usdc"]  # no temporary file left
    stage = Usd.Stage.Open(str(out))
    assert stage
    return stage


def _translations(stage, path):
    op = UsdGeom.Xformable(stage.GetPrimAtPath(path)).GetOrderedXformOps()[0]
    return np.array([list(op.Get(t)) for t in op.GetTimeSamples()])


def test_prims_and_stage_metadata(trot_stage):
    s = trot_stage
    for path in [
        "/World",
        "/World/ground",
        "/World/robot_0/trunk",
        "/World/robot_1/trunk",
        "/World/robot_0/FR_calf/collision",
        "/World/robot_0/trunk/collision_box",
    ]:
        assert s.GetPrimAtPath(path).IsValid(), path
    for leg in ("FR", "FL", "RR", "RL"):
        assert s.GetPrimAtPath(f"/World/robot_1/{leg}_wheel/collision").GetTypeName() == "Cylinder"
    assert not s.GetPrimAtPath("/World/robot_2").IsValid()
    assert UsdGeom.GetStageUpAxis(s) == UsdGeom.Tokens.z
    assert UsdGeom.GetStageMetersPerUnit(s) == 1.0
    assert s.GetTimeCodesPerSecond() == 50 and s.GetFramesPerSecond() == 50
    assert s.GetStartTimeCode() == 0 and s.GetEndTimeCode() == FRAMES - 1
    info = s.GetRootLayer().customLayerData["wqwarp"]
    assert info["version"] == wqwarp.__version__
    assert "export_usd.py" in info["commandLine"] and "--num-envs 2" in info["commandLine"]
    assert info["gait"] == "trotting" and info["numFrames"] == FRAMES
    assert s.GetDefaultPrim().GetPath() == "/World"


def test_body_transforms_sampled_every_frame_and_shapes_authored_once(trot_stage):
    s = trot_stage
    trunk = UsdGeom.Xformable(s.GetPrimAtPath("/World/robot_0/trunk"))
    ops = trunk.GetOrderedXformOps()
    assert [op.GetOpType() for op in ops] == [UsdGeom.XformOp.TypeTranslate, UsdGeom.XformOp.TypeOrient]
    assert all(op.GetNumTimeSamples() == FRAMES for op in ops)
    for prim in Usd.PrimRange(s.GetPrimAtPath("/World/robot_0/trunk")):
        if prim.GetPath() != trunk.GetPath():
            assert all(a.GetNumTimeSamples() == 0 for a in prim.GetAttributes()), prim.GetPath()
    assert all(a.GetNumTimeSamples() == 0 for a in s.GetPrimAtPath("/World/ground").GetAttributes())


def test_bodies_above_ground_and_moving(trot_stage):
    s = trot_stage
    for i in range(N_ENVS):
        trunk = _translations(s, f"/World/robot_{i}/trunk")
        assert trunk.shape == (FRAMES, 3) and np.all(np.isfinite(trunk))
        assert trunk[:, 2].min() > 0.15
        assert trunk[-1, 0] - trunk[0, 0] > 0.1  # drove forward under the 0.3 m/s command
        assert np.ptp(trunk[:, 2]) > 0.02  # the trunk bobs with the trot
        wheel_lift = []
        for leg in ("FR", "FL", "RR", "RL"):
            wheel = _translations(s, f"/World/robot_{i}/{leg}_wheel")
            calf = _translations(s, f"/World/robot_{i}/{leg}_calf")
            # wheel radius 0.075 m. The knee (calf origin) is not checked: open loop (Kp 40 PD, no policy) the trot sags
            # ~7 cm and the rear knees dip to the ground level (docs/simulation.md); the policy learns to carry it.
            assert wheel[:, 2].min() > 0.05
            assert np.ptp(calf[:, 2]) > 0.02  # every knee moves up and down
            wheel_lift.append(np.ptp(wheel[:, 2]))
        # Open loop (no policy) the front wheels lift clearly; the rear ones barely leave the ground.
        assert max(wheel_lift) > 0.03, wheel_lift
    bodies = [p for p in s.GetPrimAtPath("/World/robot_1").GetChildren() if p.GetTypeName() == "Xform"]
    assert len(bodies) == 21
    # every body origin at or above the ground (knees may touch it open loop, see above)
    assert min(_translations(s, p.GetPath())[:, 2].min() for p in bodies) > -0.02
    # robot_1 is laid out beside robot_0: composed world positions differ by the spacing along y
    cache = UsdGeom.XformCache(0)
    p0 = cache.GetLocalToWorldTransform(s.GetPrimAtPath("/World/robot_0/trunk")).ExtractTranslation()
    p1 = cache.GetLocalToWorldTransform(s.GetPrimAtPath("/World/robot_1/trunk")).ExtractTranslation()
    spacing = s.GetRootLayer().customLayerData["wqwarp"]["robotSpacing"]
    assert spacing >= 1.0 and p1[1] - p0[1] == pytest.approx(spacing, abs=1e-4)


def test_custom_attributes_per_frame(trot_stage):
    robot = trot_stage.GetPrimAtPath("/World/robot_0")
    for name in (
        "wqwarp:gait",
        "wqwarp:activeGait",
        "wqwarp:phase",
        "wqwarp:command",
        "wqwarp:baseVelocity",
        "wqwarp:pCost",
        "wqwarp:wheelContact",
    ):
        attr = robot.GetAttribute(name)
        assert attr.IsCustom() and attr.GetNumTimeSamples() == FRAMES, name
    phase = np.array([list(robot.GetAttribute("wqwarp:phase").Get(t)) for t in range(FRAMES)])
    assert phase.shape == (FRAMES, 4) and np.all((phase >= 0) & (phase < 1))
    assert np.all(np.abs(np.diff(phase[:, 0])) > 0)  # the phase advances every frame
    np.testing.assert_allclose(phase[:, 0], phase[:, 3], atol=1e-6)  # trot: FR and RL together
    assert robot.GetAttribute("wqwarp:gait").Get(10) == "trotting"
    np.testing.assert_allclose(list(robot.GetAttribute("wqwarp:command").Get(30)), [0.3, 0.0, 0.2], atol=1e-6)
    vel = np.array([list(robot.GetAttribute("wqwarp:baseVelocity").Get(t)) for t in range(FRAMES)])
    assert vel[FRAMES // 2 :, 0].mean() > 0.1  # moving forward, base frame
    p_cost = np.array([robot.GetAttribute("wqwarp:pCost").Get(t) for t in range(1, FRAMES)])
    assert np.all(p_cost > 0) and np.ptp(p_cost) > 0


def test_other_frame_rate_samples_nearest_policy_step(tool, tmp_path):
    out = tmp_path / "walk.usda"
    argv = ["--out", str(out), "--num-envs", "1", "--seconds", "0.5", "--fps", "30", "--gait", "walking"]
    assert tool.main(argv) == 0
    s = Usd.Stage.Open(str(out))
    assert s.GetTimeCodesPerSecond() == 30 and s.GetEndTimeCode() == 15
    robot = s.GetPrimAtPath("/World/robot_0")
    assert robot.GetAttribute("wqwarp:gait").Get(3) == "walking"
    assert UsdGeom.Xformable(s.GetPrimAtPath("/World/robot_0/trunk")).GetOrderedXformOps()[0].GetNumTimeSamples() == 16
    np.testing.assert_array_equal(frame_steps(0.5, 30, 0.02), np.rint(np.arange(16) / 30 / 0.02))
    np.testing.assert_array_equal(frame_steps(1.0, 50, 0.02), np.arange(51))


def test_command_script_parsing(tool, tmp_path):
    script = tmp_path / "cmd.csv"
    script.write_text("# ramp\nt,vx,vy,wz\n0, 0.2, 0, 0\n1.0 0.5 0 0.3\n\n2.5,-0.2,0,0\n")
    sched = tool.parse_command_script(str(script))
    np.testing.assert_allclose(sched.at(0.0), [0.2, 0, 0])
    np.testing.assert_allclose(sched.at(1.7), [0.5, 0, 0.3])
    np.testing.assert_allclose(sched.at(9.0), [-0.2, 0, 0])
    late = tool.CommandSchedule([1.0], [[0.4, 0, 0]])
    np.testing.assert_allclose(late.at(0.5), [0, 0, 0])  # zero before the first line
    for bad in ("0,0.2,0\n", "0,a,0,0\n", "1,0,0,0\n0.5,0,0,0\n", "-1,0,0,0\n", "0,nan,0,0\n", "# nothing\n"):
        script.write_text(bad)
        with pytest.raises(tool.UsageError):
            tool.parse_command_script(str(script))


def test_bad_input_exits_2_without_a_file(tmp_path):
    r = _run("--out", str(tmp_path / "roll.obj"), "--seconds", "0.1")
    assert r.returncode == 2 and "extension" in r.stderr and ".obj" in r.stderr
    r = _run("--out", str(tmp_path / "missing" / "roll.usdc"), "--seconds", "0.1")
    assert r.returncode == 2 and "does not exist" in r.stderr
    script = tmp_path / "cmd.txt"
    script.write_text("0,0.5,0,0\n1,0.5,zero,0\n")
    r = _run("--out", str(tmp_path / "roll.usda"), "--seconds", "0.1", "--command-script", str(script))
    assert r.returncode == 2 and "cmd.txt:2" in r.stderr
    r = _run("--out", str(tmp_path / "roll.usda"), "--seconds", "0", "--command", "0,0,0")
    assert r.returncode == 2 and "--seconds" in r.stderr
    r = _run("--out", str(tmp_path / "roll.usda"), "--command", "0.5,0")
    assert r.returncode == 2 and "vx,vy,wz" in r.stderr
    assert sorted(os.listdir(tmp_path)) == ["cmd.txt"]


@pytest.fixture(scope="module")
def checkpoint(tmp_path_factory, save_checkpoint) -> str:
    """An untrained 'ours' checkpoint (configuration, policy, estimator, predictor), as train/ppo_newton.py saves."""
    from wqwarp.rl.presets import make_preset

    cfg = make_preset("ours")
    cfg.sim.num_envs = 1
    return save_checkpoint(tmp_path_factory.mktemp("ckpt") / "model_0.pt", cfg)


def test_a_checkpoint_is_played_with_its_commands_held(tool, checkpoint, tmp_path, capsys):
    out = tmp_path / "p.usda"
    base = ["--out", str(out), "--checkpoint", checkpoint, "--num-envs", "2", "--seconds", "0.4", "--fps", "25"]
    assert tool.main([*base, "--preset", "pmtg"]) == 2  # trained as ours, not pmtg
    assert "not trained as preset 'pmtg'" in capsys.readouterr().err and not out.exists()
    bad = tmp_path / "bad.pt"
    bad.write_bytes(b"not a checkpoint")
    assert tool.main(["--out", str(out), "--checkpoint", str(bad), "--seconds", "0.2"]) == 2
    assert "cannot play checkpoint" in capsys.readouterr().err and not out.exists()
    assert tool.main([*base, "--command", "0.4,0,0.2"]) == 0
    s = Usd.Stage.Open(str(out))
    info = s.GetRootLayer().customLayerData["wqwarp"]
    assert info["mode"] == "policy" and info["preset"] == "ours" and info["iteration"] == 0
    robot = s.GetPrimAtPath("/World/robot_1")
    assert robot.GetAttribute("wqwarp:phase").GetNumTimeSamples() == 11  # 0.4 s at 25 fps, both ends
    for frame in (0, 5, 10):  # the command in force is the one asked for, at every frame
        np.testing.assert_allclose(list(robot.GetAttribute("wqwarp:command").Get(frame)), [0.4, 0, 0.2], atol=1e-6)
    trunk = UsdGeom.Xformable(s.GetPrimAtPath("/World/robot_1/trunk")).GetOrderedXformOps()[0]
    z = [trunk.Get(f)[2] for f in (0, 10)]
    assert 0.15 < z[1] < 0.5 and z[0] != z[1]  # the simulated trunk is recorded and stays above the ground


def test_failed_export_leaves_no_file(tmp_path):
    class BrokenLayer:
        def Export(self, path, *args, **kwargs):
            with open(path, "w") as f:
                f.write("partial")
            raise RuntimeError("disk full")

    target = tmp_path / "keep.usda"
    target.write_text("previous")
    with pytest.raises(RuntimeError):
        export_atomic(BrokenLayer(), str(target))
    assert sorted(os.listdir(tmp_path)) == ["keep.usda"] and target.read_text() == "previous"
