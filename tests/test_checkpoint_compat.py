"""Checkpoints against the env that loads them: another gait set is refused with one line naming both, and a
checkpoint of the earlier format (the extensions' state in ``infos``) still loads whole. Configurations written
before a setting existed load with the behaviour its field declares (``wqwarp.utils.migration``), and only those."""

from __future__ import annotations

import dataclasses
import glob
import json
import os
from dataclasses import dataclass, field

import pytest
import torch
from helpers import task_runner

from wqwarp.rl.config import EnvConfig, GaitConfig, env_config_from_dict, from_dict, to_dict
from wqwarp.utils.migration import migrate, migration_of, migrations, plain, since_default


def _runner(seed: int):
    return task_runner("ours-paper", num_envs=4, seed=seed)


def test_another_gait_set_and_the_earlier_format(tmp_path):
    a, b = _runner(1), _runner(2)
    path = str(tmp_path / "m.pt")
    a.save(path)
    ckpt = torch.load(path, weights_only=False)

    other = dict(ckpt, infos=dict(ckpt["infos"]))
    gait = dict(other["infos"]["env_cfg"]["gait"])
    gait["library"] = [dict(g, name=f"{g['name']}_tuned") for g in gait["library"]]
    other["infos"]["env_cfg"] = dict(other["infos"]["env_cfg"], gait=gait)
    torch.save(other, tmp_path / "other.pt")
    with pytest.raises(ValueError, match=r"trained with the gaits \[.*_tuned.*\], this env runs \[") as e:
        b.load(str(tmp_path / "other.pt"))
    assert "\n" not in str(e.value)

    # the same names, other parameters (a tuned trot keeps its name): refused too, naming what differs
    gait = dict(ckpt["infos"]["env_cfg"]["gait"])
    gait["library"] = [dict(g, frequency=1.11) if g["name"] == "trotting" else g for g in gait["library"]]
    tuned = dict(ckpt, infos=dict(ckpt["infos"], env_cfg=dict(ckpt["infos"]["env_cfg"], gait=gait)))
    torch.save(tuned, tmp_path / "tuned.pt")
    with pytest.raises(ValueError, match=r"another 'trotting' gait \(frequency 1.11 in the checkpoint, 1.2 here\)"):
        b.load(str(tmp_path / "tuned.pt"))

    old = {k: v for k, v in ckpt.items() if not k.startswith(("estimator_", "gait_selector_"))}
    old["infos"] = dict(
        ckpt["infos"],
        format=1,
        estimator=ckpt["estimator_state_dict"],
        estimator_optimizer=ckpt["estimator_optimizer_state_dict"],
        gait_selector=ckpt["gait_selector_state_dict"],
    )
    torch.save(old, tmp_path / "old.pt")
    b.load(str(tmp_path / "old.pt"))
    for x, y in ((a.env.estimator, b.env.estimator), (a.env.gait_selector.predictor, b.env.gait_selector.predictor)):
        assert all(torch.equal(p, q) for p, q in zip(x.state_dict().values(), y.state_dict().values(), strict=True))


TABLE_I_AS_MIGRATED = [
    {"name": "driving", "phase_offsets": [0.0, 0.0, 0.0, 0.0], "df_swing": 0.0, "frequency": 0.0, "stance_x": -0.05},
    {"name": "trotting", "phase_offsets": [0.0, 0.5, 0.5, 0.0], "df_swing": 0.4, "frequency": 1.2, "stance_x": 0.0},
    {"name": "walking", "phase_offsets": [0.0, 0.25, 0.5, 0.75], "df_swing": 0.225, "frequency": 0.8, "stance_x": 0.0},
]
OLD_MIGRATIONS = (
    ("action.phase_residual_mode", "increment", "the only reading before the setting existed"),
    ("predictor.power_normalization", "watts", "the literal formula, the only one before the setting existed"),
    ("sim.joint_model", "asset", "the USD's joint model, the only one before the setting existed"),
    ("domain_rand.nominal_friction", 1.0, "the friction without randomisation before the setting existed"),
    ("sim.unstable_position_limit", 1.0e3, "the divergence guard's default; before it, a diverged robot went unseen"),
    ("sim.unstable_velocity_limit", 1.0e3, "the divergence guard's default; before it, a diverged robot went unseen"),
    ("gait.library", TABLE_I_AS_MIGRATED, "Table I, the only library before it was a setting"),
    ("reward.only_positive", False, "the plain sum, the only reward before the setting existed"),
    ("commands.single_axis_weights", [1.0, 1.0, 1.0], "equal odds, the only sampler before the setting existed"),
    ("gait.lateral_gain", 0.0, "no lateral feed-forward before the setting existed"),
    ("gait.lateral_limit", 0.12, "its default (unused at gain 0)"),
    ("predictor.criterion", "power", "the paper's power-only rule, the only one before the setting existed"),
    ("predictor.feasible_margin", 0.02, "its default (unused with the power criterion)"),
    ("predictor.feasible_penalty", 2.0, "its default (unused with the power criterion)"),
    ("predictor.kinematic_lateral_limit", 0.1, "its default (unused with the power criterion)"),
    ("predictor.label_source", "policy", "every robot's sampled actions, the only labels before the setting existed"),
    ("predictor.label_fraction", 0.125, "its default (unused with policy labels)"),
    ("predictor.label_command_cut", False, "windows were cut only by resets and gait switches before the setting"),
    ("predictor.kinematic_yaw_limit", 10.0, "driving a candidate for every yaw command before the setting existed"),
    ("predictor.kinematic_reach", False, "no gait was kept off commands beyond its reach before the setting"),
    ("predictor.explore_fraction", 0.0, "selections were never overridden by exploration before the setting"),
    ("reward.p_cost", 0.0, "no power-cost term before the setting existed"),
    ("power_measure", "mechanical", "the paper's p_cost, the only measure before the setting"),
    ("reward.power_measure", "same", "the power term read env.power_measure before the setting existed"),
    ("sim.robot", "", "the packaged USD, the only robot before the setting existed"),
    ("reward.joint_limits", 0.0, "no joint-limit term before the setting existed"),
    ("reward.soft_joint_limit", 0.9, "the default; read only by the joint-limit term, off before it existed"),
    ("sim.contact_ke", 2.0e4, "its default; read only by the featherstone backend, which no training used before"),
    ("sim.contact_kd", 300.0, "its default; read only by the featherstone backend, which no training used before"),
    ("sim.contact_kf", 100.0, "its default; read only by the featherstone backend, which no training used before"),
    ("sim.contact_mu", 1.0, "its default; read only by the featherstone backend, which no training used before"),
    ("reward.ramp_terms", [], "no reward ramp before the setting existed"),
    ("reward.ramp_start", 0, "its default (unused without ramp terms)"),
    ("reward.ramp_iterations", 0, "its default (unused without ramp terms)"),
    ("reward.ramp_gate_vy_error", 0.0, "the ramp started at ramp_start before the gate existed"),
    ("reward.ramp_gate_window", 100, "its default (unused without the gate)"),
)
"""``wqwarp.rl.config.MIGRATIONS`` as it was when the migrations moved onto the fields (pinned: the old
checkpoints' behaviour must not move with the code)."""


def _set(data: dict, path: str, value=None, delete: bool = False) -> None:
    *head, key = path.split(".")
    for part in head:
        data = data[part]
    if delete:
        del data[key]
    else:
        data[key] = value


def test_every_fill_of_the_former_table_is_still_done_with_the_same_value():
    declared = {path: (value, why) for path, value, why in migrations(EnvConfig)}
    assert declared == {path: (value, why) for path, value, why in OLD_MIGRATIONS}
    old, expected = to_dict(EnvConfig()), to_dict(EnvConfig())
    for path, value, _ in OLD_MIGRATIONS:  # a checkpoint written before all of them
        _set(old, path, delete=True)
        _set(expected, path, value)
    notes: list[str] = []
    cfg = env_config_from_dict(old, notes)
    assert sorted(notes) == sorted(f"{path} = {value!r} ({why})" for path, value, why in OLD_MIGRATIONS)
    assert cfg == env_config_from_dict(expected)
    assert (cfg.action.phase_residual_mode, cfg.predictor.power_normalization) == ("increment", "watts")


def test_the_library_fill_is_table_i_written_out_not_the_live_constant(monkeypatch):
    from wqwarp.control import gaits
    from wqwarp.rl import config

    library = next(f for f in dataclasses.fields(GaitConfig) if f.name == "library")
    value = migration_of(library).value
    assert plain(value) == plain(gaits.TABLE_I) == TABLE_I_AS_MIGRATED  # in sync today
    assert all(type(g) is dict for g in value)  # data, no reference to the Gait objects of TABLE_I

    edited = (dataclasses.replace(gaits.TABLE_I[0], frequency=0.5), *gaits.TABLE_I[1:])  # Table I edited one day
    monkeypatch.setattr(gaits, "TABLE_I", edited)
    monkeypatch.setattr(config, "TABLE_I", edited)
    old = to_dict(EnvConfig())
    del old["gait"]["library"]
    got = env_config_from_dict(old).gait.library
    assert got == tuple(gaits.Gait.from_dict(g) for g in TABLE_I_AS_MIGRATED) and got != edited


@dataclass
class _TiltedGait(GaitConfig):
    tilt: float = field(default=0.3, metadata=migrate(0.0, "no tilt before the setting existed"))
    """A setting added in a test, with its migration."""
    tilt_limit: float = field(default=0.2, metadata=since_default("its default (unused at tilt 0)"))
    """Another, old checkpoints behave as its default."""


@dataclass
class _TiltedEnv(EnvConfig):
    gait: _TiltedGait = field(default_factory=_TiltedGait)


@dataclass
class _BareTiltedGait(GaitConfig):
    tilt: float = 0.3
    """The same setting without a migration."""


@dataclass
class _BareTiltedEnv(EnvConfig):
    gait: _BareTiltedGait = field(default_factory=_BareTiltedGait)


def test_a_setting_added_to_its_dataclass_needs_no_other_edit_to_load_an_old_checkpoint():
    old = to_dict(EnvConfig())  # written before the setting existed
    notes: list[str] = []
    cfg = from_dict(_TiltedEnv, old, migrated=notes)
    assert (cfg.gait.tilt, cfg.gait.tilt_limit) == (0.0, 0.2) and cfg.gait.library == EnvConfig().gait.library
    assert notes == [
        "gait.tilt = 0.0 (no tilt before the setting existed)",
        "gait.tilt_limit = 0.2 (its default (unused at tilt 0))",
    ]
    assert ("gait.tilt", 0.0, "no tilt before the setting existed") in migrations(_TiltedEnv)
    assert from_dict(_TiltedEnv, to_dict(cfg), migrated=notes) == cfg and len(notes) == 2  # nothing to fill

    with pytest.raises(
        ValueError,
        match=r"_BareTiltedEnv.gait: missing keys \['tilt'\].*on its own field: "
        r"metadata=migrate\(value, why\) or since_default\(why\)",
    ):
        from_dict(_BareTiltedEnv, old, migrated=[])
    with pytest.raises(ValueError, match=r"_TiltedEnv.gait: missing keys \['tilt', 'tilt_limit'\]"):
        from_dict(_TiltedEnv, old)  # without a list to report them in, nothing is filled


def _absent(cls: type, data: dict, path: str = ""):
    """Dotted paths of the fields of config tree ``cls`` that ``data`` lacks."""
    from wqwarp.utils.checked_config import field_types

    for f in dataclasses.fields(cls):
        p, t = f"{path}.{f.name}" if path else f.name, field_types(cls)[f.name]
        if f.name not in data:
            yield p
        elif dataclasses.is_dataclass(t) and isinstance(data[f.name], dict):
            yield from _absent(t, data[f.name], p)


def test_every_setting_absent_from_a_recorded_configuration_declares_its_migration():
    """The committed configurations of the trainings behind docs/ are the record of the older checkpoints: a setting
    added since is absent from some of them, and must say on its own field how they behave without it."""
    root = os.path.join(os.path.dirname(__file__), "..", "docs")
    paths = glob.glob(os.path.join(root, "**", "*train_config.json"), recursive=True)
    paths += glob.glob(os.path.join(root, "**", "config.json"), recursive=True)
    declared = {path for path, _, _ in migrations(EnvConfig)}
    undeclared: dict[str, str] = {}
    for path in sorted(paths):
        with open(path) as f:
            env = json.load(f).get("env")
        if env is None:
            continue
        predictor_optional = env.get("gait", {}).get("selection") != "predictive"  # env_config_from_dict's case
        for p in _absent(EnvConfig, env):
            if p not in declared and not (p == "predictor" and predictor_optional):
                undeclared.setdefault(p, os.path.relpath(path, root))
    assert not undeclared, (
        "settings absent from recorded configurations (docs/) declare no migration: "
        + ", ".join(f"{p} (e.g. {where})" for p, where in undeclared.items())
        + ". Add it on the field: field(default=..., metadata=migrate(OLD_VALUE, why)) or since_default(why), "
        "wqwarp.utils.migration (a RewardTerm: migration=Migration(0.0, why))."
    )
