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

Adding a gait = adding one ``Gait`` entry to ``GAIT_LIBRARY`` (its index is its gait id).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import warp as wp

from wqwarp.robot.constants import MAX_HORIZONTAL_OFFSET, NUM_LEGS


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


GAIT_LIBRARY: tuple[Gait, ...] = (
    Gait("driving", (0.0, 0.0, 0.0, 0.0), df_swing=0.0, frequency=0.0, stance_x=-MAX_HORIZONTAL_OFFSET),
    # Paper: [0, 0.5, 0, 0.5] in its own order; diagonal pairs (FR, RL) and (FL, RR) share a phase in ours.
    Gait("trotting", (0.0, 0.5, 0.5, 0.0), df_swing=0.4, frequency=1.2),
    # Table I numbers in our order FR, FL, RR, RL: swing sequence FR, FL, RR, RL (see the module docstring).
    Gait("walking", (0.0, 0.25, 0.5, 0.75), df_swing=0.225, frequency=0.8),
)
"""The gait library in paper order: driving, trotting, walking. The index of a gait is its gait id."""

GAIT_NAMES: tuple[str, ...] = tuple(g.name for g in GAIT_LIBRARY)
"""Gait names in gait-id order."""


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
    offsets = np.array([g.phase_offsets for g in library], dtype=np.float32).reshape(len(library), NUM_LEGS)
    return GaitArrays(
        phase_offsets=wp.array(offsets, dtype=wp.float32, device=device),
        df_swing=wp.array(np.array([g.df_swing for g in library], dtype=np.float32), dtype=wp.float32, device=device),
        frequency=wp.array(np.array([g.frequency for g in library], dtype=np.float32), dtype=wp.float32, device=device),
        stance_x=wp.array(np.array([g.stance_x for g in library], dtype=np.float32), dtype=wp.float32, device=device),
    )
