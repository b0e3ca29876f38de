"""The wheeled Go1 asset: joint order, masses, limits (FACTS.md) and byte-identical regeneration."""

from __future__ import annotations

import numpy as np
import pytest

from wqwarp.robot import asset as robot
from wqwarp.robot import constants as C


@pytest.fixture(scope="module")
def model():
    return robot.scene_builder(2).finalize(device="cpu")


def test_regenerating_the_asset_gives_the_same_bytes():
    from wqwarp.cli.build_asset import render

    with open(C.WHEELED_GO1_USD, encoding="utf-8") as f:
        assert f.read() == render()


def test_sixteen_actuated_joints_in_documented_order(model):
    lay = robot.robot_layout(model)
    names = [model.joint_label[i].rsplit("/", 1)[-1] for i in range(model.joint_count // 2)]
    qd_start = model.joint_qd_start.numpy()
    by_dof = {int(qd_start[i]): names[i] for i in range(len(names))}
    assert [by_dof[int(d)] for d in lay.actuated_dof] == list(C.ACTUATED_JOINT_NAMES)
    assert C.ACTUATED_JOINT_NAMES[:3] == ("FR_hip_joint", "FR_thigh_joint", "FR_calf_joint")
    assert C.ACTUATED_JOINT_NAMES[12:] == tuple(f"{leg}_wheel_joint" for leg in ("FR", "FL", "RR", "RL"))
    assert lay.dofs_per_world == 6 + 16 and lay.coords_per_world == 7 + 16
    # Wheels spin about y (parallel to the knee); hips about x; thighs and calves about y (FACTS.md).
    axis = model.joint_axis.numpy()
    expected = [(1, 0, 0), (0, 1, 0), (0, 1, 0)] * 4 + [(0, 1, 0)] * 4
    np.testing.assert_allclose(axis[lay.actuated_dof], expected)


def test_total_mass_is_the_sum_of_cited_masses(model):
    # FACTS.md: the MJCF Go1 totals 12.743 kg; plus per leg a 0.2023 kg wheel and a 0.514 kg wheel motor.
    cited = 12.743 + 4 * (0.2023 + 0.514)
    lay = robot.robot_layout(model)
    assert lay.total_mass == pytest.approx(cited, rel=0.01)
    assert abs(lay.total_mass - cited) < 0.01  # in fact exact to rounding


def test_joint_limits_match_facts(model):
    lay = robot.robot_layout(model)
    lo, hi = model.joint_limit_lower.numpy(), model.joint_limit_upper.numpy()
    facts = {"hip": (-0.863, 0.863), "thigh": (-0.686, 4.501), "calf": (-2.818, -0.888)}
    for j, name in enumerate(C.LEG_JOINT_NAMES):
        kind = name.split("_")[1]
        assert lo[lay.actuated_dof[j]] == pytest.approx(facts[kind][0], abs=1e-5)
        assert hi[lay.actuated_dof[j]] == pytest.approx(facts[kind][1], abs=1e-5)
    for j in range(12, 16):  # continuous wheels
        assert lo[lay.actuated_dof[j]] < -1e6 and hi[lay.actuated_dof[j]] > 1e6
    assert C.TORQUE_LIMITS == (23.7, 23.7, 35.55) * 4 + (6.0,) * 4


def test_usd_records_torque_limits_and_wheel_geometry():
    from pxr import Usd, UsdGeom

    stage = Usd.Stage.Open(C.WHEELED_GO1_USD)
    for name, limit in zip(C.ACTUATED_JOINT_NAMES, C.TORQUE_LIMITS, strict=True):
        prim = stage.GetPrimAtPath(f"/wheeled_go1/joints/{name}")
        assert prim.IsValid(), name
        assert prim.GetAttribute("wqwarp:effortLimit").Get() == pytest.approx(limit)
    wheel = UsdGeom.Cylinder(stage.GetPrimAtPath("/wheeled_go1/FR_wheel/collision"))
    assert wheel.GetRadiusAttr().Get() == pytest.approx(0.075)
    assert wheel.GetHeightAttr().Get() == pytest.approx(0.03)
    assert UsdGeom.GetStageUpAxis(stage) == "Z"
