"""The nominal gait library (paper Table I) as data.

References:
    Paper, "Augmented Nominal Gait Design", Table I (nominal gait parameters).

Phase table in project leg order FR, FL, RR, RL (phi_i = phase offset; leg i swings while its phase is in
[0, DF_swing))::

    gait      offsets FR   FL    RR    RL     DF_swing  f [Hz]   stance x [m] (authors' generator, not Table I)
    driving           0    0     0     0      0         0        -0.05
    trotting          0    0.5   0.5   0      0.4       1.2
    walking           0    0.25  0.5   0.75   0.225     0.8

Leg-order mapping: the paper does not state its leg order. Its trot offsets [0, 0.5, 0, 0.5] pair legs 1-3 and
2-4, which must be the diagonal pairs; in our order the diagonals are (FR, RL) and (FL, RR), so trotting is
(0, 0.5, 0.5, 0). Walking keeps Table I's numbers (0, 0.25, 0.5, 0.75) in our order, i.e. the swing sequence
FR -> FL -> RR -> RL, each a quarter cycle apart. Any assignment of the four quarter offsets keeps the property
that matters (DF 0.225 < 0.25: never more than one leg in swing); if the paper's order were FL, FR, RR, RL its walk
would read (0.25, 0, 0.5, 0.75) here, the same sequence started one quarter later on the other front leg.

The library is configuration: ``GaitConfig.library`` (``wqwarp.rl.config``, default :data:`TABLE_I`) is what the
nominal gait, the env, the gait selector and the power predictor use, and it is stored in every checkpoint. Adding a
gait = adding one ``Gait`` entry to a library (its index is its gait id): ``GaitConfig(library=(*TABLE_I, pace))``.
Gaits tuned on the differentiable path (``tools/optimize_gait.py`` JSON) load with :func:`load_tuned_gait`.

This module imports no Warp at import (``wqwarp.rl.config`` reads it); :func:`gait_library_arrays` imports it.
"""

from __future__ import annotations

import dataclasses
import json
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from wqwarp.robot.constants import MAX_HORIZONTAL_OFFSET, NUM_LEGS

if TYPE_CHECKING:
    import warp as wp


@dataclass(frozen=True)
class Gait:
    """One nominal gait primitive."""

    name: str
    """Gait name, unique in the library."""
    phase_offsets: tuple[float, float, float, float]
    """Phase offset of each leg in [0, 1), legs FR, FL, RR, RL [cycles]."""
    df_swing: float
    """DF_swing in [0, 1]: fraction of the cycle spent in swing (0 = the legs never swing) [-]."""
    frequency: float
    """Gait frequency f [Hz]."""
    stance_x: float = 0.0
    """x offset of every stance foot point from its nominal position [m] (authors' generator, PMTG.py: the driving
    gait holds x = -max_horizontal_offset = -0.05 m; the legged gaits 0)."""

    def __post_init__(self) -> None:
        if len(self.phase_offsets) != NUM_LEGS:
            raise ValueError(f"gait {self.name!r}: need {NUM_LEGS} phase offsets, got {len(self.phase_offsets)}")
        if not all(0.0 <= p < 1.0 for p in self.phase_offsets):
            raise ValueError(f"gait {self.name!r}: phase offsets must lie in [0, 1), got {self.phase_offsets}")
        if not 0.0 <= self.df_swing <= 1.0:
            raise ValueError(f"gait {self.name!r}: df_swing must lie in [0, 1], got {self.df_swing}")
        if self.frequency < 0.0:
            raise ValueError(f"gait {self.name!r}: frequency must be >= 0, got {self.frequency}")

    @classmethod
    def from_dict(cls, data: dict) -> Gait:
        """The gait ``dataclasses.asdict`` wrote (a checkpoint's ``env_cfg['gait']['library']`` entry)."""
        return cls(**{**data, "phase_offsets": tuple(float(p) for p in data["phase_offsets"])})


TABLE_I: tuple[Gait, ...] = (
    Gait("driving", (0.0, 0.0, 0.0, 0.0), df_swing=0.0, frequency=0.0, stance_x=-MAX_HORIZONTAL_OFFSET),
    # Paper: [0, 0.5, 0, 0.5] in its own order; diagonal pairs (FR, RL) and (FL, RR) share a phase in ours.
    Gait("trotting", (0.0, 0.5, 0.5, 0.0), df_swing=0.4, frequency=1.2),
    # Table I numbers in our order FR, FL, RR, RL: swing sequence FR, FL, RR, RL (see the module docstring).
    Gait("walking", (0.0, 0.25, 0.5, 0.75), df_swing=0.225, frequency=0.8),
)
"""The paper's gait library in paper order: driving, trotting, walking. The index of a gait is its gait id."""

GAIT_LIBRARY: tuple[Gait, ...] = TABLE_I
"""The default library (``GaitConfig.library``): a run's own library is ``env.cfg.gait.library``."""

GAIT_NAMES: tuple[str, ...] = tuple(g.name for g in GAIT_LIBRARY)
"""Gait names of the default library in gait-id order (a run's own: ``env.gait_names``)."""


def load_tuned_gait(path: str, library: tuple[Gait, ...] = TABLE_I, name: str | None = None) -> Gait:
    """The gait tuned on the differentiable path: ``tools/optimize_gait.py``'s JSON (``wqwarp.diff.tuning.optimize``
    under ``"tuning"``, or its bare result), its best iterate's frequency, DF_swing and stance x on the phase
    offsets of the library gait it started from, called ``name`` (default: that gait's name, so that it replaces
    it). The tuned h_b and h_s are global settings (``GaitConfig.body_height`` / ``swing_height``), not part of a
    gait: read them from the file's ``best.params`` if you want them."""
    with open(path, encoding="utf-8") as f:
        data = json.load(f)
    tuning = data.get("tuning", data)
    params = dict(zip(tuning["param_names"], tuning["best"]["params"], strict=True))
    base = library[gait_index(tuning["config"]["gait"], library)]
    return dataclasses.replace(
        base,
        name=name or base.name,
        frequency=float(params.get("frequency", base.frequency)),
        df_swing=float(params.get("df_swing", base.df_swing)),
        stance_x=float(params.get("stance_x", base.stance_x)),
    )


MIRROR_LEGS = (1, 0, 3, 2)
"""The leg each leg becomes under the left-right mirror (FR<->FL, RR<->RL)."""


def mirror_offsets(gait: Gait) -> tuple[float, ...]:
    """Phase offsets of the left-right mirror image of ``gait`` (each leg takes its mirror leg's offset)."""
    return tuple(gait.phase_offsets[MIRROR_LEGS[leg]] for leg in range(NUM_LEGS))


def is_mirror_symmetric(gait: Gait, tol: float = 1e-9) -> bool:
    """True if the mirror image of ``gait`` is ``gait`` itself up to a shift of the gait clock. Trotting and driving
    are; Table I's walking (swing sequence FR, FL, RR, RL) is not: its mirror swings FL, FR, RL, RR, a gait the
    library does not hold, so mirrored walking observations show phases the robot never runs."""
    shift = np.asarray(mirror_offsets(gait)) - np.asarray(gait.phase_offsets)  # the same for every leg, mod 1
    return bool(np.allclose(np.mod(shift - shift[0] + 0.5, 1.0) - 0.5, 0.0, atol=tol))


def with_gait(library: tuple[Gait, ...], gait: Gait) -> tuple[Gait, ...]:
    """``library`` with ``gait`` replacing the gait of the same name, or appended if the name is new."""
    names = [g.name for g in library]
    if gait.name in names:
        return tuple(gait if g.name == gait.name else g for g in library)
    return (*library, gait)


def gait_index(name: str, library: tuple[Gait, ...] = GAIT_LIBRARY) -> int:
    """Gait id of the gait called ``name``; raises ValueError naming the known gaits for an unknown name."""
    for i, gait in enumerate(library):
        if gait.name == name:
            return i
    raise ValueError(f"unknown gait {name!r}; known gaits: {', '.join(g.name for g in library)}")


@dataclass(frozen=True)
class GaitArrays:
    """The gait library as Warp arrays, indexed by gait id (input of ``wqwarp.kernels.gait``)."""

    phase_offsets: wp.array2d
    """(num_gaits, 4) float32 phase offsets, legs FR, FL, RR, RL [cycles]."""
    df_swing: wp.array
    """(num_gaits,) float32 swing duty factor [-]."""
    frequency: wp.array
    """(num_gaits,) float32 gait frequency [Hz]."""
    stance_x: wp.array
    """(num_gaits,) float32 stance x offset of the foot points [m]."""

    @property
    def num_gaits(self) -> int:
        return self.df_swing.shape[0]


def gait_library_arrays(device: wp.context.Devicelike = None, library: tuple[Gait, ...] = GAIT_LIBRARY) -> GaitArrays:
    """Copy ``library`` onto ``device`` as :class:`GaitArrays`."""
    import warp as wp

    offsets = np.array([g.phase_offsets for g in library], dtype=np.float32).reshape(len(library), NUM_LEGS)
    return GaitArrays(
        phase_offsets=wp.array(offsets, dtype=wp.float32, device=device),
        df_swing=wp.array(np.array([g.df_swing for g in library], dtype=np.float32), dtype=wp.float32, device=device),
        frequency=wp.array(np.array([g.frequency for g in library], dtype=np.float32), dtype=wp.float32, device=device),
        stance_x=wp.array(np.array([g.stance_x for g in library], dtype=np.float32), dtype=wp.float32, device=device),
    )
