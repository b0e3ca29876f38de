"""The paper authors' MuJoCo robot (MIT, tests/data/authors_wheeled_go1/) built from its MJCF by path
(``SimConfig.robot``): its own masses, shapes and joint model, the project's joint order and wheel convention, and it
stands and drives under this project's nominal gait."""

from __future__ import annotations

import os

import numpy as np
import pytest

from wqwarp.control.driver import OpenLoopDriver
from wqwarp.robot import asset as robot
from wqwarp.robot import constants as C
from wqwarp.sim.config import SimConfig
from wqwarp.sim.simulator import Simulator

AUTHORS_MJCF = os.path.join(os.path.dirname(__file__), "..", "data", "authors_wheeled_go1", "wheeled_go1.xml")


def _axes(builder) -> dict[str, tuple]:
    names = [k.rsplit("/", 1)[-1] for k in builder.joint_label]
    return {n: tuple(builder.joint_axis[builder.joint_qd_start[names.index(n)]]) for n in C.WHEEL_JOINT_NAMES}


def test_the_authors_mjcf_loads_with_their_masses_and_joint_model_and_our_wheel_convention():
    b = robot.robot_builder(AUTHORS_MJCF)
    axes = _axes(b)  # their right wheels spin about -y (README): turned, so +qd rolls forward on every leg
    assert axes["FL_wheel_joint"] == (0.0, 0.0, -1.0) and axes["RL_wheel_joint"] == (0.0, 0.0, -1.0)
    assert axes["FR_wheel_joint"] == (0.0, 0.0, 1.0) and axes["RR_wheel_joint"] == (0.0, 0.0, 1.0)
    sim = Simulator(SimConfig(num_envs=2, robot=AUTHORS_MJCF))
    assert sim.robot_mass == pytest.approx(14.26, abs=0.01)  # ours: the packaged USD's
    assert sim.robot_mass != pytest.approx(Simulator(SimConfig(num_envs=1)).robot_mass, abs=0.01)
    dof = sim.layout.actuated_dof
    assert np.allclose(sim.model.joint_armature.numpy()[dof], 0.01)  # from their file (ours: 2.19e-3 on wheels)
    assert np.allclose(sim.model.joint_friction.numpy()[dof], 0.2)
    with pytest.raises(ValueError, match="no such robot file"):
        SimConfig(robot="nope.xml").check()


@pytest.mark.parametrize("command", [(0.0, 0.0, 0.0), (0.5, 0.0, 0.0)])
def test_the_authors_robot_stands_and_drives_under_the_nominal_driving_gait(command):
    sim = Simulator(SimConfig(num_envs=2, robot=AUTHORS_MJCF))
    drv = OpenLoopDriver(sim, "driving", command)
    drv.run(3.0)
    z, x, vx = sim.joint_q.numpy()[:, 2], sim.joint_q.numpy()[:, 0], sim.joint_qd.numpy()[:, 0]
    assert np.all(z > 0.2) and int(sim.body_collision.numpy()[:, 0].sum()) == 0  # upright, trunk off the ground
    if command[0] == 0.0:
        assert np.all(np.abs(x) < 0.05) and np.all(np.abs(vx) < 0.05)
    else:  # forward, at the commanded speed: the wheels' directions agree with ours
        assert np.all(x > 1.0) and vx == pytest.approx(np.full_like(vx, 0.5), rel=0.15)
