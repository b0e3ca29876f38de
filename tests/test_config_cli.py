"""The config tree: typed choices checked when set, numeric sanity at construction, no physics imported; every field
settable from the command line (tyro) with its docstring as help; the preset and task registries."""

from __future__ import annotations

import dataclasses
import json
import os
import subprocess
import sys

import pytest

from wqwarp.cli.args import UsageError
from wqwarp.cli.train_args import ALIASES, parse_train_args, resolved_config
from wqwarp.rl.config import EnvConfig, GaitConfig, PredictorConfig, TrainConfig, env_config_from_dict, to_dict
from wqwarp.rl.presets import PAPER_NAMES, PRESET_ORDER, PRESETS, infer_preset, make_preset, preset_differences
from wqwarp.rl.tasks import BATTERY_LEVERS, DEFAULT_TASK, RECIPE_LEVERS, TASKS, get_path, infer_task
from wqwarp.sim.config import BACKENDS, SimConfig

PHYSICS = {"newton", "mujoco", "warp", "torch"}


@pytest.mark.parametrize(
    "module", ["wqwarp.rl.config", "wqwarp.sim.config", "wqwarp.rl.presets", "wqwarp.rl.tasks", "wqwarp.cli.train_args"]
)
def test_reading_a_config_imports_no_physics_engine_and_no_torch(module):
    code = (
        f"import {module}, sys; from wqwarp.rl.presets import make_preset; make_preset('ours').sim; "
        f"print(sorted({PHYSICS!r} & {{m.split('.')[0] for m in sys.modules}}))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]", out


@pytest.mark.parametrize(
    ("build", "field", "bad"),
    [
        (lambda v: GaitConfig(selection=v), "GaitConfig.selection", "greedy"),
        (lambda v: PredictorConfig(power_normalization=v), "PredictorConfig.power_normalization", "kilowatts"),
        (lambda v: PredictorConfig(temperature_shape=v), "PredictorConfig.temperature_shape", "step"),
        (lambda v: PredictorConfig(evaluation_selection=v), "PredictorConfig.evaluation_selection", "max"),
        (lambda v: SimConfig(backend=v), "SimConfig.backend", "physx"),
        (lambda v: SimConfig(joint_model=v), "SimConfig.joint_model", "urdf"),
    ],
)
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


@pytest.mark.parametrize(
    ("build", "match"),
    [
        (lambda: SimConfig(num_envs=0), "SimConfig.num_envs must be >= 1"),
        (lambda: SimConfig(dt=0.0), "SimConfig.dt must be > 0"),
        (lambda: SimConfig(device="tpu"), "SimConfig.device must be cpu or cuda:N"),
        (lambda: PredictorConfig(temperature_start=0.0), "PredictorConfig.temperature_start must be > 0"),
        (lambda: PredictorConfig(decision_interval_s=-1.0), "PredictorConfig.decision_interval_s must be > 0"),
        (lambda: PredictorConfig(holdout_fraction=1.0), r"PredictorConfig.holdout_fraction must be in \[0, 1\)"),
        (lambda: TrainConfig(max_iterations=0), "TrainConfig.max_iterations must be > 0"),
    ],
)
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


ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DOC = "Title.\n\nEpilog."


def _parse(*argv: str):
    return parse_train_args(DOC, list(argv))


def _help(*argv: str, capsys) -> str:
    with pytest.raises(SystemExit) as e:
        _parse(*argv, "--help")
    assert e.value.code in (0, None)
    return capsys.readouterr().out


def _default_of(text: str, option: str) -> str:
    """The ``(default: X)`` tyro's help shows for ``option`` (its box and line wraps removed)."""
    flat = " ".join(line.strip(" │|") for line in text.splitlines())
    section = flat.split(f" {option} ", 1)[1].split(" --", 1)[0]
    return section.split("(default: ", 1)[1].split(")", 1)[0]


def test_every_type_of_field_parses_from_the_command_line():
    args = _parse(
        "--env.reward.energy",
        "-2e-5",
        "--env.sim.num_envs",
        "3",
        "--env.obs.no-noise",
        "--env.commands.vx-range",
        "-1",
        "1.5",
        "--env.predictor.hidden-dims",
        "32",
        "16",
        "8",
        "--env.sim.nthread",
        "None",
        "--env.domain-rand.no-enabled",
        "--env.gait.selection",
        "fixed",
        "--train.max-iterations=7",
        "--env.sim.cuda-graph",
        "--env.reward.ramp-terms",
        "p_cost",
        "--env.gait.library.1.frequency",
        "1.5",
    )
    env, train = args.env, args.train
    assert env.reward.energy == -2e-5 and env.sim.num_envs == 3 and env.obs.noise is False
    assert env.commands.vx_range == (-1.0, 1.5) and env.predictor.hidden_dims == (32, 16, 8)
    assert env.sim.nthread is None and env.domain_rand.enabled is False and env.gait.selection == "fixed"
    assert train.max_iterations == 7 and env.sim.cuda_graph is True and env.reward.ramp_terms == ("p_cost",)
    assert env.gait.library[1].frequency == 1.5 and env.gait.library[1].name == "trotting"
    assert args.overrides["env.reward.energy"] == -2e-5 and args.overrides["train.max_iterations"] == 7
    env.validate()


def test_the_task_comes_first_then_the_short_flags_and_long_options():
    args = _parse(
        "baseline-paper",
        "--num-envs",
        "8",
        "--dt",
        "0.002",
        "--decimation",
        "10",
        "--reward",
        "energy=-1e-4",
        "--temperature",
        "3",
        "0.1",
        "--true-state",
        "--max-iterations",
        "5",
    )
    env, train = args.env, args.train
    assert args.task == "baseline-paper" and env.gait.selection == "none" and env.reward.residual == 0.0
    assert env.sim.num_envs == 8 and (env.sim.dt, env.sim.decimation) == (0.002, 10)
    assert env.reward.energy == -1e-4 and env.estimator.use_true_state is True
    assert (env.predictor.temperature_start, env.predictor.temperature_end) == (3.0, 0.1)
    assert train.max_iterations == 5
    args = _parse("--task", "pmtg", "--env.sim.num-envs", "6")
    assert args.task == "pmtg" and args.env.sim.num_envs == 6
    args = _parse()
    assert args.task == "ours" and args.env.sim.num_envs == 128 and args.env.gait.selection == "predictive"


def test_the_resolved_config_holds_the_task_the_command_line_and_what_it_changed():
    args = _parse("--num-envs", "4", "--env.reward.energy", "-2e-5", "--seed", "3", "--log-dir", "x")
    rec = resolved_config(args)
    assert rec["task"] == "ours" and rec["command"] == (
        "train/ppo_newton.py --num-envs 4 --env.reward.energy -2e-5 --seed 3 --log-dir x"
    )
    assert rec["overrides"] == {"env.sim.num_envs": 4, "env.reward.energy": -2e-5, "env.seed": 3}
    assert rec["args"]["log_dir"] == "x" and rec["args"]["resume"] is None and rec["env"]["sim"]["num_envs"] == 4
    assert json.loads(json.dumps(rec)) == json.loads(json.dumps(rec))  # JSON-serialisable


def test_every_short_flag_targets_a_config_field():
    env, train = TASKS["ours"].make()
    for flag, path in ALIASES.items():
        get_path({"env": env, "train": train}, path)  # AttributeError for a stale path
        assert flag.startswith("--") and "_" not in flag


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--env.gait.selection", "greedy"], "invalid choice 'greedy'"),
        (["--env.sim.dt", "fast"], "could not convert string to float: 'fast'"),
        (["--env.sim.dtt", "0.1"], "did you mean --env.sim.dt?"),
        (["--reward", "speed=1"], "unknown term 'speed'"),
        (["--num-envs", "0"], "SimConfig.num_envs must be >= 1"),
        (["--env.commands.vx-range", "2", "1"], "CommandConfig.vx_range must be (lo, hi) with lo <= hi"),
        (["--temperature", "1"], "--temperature expects 2 values"),
        (["ourz"], "unknown task 'ourz'; tasks: ours, ours-paper"),
        (["--profile", "select"], "--profile was removed: the task id carries the recipe"),
        (["--preset", "pmtg"], "--preset was removed: the method is the task id now"),
    ],
)
def test_a_bad_command_line_is_one_usage_error(argv, message):
    with pytest.raises(UsageError) as e:
        _parse(*argv)
    assert message in str(e.value) and "\n" not in str(e.value), str(e.value)


def test_help_lists_the_tasks_the_short_flags_and_each_option_with_its_docstring(capsys):
    text = _help(capsys=capsys)
    for name in TASKS:
        assert f"  {name} " in text, name
    for flag in ALIASES:
        assert flag in text, flag
    assert "Physics substep [s]" in text and "--env.sim.dt" in text and "--train.max-iterations" in text
    assert "||tau * qd||^2" in text  # a generated dataclass's field (RewardConfig): its doc reaches the help
    assert _default_of(text, "--env.sim.wheel-ki") == "0.0"  # the ours task's value
    assert _default_of(_help("ours-paper", capsys=capsys), "--env.sim.wheel-ki") == "2.0"  # the paper's


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
        "action.use_nominal_wheels False (preset ours: True)",
    ]


def test_the_tasks_are_each_method_with_its_levers_and_as_the_paper_writes_it():
    assert list(TASKS)[:2] == ["ours", "ours-paper"] and DEFAULT_TASK == "ours"
    assert set(TASKS) == {n for m in PRESETS for n in (m, f"{m}-paper", f"{m}-battery")}
    for name, task in TASKS.items():
        env, train = task.make()
        assert infer_task(env, train) == name and infer_preset(env) == task.method
        assert env.sim.num_envs * train.num_steps_per_env * train.max_iterations == pytest.approx(9.2e6, rel=1e-2)
        if name.endswith("-paper"):  # the preset itself, with the budget
            ref = make_preset(task.method)
            ref.sim.num_envs = 128
            assert to_dict(env) == to_dict(ref) and train == TrainConfig(max_iterations=3000), name
    env, train = TASKS["ours"].make()  # the former --profile select
    assert env.sim.wheel_ki == 0.0 and env.gait.lateral_gain == 0.35 and env.reward.p_cost == 0.0
    assert (env.predictor.criterion, env.predictor.label_source) == ("kinematic_feasible", "mean")
    assert env.predictor.label_command_cut and env.predictor.label_fraction == 0.03125
    assert env.predictor.kinematic_yaw_limit == 0.2 and train.init_noise_std_groups == (0.5, 0.25, 0.5)
    no_pred, np_train = TASKS["no_predictor"].make()  # a fixed gait: no predictor lever
    assert no_pred.gait.lateral_gain == 0.35 and no_pred.predictor == PredictorConfig() and no_pred.sim.wheel_ki == 0
    assert np_train.init_noise_std_groups == (0.5, 0.25, 0.5)
    base, base_train = TASKS["baseline"].make()  # no nominal gait: only the wheel law applies
    ref, _ = TASKS["baseline-paper"].make()
    ref.sim.wheel_ki = 0.0
    assert to_dict(base) == to_dict(ref) and base_train.init_noise_std_groups == ()
    assert _parse("--env.gait.lateral-gain", "0.2").env.gait.lateral_gain == 0.2  # an option wins over the task
    battery, _ = TASKS["no_predictor-battery"].make()  # the recipe and the battery's power term, every method
    assert battery.gait.lateral_gain == 0.35 and battery.reward.power_measure == "electrical"
    assert battery.power_measure == "mechanical" and battery.reward_power_output == "p_elec"
    assert (battery.reward.p_cost, battery.reward.joint_limits, battery.reward.ramp_terms) == (
        -0.002,
        -10.0,
        ("p_cost",),
    )
    assert infer_task(battery) == "no_predictor-battery" and infer_task(no_pred) == "no_predictor"
    for lever in RECIPE_LEVERS + BATTERY_LEVERS:  # each lever is a config field, measured in a study that exists
        get_path({"env": env, "train": train}, lever.path)
        assert os.path.isfile(os.path.join(ROOT, "docs", "studies", lever.study, "README.md")), lever.study


def test_a_new_task_is_one_registry_entry(monkeypatch):
    from wqwarp.rl import tasks

    entry = tasks.Task(
        "ours-fast",
        "ours",
        "ours with a short horizon",
        (tasks.Lever("env.predictor.horizon_s", 0.5, lambda cfg: True, "a test", "feasible_selection"),),
    )
    monkeypatch.setitem(tasks.TASKS, entry.name, entry)
    args = _parse("ours-fast")
    assert args.task == "ours-fast" and args.env.predictor.horizon_s == 0.5 and args.env.sim.wheel_ki == 2.0


def test_a_new_preset_is_one_factory_and_one_registry_entry(monkeypatch):
    from wqwarp.rl import presets, tasks

    def walking_only() -> EnvConfig:
        cfg = EnvConfig()
        cfg.gait = GaitConfig(selection="fixed", fixed_gait="walking")
        return cfg

    entry = presets.Preset("walking_only", walking_only, "Walking", "fixed walking gait")
    monkeypatch.setitem(presets.PRESETS, entry.name, entry)
    monkeypatch.setitem(tasks.TASKS, "walking_only", tasks.Task("walking_only", "walking_only", "walking"))
    env = _parse("walking_only").env
    assert env.gait.fixed_gait == "walking" and infer_preset(env) == "walking_only"


def test_print_config_shows_the_resolved_task_and_builds_nothing(tmp_path):
    """``ppo_newton.py --print-config``: the ours task with P-only wheels and the feasibility-aware selection;
    ``ours-paper``: the paper's values. Nothing is written, no env is built (no physics imported)."""

    def show(*argv):
        r = subprocess.run(
            [
                sys.executable,
                os.path.join(ROOT, "train", "ppo_newton.py"),
                *argv,
                "--print-config",
                "--log-dir",
                str(tmp_path / "run"),
            ],
            capture_output=True,
            text=True,
            cwd=tmp_path,
            timeout=120,
        )
        assert r.returncode == 0, r.stderr
        return json.loads(r.stdout)

    ours = show()
    assert ours["task"] == "ours" and ours["env"]["sim"]["wheel_ki"] == 0.0 and ours["overrides"] == {}
    assert ours["env"]["predictor"]["criterion"] == "kinematic_feasible"
    assert ours["env"]["predictor"]["label_command_cut"] is True
    paper = show("ours-paper", "--seed", "4")
    assert (
        paper["task"] == "ours-paper"
        and paper["env"]["sim"]["wheel_ki"] == 2.0
        and paper["overrides"] == {"env.seed": 4}
    )
    assert paper["env"]["predictor"]["criterion"] == "power" and paper["env"]["gait"]["lateral_gain"] == 0.0
    assert not (tmp_path / "run").exists() and not (tmp_path / "runs").exists()


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
    from wqwarp.control.gaits import load_tuned_gait

    trot, walk = (
        os.path.join(ROOT, "docs", "studies", "diffsim", f"optimize_{g}_0.3.json") for g in ("trotting", "walking")
    )
    args = _parse("--env.gait.tuned", trot, "--num-envs", "4", f"--env.gait.tuned={walk}")
    env = args.env
    tuned = [load_tuned_gait(trot), load_tuned_gait(walk)]
    assert env.gait.library[1:] == tuple(tuned) and tuned[0].frequency != 1.2 and tuned[1].frequency != 0.8
    library = to_dict(env)["gait"]["library"]
    assert [g["name"] for g in library] == ["driving", "trotting", "walking"]
    assert library[1]["df_swing"] == tuned[0].df_swing and env_config_from_dict(to_dict(env)).gait == env.gait
    assert resolved_config(args)["tuned_gaits"] == [trot, walk]

    (tmp_path / "bad.json").write_text("{not json")
    (tmp_path / "other.json").write_text(json.dumps({"loss": 1.0}))
    for path, match in (
        (tmp_path / "missing.json", "No such file"),
        (tmp_path / "bad.json", "not JSON"),
        (tmp_path / "other.json", "not a tuned gait"),
    ):
        with pytest.raises(UsageError, match=rf"^--env.gait.tuned '{path}': .*{match}") as e:
            _parse("--env.gait.tuned", str(path))
        assert "\n" not in str(e.value)
    r = subprocess.run(
        [
            sys.executable,
            os.path.join(ROOT, "train", "ppo_newton.py"),
            "--env.gait.tuned",
            str(tmp_path / "missing.json"),
            "--log-dir",
            str(tmp_path / "run"),
        ],
        capture_output=True,
        text=True,
        cwd=ROOT,
        timeout=120,
    )
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and "--env.gait.tuned" in r.stderr, r.stderr
    assert not (tmp_path / "run").exists()


@pytest.mark.parametrize(
    ("name", "match"),
    [
        ("WqPPO", "must be 'module:Class'"),
        ("wqwarp.rl.algorithm:Nope", "does not import"),
        ("rsl_rl.algorithms:PPO", "must name WqPPO or a subclass"),
    ],
)
def test_the_algorithm_class_must_name_an_importable_wqppo(name, match):
    with pytest.raises(UsageError, match=rf"TrainConfig.algorithm_class .*{match}"):
        _parse("--train.algorithm-class", name)
    train = _parse("--train.algorithm-class", "wqwarp.rl.algorithm:KeptMeanActorsPPO").train
    assert train.rsl_rl_dict()["algorithm"]["class_name"] == "wqwarp.rl.algorithm:KeptMeanActorsPPO"


UTF8_BOX = (
    "╭─ Required options ──────────────────────────────────────────────╮\n"
    "│ Missing from x:                                                 │\n"
    "│     --checkpoint STR                                            │\n"
    "│         model_<it>.pt written by train/ppo_newton.py (required) │\n"
    "│ ─────────────────────────────────────────────────────────────── │\n"
    "│ Unrecognized options:                                           │\n"
    "│     --no-such-option                                            │\n"
    "│ ─────────────────────────────────────────────────────────────── │\n"
    "│ For full helptext, run:                                         │\n"
    "│     x --help                                                    │\n"
    "╰─────────────────────────────────────────────────────────────────╯\n"
)
ASCII_BOX = (
    " Unrecognized options                                        \n"
    " ----------------------------------------------------------- \n"
    "  Unrecognized options: --env.sim.dtt, 3                     \n"
    "  -----------------------------------------------------------\n"
    "  Perhaps you meant:                                         \n"
    "      --env.sim.dt FLOAT                                     \n"
    "  -----------------------------------------------------------\n"
    "  For full helptext, see x --help                            \n"
)


def test_tyro_errors_become_one_line_in_either_box_style():
    """tyro draws its errors in a UTF-8 box on a UTF-8 terminal and without one otherwise: the same one line."""
    from wqwarp.cli.args import tyro_error_line

    one = "Missing from x: --checkpoint STR model_<it>.pt written by train/ppo_newton.py (required); "
    assert tyro_error_line(UTF8_BOX) == one + "Unrecognized options: --no-such-option (see --help)"
    two = "Unrecognized options: --env.sim.dtt, 3 (did you mean --env.sim.dt?) (see --help)"
    assert tyro_error_line(ASCII_BOX) == two
    assert tyro_error_line("") == "invalid command line (see --help)"


def test_resuming_with_no_option_continues_with_the_checkpoints_own_configuration(tmp_path, capsys):
    """``--resume CKPT`` alone: the run's non-default options (robots, a reward weight, the PPO settings stored in the
    checkpoint) come back; an option beside it overrides and is listed; a checkpoint without PPO settings takes its
    run's config.json; resuming in the folder of later checkpoints, which it would write over, is refused."""
    import helpers

    from wqwarp.cli.train import main as train_main

    runner = helpers.task_runner(
        "ours-paper", num_envs=4, seed=1, steps_per_env=8, overrides={"env.reward.energy": -3e-5}
    )
    runner.train_config = to_dict(TrainConfig(save_interval=7, max_iterations=9, num_steps_per_env=8))
    ckpt = str(tmp_path / "model_2.pt")
    runner.save(ckpt)
    args = _parse("--resume", ckpt)
    assert args.task == "ours-paper" and args.overrides == {} and args.env.sim.num_envs == 4
    assert args.env.reward.energy == -3e-5 and (args.train.save_interval, args.train.max_iterations) == (7, 9)
    args = _parse("--resume", ckpt, "--seed", "9", "--env.sim.num-envs", "4")
    assert args.overrides == {"env.seed": 9}  # only what differs from the checkpoint's configuration
    with pytest.raises(UsageError, match="was trained as ours-paper, not as task ours"):
        _parse("ours", "--resume", ckpt)

    runner.train_config = None  # a checkpoint written before the PPO settings were stored in it
    old = tmp_path / "old"
    old.mkdir()
    runner.save(str(old / "model_2.pt"))
    with pytest.raises(UsageError, match="no PPO settings in it nor a readable config.json"):
        _parse("--resume", str(old / "model_2.pt"))
    (old / "config.json").write_text(json.dumps({"train": to_dict(TrainConfig(save_interval=5))}))
    assert _parse("--resume", str(old / "model_2.pt")).train.save_interval == 5

    runner.save(str(tmp_path / "model_5.pt"))
    assert train_main(["--resume", ckpt, "--no-export"]) == 2
    assert "its folder holds later checkpoints (model_5.pt)" in capsys.readouterr().err
