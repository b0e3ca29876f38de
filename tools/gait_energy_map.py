"""Gait energy map of a predictive checkpoint: over a grid of commands, the measured power of each gait, the power
predictor's estimate of it, and the gait that wins.

Usage::

    python tools/gait_energy_map.py --checkpoint runs/ours_X/model_999.pt --json map.json --png map.png
"""

from __future__ import annotations

import sys

from wqwarp.cli.evaluate import main as protocol_main
from wqwarp.eval import energy_map


def main(argv: list[str] | None = None) -> int:
    """``train/evaluate.py --protocol energymap`` under this tool's name (``wqwarp.eval.protocols``); the help's
    epilog is the protocol's description (``wqwarp.eval.energy_map``)."""
    return protocol_main(argv, "energymap", __doc__ + "\n\n" + energy_map.__doc__.split("\n\n", 1)[1])


if __name__ == "__main__":
    sys.exit(main())
