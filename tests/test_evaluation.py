"""The evaluation's metric arithmetic on scripted trajectories, the sim-to-sim physics configurations, and the
protocol registry (options, command lines, an env left as found)."""

from __future__ import annotations

import dataclasses
import io
import json
import os
import shlex

import numpy as np
import pytest
import torch

from wqwarp.eval.metrics import TaskMetrics
from wqwarp.kernels.power import REPORTED_POWER
from wqwarp.rl.presets import make_preset

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def _power(**watts) -> dict:
    out = {k: torch.zeros(2) for k in REPORTED_POWER}
    out.update({k: torch.tensor(v, dtype=torch.float32) for k, v in watts.items()})
    return out


def test_task_metrics_on_a_scripted_trajectory():
    """Two robots commanded v_x = 0.5 m/s, one at 0.4 and one alternating 0.6 / 0.8 m/s, with known power."""
    cmd = torch.tensor([[0.5, 0.0, 0.0], [0.5, 0.0, 0.0]])
    m = TaskMetrics("vx", cmd)
    for k in range(4):
        v1 = 0.6 if k % 2 == 0 else 0.8
        vel = torch.tensor([[0.4, 0.0, 0.1], [v1, 0.3, 0.0]])  # robot 0 also yaws, robot 1 also drifts sideways
        m.add(
            vel,
            _power(
                p_cost=[100.0, 50.0],
                p_cost_legs=[60.0, 10.0],
                p_cost_wheels=[40.0, 40.0],
                p_mech_legs=[30.0, 5.0],
                p_mech_wheels=[20.0, 25.0],
                p_elec=[90.0, 40.0],
                p_elec_legs=[70.0, 10.0],
                p_elec_wheels=[20.0, 30.0],
                p_copper_legs=[8.0, 2.0],
            ),
        )
    s = m.summary(robot_mass=15.0, electronics_w=5.0)
    # v_x errors: robot 0 always -0.1; robot 1 +0.1, +0.3 alternating -> squares 0.01 and (0.01 + 0.09) / 2 = 0.05
    assert s["mse"] == pytest.approx((0.01 + 0.05) / 2)
    assert s["mean_abs_error"] == pytest.approx((0.1 + 0.2) / 2)
    np.testing.assert_allclose(s["mse_axes"], [0.03, 0.09 / 2, 0.01 / 2], rtol=1e-5)
    assert s["mean_p_cost"] == pytest.approx(75.0) and s["mean_p_cost_legs"] == pytest.approx(35.0)
    assert s["mean_p_cost_wheels"] == pytest.approx(40.0)
    assert s["mean_p_mech"] == pytest.approx(40.0) and s["mean_p_mech_wheels"] == pytest.approx(22.5)
    assert s["mean_p_elec"] == pytest.approx(65.0) and s["mean_p_elec_legs"] == pytest.approx(40.0)
    assert s["mean_p_elec_wheels"] == pytest.approx(25.0) and s["mean_p_copper_legs"] == pytest.approx(5.0)
    speed = (0.4 + (np.hypot(0.6, 0.3) + np.hypot(0.8, 0.3)) / 2) / 2
    assert s["mean_speed"] == pytest.approx(speed, rel=1e-5)
    assert s["cost_of_transport"] == pytest.approx(75.0 / (15.0 * 9.81 * speed), rel=1e-5)
    # the battery's cost of transport counts the electronics draw beside the motors
    assert s["cost_of_transport_elec"] == pytest.approx((65.0 + 5.0) / (15.0 * 9.81 * speed), rel=1e-5)
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
    from wqwarp.eval.physics import evaluation_config
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
    np.testing.assert_allclose([mm.geom_friction[:, 0] for mm in env.sim.physics.mj_models], AUTHORS_GROUND_FRICTION)
    assert torch.allclose(env.friction, torch.full((2,), AUTHORS_GROUND_FRICTION))  # what the critic is told
    base = WheeledGo1Env(evaluation_config(trained, 1))
    mb = base.sim.mj_model
    assert np.all(mb.dof_damping == 0) and np.all(mb.dof_frictionloss == 0)
    assert mb.dof_armature[-1] == pytest.approx(6.07e-5 * 36, rel=1e-4)  # the USD's wheel armature


def test_run_task_pushes_on_schedule_and_holds_its_commands(tmp_path, save_checkpoint):
    """Pushes every ``push_interval`` (observed through the env's recorded impulse), velocity impulses no larger than
    the maximum, and the task's commands unchanged throughout."""
    from wqwarp.eval.loading import make_policy_runner
    from wqwarp.eval.tracking import run_task, spread_commands

    cfg = make_preset("no_predictor")
    cfg.sim.num_envs = 1
    torch.manual_seed(0)  # the untrained networks, so that whether a robot falls (and is reset) does not vary by run
    save_checkpoint(tmp_path / "model_0.pt", cfg)
    pr = make_policy_runner(str(tmp_path / "model_0.pt"), None, num_envs=3)
    env = pr.env
    seen, commands = [], []

    def progress(k, n):
        seen.append(env.push_vel.clone())
        commands.append(env.commands.clone())

    r = run_task(pr, "vy", seconds=2.1, settle=0.1, max_push=0.6, push_interval=0.5, progress=progress)
    # A push draws a new impulse for every robot; a robot that falls and is reset has its impulse zeroed alone.
    changed = [
        k + 1
        for k in range(1, len(seen))
        if bool((seen[k] != seen[k - 1]).any(1).all()) and bool((seen[k] != 0).any(1).all())
    ]
    assert changed == [26, 51, 76, 101]  # policy steps 25, 50, 75, 100 of 0.02 s
    assert max(float(v.abs().max()) for v in seen) <= 0.6 and r.max_push == 0.6
    expected = spread_commands("vy", 3).to(env.device)
    assert all(torch.equal(c, expected) for c in commands)


def test_run_task_names_the_commands_of_the_robots_that_fell(tmp_path, save_checkpoint):
    """``fallen_commands`` holds the task-axis command of exactly the robots whose episode restarted (the rollout's
    episodes outlast it, so a restart is a fall), and the push table prints them."""

    from wqwarp.eval.loading import make_policy_runner
    from wqwarp.eval.tracking import _print_table3, run_task, spread_commands

    cfg = make_preset("no_predictor")
    cfg.sim.num_envs = 1
    torch.manual_seed(0)
    save_checkpoint(tmp_path / "model_0.pt", cfg)
    pr = make_policy_runner(str(tmp_path / "model_0.pt"), None, num_envs=6)
    env, lengths, PUSH = pr.env, [], 1.0  # m/s every 0.3 s: an untrained policy keeps 2 of 6 robots up
    r = run_task(
        pr,
        "vy",
        seconds=2.0,
        settle=0.1,
        max_push=PUSH,
        push_interval=0.3,
        progress=lambda k, n: lengths.append(env.episode_length_buf.clone()),
    )
    restarted = torch.stack([lengths[k] < lengths[k - 1] for k in range(1, len(lengths))]).any(0)
    assert 0 < int(restarted.sum()) < 6, "the pushes should topple some robots and not others"
    expected = spread_commands("vy", 6)[restarted.cpu(), 1]
    assert r.fallen_commands == sorted(round(float(v), 4) for v in expected)
    assert len(r.fallen_commands) == round((1 - r.upright) * 6)
    log = io.StringIO()
    _print_table3(log, [dataclasses.asdict(r)], ["vy"], [PUSH])
    assert f"vy at {PUSH:g} m/s: fell at commands " + ", ".join(f"{v:g}" for v in r.fallen_commands) in log.getvalue()


def test_a_loaded_checkpoint_starts_the_same_whatever_torch_drew_before(tmp_path, save_checkpoint):
    """The env observes and selects gaits with the networks it is built with; after a checkpoint is loaded the first
    observation and the gait each robot is reset into must come from the loaded ones, not from torch's global RNG."""
    from wqwarp.eval.loading import make_policy_runner
    from wqwarp.eval.rollout import start_rollout

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


def _settings(env) -> dict:
    """What an evaluation protocol may change on an env and must give back."""
    sel = env.gait_selector
    return {
        "collect": env.collect_training_data,
        "max_episode_length": env.max_episode_length,
        "push_interval_steps": env.push_interval_steps,
        "held": env.held_commands,
        "forced_gait": sel.forced_gait,
        "steps": env.common_step_counter,
        "last_active": None if sel.last_active is None else sel.last_active.tolist(),
        "rng": [env.gen.get_state().tolist(), sel.gen.get_state().tolist()],
        "requested": env.requested_gait().tolist(),
    }


def test_protocols_run_back_to_back_on_one_env_give_what_a_fresh_env_gives(tmp_path, save_checkpoint):
    """A protocol leaves the env as it found it (held commands, push schedule, episode length, forced gait, random
    generators): the second of two protocols on one runner equals the same protocol on a fresh runner."""
    from wqwarp.eval.loading import make_policy_runner
    from wqwarp.eval.timeline import parse_segments, run_timeline
    from wqwarp.eval.tracking import run_task

    cfg = make_preset("ours")
    cfg.sim.num_envs = 2
    path = str(save_checkpoint(tmp_path / "model_0.pt", cfg))
    used = make_policy_runner(path, None, num_envs=3, seed=2)
    before = _settings(used.env)
    first = run_task(used, "vy", seconds=1.0, settle=0.2, max_push=0.5, push_interval=0.4, forced_gait=1)
    assert first.gait_usage["trotting"] > 0.5  # the forced gait ran
    assert _settings(used.env) == before
    run_timeline(used, parse_segments("0.3,0,0:0.3;0,0,0.4:0.3"))
    assert _settings(used.env) == before

    def second(runner):
        return dataclasses.asdict(run_task(runner, "vx", seconds=1.0, settle=0.2, max_push=0.3, push_interval=0.5))

    assert second(used) == second(make_policy_runner(path, None, num_envs=3, seed=2))


@pytest.mark.parametrize("name", ["tracking", "push", "sim2sim", "timeline", "energymap", "lateral"])
def test_each_protocol_records_a_command_line_that_gives_back_its_options(name):
    from wqwarp.cli.evaluate import parse_options
    from wqwarp.eval.protocols import equivalent_command, make_options

    extra = {"segments": "0,0,0:0.5;0.8,0,0:0.5"} if name == "timeline" else {}  # a shell would split at ';'
    opts = make_options(name, checkpoint="runs/x/model_9.pt", seed=3, json="r.json", **extra)
    opts.validate()
    cmd = shlex.split(equivalent_command(name, opts))
    assert cmd[:3] == ["train/evaluate.py", "--protocol", name] and "--seed" in cmd
    assert parse_options(name, cmd[3:], "evaluate.py", "") == opts


def test_protocol_options_are_checked_before_any_work(tmp_path):
    from wqwarp.eval.protocols import make_options, run_protocol

    for name, bad, match in (
        ("tracking", {"tasks": "jump"}, "unknown task"),
        ("push", {"push_levels": "0,0.5"}, "push-levels"),
        ("sim2sim", {"physics": "bullet"}, "--physics"),
        ("timeline", {"segments": "0.5,0:1"}, "bad segment"),
        ("energymap", {"grid": 1}, "--grid"),
        ("lateral", {"commands": "left"}, "--commands"),
        ("tracking", {"json": str(tmp_path / "no" / "r.json")}, "does not exist"),
    ):
        with pytest.raises(ValueError, match=match):
            run_protocol(name, make_options(name, checkpoint=str(tmp_path / "never_read.pt"), **bad))
    with pytest.raises(ValueError, match="unknown protocol"):
        make_options("jump", checkpoint="x")


def test_a_new_protocol_is_one_function_and_one_registry_entry(tmp_path, monkeypatch):
    """Registered once, a protocol is on ``train/evaluate.py --protocol`` with its options, and its result is
    written with the command line that made it."""
    import json
    from dataclasses import dataclass

    from wqwarp.cli import evaluate
    from wqwarp.eval import protocols
    from wqwarp.eval.options import ProtocolOptions, option

    @dataclass(kw_only=True)
    class HopOptions(ProtocolOptions):
        hops: int = option(2, help="hops")

    def hop(opts, log):
        print(f"{opts.hops} hops", file=log)
        return {"hops": opts.hops, "seed": opts.seed}

    monkeypatch.setitem(protocols.PROTOCOLS, "hop", protocols.Protocol("hop", hop, HopOptions, "hops in place"))
    out = tmp_path / "hop.json"
    assert evaluate.main(["--protocol", "hop", "--checkpoint", "m.pt", "--hops", "5", "--json", str(out)]) == 0
    d = json.loads(out.read_text())
    assert d["hops"] == 5 and d["seed"] == 0 and "--hops 5" in d["command"] and d["git"]


def test_physics_variants_are_one_registry_whose_overrides_are_recorded():
    """Result files record each variant's overrides (``"overrides"`` of the sim-to-sim results): derived from the
    registry, the set fields only."""
    from wqwarp.eval.physics import PHYSICS, PHYSICS_VARIANTS, physics_variant
    from wqwarp.robot.constants import AUTHORS_GROUND_FRICTION

    assert (
        list(PHYSICS)
        == list(PHYSICS_VARIANTS)
        == [
            "train",
            "dt0.001",
            "authors",
            "authors_dt0.001",
            "authors_robot",
            "authors_robot_control",
        ]
    )
    assert PHYSICS["train"] == {} and PHYSICS["dt0.001"] == {"dt": 0.001}
    assert PHYSICS["authors_dt0.001"] == {"dt": 0.001, "joint_model": "authors", "friction": AUTHORS_GROUND_FRICTION}
    assert PHYSICS["authors_robot_control"]["sim.wheel_kp"] == 2.0 and PHYSICS["authors_robot"]["robot"] == "given"
    assert all(v.doc for v in PHYSICS_VARIANTS.values())
    with pytest.raises(ValueError, match="unknown physics 'bullet'; choose from train, dt0.001"):
        physics_variant("bullet")


def test_sim_to_sim_on_the_authors_robot_runs_a_policy_on_their_mjcf_under_both_control_laws(tmp_path, save_checkpoint):
    """``--physics authors_robot,authors_robot_control --robot PATH``: the policy closed loop on the paper authors'
    MuJoCo robot (their masses: 14.26 kg), under this project's control law and under theirs (wheels P 2, no
    integral); each physics records its robot and gains; a variant without ``--robot`` is one clear error."""
    from wqwarp.eval.protocols import make_options, run_protocol

    cfg = make_preset("ours")
    cfg.sim.num_envs = 2
    path = str(save_checkpoint(tmp_path / "model_0.pt", cfg))
    mjcf = os.path.join(ROOT, "tests", "data", "authors_wheeled_go1", "wheeled_go1.xml")
    opts = dict(checkpoint=path, tasks="stand", num_envs=2, seconds=2.1, physics="authors_robot,authors_robot_control")
    out = run_protocol("tracking", make_options("tracking", robot=mjcf, **opts), io.StringIO())
    sims = {p: out["sim2sim"][p]["config"]["sim"] for p in ("authors_robot", "authors_robot_control")}
    assert all(s["robot"] == mjcf for s in sims.values()) and out["config"]["sim"]["robot"] == ""
    assert (sims["authors_robot"]["wheel_kp"], sims["authors_robot_control"]["wheel_kp"]) == (0.5, 2.0)
    assert sims["authors_robot_control"]["wheel_ki"] == 0.0
    for p in sims:
        r = out["sim2sim"][p]["results"][0]
        assert r["upright"] == 1.0 and r["mean_p_elec"] > 0
    with pytest.raises(ValueError, match="builds the robot from --robot PATH"):
        run_protocol("tracking", make_options("tracking", **opts), io.StringIO())


def test_protocols_name_the_gaits_of_the_checkpoints_library(tmp_path, save_checkpoint):
    """A checkpoint trained with a fourth gait is evaluated with its own library: ``--force-gait`` takes the new gait
    (an unknown one is a one-line error naming the run's gaits), and the results of tracking, the timeline and the
    energy map (one robot per gait and cell, the figure too) are labelled with the run's gait names."""
    import io

    from wqwarp.control.gaits import TABLE_I, Gait
    from wqwarp.eval.protocols import make_options, run_protocol

    cfg = make_preset("ours")
    cfg.sim.num_envs = 1
    cfg.gait.library = (*TABLE_I, Gait("pacing", (0.0, 0.5, 0.0, 0.5), df_swing=0.4, frequency=1.0))
    path = str(save_checkpoint(tmp_path / "model_0.pt", cfg))
    names = ["driving", "trotting", "walking", "pacing"]
    log = io.StringIO()

    track = run_protocol(
        "tracking",
        make_options("tracking", checkpoint=path, tasks="vx", num_envs=2, seconds=2.1, force_gait="pacing"),
        log,
    )
    r = track["results"][0]
    assert list(r["predicted_power"]) == names and r["gait_usage"]["pacing"] > 0.5
    with pytest.raises(ValueError, match="--force-gait: unknown gait 'bounding'; known gaits: driving, .*, pacing"):
        run_protocol(
            "tracking",
            make_options("tracking", checkpoint=path, tasks="vx", num_envs=1, seconds=2.1, force_gait="bounding"),
            log,
        )

    timeline = run_protocol(
        "timeline", make_options("timeline", checkpoint=path, robots=1, segments="0.3,0,0:0.1"), log
    )
    assert timeline["gait_names"] == names and list(timeline["segments"][0]["gait_usage"]) == names
    assert set(timeline["series_robot0"]["gait_running"]) <= set(names)

    png = tmp_path / "map.png"
    emap = run_protocol("energymap", make_options("energymap", checkpoint=path, grid=2, seconds=0.2, png=str(png)), log)
    cell = emap["cells"][0]
    assert list(cell["measured_p_cost"]) == list(cell["predicted_p_cost"]) == names and png.stat().st_size > 0
    # both measures per gait (holding the trunk up costs the battery copper losses in every gait), each its winner
    assert all(cell["measured_p_elec"][g] > 0.0 for g in names)
    assert cell["measured_winner_elec"] in names and emap["power_measure"] == "mechanical"


def test_the_selection_criterion_can_be_swapped_at_evaluation_on_one_policy(tmp_path):
    """``--criterion`` evaluates one policy under another gait selection rule: a checkpoint trained with the kinematic
    mask whose predictor calls driving the cheapest gait never drives a lateral command under its own rule, and
    drives it under the paper's power rule; the result records the rule it ran. A rule that needs a tracking head is
    a one-line error on a checkpoint without one."""
    from helpers import quiet_runner

    from wqwarp.eval.protocols import make_options, run_protocol

    cfg = make_preset("ours")
    cfg.sim.num_envs = 1
    cfg.predictor.criterion, cfg.predictor.kinematic_yaw_limit = "kinematic", 0.2  # as the omni profile
    runner = quiet_runner(cfg)
    with torch.no_grad():
        for prm in runner.env.gait_selector.predictor.net.parameters():
            prm.zero_()
        runner.env.gait_selector.predictor.net[-1].bias.copy_(torch.tensor([-3.0, 3.0, 1.0]))  # driving cheapest
    path = str(tmp_path / "model_0.pt")
    runner.save(path)
    log = io.StringIO()
    usage = {}
    for criterion in (None, "power"):
        out = run_protocol(
            "tracking",
            make_options("tracking", checkpoint=path, tasks="vy", num_envs=2, seconds=3.0, criterion=criterion),
            log,
        )
        assert out["config"]["predictor"]["criterion"] == (criterion or "kinematic")
        usage[criterion] = out["results"][0]["gait_usage"]["driving"]
    assert usage[None] == 0.0 and usage["power"] > 0.9, usage
    selected, measured = {}, {}
    for criterion in (None, "power"):  # the energy map's per-cell choice follows the same rule
        emap = run_protocol(
            "energymap", make_options("energymap", checkpoint=path, grid=2, seconds=0.4, criterion=criterion), log
        )
        selected[criterion] = {c["selected"] for c in emap["cells"]}  # every cell: |v_y| or |w| = 0.7
        measured[criterion] = [c["measured_p_cost"] for c in emap["cells"]]
    assert selected == {None: {"walking"}, "power": {"driving"}}
    # each robot runs its forced gait from the reset, not the gait the rule chose before: the rule changes no
    # measurement
    assert measured[None] == measured["power"]
    with pytest.raises(
        ValueError,
        match="criterion kinematic_feasible needs a tracking head; model_0.pt was trained with kinematic and has none",
    ):
        run_protocol(
            "tracking",
            make_options(
                "tracking", checkpoint=path, tasks="vy", num_envs=1, seconds=2.1, criterion="kinematic_feasible"
            ),
            log,
        )


def test_the_energy_maps_rule_summary_on_hand_values():
    from wqwarp.eval.energy_map import rule_summary

    def cell(err, pred_err, selected, winner, fell=()):
        return {
            "sq_velocity_error": dict(zip("dtw", err, strict=True)),
            "selected": selected,
            "predicted_sq_velocity_error": dict(zip("dtw", pred_err, strict=True)),
            "measured_winner_tracking": winner,
            "fell": {g: g in fell for g in "dtw"},
        }

    cells = [
        cell((0.01, 0.02, 0.03), (0.20, 0.10, 0.30), "t", "d"),  # trots where driving tracks cheaper
        cell((0.50, 0.04, 0.30), (0.01, 0.05, 0.20), "t", "t"),  # lateral: driving is no candidate
        cell((0.50, 0.40, 0.30), (0.30, 0.20, 0.40), "w", None, fell=("w",)),
    ]  # nothing tracks; w fell
    kinematic = torch.tensor([[True, True, True], [False, True, True], [False, True, True]])
    out = rule_summary(cells, kinematic)
    assert {
        k: out[k] for k in ("selects_cheapest_tracking", "cells_with_a_tracking_gait", "selects_a_tracking_gait")
    } == {"selects_cheapest_tracking": 1, "cells_with_a_tracking_gait": 2, "selects_a_tracking_gait": 2}
    # head argmin vs measured best among the candidates: cell 0 t vs d (no), cell 1 t vs t (yes), cell 2 t vs w (no)
    assert out["tracking_head"]["argmin_is_best_tracker"] == 1
    assert out["tracking_head"]["robot_cells_tracking"] == 4  # d, t, w of cell 0 and t of cell 1
    assert out["tracking_head"]["median_predicted_where_tracking"] == pytest.approx((0.10 + 0.20) / 2)
    # without the kinematic mask the head's d (0.01) wins cell 1, where t tracks best
    assert rule_summary(cells, None)["tracking_head"]["argmin_is_best_tracker"] == 0
    no_head = [{k: v for k, v in c.items() if k != "predicted_sq_velocity_error"} for c in cells]
    assert "tracking_head" not in rule_summary(no_head, kinematic)


def test_the_lateral_probe_reports_per_command_and_per_gait(tmp_path, save_checkpoint):
    """Rows per held v_y command with the achieved v_y, w_z, the commanded foot-y stroke, the posture and the
    phase-residual spread; --per-gait on a predictive checkpoint runs every gait forced, and each forced run ran only
    that gait."""
    from wqwarp.eval.protocols import make_options, run_protocol

    cfg = make_preset("ours")
    cfg.sim.num_envs = 1
    torch.manual_seed(0)
    save_checkpoint(tmp_path / "model_0.pt", cfg)
    opts = make_options(
        "lateral",
        checkpoint=str(tmp_path / "model_0.pt"),
        commands="-0.3,0.3",
        robots_per_command=2,
        seconds=2.5,
        per_gait=True,
        json=str(tmp_path / "lat.json"),
    )
    r = run_protocol("lateral", opts, log=io.StringIO())
    assert set(r["runs"]) == {"selected", "driving", "trotting", "walking"}
    for gait in ("driving", "trotting", "walking"):
        rows = r["runs"][gait]
        assert [x["command_vy"] for x in rows] == [-0.3, 0.3]
        assert all(x["gait_usage"][gait] == pytest.approx(1.0) for x in rows)
        assert all(x["foot_y_stroke_m"] >= 0 and "std" in x["phase_residual"] for x in rows)
        for x in rows:  # the posture: time-mean foot residual per leg and axis, after the clip
            posture = np.asarray(x["foot_residual_mean_m"])
            assert posture.shape == (4, 3) and np.abs(posture).max() <= cfg.action.foot_clip + 1e-6
            assert x["foot_residual_abs_mean_m"] == pytest.approx(np.abs(posture).mean(), rel=1e-5)
    assert not r["all_tracked"]  # an untrained policy does not step sideways
    assert (tmp_path / "lat.json").is_file()


def test_the_nominal_stepping_gaits_move_sideways_with_the_lateral_feed_forward(tmp_path, save_checkpoint):
    """tools/studies/lateral_probe.py --reach: every action 0, each stepping gait forced; the feed-forward alone
    moves the trunk toward a held lateral command (Table I's trot and walk, and each at 1.5x its frequency)."""
    import importlib

    from wqwarp.rl.tasks import TASKS

    probe_reach = importlib.import_module("tools.studies.lateral_probe").probe_reach
    cfg = TASKS["ours"].make()[0]  # the recipe: lateral feed-forward on
    assert cfg.gait.lateral_gain > 0
    cfg.sim.num_envs = 1
    save_checkpoint(tmp_path / "model_0.pt", cfg)
    out = probe_reach(str(tmp_path / "model_0.pt"), [0.12], robots=1, seconds=3.5, frequency_scales=[1.0, 1.5])
    rows = {(r["gait"], round(r["frequency_hz"], 3)): r for r in out["reach"]}
    assert set(rows) == {("trotting", 1.2), ("trotting", 1.8), ("walking", 0.8), ("walking", 1.2)}
    assert rows["trotting", 1.2]["nominal_reach_mps"] == pytest.approx(0.48)
    for gait in ("trotting", "walking"):
        slow = rows[gait, 1.2 if gait == "trotting" else 0.8]["commands"]
        assert slow[1]["command_vy"] == 0.2 and slow[1]["upright"] == 1.0
        assert 0.05 < slow[1]["vy"] < 0.4  # toward the command, not past twice it


def test_the_noise_escape_probe_finds_no_escape_in_an_untrained_policy(tmp_path, save_checkpoint):
    """tools/studies/noise_escape_probe.py: around a near-zero mean residual, the sampled noise reaches the leg
    targets as it would around the nominal foot (ratio ~1), and no foot sample sits at the clip."""
    import importlib

    probe = importlib.import_module("tools.studies.noise_escape_probe").probe
    cfg = make_preset("ours")
    cfg.sim.num_envs = 1
    torch.manual_seed(0)
    save_checkpoint(tmp_path / "model_0.pt", cfg)
    out = probe(str(tmp_path / "model_0.pt"), seconds=0.4, samples=6, seed=0)
    assert set(out["commands"]) == {"stand", "vx0.5", "vy0.3", "wz0.5"}
    for r in out["commands"].values():
        assert r["joint_target_noise_without_posture_rad"] > 0.01  # std 0.5 x 0.2 m of foot noise moves the joints
        assert 0.7 < r["ratio"] < 1.4 and r["foot_at_clip"] < 0.02
        assert r["joint_beyond_soft_limit"] == 0.0 and r["joint_limits_term_rad"] == 0.0  # the nominal gait's joints


def test_the_nominal_gait_with_zero_residual_tracks_forward_commands_on_little_power(tmp_path, save_checkpoint):
    """``--zero-residual`` runs the nominal gait alone (every action 0), the floor of the energy targets: with the
    driving gait forced, robots commanded -1, 0 and 1 m/s drive at the commanded speed (MSE 0.0009 measured) and
    standing costs a fraction of a watt (0.2 W measured; the open-loop audit 0.07 W, an untrained policy's small
    residual 1.3 W); a preset without a nominal gait is refused."""
    from wqwarp.eval.protocols import make_options, run_protocol

    cfg = make_preset("ours")
    cfg.sim.num_envs = 1
    path = str(save_checkpoint(tmp_path / "model_0.pt", cfg))
    log = io.StringIO()
    opts = make_options(
        "tracking", checkpoint=path, tasks="stand,vx", num_envs=3, seconds=4.0, force_gait="driving", zero_residual=True
    )
    out = run_protocol("tracking", opts, log)
    assert out["zero_residual"] and out["forced_gait"] == "driving" and "zero residual" in log.getvalue()
    by = {r["task"]: r for r in out["results"]}
    for r in by.values():
        assert r["gait_usage"]["driving"] == pytest.approx(1.0) and r["upright"] == 1.0
    assert by["vx"]["mse"] < 0.005, by["vx"]
    assert by["stand"]["mean_p_cost"] < 1.0 and by["stand"]["mse"] < 1e-3, by["stand"]
    assert by["vx"]["mean_p_cost_wheels"] > by["stand"]["mean_p_cost_wheels"]

    base = make_preset("baseline")
    base.sim.num_envs = 1
    (tmp_path / "base").mkdir()
    path = str(save_checkpoint(tmp_path / "base" / "model_0.pt", base))
    with pytest.raises(ValueError, match="--zero-residual needs a preset with a nominal gait"):
        run_protocol(
            "tracking",
            make_options("tracking", checkpoint=path, tasks="vx", num_envs=1, seconds=2.1, zero_residual=True),
            log,
        )


def test_a_protocol_prints_to_the_stdout_of_its_call_not_of_its_import(monkeypatch):
    """``run_protocol`` without a log writes to ``sys.stdout`` as it is when called (a default bound at import
    wrote to whatever stream was current then, e.g. a test's closed capture)."""
    from dataclasses import dataclass

    from wqwarp.eval import protocols
    from wqwarp.eval.options import ProtocolOptions

    @dataclass(kw_only=True)
    class Opts(ProtocolOptions):
        pass

    def hello(opts, log):
        print("hello from the protocol", file=log)
        return {}

    monkeypatch.setitem(protocols.PROTOCOLS, "hello", protocols.Protocol("hello", hello, Opts, "says hello"))
    buf = io.StringIO()
    monkeypatch.setattr("sys.stdout", buf)
    protocols.run_protocol("hello", Opts(checkpoint="m.pt"))
    assert "hello from the protocol" in buf.getvalue()


def test_the_wheel_probe_samples_the_training_noise_around_the_mean_with_and_without_its_wheel_offsets(
    tmp_path, save_checkpoint
):
    """tools/studies/wheel_residual_probe.py --noise --held-wheels: the deterministic pair as before (zeroed: wheel
    actions exactly 0), the held-wheel pair (constant wheel actions, the policy's mean), and a sampled pair that
    draws the policy's learned std (an untrained policy: the initial std on every action) around the mean with and
    without its wheel part; the noise costs wheel power (33 W against 24 W measured)."""
    import importlib

    probe = importlib.import_module("tools.studies.wheel_residual_probe")
    cfg = make_preset("ours")
    cfg.sim.num_envs = 1
    torch.manual_seed(0)
    path = str(save_checkpoint(tmp_path / "model_0.pt", cfg))
    out_json = tmp_path / "probe.json"
    assert (
        probe.main(
            [
                "--checkpoint",
                path,
                "--robots",
                "2",
                "--seconds",
                "2.6",
                "--noise",
                "--held-wheels",
                "--json",
                str(out_json),
            ]
        )
        == 0
    )
    res = json.loads(out_json.read_text())["results"]
    assert set(res) == {
        "policy",
        "zero_wheel_residuals",
        "zero_leg_residuals",
        "nominal",
        "policy_sampled",
        "zero_wheel_mean_sampled",
        "policy_held_wheels",
        "nominal_held_wheels",
    }
    held = res["policy"]["wheel_action"]  # --held-wheels: every robot and step on the policy's mean wheel action
    for name in ("policy_held_wheels", "nominal_held_wheels"):
        assert res[name]["wheel_action"] == pytest.approx(held, abs=1e-4)
        assert res[name]["wheel_action_rms_about_mean"] == [0.0] * 4
    assert res["nominal"]["wheel_action"] == [0.0] * 4 and res["zero_leg_residuals"]["wheel_action"] != [0.0] * 4
    assert res["zero_wheel_residuals"]["wheel_action"] == [0.0, 0.0, 0.0, 0.0]
    std = res["policy_sampled"]["action_std"]
    assert len(std) == 20 and std == res["zero_wheel_mean_sampled"]["action_std"]
    assert all(s == pytest.approx(std[0]) for s in std) and std[0] > 0.1  # untrained: one initial std
    assert "action_std" not in res["policy"]
    assert res["policy_sampled"]["p_cost_wheels"] > 1.2 * res["policy"]["p_cost_wheels"]


def test_a_wheel_speed_mismatch_costs_power_that_an_agreeing_offset_does_not(tmp_path, save_checkpoint):
    """tools/studies/wheel_mismatch.py: the forced driving gait with every residual 0 and P-only wheels
    (``--wheel-ki 0``, no integral transient); all four wheels 0.5 rad/s faster (they agree) only speeds the robot
    up, front +0.5 / rear -0.5 rad/s makes them push against each other through the ground at the same speed
    (measured, 8 robots x 6 s: 0.2 W against 9.8 W); the checkpoint's gains otherwise (recorded); bad input is one
    line, exit 2."""
    import importlib

    mismatch = importlib.import_module("tools.studies.wheel_mismatch")
    cfg = make_preset("ours")
    cfg.sim.num_envs = 1
    path = str(save_checkpoint(tmp_path / "model_0.pt", cfg))
    out_json = tmp_path / "mismatch.json"
    assert (
        mismatch.main(
            [
                "--checkpoint",
                path,
                "--robots",
                "2",
                "--seconds",
                "3",
                "--offsets",
                "0.5",
                "--patterns",
                "common,fore_aft",
                "--wheel-ki",
                "0",
                "--json",
                str(out_json),
            ]
        )
        == 0
    )
    out = json.loads(out_json.read_text())
    assert out["wheel_pid"]["wheel_ki"] == 0.0
    rows = {r["pattern"]: r for r in out["rollouts"]}
    assert list(rows) == ["nominal", "common", "fore_aft"]
    assert rows["fore_aft"]["wheel_offsets_rad_s"] == [0.5, 0.5, -0.5, -0.5]
    assert all(r["gait_usage"]["driving"] == 1.0 and r["fell"] == 0 for r in rows.values())
    assert rows["common"]["vx"] > rows["nominal"]["vx"] + 0.01  # agreeing wheels roll the robot faster
    assert abs(rows["fore_aft"]["vx"] - rows["nominal"]["vx"]) < 0.02  # disagreeing ones do not
    assert rows["fore_aft"]["p_cost_wheels"] > max(5.0, 8.0 * rows["common"]["p_cost_wheels"])
    torque = rows["fore_aft"]["wheel_torque"]
    assert torque[0] > 0 and torque[1] > 0 and torque[2] < 0 and torque[3] < 0  # the front pushes, the rear brakes
    assert (
        mismatch.main(
            [
                "--checkpoint",
                path,
                "--robots",
                "1",
                "--seconds",
                "2.2",
                "--offsets",
                "0.5",
                "--patterns",
                "one",
                "--json",
                str(out_json),
            ]
        )
        == 0
    )
    assert json.loads(out_json.read_text())["wheel_pid"]["wheel_ki"] == cfg.sim.wheel_ki
    for bad in (["--offsets", "0,0.5"], ["--offsets", "x"], ["--patterns", "sideways"], ["--wheel-ki", "-1"]):
        assert mismatch.main(["--checkpoint", path, *bad]) == 2
