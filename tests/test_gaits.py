"""Gait library (wqwarp/gaits.py): Table I data, lookup, Warp arrays and the phase patterns."""

import dataclasses

import numpy as np
import pytest
import warp as wp

from wqwarp.control.gaits import GAIT_LIBRARY, GAIT_NAMES, Gait, gait_index, gait_library_arrays

DEVICES = ["cpu"] + (["cuda:0"] if wp.is_cuda_available() else [])


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


@pytest.mark.parametrize("device", DEVICES)
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
