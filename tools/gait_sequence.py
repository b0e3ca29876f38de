"""The paper's Fig. 6 (the commanded-velocity experiment) for a trained checkpoint: one robot through a sequence of
commands, with the height of the front-right wheel, the requested and running gait, the measured power and the tracked
velocity over time.

Usage::

    python tools/gait_sequence.py --checkpoint runs/ours_X/model_1499.pt --json fig6.json \\
        --png fig6.png [--segments "0.5,0,0:4;0,0.3,0:4;0,0,0.5:4;0,0,0:4"] [--robots 8]

Each segment is ``v_x,v_y,w_z:seconds``. ``--robots`` runs that many robots (no domain randomisation, each with its
own random spawn yaw) and reports per segment the mean p_cost per joint group, the tracking error and the share of
each running gait over all of them; the figure shows robot 0. Nothing learns: the estimator and the power predictor
stay as saved.
"""

from __future__ import annotations

import sys

from wqwarp.cli.evaluate import main as protocol_main


def main(argv: list[str] | None = None) -> int:
    """``train/evaluate.py --protocol timeline`` under this tool's name (``wqwarp.eval.protocols``)."""
    return protocol_main(argv, "timeline", __doc__)


if __name__ == "__main__":
    sys.exit(main())
