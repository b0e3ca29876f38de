"""The residual-RL environment: shapes and groups, layout decoding, reward logging, presets, and no NaN."""

from __future__ import annotations

import json
import os

import numpy as np
import pytest
import torch
import warp as wp

from wqwarp.rl.config import REWARD_TERMS, RewardConfig
from wqwarp.rl.env import WheeledGo1Env
from wqwarp.rl.observations import decode_observation, observation_layout
from wqwarp.rl.presets import PRESETS, make_preset

N = 4


def _env(preset: str = "no_predictor", device: str = "cpu", **over) -> WheeledGo1Env:
    cfg = make_preset(preset)
    cfg.sim.num_envs = N
    cfg.sim.device = device
    for k, v in over.items():
        setattr(cfg, k, v)
    return WheeledGo1Env(cfg)


@pytest.fixture(scope="module")
def env(device):
    return _env(device=device)


def test_shapes_and_groups(env):
    obs = env.get_observations()
    assert set(obs.keys()) == {"policy", "privileged"}
    assert env.num_actions == 20
    assert obs["policy"].shape == (N, 3 + 3 + 12 + 16 + 18 + 3 + 3 + 2 * 20)
    assert obs["privileged"].shape == (N, 3 + 1 + 1 + 1 + 1 + 4 + 2 + 3) == (N, env.privileged_dim)
    assert env.estimate_index == 3 + 3 + 12 + 16 + 18 and env.proprio_dim == env.num_obs - 3
    o, r, d, extras = env.step(torch.zeros(N, env.num_actions))
    assert r.shape == (N,) and d.shape == (N,) and extras["time_outs"].shape == (N,)


def test_power_is_logged_per_joint_group_and_the_energy_terms_read_the_substep_average(env):
    a = torch.randn(N, env.num_actions, generator=torch.Generator().manual_seed(0))
    _, _, _, extras = env.step(a)
    log = extras["log"]
    total = float(log["Metrics/p_cost"])
    assert total > 0.0
    assert float(log["Metrics/p_cost_legs"]) + float(log["Metrics/p_cost_wheels"]) == pytest.approx(total, rel=1e-4)
    for k in ("p_mech_legs", "p_mech_wheels", "p_elec", "p_elec_legs", "p_elec_wheels", "p_copper_legs"):
        assert f"Metrics/{k}" in log
    # the battery pays at least the copper loss of holding the legs up: p_elec >= p_copper > 0
    assert float(log["Metrics/p_copper_legs"]) > 0.0 and float(log["Metrics/p_elec"]) > 0.0
    # the reward's energy term is -1e-5 * substep-averaged sum (tau qd)^2 * dt, not the last substep's value
    terms = wp.to_torch(env.reward_terms_wp)
    k = REWARD_TERMS.index("energy")
    expected = -1e-5 * env.tv["power_sq"] * env.dt
    torch.testing.assert_close(terms[:, k], expected, rtol=1e-4, atol=1e-7)
    # the power-cost term (beyond Table II, weight 0 by default) reads the same substep-averaged p_cost, in W
    weights, k = wp.to_torch(env.reward_weights), REWARD_TERMS.index("p_cost")
    assert float(weights[k]) == 0.0 and float(terms[:, k].abs().max()) == 0.0
    weights[k] = -0.02
    try:
        env.step(a)
        torch.testing.assert_close(terms[:, k], -0.02 * env.tv["p_cost"] * env.dt, rtol=1e-4, atol=1e-7)
    finally:
        weights[k] = 0.0


def test_joint_limit_term_reads_the_legs_positions_after_the_step(env):
    """The joint-limit term (beyond Table II, off by default) sums the leg joints' excursions beyond the soft range
    (0.9 of each range) of the simulator's positions after the step; a large random action drives some there."""
    from wqwarp.rl.rewards import soft_joint_limits

    weights, k = wp.to_torch(env.reward_weights), REWARD_TERMS.index("joint_limits")
    assert float(weights[k]) == 0.0
    weights[k] = -10.0
    try:
        for _ in range(3):
            env.step(5.0 * torch.randn(N, env.num_actions, generator=torch.Generator().manual_seed(1)))
        low, high = (torch.tensor(b, dtype=torch.float32) for b in soft_joint_limits(0.9))
        q = wp.to_torch(env.sim.actuated_q)[:, :12].cpu()
        beyond = ((low - q).clamp(min=0) + (q - high).clamp(min=0)).sum(1)
        got = wp.to_torch(env.reward_terms_wp)[:, k].cpu()
        torch.testing.assert_close(got, -10.0 * beyond * env.dt, rtol=1e-4, atol=1e-7)
    finally:
        weights[k] = 0.0
    assert float(beyond.max()) > 0.0  # the case was exercised


def test_observation_decodes_into_named_parts(env):
    env.cfg.obs.noise = False
    cmd = torch.tensor([[0.5, -0.2, 0.3]] * N)
    env.set_commands(cmd)
    a = torch.linspace(-1, 1, env.num_actions).repeat(N, 1)
    env.step(a)
    b = torch.full((N, env.num_actions), 0.25)
    obs, *_ = env.step(b)
    parts = decode_observation(obs["policy"], env.num_actions)
    assert list(parts) == [name for name, _ in observation_layout(env.num_actions)]
    torch.testing.assert_close(parts["command"], cmd * torch.tensor([2.0, 2.0, 0.25]))
    torch.testing.assert_close(parts["prev_action"], b)
    torch.testing.assert_close(parts["prev2_action"], a)
    base = env.base_state()
    torch.testing.assert_close(parts["gravity"], base["gravity"])
    torch.testing.assert_close(parts["leg_pos"], env.tv["actuated_q"][:, :12] - env.default_leg_q)
    gait = parts["gait"]
    phase = torch.atan2(gait[:, :4], gait[:, 4:8]) / (2 * np.pi) % 1.0
    torch.testing.assert_close(phase, torch.as_tensor(env.nominal.phase.numpy()), atol=1e-5, rtol=0)
    torch.testing.assert_close(gait[:, 12], torch.full((N,), 1.2))  # trotting f [Hz]
    torch.testing.assert_close(gait[:, 13], torch.full((N,), 0.4))  # trotting DF_swing
    torch.testing.assert_close(gait[:, 8:12], torch.clamp(0.2 * b[:, :4], -0.2, 0.2))  # phase residuals
    torch.testing.assert_close(parts["estimate"], env.estimate * torch.tensor([2.0, 2.0, 1.0]))
    env.cfg.obs.noise = True
    with pytest.raises(ValueError):
        decode_observation(obs["policy"][:, :-1], env.num_actions)


def test_the_envs_mirror_is_an_involution_that_flips_lateral_commands(env):
    obs = env.get_observations()
    mirrored = env.mirror_observations(obs)
    for group in ("policy", "privileged"):
        torch.testing.assert_close(env.mirror_observations(mirrored)[group], obs[group], rtol=0, atol=0)
    a = torch.randn(N, env.num_actions)
    torch.testing.assert_close(env.mirror_actions(env.mirror_actions(a)), a, rtol=0, atol=0)
    cmd = decode_observation(obs["policy"], env.num_actions)["command"]
    got = decode_observation(mirrored["policy"], env.num_actions)["command"]
    torch.testing.assert_close(got, cmd * torch.tensor([1.0, -1.0, -1.0]))


def test_random_actions_give_no_nan_and_log_every_nonzero_term():
    env = _env()
    logged = set()
    for _ in range(60):
        obs, r, d, extras = env.step(torch.randn(N, env.num_actions))
        assert torch.isfinite(obs["policy"]).all() and torch.isfinite(obs["privileged"]).all()
        assert torch.isfinite(r).all()
        logged |= {k.split("/", 1)[1] for k in extras["log"] if k.startswith("Episode_Reward/")}
    env.episode_length_buf[:] = env.max_episode_length  # force a timeout of every robot
    _, _, d, extras = env.step(torch.zeros(N, env.num_actions))
    assert d.all() and extras["time_outs"].all()
    logged |= {k.split("/", 1)[1] for k in extras["log"] if k.startswith("Episode_Reward/")}
    nonzero = {k for k, w in zip(REWARD_TERMS, RewardConfig().weights(), strict=True) if w != 0}
    assert logged == nonzero


def test_zero_weight_terms_are_not_logged_or_computed():
    cfg = make_preset("baseline")
    assert cfg.reward.residual == 0.0  # the paper omits the residual penalty for the baseline
    cfg.sim.num_envs = N
    env = WheeledGo1Env(cfg)
    env.episode_length_buf[:] = env.max_episode_length
    _, _, _, extras = env.step(torch.randn(N, env.num_actions))
    assert "Episode_Reward/residual" not in extras["log"]
    assert (env.reward_terms_wp.numpy()[:, REWARD_TERMS.index("residual")] == 0).all()


def test_reward_terms_sum_to_the_reward(env):
    _, r, _, _ = env.step(torch.randn(N, env.num_actions) * 0.3)
    terms = torch.as_tensor(env.reward_terms_wp.numpy())
    torch.testing.assert_close(terms.sum(1), r, atol=1e-5, rtol=1e-5)
    # Tracking terms lie in [0, w dt], penalties are <= 0.
    w = torch.tensor(RewardConfig().weights()) * env.dt
    assert (terms[:, :3] >= 0).all() and (terms[:, :3] <= w[:3] + 1e-6).all()
    assert (terms[:, 3:] <= 1e-7).all()


@pytest.mark.parametrize("preset", sorted(PRESETS))
def test_each_preset_builds_and_steps(preset, device):
    env = _env(preset, device)
    assert env.num_actions == (16 if preset == "baseline" else 20)
    for _ in range(5):
        obs, r, d, _ = env.step(torch.randn(N, env.num_actions, device=env.device) * 0.2)
    assert torch.isfinite(r).all()
    if preset == "pmtg":  # no nominal wheel velocity: wheel targets come from the policy only
        env.step(torch.zeros(N, env.num_actions, device=env.device))
        assert np.allclose(env.sim.wheel_qd_target.numpy(), 0.0)
    if preset == "no_predictor":
        env.reset()
        env.set_commands(torch.tensor([[0.6, 0.0, 0.0]] * N))
        for _ in range(10):  # robots spawn 2 cm up; wheels count once they touch down
            env.step(torch.zeros(N, env.num_actions, device=env.device))
        wheels = env.sim.wheel_qd_target.numpy()
        # Eq. (3) for wheels on the ground; a wheel in the air keeps its previous target (0 after the reset).
        on_target = np.isclose(wheels, 0.6 / 0.075, rtol=0.05)
        assert on_target.mean() >= 0.5 and np.all(on_target | (wheels == 0.0))


def test_unknown_preset_is_a_clear_error():
    with pytest.raises(ValueError, match="known presets"):
        make_preset("ours_v2")


@pytest.mark.parametrize("preset", sorted(PRESETS))
def test_every_config_round_trips_and_a_foreign_one_is_a_clear_error(preset):
    import json

    from wqwarp.rl.config import env_config_from_dict, to_dict

    cfg = make_preset(preset)
    cfg.sim.dt, cfg.sim.decimation, cfg.predictor.hidden_dims = 0.001, 20, (32, 16)
    back = env_config_from_dict(json.loads(json.dumps(to_dict(cfg))))  # as config.json stores it
    assert back == cfg and isinstance(back.predictor.hidden_dims, tuple)
    d = to_dict(cfg)
    d["reward"]["new_term"] = 1.0
    with pytest.raises(ValueError, match=r"EnvConfig.reward: unknown keys \['new_term'\]"):
        env_config_from_dict(d)
    d = to_dict(cfg)
    del d["sim"]["leg_kp"]
    with pytest.raises(ValueError, match=r"EnvConfig.sim: missing keys \['leg_kp'\]"):
        env_config_from_dict(d)


def test_settings_added_later_are_filled_with_the_old_behaviour_and_reported():
    from wqwarp.rl.config import env_config_from_dict, to_dict

    d = to_dict(make_preset("no_predictor"))
    del d["action"]["phase_residual_mode"], d["predictor"]  # a checkpoint from before both settings
    notes: list[str] = []
    cfg = env_config_from_dict(d, notes)
    assert cfg.action.phase_residual_mode == "increment" and len(notes) == 2
    d = to_dict(make_preset("ours"))
    del d["predictor"]  # a predictive run must have its own predictor settings
    with pytest.raises(ValueError, match="missing keys \\['predictor'\\]"):
        env_config_from_dict(d)


def test_every_committed_training_configuration_still_loads():
    """The configurations of the trainings behind docs/ (``*_train_config.json``, ``config.json`` of study runs) load
    with today's code: each setting added since declares on its field how they behave without it
    (``wqwarp.utils.migration``; ``tests/test_checkpoint_compat.py`` names any that does not), so their checkpoints
    evaluate and resume."""
    import glob

    from wqwarp.rl.config import env_config_from_dict

    root = os.path.join(os.path.dirname(__file__), "..", "docs")
    paths = glob.glob(os.path.join(root, "**", "*train_config.json"), recursive=True)
    paths += glob.glob(os.path.join(root, "**", "config.json"), recursive=True)
    assert len(paths) > 20
    for path in paths:
        with open(path) as f:
            data = json.load(f)
        if "env" not in data:
            continue
        try:
            cfg = env_config_from_dict(data["env"])
        except ValueError as e:
            pytest.fail(f"{os.path.relpath(path, root)} no longer loads: {e}")
        assert cfg.seed == data["env"]["seed"], path


def test_evaluation_builds_the_env_from_the_checkpoints_own_configuration(tmp_path, save_checkpoint):
    from wqwarp.eval.loading import make_policy_runner

    cfg = make_preset("no_predictor")
    cfg.sim.num_envs, cfg.sim.dt, cfg.sim.decimation = 2, 0.001, 20
    cfg.action.phase_residual_mode = "increment"
    cfg.reward.energy = -3e-4
    save_checkpoint(tmp_path / "model_0.pt", cfg)
    pr = make_policy_runner(str(tmp_path / "model_0.pt"), None, num_envs=3)
    got = pr.env.cfg
    assert (got.sim.dt, got.sim.decimation, got.action.phase_residual_mode) == (0.001, 20, "increment")
    assert got.reward.energy == -3e-4 and got.sim.num_envs == 3 and not got.domain_rand.enabled
    assert cfg.sim.num_envs == 2 and cfg.domain_rand.enabled  # the trained config is not touched
    pr = make_policy_runner(str(tmp_path / "model_0.pt"), None, num_envs=2, dt=0.005)
    assert (pr.env.cfg.sim.dt, pr.env.cfg.sim.decimation) == (0.005, 4)  # a named override keeps 50 Hz
    from wqwarp.eval.metrics import PUSH_TASKS
    from wqwarp.eval.tracking import run_task

    res = run_task(pr, "vy", seconds=2.2, settle=0.2)
    assert res.command_range == [-0.7, 0.7] and not res.outside_training_range
    res = run_task(pr, "vy", seconds=2.2, settle=0.2, command_range=PUSH_TASKS["vy"][1])
    assert res.command_range == [-1.0, 1.0] and res.outside_training_range  # Table III's v_y leaves +-0.7
    with pytest.raises(ValueError, match="not trained as preset 'pmtg'"):
        make_policy_runner(str(tmp_path / "model_0.pt"), "pmtg", num_envs=1)
    with pytest.raises(ValueError, match="does not divide"):
        make_policy_runner(str(tmp_path / "model_0.pt"), None, num_envs=1, dt=0.003)


def test_held_commands_reach_every_observation_also_after_resets():
    env = _env("no_predictor")
    cmd = torch.tensor([[0.3, 0.0, 0.0], [0.0, -0.2, 0.0], [0.0, 0.0, 0.5], [0.0, 0.0, 0.0]])
    env.hold_commands(cmd)
    env.resample_steps = 3  # resample (and reset robot 0) often
    scale = torch.tensor([2.0, 2.0, 0.25])
    obs = env.reset()
    for k in range(12):
        if k == 5:
            env.episode_length_buf[0] = env.max_episode_length - 1  # robot 0 times out and resets
        obs, *_ = env.step(torch.zeros(N, env.num_actions))
        seen = decode_observation(obs["policy"], env.num_actions)["command"]
        assert torch.allclose(seen, cmd * scale), k
    env.hold_commands(None)
    env._resample_commands(torch.arange(N))
    assert not torch.allclose(env.commands, cmd)


def test_pushes_are_velocity_impulses_along_the_trunk_axes(device):
    env = _env("no_predictor", device)  # robots spawn with random yaw
    before = env.tv["joint_qd"][:, :2].clone()
    q = env.tv["joint_q"][:, 3:7]
    yaw = torch.atan2(2 * (q[:, 3] * q[:, 2] + q[:, 0] * q[:, 1]), 1 - 2 * (q[:, 1] ** 2 + q[:, 2] ** 2))
    env._push_robots(0.5)
    dv = env.push_vel  # the impulse in the trunk frame
    assert dv.abs().max() <= 0.5 and dv.abs().max() > 0.0
    c, s = torch.cos(yaw), torch.sin(yaw)
    world = torch.stack([c * dv[:, 0] - s * dv[:, 1], s * dv[:, 0] + c * dv[:, 1]], 1)
    assert torch.allclose(env.tv["joint_qd"][:, :2] - before, world, atol=1e-5)


def test_command_sampling_and_the_push_rotation():
    from wqwarp.rl.commands import sample_commands
    from wqwarp.rl.config import CommandConfig
    from wqwarp.rl.events import push_to_world

    c = CommandConfig(single_axis_prob=1.0, zero_prob=0.0)
    cmd = sample_commands(c, 200, torch.Generator().manual_seed(0), "cpu")
    assert ((cmd != 0).sum(1) <= 1).all() and (cmd[:, 0].abs() <= 1.5).all() and (cmd[:, 1].abs() <= 0.7).all()
    zero = sample_commands(CommandConfig(single_axis_prob=0.0, zero_prob=1.0), 10, torch.Generator(), "cpu")
    assert (zero == 0).all()
    yaw = torch.tensor([0.0, np.pi / 2])  # trunk along world x, then along world y
    world = push_to_world(yaw, torch.tensor([[1.0, 0.5], [1.0, 0.5]]))
    torch.testing.assert_close(world, torch.tensor([[1.0, 0.5], [-0.5, 1.0]]))


def test_the_electrical_power_measure_feeds_the_predictor_labels_and_the_power_reward():
    """``power_measure: electrical``: each labelled window's target is the robot's mean p_elec over the window (not
    its p_cost), and the reward's power term reads p_elec."""
    env = _env("ours", power_measure="electrical")
    sel, h = env.gait_selector, env.gait_selector.horizon
    env.collect_training_data = True
    weights, k = wp.to_torch(env.reward_weights), REWARD_TERMS.index("p_cost")
    weights[k] = -0.02
    p_elec, p_cost = [], []
    for _ in range(h + 6):
        env.step(torch.zeros(N, env.num_actions))
        p_elec.append(env.tv["p_elec"].clone())
        p_cost.append(env.tv["p_cost"].clone())
    terms = wp.to_torch(env.reward_terms_wp)[:, k]
    torch.testing.assert_close(terms, -0.02 * env.tv["p_elec"] * env.dt, rtol=1e-4, atol=1e-7)
    labels = torch.cat([sel.replay.y[: sel.replay.n], sel.holdout.y[: sel.holdout.n]])
    assert labels.numel() > 0
    pe, pc = torch.stack(p_elec), torch.stack(p_cost)  # (steps, N)
    windows_e = torch.stack([pe[s : s + h].mean(0) for s in range(7)])  # every window start the run allows
    windows_c = torch.stack([pc[s : s + h].mean(0) for s in range(7)])
    for y in labels:
        assert torch.isclose(windows_e, y, rtol=1e-4).any(), float(y)
        assert not torch.isclose(windows_c, y, rtol=1e-2).any(), float(y)


def test_the_reward_can_read_the_other_power_measure_than_the_selection():
    """``reward.power_measure: electrical`` under the mechanical selection: the power term reads p_elec while the
    predictor's labels stay p_cost (the config names both)."""
    reward = make_preset("ours").reward
    reward.power_measure = "electrical"
    env = _env("ours", reward=reward)
    assert env.cfg.reward_power_output == "p_elec" and env.cfg.power_measure == "mechanical"
    weights, k = wp.to_torch(env.reward_weights), REWARD_TERMS.index("p_cost")
    weights[k] = -0.02
    env.step(torch.zeros(N, env.num_actions))
    terms = wp.to_torch(env.reward_terms_wp)[:, k]
    torch.testing.assert_close(terms, -0.02 * env.tv["p_elec"] * env.dt, rtol=1e-4, atol=1e-7)
    assert env.power_measured.data_ptr() == env.tv["p_cost"].data_ptr()  # the labels' source
