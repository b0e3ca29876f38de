"""The evaluation protocols of the paper, registered once: each is one function ``run(options, log) -> result`` with
its options dataclass (``wqwarp.eval.options``), its defaults and its outputs (a JSON result, and a PNG where it
draws one). ``train/evaluate.py --protocol NAME`` and ``train/reproduce.py``'s stages both go through
:func:`run_protocol`; adding a protocol is one function (with its options) and one :data:`PROTOCOLS` entry.

The protocols, their options and defaults: :data:`PROTOCOLS` (``python train/evaluate.py --help`` lists them).
"""

from __future__ import annotations

import sys
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TextIO

from wqwarp.eval.energy_map import EnergyMapOptions, draw_energy_map, energy_map
from wqwarp.eval.lateral import LateralOptions, lateral
from wqwarp.eval.options import ProtocolOptions, command_line
from wqwarp.eval.timeline import TimelineOptions, draw_timeline, timeline
from wqwarp.eval.tracking import TrackingOptions, push, sim2sim, tracking


@dataclass(frozen=True)
class Protocol:
    """One evaluation protocol."""

    name: str
    run: Callable[[ProtocolOptions, TextIO], dict]
    """``run(options, log)``: the result (written as JSON); prints its tables to ``log``."""
    options: type[ProtocolOptions]
    doc: str
    defaults: dict = field(default_factory=dict)
    """This protocol's defaults over those of its options dataclass."""
    draw: Callable[[dict, str, str | None], None] | None = None
    """``draw(result, png_path, command)``: the figure of ``--png``, if the protocol has one."""
    json_indent: int | None = 2
    """Indent of the JSON result (None: compact, for time series)."""


PROTOCOLS = {
    p.name: p
    for p in (
        Protocol("tracking", tracking, TrackingOptions, "--tasks over the paper's tracking ranges, --push optional"),
        Protocol(
            "push",
            push,
            TrackingOptions,
            "Table III - tasks stand, vx, vy, wz with commands in [-1, 1], random "
            "pushes up to each of --push-levels m/s every 15 s along the trunk's x and y; a robot recovers if its "
            "trunk never touches the ground (default 60 s per run)",
            defaults={"tasks": "stand,vx,vy,wz", "seconds": 60.0},
        ),
        Protocol(
            "sim2sim",
            sim2sim,
            TrackingOptions,
            "tracking under the training physics and under each of --physics "
            "(default the paper's dt 0.001 x 20 and the authors' joint model), with the deltas",
            defaults={"physics": "dt0.001,authors"},
        ),
        Protocol(
            "timeline",
            timeline,
            TimelineOptions,
            "the paper's Fig. 6: robots through held --segments, gaits, "
            "power and the FR wheel height over time (train/reproduce.py: the Fig. 6 segments)",
            draw=draw_timeline,
            json_indent=None,
        ),
        Protocol(
            "lateral",
            lateral,
            LateralOptions,
            "pure lateral commands held (default +-0.3, +-0.6 m/s): v_y and its "
            "ratio to the command, the yaw rate it drags along, the commanded foot-y stroke, the phase-residual "
            "spread, falls; tracked = within 30 % with |w_z| < 0.2 rad/s and no falls; --per-gait forces each gait",
        ),
        Protocol(
            "energymap",
            energy_map,
            EnergyMapOptions,
            "per command cell of a (v_x, v_y) and a (v_x, w) grid: each "
            "gait's measured and predicted power and the cheapest gait",
            draw=draw_energy_map,
            json_indent=None,
        ),
    )
}
"""Every evaluation protocol, by name."""


def protocol(name: str) -> Protocol:
    """The protocol ``name``; ValueError naming the choices otherwise."""
    if name not in PROTOCOLS:
        raise ValueError(f"unknown protocol {name!r}; choose from {', '.join(PROTOCOLS)}")
    return PROTOCOLS[name]


def make_options(name: str, **values) -> ProtocolOptions:
    """Options of protocol ``name``: its defaults, then ``values``."""
    p = protocol(name)
    return p.options(**{**p.defaults, **values})


def equivalent_command(name: str, opts: ProtocolOptions) -> str:
    """The command line a user would type for ``opts`` (recorded in the result files)."""
    p = protocol(name)
    return command_line(f"train/evaluate.py --protocol {name}", opts, p.defaults)


def run_protocol(name: str, opts: ProtocolOptions, log: TextIO | None = None, command: str | None = None) -> dict:
    """Run protocol ``name`` with ``opts``: validate them and check every output is writable (ValueError with a
    one-line message, before any work), run, write the JSON result (``opts.json``) and the figure (``png``) with
    ``command`` as their provenance (default :func:`equivalent_command`). Returns the result."""
    log = sys.stdout if log is None else log  # the stream of the call, not of the import
    from wqwarp.utils.io import output_problem
    from wqwarp.utils.provenance import write_result_json

    p = protocol(name)
    opts.validate()
    for flag, path in opts.outputs().items():
        if problem := output_problem(path):
            raise ValueError(f"{flag} {path!r}: {problem}")
    command = equivalent_command(name, opts) if command is None else command
    result = p.run(opts, log)
    if opts.json:
        write_result_json(opts.json, result, indent=p.json_indent, command=command)
    png = opts.outputs().get("--png")
    if png and p.draw is not None:
        p.draw(result, png, command)
    return result
