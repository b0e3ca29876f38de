"""The config tree: typed choices checked when set, numeric sanity at construction, no physics imported; every field
settable from the command line with its docstring as help; the preset registry."""

from __future__ import annotations

import argparse
import dataclasses
import subprocess
import sys

import pytest

from wqwarp.cli.args import ArgumentParser
from wqwarp.cli.config_args import (
    add_config_arguments,
    apply_overrides,
    config_options,
    config_overrides,
    field_docs,
    normalize_options,
)
from wqwarp.cli.train_args import ALIASES, build_parser, default_roots, parse_train_args, resolve_config, run_record
from wqwarp.rl.config import EnvConfig, GaitConfig, PredictorConfig, TrainConfig, env_config_from_dict, to_dict
from wqwarp.rl.presets import PAPER_NAMES, PRESET_ORDER, PRESETS, infer_preset, make_preset, preset_differences
from wqwarp.sim.config import BACKENDS, SimConfig

PHYSICS = {"newton", "mujoco", "warp", "torch"}


@pytest.mark.parametrize("module", ["wqwarp.rl.config", "wqwarp.sim.config", "wqwarp.rl.presets",
                                    "wqwarp.rl.profiles", "wqwarp.cli.train_args"])  # fmt: skip
def test_reading_a_config_imports_no_physics_engine_and_no_torch(module):
    code = (f"import {module}, sys; from wqwarp.rl.presets import make_preset; make_preset('ours').sim; "
            f"print(sorted({PHYSICS!r} & {{m.split('.')[0] for m in sys.modules}}))")  # fmt: skip
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]", out


@pytest.mark.parametrize(("build", "field", "bad"), [
    (lambda v: GaitConfig(selection=v), "GaitConfig.selection", "greedy"),
    (lambda v: PredictorConfig(power_normalization=v), "PredictorConfig.power_normalization", "kilowatts"),
    (lambda v: PredictorConfig(temperature_shape=v), "PredictorConfig.temperature_shape", "step"),
    (lambda v: PredictorConfig(evaluation_selection=v), "PredictorConfig.evaluation_selection", "max"),
    (lambda v: SimConfig(backend=v), "SimConfig.backend", "physx"),
    (lambda v: SimConfig(joint_model=v), "SimConfig.joint_model", "urdf"),
])  # fmt: skip
def test_a_bad_choice_is_one_error_naming_field_value_and_choices(build, field, bad):
    with pytest.raises(ValueError, match=rf"^{field} '{bad}' is not one of \w+"):
        build(bad)


def test_a_choice_is_also_checked_when_assigned_later():
    cfg = make_preset("ours")
    with pytest.raises(ValueError, match="ActionConfig.phase_residual_mode 'sideways' is not one of offset, increment"):
        cfg.action.phase_residual_mode = "sideways"
    assert cfg.action.phase_residual_mode == "offset"
    cfg.sim.backend = "featherstone"  # a valid choice is simply set
    assert cfg.sim.backend == "featherstone" and set(BACKENDS) >= {"auto", "featherstone"}


@pytest.mark.parametrize(("build", "match"), [
    (lambda: SimConfig(num_envs=0), "SimConfig.num_envs must be >= 1"),
    (lambda: SimConfig(dt=0.0), "SimConfig.dt must be > 0"),
    (lambda: SimConfig(device="tpu"), "SimConfig.device must be cpu or cuda:N"),
    (lambda: PredictorConfig(temperature_start=0.0), "PredictorConfig.temperature_start must be > 0"),
    (lambda: PredictorConfig(decision_interval_s=-1.0), "PredictorConfig.decision_interval_s must be > 0"),
    (lambda: PredictorConfig(holdout_fraction=1.0), r"PredictorConfig.holdout_fraction must be in \[0, 1\)"),
    (lambda: TrainConfig(max_iterations=0), "TrainConfig.max_iterations must be > 0"),
])  # fmt: skip
def test_numeric_sanity_at_construction(build, match):
    with pytest.raises(ValueError, match=match):
        build()


def test_validate_checks_the_whole_tree_after_assignments():
    cfg = make_preset("ours")
    cfg.commands.vx_range = (1.0, -1.0)
    with pytest.raises(ValueError, match=r"CommandConfig.vx_range must be \(lo, hi\) with lo <= hi"):
        cfg.validate()
    cfg = make_preset("baseline")
    cfg.action.use_nominal_legs = True
    with pytest.raises(ValueError, match="use_nominal_legs needs a nominal gait"):
        cfg.validate()


def test_field_docs_come_from_the_docstring_under_each_field():
    assert field_docs(SimConfig)["dt"].startswith("Physics substep [s]")
    assert "gait clock" in field_docs(type(make_preset("ours").action))["phase_residual_mode"]
    assert field_docs(TrainConfig)["max_iterations"] == "PPO iterations (paper: 4000 epochs)."
    assert field_docs(type(make_preset("ours").reward))["energy"]  # a generated dataclass: field.metadata["doc"]


def _parse(*argv: str) -> argparse.Namespace:
    return build_parser("Title.\n\nEpilog.").parse_args(normalize_options(list(argv)))


def test_every_type_of_field_parses_from_the_command_line():
    roots = {"env": EnvConfig(), "train": TrainConfig()}
    p = ArgumentParser(prog="x")
    add_config_arguments(p, roots)
    args = p.parse_args(normalize_options([
        "--env.reward.energy", "-2e-5", "--env.sim.num_envs", "3", "--env.obs.no-noise", "--env.commands.vx-range",
        "-1", "1.5", "--env.predictor.hidden-dims", "32", "16", "8", "--env.sim.nthread", "none",
        "--env.domain_rand.enabled", "false", "--env.gait.selection", "predictive", "--train.max-iterations=7",
        "--env.sim.cuda-graph"]))  # fmt: skip
    over = config_overrides(args)
    apply_overrides(roots, over)
    env, train = roots["env"], roots["train"]
    assert env.reward.energy == -2e-5 and env.sim.num_envs == 3 and env.obs.noise is False
    assert env.commands.vx_range == (-1.0, 1.5) and env.predictor.hidden_dims == (32, 16, 8)
    assert env.sim.nthread is None and env.domain_rand.enabled is False and env.gait.selection == "predictive"
    assert train.max_iterations == 7 and env.sim.cuda_graph is True
    assert list(over)[0] == "env.reward.energy"  # command-line order
    env.validate()


def test_the_preset_comes_first_then_the_aliases_and_long_options_in_order():
    args = _parse("--preset", "baseline", "--num-envs", "8", "--env.sim.num-envs", "6", "--dt", "0.002",
                  "--decimation", "10", "--reward", "energy=-1e-4", "--temperature", "3", "0.1", "--true-state",
                  "--max-iterations", "5")  # fmt: skip
    env, train = resolve_config(args)
    assert env.gait.selection == "none" and env.reward.residual == 0.0  # the baseline preset
    assert env.sim.num_envs == 6 and (env.sim.dt, env.sim.decimation) == (0.002, 10)  # the later option wins
    assert env.reward.energy == -1e-4 and env.estimator.use_true_state is True
    assert (env.predictor.temperature_start, env.predictor.temperature_end) == (3.0, 0.1)
    assert train.max_iterations == 5 and args.num_envs == 6 and args.max_iterations == 5
    env, _ = resolve_config(_parse())
    assert env.sim.num_envs == 128 and env.gait.selection == "predictive"  # the training command's defaults


def test_the_run_record_holds_the_command_line_its_options_and_the_resolved_flags():
    args = parse_train_args("Title.\n\nEpilog.", ["--num-envs", "4", "--env.reward.energy", "-2e-5", "--seed", "3"])
    resolve_config(args)
    rec = run_record(args)
    assert rec["command"] == "train/ppo_newton.py --num-envs 4 --env.reward.energy -2e-5 --seed 3"
    assert rec["overrides"] == {"env.sim.num_envs": 4, "env.reward.energy": -2e-5, "env.seed": 3}
    assert rec["args"]["num_envs"] == 4 and rec["args"]["preset"] == "ours" and rec["args"]["save_interval"] == 50
    assert not any(k.startswith("@") for k in rec["args"])


def test_every_alias_targets_a_config_field():
    roots = default_roots()
    paths = {o.path for name, cfg in roots.items() for _, _, leaves in config_options(name, cfg) for o in leaves}
    assert {a.path for a in ALIASES} <= paths


@pytest.mark.parametrize(("argv", "message"), [
    (["--env.gait.selection", "greedy"], "invalid choice: 'greedy'"),
    (["--env.sim.dt", "fast"], "invalid float value: 'fast'"),
    (["--reward", "speed=1"], "unknown term 'speed'"),
    (["--reward", "energy=lots"], "the weight must be a number"),
    (["--env.obs.noise", "maybe"], "expected true or false"),
])  # fmt: skip
def test_a_bad_value_exits_2_with_one_line(argv, message, capsys):
    with pytest.raises(SystemExit) as e:
        _parse(*argv)
    err = capsys.readouterr().err
    assert e.value.code == 2 and err.count("\n") == 1 and message in err, err


def test_help_lists_every_option_with_its_help():
    text = build_parser("Title.\n\nEpilog.").format_help()
    for name, cfg in default_roots().items():
        for _, _, leaves in config_options(name, cfg):
            for leaf in leaves:
                assert "--" + leaf.path.replace("_", "-") in text, leaf.path
    assert "Physics substep [s]" in text and "--env.sim.*" in text and "--num-envs" in text


def test_registry_names_each_preset_once():
    assert PRESET_ORDER[0] == "ours" and set(PRESET_ORDER) == set(PRESETS) == set(PAPER_NAMES)
    assert [p for p in PRESETS.values() if p.predictive] == [PRESETS["ours"], PRESETS["no_wheel_vel"]]
    assert [p.name for p in PRESETS.values() if p.selection_studies] == ["ours"]
    for name in PRESETS:
        cfg = make_preset(name)
        assert infer_preset(cfg) == name and not preset_differences(name, cfg)
        assert make_preset(name) is not cfg and PRESETS[name].selector == cfg.gait.selection
    assert preset_differences("ours", make_preset("pmtg")) == [
        "gait.selection 'fixed' (preset ours: 'predictive')",
        "action.use_nominal_wheels False (preset ours: True)"]  # fmt: skip


def test_a_new_preset_is_one_factory_and_one_registry_entry(monkeypatch):
    from wqwarp.rl import presets

    def walking_only() -> EnvConfig:
        cfg = EnvConfig()
        cfg.gait = GaitConfig(selection="fixed", fixed_gait="walking")
        return cfg

    entry = presets.Preset("walking_only", walking_only, "Walking", "fixed walking gait")
    monkeypatch.setitem(presets.PRESETS, entry.name, entry)
    env, _ = resolve_config(_parse("--preset", "walking_only"))
    assert env.gait.fixed_gait == "walking" and infer_preset(env) == "walking_only"


def test_old_checkpoint_configs_still_read():
    data = to_dict(make_preset("ours"))
    del data["action"]["phase_residual_mode"]
    notes: list[str] = []
    cfg = env_config_from_dict(data, notes)
    assert cfg.action.phase_residual_mode == "increment" and "issue" not in " ".join(notes)
    assert dataclasses.asdict(env_config_from_dict(to_dict(make_preset("pmtg")))) == to_dict(make_preset("pmtg"))


def test_gaits_tuned_on_the_differentiable_path_reach_the_resolved_config(tmp_path):
    """``--env.gait.tuned PATH`` (repeatable) puts the tuned frequency, DF_swing and stance x in place of the gait
    they were tuned from; the resolved config (what ``config.json`` and the checkpoints hold) carries them. A missing,
    malformed or foreign file is one line naming the option, exit 2."""
    import json
    import os

    from wqwarp.control.gaits import load_tuned_gait

    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    trot, walk = (os.path.join(root, "docs", "studies", "diffsim", f"optimize_{g}_0.3.json")
                  for g in ("trotting", "walking"))  # fmt: skip
    args = parse_train_args("Title.\n\nEpilog.", ["--env.gait.tuned", trot, "--num-envs", "4", "--env.gait.tuned",
                                                   walk])  # fmt: skip
    env, _ = resolve_config(args)
    tuned = [load_tuned_gait(trot), load_tuned_gait(walk)]
    assert env.gait.library[1:] == tuple(tuned) and tuned[0].frequency != 1.2 and tuned[1].frequency != 0.8
    library = to_dict(env)["gait"]["library"]
    assert [g["name"] for g in library] == ["driving", "trotting", "walking"]
    assert library[1]["df_swing"] == tuned[0].df_swing and env_config_from_dict(to_dict(env)).gait == env.gait
    assert run_record(args)["args"]["tuned_gaits"] == [trot, walk]

    (tmp_path / "bad.json").write_text("{not json")
    (tmp_path / "other.json").write_text(json.dumps({"loss": 1.0}))
    for path, match in ((tmp_path / "missing.json", "No such file"), (tmp_path / "bad.json", "not JSON"),
                        (tmp_path / "other.json", "not a tuned gait")):  # fmt: skip
        with pytest.raises(ValueError, match=rf"^--env.gait.tuned '{path}': .*{match}") as e:
            resolve_config(_parse("--env.gait.tuned", str(path)))
        assert "\n" not in str(e.value)
    r = subprocess.run([sys.executable, os.path.join(root, "train", "ppo_newton.py"), "--env.gait.tuned",
                        str(tmp_path / "missing.json"), "--log-dir", str(tmp_path / "run")], capture_output=True,
                       text=True, cwd=root, timeout=120)  # fmt: skip
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and "--env.gait.tuned" in r.stderr, r.stderr
    assert not (tmp_path / "run").exists()


@pytest.mark.parametrize(("name", "match"), [
    ("WqPPO", "must be 'module:Class'"),
    ("wqwarp.rl.algorithm:Nope", "does not import"),
    ("rsl_rl.algorithms:PPO", "must name WqPPO or a subclass"),
])  # fmt: skip
def test_the_algorithm_class_must_name_an_importable_wqppo(name, match):
    with pytest.raises(ValueError, match=rf"^TrainConfig.algorithm_class .*{match}"):
        resolve_config(_parse("--train.algorithm-class", name))
    _, train = resolve_config(_parse("--train.algorithm-class", "wqwarp.rl.algorithm:KeptMeanActorsPPO"))
    assert train.rsl_rl_dict()["algorithm"]["class_name"] == "wqwarp.rl.algorithm:KeptMeanActorsPPO"


def test_the_default_profile_sets_the_levers_each_method_can_use_and_paper_sets_none():
    from wqwarp.rl.profiles import DEFAULT_PROFILE, OMNI_LEVERS, PROFILES

    assert DEFAULT_PROFILE == "omni" and PROFILES["paper"].levers == ()
    env, train = resolve_config(_parse())  # the default main job: ours with the omni levers, 15 M samples
    assert env.gait.selection == "predictive" and env.gait.lateral_gain == 0.35
    assert (env.predictor.criterion, env.predictor.label_source) == ("kinematic", "mean")
    assert env.predictor.label_fraction == 0.03125 and env.predictor.kinematic_yaw_limit == 0.2
    assert train.init_noise_std_groups == (0.5, 0.25, 0.5)
    assert env.sim.num_envs * train.num_steps_per_env * train.max_iterations == pytest.approx(15.0e6, rel=1e-3)
    for name in PRESETS:  # --profile paper: the preset itself, with the command's own budget
        env, train = resolve_config(_parse("--preset", name, "--profile", "paper"))
        ref = make_preset(name)
        ref.sim.num_envs = 128
        assert to_dict(env) == to_dict(ref) and train.init_noise_std_groups == ()
    no_pred, np_train = resolve_config(_parse("--preset", "no_predictor"))  # a fixed gait: no predictor levers
    assert no_pred.gait.lateral_gain == 0.35 and no_pred.predictor == PredictorConfig()
    assert np_train.init_noise_std_groups == (0.5, 0.25, 0.5)
    base, base_train = resolve_config(_parse("--preset", "baseline"))  # no nominal gait: no lever applies
    ref = make_preset("baseline")
    ref.sim.num_envs = 128
    assert to_dict(base) == to_dict(ref) and base_train.init_noise_std_groups == ()
    env, _ = resolve_config(_parse("--env.gait.lateral-gain", "0.2"))  # an option still wins over the profile
    assert env.gait.lateral_gain == 0.2
    fields = {o.path for name, cfg in default_roots().items() for _, _, leaves in config_options(name, cfg)
              for o in leaves}  # fmt: skip
    assert {lever.path for lever in OMNI_LEVERS} <= fields  # every lever is a command-line option too


def test_the_energy_profile_adds_the_issue_22_levers_to_every_method():
    from wqwarp.rl.profiles import ENERGY_LEVERS, OMNI_LEVERS, PROFILES

    assert PROFILES["energy"].levers == OMNI_LEVERS + ENERGY_LEVERS
    for name in PRESETS:  # the same energy recipe for every method, on top of what omni gives it
        env, train = resolve_config(_parse("--preset", name, "--profile", "energy"))
        omni_env, omni_train = resolve_config(_parse("--preset", name))
        assert (env.reward.p_cost, env.sim.wheel_ki) == (-0.01, 0.0)
        assert (env.reward.ramp_terms, env.reward.ramp_start, env.reward.ramp_iterations) == (("p_cost",), 2000, 1000)
        assert env.reward.ramp_scale(1999) == 0.0 and env.reward.ramp_scale(2500) == 0.5
        assert env.reward.ramp_scale(3000) == env.reward.ramp_scale(4882) == 1.0
        env.reward.p_cost, env.sim.wheel_ki = omni_env.reward.p_cost, omni_env.sim.wheel_ki
        env.reward.ramp_terms, env.reward.ramp_start, env.reward.ramp_iterations = (), 0, 0
        assert to_dict(env) == to_dict(omni_env) and train == omni_train  # nothing else differs
    env, _ = resolve_config(_parse("--profile", "energy", "--reward", "p_cost=-0.02", "--env.sim.wheel-ki", "2"))
    assert (env.reward.p_cost, env.sim.wheel_ki) == (-0.02, 2.0)  # an option still wins over the profile
    fields = {o.path for name, cfg in default_roots().items() for _, _, leaves in config_options(name, cfg)
              for o in leaves}  # fmt: skip
    assert {lever.path for lever in ENERGY_LEVERS} <= fields


def test_the_wheels_profile_is_omni_with_p_only_wheels_and_no_energy_term():
    from wqwarp.rl.profiles import OMNI_LEVERS, P_ONLY_WHEELS, PROFILES

    assert PROFILES["wheels"].levers == (*OMNI_LEVERS, P_ONLY_WHEELS) and P_ONLY_WHEELS in PROFILES["energy"].levers
    for name in PRESETS:
        env, train = resolve_config(_parse("--preset", name, "--profile", "wheels"))
        same, same_train = resolve_config(_parse("--preset", name, "--env.sim.wheel-ki", "0"))  # the A/B's command
        assert env.sim.wheel_ki == 0.0 and env.reward.p_cost == 0.0 and env.reward.ramp_terms == ()
        assert to_dict(env) == to_dict(same) and train == same_train


def test_the_select_profile_is_wheels_with_the_feasible_rule_and_cut_labels():
    from wqwarp.rl.profiles import PROFILES

    for name in PRESETS:
        env, train = resolve_config(_parse("--preset", name, "--profile", "select"))
        wheels, wheels_train = resolve_config(_parse("--preset", name, "--profile", "wheels"))
        if wheels.gait.selection != "predictive":  # a method without the predictor trains as under wheels
            assert to_dict(env) == to_dict(wheels) and train == wheels_train, name
            continue
        ab = ("--profile", "wheels", "--env.predictor.criterion", "kinematic_feasible",
              "--env.predictor.label-command-cut")
        same, same_train = resolve_config(_parse("--preset", name, *ab))  # the A/B's command
        assert to_dict(env) == to_dict(same) and train == same_train, name
        assert env.predictor.criterion == "kinematic_feasible" and env.predictor.label_command_cut, name
    assert "select" in PROFILES


def test_an_unknown_profile_exits_2_with_one_line(capsys):
    with pytest.raises(SystemExit) as e:
        _parse("--profile", "fast")
    err = capsys.readouterr().err
    assert e.value.code == 2 and err.count("\n") == 1 and "invalid choice: 'fast'" in err, err
