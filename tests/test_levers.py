"""The omnidirectional-skill levers (issue 21), each against hand values or its definition: the lateral
feed-forward's sawtooth (kernel and nominal gait), the command sampler's axis odds, the per-group initial std, the
clip of the step reward at zero and the per-group action logs."""

from __future__ import annotations

import numpy as np
import pytest
import torch
import warp as wp

from wqwarp.control.gaits import GAIT_LIBRARY, gait_index
from wqwarp.control.nominal import NominalGait
from wqwarp.kernels import gait
from wqwarp.rl.commands import sample_commands
from wqwarp.rl.config import CommandConfig, TrainConfig


@wp.kernel
def _stroke(
    phi: wp.array(dtype=float), df: wp.array(dtype=float), a: wp.array(dtype=float), out: wp.array(dtype=float)
):
    i = wp.tid()
    out[i] = gait.lateral_stroke(phi[i], df[i], a[i])


def _stroke_np(phi, df, a):
    """The sawtooth: -A -> +A over swing (phi < DF), +A -> -A over stance; 0 without swing."""
    phi, df, a = np.broadcast_arrays(*(np.asarray(x, np.float64) for x in (phi, df, a)))
    swing = a * (2 * phi / np.where(df > 0, df, 1) - 1)
    stance = a * (1 - 2 * (phi - df) / np.where(df < 1, 1 - df, 1))
    return np.where(df <= 0, 0.0, np.where(phi < df, swing, stance))


def test_lateral_stroke_against_numpy_and_hand_values(device):
    phi = np.array([0.0, 0.2, 0.4 - 1e-6, 0.4, 0.7, 1.0 - 1e-6, 0.3, 0.1], np.float32)
    df = np.array([0.4, 0.4, 0.4, 0.4, 0.4, 0.4, 0.0, 0.4], np.float32)
    a = np.array([0.1, 0.1, 0.1, 0.1, 0.1, 0.1, 0.1, -0.05], np.float32)
    out = wp.zeros(len(phi), dtype=float, device=device)
    wp.launch(
        _stroke,
        dim=len(phi),
        inputs=[wp.array(phi, device=device), wp.array(df, device=device), wp.array(a, device=device)],
        outputs=[out],
        device=device,
    )
    got = out.numpy()
    np.testing.assert_allclose(got, _stroke_np(phi, df, a), atol=1e-6)
    # lift-off at -A, mid-swing 0, touch-down +A (continuous into stance), mid-stance 0, back to -A at the wrap
    np.testing.assert_allclose(got[:6], [-0.1, 0.0, 0.1, 0.1, 0.0, -0.1], atol=1e-5)
    assert got[6] == 0.0  # driving: no swing, no stroke
    assert got[7] == pytest.approx(0.05 * 0.5)  # A < 0 mirrors the stroke


def test_the_nominal_gait_carries_the_clipped_stroke_on_stepping_legs():
    """With gain 0.35 s and v_y 0.6 m/s the amplitude is clipped to 0.12 m: over one trot cycle each leg's nominal
    foot y spans 2 A around its stance y; the driving gait's feet do not move sideways; gain 0 is the paper's gait."""
    spans = {}
    for name, gain in (("trotting", 0.35), ("trotting", 0.0), ("driving", 0.35)):
        ng = NominalGait(1, "cpu", lateral_gain=gain, lateral_limit=0.12, phase_mode="offset")
        ng.command.assign(np.array([[0.0, 0.6, 0.0]], np.float32))
        ng.gait_id.assign(np.array([gait_index(name, GAIT_LIBRARY)], np.int32))
        ng.reset([0])
        q = wp.zeros((1, 12), dtype=float)
        contact = wp.array(np.ones((1, 4), np.int32), dtype=wp.int32)
        ys = []
        f = GAIT_LIBRARY[gait_index("trotting", GAIT_LIBRARY)].frequency
        for _ in range(int(round(1.0 / f / 0.02)) + 1):
            ng.step(q, contact, 0.02)
            ys.append(ng.foot_target.numpy()[0, :, 1].copy())
        ys = np.array(ys)
        spans[(name, gain)] = ys.max(0) - ys.min(0)
    np.testing.assert_allclose(spans[("trotting", 0.35)], 0.24, atol=0.02)
    np.testing.assert_allclose(spans[("trotting", 0.0)], 0.0, atol=1e-6)
    np.testing.assert_allclose(spans[("driving", 0.35)], 0.0, atol=1e-6)


def test_single_axis_odds():
    gen = torch.Generator().manual_seed(0)
    cfg = CommandConfig(single_axis_prob=1.0, zero_prob=0.0, single_axis_weights=(0.0, 1.0, 0.0))
    c = sample_commands(cfg, 2000, gen, "cpu")
    assert (c[:, [0, 2]] == 0).all() and (c[:, 1] != 0).all()  # only lateral commands
    cfg = CommandConfig(single_axis_prob=1.0, zero_prob=0.0, single_axis_weights=(1.0, 2.0, 1.0))
    axis = (sample_commands(cfg, 20000, gen, "cpu") != 0).float().mean(0)
    np.testing.assert_allclose(axis.numpy(), [0.25, 0.5, 0.25], atol=0.02)
    assert sample_commands(cfg, 0, gen, "cpu").shape == (0, 3)
    with pytest.raises(ValueError, match="single_axis_weights"):
        CommandConfig(single_axis_weights=(0.0, 0.0, 0.0))


def test_default_odds_draw_the_same_commands_as_before():
    """Equal odds keep the old draw (``torch.randint``), so the default sampler's stream is unchanged."""
    cfg = CommandConfig()
    a = sample_commands(cfg, 64, torch.Generator().manual_seed(3), "cpu")
    gen = torch.Generator().manual_seed(3)
    lo, hi = (
        torch.tensor([r[0] for r in (cfg.vx_range, cfg.vy_range, cfg.wz_range)]),
        torch.tensor([r[1] for r in (cfg.vx_range, cfg.vy_range, cfg.wz_range)]),
    )
    raw = torch.stack([lo[i] + (hi[i] - lo[i]) * torch.rand(64, generator=gen) for i in range(3)], 1)
    u = torch.rand(64, generator=gen)
    axis = torch.randint(0, 3, (64,), generator=gen)
    single = u < cfg.single_axis_prob
    b = torch.where(single[:, None], raw * torch.nn.functional.one_hot(axis, 3).float(), raw)
    b[(u >= cfg.single_axis_prob) & (u < cfg.single_axis_prob + cfg.zero_prob)] = 0.0
    torch.testing.assert_close(a, b)


def test_per_group_std_and_action_logs():
    """The per-group initial std lands in the actor's std parameter; one training iteration logs the std and the
    mean |a| of every group; the clip at zero keeps every step reward non-negative."""
    import contextlib
    import io

    from wqwarp.rl.env import WheeledGo1Env
    from wqwarp.rl.presets import make_preset
    from wqwarp.rl.runner import WqRunner

    cfg = make_preset("no_predictor")
    cfg.sim.num_envs = 4
    cfg.reward.only_positive = True
    env = WheeledGo1Env(cfg)
    train = TrainConfig(num_steps_per_env=4, init_noise_std_groups=(1.0, 0.3, 0.6), symmetry="augmentation")
    with contextlib.redirect_stdout(io.StringIO()):
        runner = WqRunner(env, train.rsl_rl_dict(), log_dir=None, device="cpu")
    std = runner.alg.actor.distribution.std_param.detach()
    torch.testing.assert_close(std, torch.tensor([1.0] * 4 + [0.3] * 12 + [0.6] * 4))
    obs = env.get_observations()
    for _ in range(5):
        obs, rew, _, extras = env.step(runner.alg.act(obs))
        assert (rew >= 0).all()
    assert {"Actions/phase_abs", "Actions/foot_abs", "Actions/wheel_abs"} <= set(extras["log"])
    with contextlib.redirect_stdout(io.StringIO()):
        runner.learn(1)
    with pytest.raises(ValueError, match="action groups"):
        runner.alg.set_group_std([1.0, 2.0])


def test_the_reward_ramp_against_hand_values():
    """``RewardConfig.ramp_scale``: 0 before ramp_start, linear to 1 over ramp_iterations, 1 after; a step at
    ramp_start when ramp_iterations is 0."""
    from wqwarp.rl.config import RewardConfig

    r = RewardConfig(ramp_terms=("p_cost",), ramp_start=100, ramp_iterations=50)
    assert [r.ramp_scale(i) for i in (0, 99, 100, 125, 150, 4000)] == [0.0, 0.0, 0.0, 0.5, 1.0, 1.0]
    step = RewardConfig(ramp_terms=("p_cost",), ramp_start=10)
    assert [step.ramp_scale(i) for i in (9, 10, 11)] == [0.0, 1.0, 1.0]


def test_training_ramps_the_named_weights_and_resumes_on_the_ramp(tmp_path):
    """The runner moves the ramped weight with the PPO iteration (the rollout of iteration k sees ramp_scale(k)),
    leaves the other weights, logs the scale, and a run resumed from a checkpoint continues on the ramp; an env
    outside training sees the full weights; a ramp naming no term is refused."""
    import contextlib
    import io

    from helpers import quiet_runner

    from wqwarp.rl.env import WheeledGo1Env
    from wqwarp.rl.presets import make_preset

    cfg = make_preset("no_predictor")
    cfg.sim.num_envs = 2
    cfg.reward.p_cost = -0.01
    cfg.reward.ramp_terms, cfg.reward.ramp_start, cfg.reward.ramp_iterations = ("p_cost",), 1, 2
    train = TrainConfig(num_steps_per_env=2, save_interval=1)
    runner = quiet_runner(cfg, log_dir=str(tmp_path), seed=1, train=train)
    env = runner.env
    k = env.reward_names.index("p_cost")
    others = np.delete(env.full_reward_weights, k)
    assert env.reward_weights.numpy()[k] == pytest.approx(-0.01)  # outside training: full weight
    with contextlib.redirect_stdout(io.StringIO()):
        runner.learn(2)  # iterations 0 and 1 ran; the next is 2
    assert env.reward_ramp_scale == 0.5 and env.reward_weights.numpy()[k] == pytest.approx(-0.005)
    np.testing.assert_array_equal(np.delete(env.reward_weights.numpy(), k), others)
    _, _, _, extras = env.step(torch.zeros(env.num_envs, env.num_actions))
    assert extras["log"]["Reward/ramp_scale"] == 0.5
    resumed = quiet_runner(cfg, log_dir=str(tmp_path), seed=1, train=train)
    resumed.load(str(tmp_path / "model_1.pt"))
    with contextlib.redirect_stdout(io.StringIO()):
        resumed.learn(2)  # rsl-rl resumes at the saved iteration: 1 and 2 ran, the next is 3, past the ramp
    assert resumed.env.reward_ramp_scale == 1.0
    assert resumed.env.reward_weights.numpy()[k] == pytest.approx(-0.01)
    cfg.reward.ramp_terms = ("speed",)
    with pytest.raises(ValueError, match="RewardConfig.ramp_terms names no reward term: speed"):
        WheeledGo1Env(cfg)


def test_the_skill_gate_holds_the_ramp_until_the_lateral_error_is_low_and_resumes_open(tmp_path):
    """``ramp_gate_vy_error``: the ramp starts only once the mean training v_y error of a full window of iterations is
    below the threshold (a closed gate keeps the weight at 0), from the iteration after it opened; the opening and
    the window are saved, so a resumed run continues on the ramp."""
    import contextlib
    import io

    from helpers import quiet_runner

    from wqwarp.rl.algorithm import RewardRampLearner
    from wqwarp.rl.presets import make_preset

    def runner_for(threshold: float, log_dir):
        cfg = make_preset("no_predictor")
        cfg.sim.num_envs = 2
        cfg.reward.p_cost = -0.01
        cfg.reward.ramp_terms, cfg.reward.ramp_start, cfg.reward.ramp_iterations = ("p_cost",), 0, 2
        cfg.reward.ramp_gate_vy_error, cfg.reward.ramp_gate_window = threshold, 2
        train = TrainConfig(num_steps_per_env=2, save_interval=1)
        runner = quiet_runner(cfg, log_dir=str(log_dir), seed=1, train=train)
        ramp = next(x for x in runner.alg.learners if isinstance(x, RewardRampLearner))
        return runner, ramp

    closed, ramp = runner_for(1e-9, tmp_path / "closed")  # no robot tracks v_y to a nanometre per second
    with contextlib.redirect_stdout(io.StringIO()):
        closed.learn(3)
    assert ramp.opened_at is None and len(ramp.errors) == 2 and closed.env.reward_ramp_scale == 0.0
    k = closed.env.reward_names.index("p_cost")
    assert closed.env.reward_weights.numpy()[k] == 0.0
    opened, ramp = runner_for(100.0, tmp_path / "open")  # any error is below 100 m/s: opens once the window is full
    with contextlib.redirect_stdout(io.StringIO()):
        opened.learn(3)  # iterations 0, 1 fill the window; the gate opens for 2; the next is 3, half-way
    assert ramp.opened_at == 2 and opened.env.reward_ramp_scale == 0.5
    assert opened.env.reward_weights.numpy()[k] == pytest.approx(-0.005)
    resumed, again = runner_for(100.0, tmp_path / "open")
    resumed.load(str(tmp_path / "open" / "model_2.pt"))
    assert again.opened_at == 2 and list(again.errors) == pytest.approx(list(ramp.errors))
    with contextlib.redirect_stdout(io.StringIO()):
        resumed.learn(1)  # iteration 2 again; the next is 3
    assert resumed.env.reward_ramp_scale == 0.5
