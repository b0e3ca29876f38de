"""Extending the system without editing the package: a fourth gait (configuration) and a thirteenth reward term (one
``@wp.func`` and one registry entry, both defined here) run through the env, the critic, the power predictor and one
training iteration."""

from __future__ import annotations

import contextlib
import io

import pytest
import torch
import warp as wp

from wqwarp.control.gaits import TABLE_I, Gait
from wqwarp.kernels.rewards import RewardInputs
from wqwarp.rl.config import TrainConfig
from wqwarp.rl.env import WheeledGo1Env
from wqwarp.rl.presets import make_preset
from wqwarp.rl.rewards import TABLE_II, RewardTerm

N = 4
PACE = Gait("pacing", (0.0, 0.5, 0.0, 0.5), df_swing=0.4, frequency=1.0)
"""Same-side legs together: FR with RR, FL with RL."""


@wp.func
def wheel_speed(inp: RewardInputs, i: int, v: wp.vec3, w: wp.vec3, g: wp.vec3) -> float:
    """||qd_wheels||^2 [rad^2/s^2]: squared wheel speeds."""
    r = float(0.0)
    for j in range(12, 16):
        r += inp.actuated_qd[i, j] * inp.actuated_qd[i, j]
    return r


WHEEL_SPEED = RewardTerm(
    "wheel_speed",
    -1e-3,
    "||qd_wheels||^2 [rad^2/s^2].",
    func=wheel_speed,
    reference=lambda x: (x["actuated_qd"][:, 12:] ** 2).sum(1),
)


def test_a_fourth_gait_and_a_thirteenth_reward_term_train_one_iteration():
    from wqwarp.rl.runner import WqRunner

    cfg = make_preset("ours")
    cfg.sim.num_envs = N
    cfg.gait.library = (*TABLE_I, PACE)
    cfg.gait.fixed_gait = "pacing"
    env = WheeledGo1Env(cfg, reward_terms=(*TABLE_II, WHEEL_SPEED))
    assert env.gait_names == ("driving", "trotting", "walking", "pacing")
    assert env.reward_names[-1] == "wheel_speed" and env.reward_terms_wp.shape == (N, 13)
    assert dict(env.privileged_layout)["gait_id"] == 4 and env.gait_selector.predictor.net[-1].out_features == 4
    env.gait_selector.forced_gait = torch.tensor([3, 3, 1, 0])  # the new gait runs on two robots
    env.refresh_after_load()  # every robot due for a selection now

    obs, r, _, _ = env.step(torch.zeros(N, env.num_actions))
    assert torch.isfinite(r).all()
    terms = wp.to_torch(env.reward_terms_wp)
    expected = -1e-3 * (env.tv["actuated_qd"][:, 12:] ** 2).sum(1) * env.dt
    torch.testing.assert_close(terms[:, 12], expected, rtol=1e-4, atol=1e-8)
    torch.testing.assert_close(terms.sum(1), r, rtol=1e-5, atol=1e-5)
    for _ in range(3):  # past the continuity rule: the requested pace takes effect
        obs, *_ = env.step(torch.zeros(N, env.num_actions))
    assert env.active_gait().tolist()[:2] == [3, 3]
    assert obs["privileged"][:2, -4:].tolist() == [[0.0, 0.0, 0.0, 1.0]] * 2  # the critic sees the running pace
    assert env.gait_selector.predict(obs["policy"]).shape == (N, 4)
    env.episode_length_buf[:] = env.max_episode_length
    _, _, _, extras = env.step(torch.zeros(N, env.num_actions))
    assert "Episode_Reward/wheel_speed" in extras["log"]

    env.gait_selector.forced_gait = None
    with contextlib.redirect_stdout(io.StringIO()):
        runner = WqRunner(env, TrainConfig(num_steps_per_env=4).rsl_rl_dict(), log_dir=None, device="cpu")
        runner.learn(1)
    critic_in = torch.cat([obs["policy"], obs["privileged"]], 1)
    assert runner.alg.critic(obs).shape == (N, 1) and critic_in.shape[1] == env.num_obs + env.privileged_dim
    assert all(torch.isfinite(p).all() for p in env.gait_selector.predictor.parameters())


def test_an_unknown_gait_name_and_a_duplicate_term_fail_at_start_up():
    cfg = make_preset("no_predictor")
    cfg.sim.num_envs = N
    with pytest.raises(ValueError, match="not in the library"):
        cfg.gait.fixed_gait = "pacing"
        cfg.gait.validate()
    cfg.gait.fixed_gait = "trotting"
    with pytest.raises(ValueError, match="twice"):
        WheeledGo1Env(cfg, reward_terms=(*TABLE_II, TABLE_II[0]))
