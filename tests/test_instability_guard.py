"""The divergence guard: a robot whose simulation blows up is flagged, terminated and reset alone, and nothing it
produced reaches rewards, power, logs or the learners. On ``mujoco_cpu`` MuJoCo resets a diverged robot's data itself
(its time falls back); on ``mujoco_warp`` the NaN stays and the state check catches it."""

from __future__ import annotations

import os

import numpy as np
import pytest
import torch

from wqwarp.rl.env import WheeledGo1Env
from wqwarp.rl.presets import make_preset
from wqwarp.sim.config import SimConfig
from wqwarp.sim.simulator import Simulator

N = 4


def _poison(sim: Simulator, robot: int, value: float) -> None:
    """Write ``value`` into the base velocity of one robot, as a diverging step would."""
    q = sim.joint_q.numpy()[[robot]].copy()
    qd = sim.joint_qd.numpy()[[robot]].copy()
    qd[0, :3] = value
    sim.set_state([robot], q, qd)


@pytest.mark.parametrize("backend", ["mujoco_cpu", "mujoco_warp"])
@pytest.mark.parametrize("value", [float("nan"), 5.0e3])
def test_the_simulator_flags_exactly_the_diverged_robot(backend, value, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # where MuJoCo's default handler would write its log file
    sim = Simulator(SimConfig(num_envs=N, backend=backend))
    for _ in range(3):
        sim.step()
    assert not sim.unstable.numpy().any()
    _poison(sim, 2, value)
    sim.step()
    assert sim.unstable.numpy().tolist() == [0, 0, 1, 0]
    sim.reset([2])
    assert not sim.unstable.numpy().any()
    if backend == "mujoco_cpu" and value != value:  # MuJoCo warned (NaN): to the logger, not to MUJOCO_LOG.TXT
        from wqwarp.sim.backends.mujoco_cpu import MUJOCO_WARNINGS

        assert MUJOCO_WARNINGS and "unstable" in MUJOCO_WARNINGS[-1]
        assert not os.path.exists("MUJOCO_LOG.TXT")
    for _ in range(3):
        sim.step()
    assert not sim.unstable.numpy().any()
    assert np.isfinite(sim.joint_q.numpy()).all() and np.isfinite(sim.joint_qd.numpy()).all()


@pytest.mark.parametrize("backend", ["mujoco_cpu", "mujoco_warp"])
def test_the_env_terminates_and_resets_only_the_diverged_robot(backend):
    cfg = make_preset("ours")
    cfg.sim.num_envs = N
    cfg.sim.backend = backend
    env = WheeledGo1Env(cfg)
    env.collect_training_data = True
    zero = torch.zeros(N, env.num_actions)
    for _ in range(5):
        env.step(zero)
    _poison(env.sim, 1, float("nan"))
    obs, rew, dones, extras = env.step(zero)
    assert dones.tolist() == [0, 1, 0, 0] and not extras["time_outs"].any()
    assert torch.isfinite(rew).all() and rew[1] == 0.0
    assert torch.isfinite(obs["policy"]).all() and torch.isfinite(obs["privileged"]).all()
    log = extras["log"]
    assert all(torch.isfinite(torch.as_tensor(v)).all() for v in log.values()), log
    assert float(log["Episode_Termination/unstable"]) == 1.0 and float(log["Episode_Termination/base_contact"]) == 0
    assert int(env.unstable_count) == 1
    assert env.episode_length_buf.tolist() == [6, 0, 6, 6]  # only robot 1 was reset
    assert torch.isfinite(env.tv["p_cost"]).all()
    for _ in range(5):  # the learners never see a non-finite value
        obs, rew, dones, extras = env.step(zero)
        assert torch.isfinite(obs["policy"]).all() and torch.isfinite(rew).all()
    env.estimator_trainer.fit()
    assert all(torch.isfinite(p).all() for p in env.estimator.parameters())
