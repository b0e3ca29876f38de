"""Gait library (wqwarp/control/gaits.py): Table I data, lookup, Warp arrays, the phase patterns, and the library as
configuration (checkpoints, tuned gaits)."""

import dataclasses

import numpy as np
import pytest
import warp as wp

from wqwarp.control.gaits import (
    GAIT_LIBRARY,
    GAIT_NAMES,
    TABLE_I,
    Gait,
    gait_index,
    gait_library_arrays,
    is_mirror_symmetric,
    load_tuned_gait,
    mirror_offsets,
    with_gait,
)
from wqwarp.rl.config import EnvConfig, GaitConfig, env_config_from_dict, to_dict

TUNED = "docs/studies/diffsim/optimize_trotting_0.3.json"


def _in_swing(gait: Gait, t: np.ndarray) -> np.ndarray:
    """(len(t), 4) swing flags at gait-clock phases t."""
    phase = np.mod(t[:, None] + np.array(gait.phase_offsets)[None, :], 1.0)
    return phase < gait.df_swing


def test_table_one():
    assert GAIT_NAMES == ("driving", "trotting", "walking")
    driving, trotting, walking = GAIT_LIBRARY
    assert driving == Gait("driving", (0.0, 0.0, 0.0, 0.0), 0.0, 0.0, stance_x=-0.05)  # PMTG.py driving x
    assert (trotting.df_swing, trotting.frequency) == (0.4, 1.2)
    assert trotting.phase_offsets == (0.0, 0.5, 0.5, 0.0)  # FR, FL, RR, RL: diagonals (FR, RL), (FL, RR)
    assert walking == Gait("walking", (0.0, 0.25, 0.5, 0.75), 0.225, 0.8)


def test_gait_index():
    for i, name in enumerate(GAIT_NAMES):
        assert gait_index(name) == i
    with pytest.raises(ValueError, match="unknown gait 'galloping'.*driving, trotting, walking"):
        gait_index("galloping")


def test_gait_is_frozen_and_validated():
    with pytest.raises(dataclasses.FrozenInstanceError):
        GAIT_LIBRARY[0].frequency = 1.0
    with pytest.raises(ValueError):
        Gait("bad", (0.0, 0.5, 0.5), 0.4, 1.0)
    with pytest.raises(ValueError):
        Gait("bad", (0.0, 0.5, 0.5, 1.0), 0.4, 1.0)
    with pytest.raises(ValueError):
        Gait("bad", (0.0, 0.5, 0.5, 0.0), 1.5, 1.0)


def test_trot_diagonal_pairs_share_phase():
    trot = GAIT_LIBRARY[gait_index("trotting")]
    fr, fl, rr, rl = trot.phase_offsets
    assert fr == rl and fl == rr and abs(fl - fr) == 0.5


def test_walk_never_more_than_one_leg_in_swing():
    walk = GAIT_LIBRARY[gait_index("walking")]
    swing = _in_swing(walk, np.linspace(0.0, 1.0, 20001))
    assert swing.sum(axis=1).max() == 1
    assert swing.any(axis=0).all()


def test_every_gait_has_an_all_stance_window():
    # gait switching (kernels/gait.py) re-bases phases inside such a window
    for g in GAIT_LIBRARY:
        assert (~_in_swing(g, np.linspace(0.0, 1.0, 20001)).any(axis=1)).any(), g.name


def test_gait_library_arrays(device):
    arrays = gait_library_arrays(device)
    assert arrays.num_gaits == len(GAIT_LIBRARY)
    assert arrays.phase_offsets.shape == (len(GAIT_LIBRARY), 4) and arrays.phase_offsets.dtype == wp.float32
    assert arrays.phase_offsets.device == wp.get_device(device)
    np.testing.assert_allclose(arrays.phase_offsets.numpy(), [g.phase_offsets for g in GAIT_LIBRARY])
    np.testing.assert_allclose(arrays.df_swing.numpy(), [g.df_swing for g in GAIT_LIBRARY])
    np.testing.assert_allclose(arrays.frequency.numpy(), [g.frequency for g in GAIT_LIBRARY])


def test_adding_a_gait_is_one_entry():
    pace = Gait("pacing", (0.0, 0.5, 0.0, 0.5), 0.4, 1.5)
    library = (*GAIT_LIBRARY, pace)
    assert gait_index("pacing", library) == 3
    assert gait_library_arrays("cpu", library).num_gaits == 4


def test_the_library_is_configuration_stored_in_checkpoints():
    cfg = EnvConfig()
    assert cfg.gait.library == TABLE_I == GAIT_LIBRARY
    pace = Gait("pacing", (0.0, 0.5, 0.0, 0.5), 0.4, 1.5)
    cfg.gait = GaitConfig(library=(*TABLE_I, pace), fixed_gait="pacing")
    data = to_dict(cfg)
    assert [g["name"] for g in data["gait"]["library"]] == [*GAIT_NAMES, "pacing"]
    assert env_config_from_dict(data) == cfg  # entries come back as Gait
    del data["gait"]["library"]  # a checkpoint written before the library was a setting gets Table I
    notes = []
    data["gait"]["fixed_gait"] = "trotting"
    assert env_config_from_dict(data, notes).gait.library == TABLE_I
    assert any(n.startswith("gait.library = ") for n in notes)
    with pytest.raises(ValueError, match="unique names"):
        GaitConfig(library=(*TABLE_I, TABLE_I[0]))


def test_a_tuned_gait_loads_from_the_differentiable_paths_json():
    import json
    import os

    path = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), TUNED)
    with open(path, encoding="utf-8") as f:
        tuning = json.load(f)["tuning"]
    best = dict(zip(tuning["param_names"], tuning["best"]["params"], strict=True))
    tuned = load_tuned_gait(path)
    trot = TABLE_I[gait_index("trotting")]
    assert tuned.name == "trotting" and tuned.phase_offsets == trot.phase_offsets
    assert (tuned.frequency, tuned.df_swing, tuned.stance_x) == (best["frequency"], best["df_swing"], best["stance_x"])
    assert (tuned.frequency, tuned.df_swing) != (trot.frequency, trot.df_swing)
    replaced = GaitConfig().with_tuned(path)
    assert [g.name for g in replaced.library] == list(GAIT_NAMES) and replaced.library[1] == tuned
    added = GaitConfig().with_tuned(path, name="trotting_tuned")
    assert added.library[:3] == TABLE_I and added.library[3].name == "trotting_tuned"
    assert with_gait(TABLE_I, tuned)[1] is tuned


def test_which_gaits_are_their_own_mirror_image():
    driving, trotting, walking = TABLE_I
    assert mirror_offsets(walking) == (0.25, 0.0, 0.75, 0.5)  # FR<->FL, RR<->RL: the sequence FL, FR, RL, RR
    assert is_mirror_symmetric(driving) and is_mirror_symmetric(trotting)  # trot: shifted by half a cycle
    assert not is_mirror_symmetric(walking)
    assert is_mirror_symmetric(Gait("pacing", (0.0, 0.5, 0.0, 0.5), 0.4, 1.5))
