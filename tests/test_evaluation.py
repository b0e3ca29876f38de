"""The evaluation's metric arithmetic on scripted trajectories, and the sim-to-sim physics configurations."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from wqwarp.eval.protocols import POWER_KEYS, TaskMetrics
from wqwarp.rl.config import make_preset


def _power(**watts) -> dict:
    out = {k: torch.zeros(2) for k in POWER_KEYS}
    out.update({k: torch.tensor(v, dtype=torch.float32) for k, v in watts.items()})
    return out


def test_task_metrics_on_a_scripted_trajectory():
    """Two robots commanded v_x = 0.5 m/s, one at 0.4 and one alternating 0.6 / 0.8 m/s, with known power."""
    cmd = torch.tensor([[0.5, 0.0, 0.0], [0.5, 0.0, 0.0]])
    m = TaskMetrics("vx", cmd)
    for k in range(4):
        v1 = 0.6 if k % 2 == 0 else 0.8
        vel = torch.tensor([[0.4, 0.0, 0.1], [v1, 0.3, 0.0]])  # robot 0 also yaws, robot 1 also drifts sideways
        m.add(vel, _power(p_cost=[100.0, 50.0], p_cost_legs=[60.0, 10.0], p_cost_wheels=[40.0, 40.0],
                          p_mech_legs=[30.0, 5.0], p_mech_wheels=[20.0, 25.0], p_joule_legs=[1.0, 1.0]))  # fmt: skip
    s = m.summary(robot_mass=15.0)
    # v_x errors: robot 0 always -0.1; robot 1 +0.1, +0.3 alternating -> squares 0.01 and (0.01 + 0.09) / 2 = 0.05
    assert s["mse"] == pytest.approx((0.01 + 0.05) / 2)
    assert s["mean_abs_error"] == pytest.approx((0.1 + 0.2) / 2)
    np.testing.assert_allclose(s["mse_axes"], [0.03, 0.09 / 2, 0.01 / 2], rtol=1e-5)
    assert s["mean_p_cost"] == pytest.approx(75.0) and s["mean_p_cost_legs"] == pytest.approx(35.0)
    assert s["mean_p_cost_wheels"] == pytest.approx(40.0)
    assert s["mean_p_mech"] == pytest.approx(40.0) and s["mean_p_mech_wheels"] == pytest.approx(22.5)
    assert s["mean_p_joule"] == pytest.approx(1.0)
    speed = (0.4 + (np.hypot(0.6, 0.3) + np.hypot(0.8, 0.3)) / 2) / 2
    assert s["mean_speed"] == pytest.approx(speed, rel=1e-5)
    assert s["cost_of_transport"] == pytest.approx(75.0 / (15.0 * 9.81 * speed), rel=1e-5)
    # No cost of transport for yaw and stand tasks, or when the robots barely move.
    for task in ("wz", "stand"):
        m = TaskMetrics(task, torch.zeros(2, 3))
        m.add(torch.tensor([[0.3, 0.0, 0.5], [0.3, 0.0, 0.5]]), _power(p_cost=[10.0, 10.0]))
        assert m.summary(15.0)["cost_of_transport"] is None
    m = TaskMetrics("vy", torch.tensor([[0.0, 0.5, 0.0]] * 2))
    m.add(torch.tensor([[0.0, 0.05, 0.0]] * 2), _power(p_cost=[10.0, 10.0]))
    assert m.summary(15.0)["cost_of_transport"] is None and m.summary(15.0)["mse"] == pytest.approx(0.2025)
    with pytest.raises(ValueError, match="unknown task"):
        TaskMetrics("jump", cmd)


def test_sim_to_sim_physics_are_named_overrides_of_the_trained_configuration():
    from wqwarp.eval.loading import evaluation_config
    from wqwarp.rl.env import WheeledGo1Env
    from wqwarp.robot.constants import AUTHORS_GROUND_FRICTION, AUTHORS_JOINT_MODEL

    trained = make_preset("ours")
    trained.sim.num_envs = 8
    cfg = evaluation_config(trained, 2, physics="dt0.001")
    assert (cfg.sim.dt, cfg.sim.decimation, cfg.sim.joint_model) == (0.001, 20, "asset")
    cfg = evaluation_config(trained, 2, physics="authors_dt0.001", seed=7)
    assert (cfg.sim.dt, cfg.sim.decimation, cfg.sim.joint_model, cfg.seed) == (0.001, 20, "authors", 7)
    assert cfg.domain_rand.nominal_friction == AUTHORS_GROUND_FRICTION and not cfg.domain_rand.enabled
    assert trained.sim.joint_model == "asset" and trained.sim.num_envs == 8  # the trained config is untouched
    with pytest.raises(ValueError, match="unknown physics"):
        evaluation_config(trained, 2, physics="bullet")

    cfg = evaluation_config(trained, 2, physics="authors")
    env = WheeledGo1Env(cfg)
    m = env.sim.mj_model
    hinge = np.arange(6, m.nv)  # after the free joint: the 16 actuated joints
    assert m.nv == 22
    np.testing.assert_allclose(m.dof_damping[hinge], AUTHORS_JOINT_MODEL["damping"])
    np.testing.assert_allclose(m.dof_armature[hinge], AUTHORS_JOINT_MODEL["armature"])
    np.testing.assert_allclose(m.dof_frictionloss[hinge], AUTHORS_JOINT_MODEL["friction"])
    assert np.all(m.dof_damping[:6] == 0) and np.all(m.dof_frictionloss[:6] == 0)
    np.testing.assert_allclose([mm.geom_friction[:, 0] for mm in env.sim._mj_models], AUTHORS_GROUND_FRICTION)
    assert torch.allclose(env.friction, torch.full((2,), AUTHORS_GROUND_FRICTION))  # what the critic is told
    base = WheeledGo1Env(evaluation_config(trained, 1))
    mb = base.sim.mj_model
    assert np.all(mb.dof_damping == 0) and np.all(mb.dof_frictionloss == 0)
    assert mb.dof_armature[-1] == pytest.approx(6.07e-5 * 36, rel=1e-4)  # the USD's wheel armature


def test_run_task_pushes_on_schedule_and_holds_its_commands(tmp_path, save_checkpoint):
    """Pushes every ``push_interval`` (observed through the env's recorded impulse), velocity impulses no larger than
    the maximum, and the task's commands unchanged throughout."""
    from wqwarp.eval.loading import make_policy_runner
    from wqwarp.eval.protocols import run_task, spread_commands

    cfg = make_preset("no_predictor")
    cfg.sim.num_envs = 1
    save_checkpoint(tmp_path / "model_0.pt", cfg)
    pr = make_policy_runner(str(tmp_path / "model_0.pt"), None, num_envs=3)
    env = pr.env
    seen, commands = [], []

    def progress(k, n):
        seen.append(env.push_vel.clone())
        commands.append(env.commands.clone())

    r = run_task(pr, "vy", seconds=2.1, settle=0.1, max_push=0.6, push_interval=0.5, progress=progress)
    # A push draws a new impulse for every robot; a robot that falls and is reset has its impulse zeroed alone.
    changed = [k + 1 for k in range(1, len(seen))
               if bool((seen[k] != seen[k - 1]).any(1).all()) and bool((seen[k] != 0).any(1).all())]  # fmt: skip
    assert changed == [26, 51, 76, 101]  # policy steps 25, 50, 75, 100 of 0.02 s
    assert max(float(v.abs().max()) for v in seen) <= 0.6 and r.max_push == 0.6
    expected = spread_commands("vy", 3).to(env.device)
    assert all(torch.equal(c, expected) for c in commands)


def test_a_loaded_checkpoint_starts_the_same_whatever_torch_drew_before(tmp_path, save_checkpoint):
    """The env observes and selects gaits with the networks it is built with; after a checkpoint is loaded the first
    observation and the gait each robot is reset into must come from the loaded ones, not from torch's global RNG."""
    from wqwarp.eval.loading import make_policy_runner
    from wqwarp.eval.protocols import start_rollout

    cfg = make_preset("ours")
    cfg.sim.num_envs = 2
    torch.manual_seed(0)
    save_checkpoint(tmp_path / "model_0.pt", cfg)
    first = []
    for seed in (1, 2, 3):
        torch.manual_seed(seed)  # different random initialisation of the networks the env is built with
        pr = make_policy_runner(str(tmp_path / "model_0.pt"), None, num_envs=4, seed=5)
        obs = start_rollout(pr.env, torch.zeros(4, 3), 1.0)
        first.append((obs["policy"].clone(), pr.env.requested_gait().clone()))
    for o, g in first[1:]:
        assert torch.equal(o, first[0][0]) and torch.equal(g, first[0][1])
