"""Evaluate a trained checkpoint as in the paper: tracking error, energy (p_cost) and push recovery.

Examples::

    python train/evaluate.py --checkpoint runs/no_predictor_X/model_1499.pt --tasks vx --seconds 20
    python train/evaluate.py --checkpoint CKPT --tasks vx,vy,wz --push 0.5 --num-envs 256 --json eval.json
    python train/evaluate.py --protocol push --checkpoint CKPT --json push.json
    python train/evaluate.py --protocol timeline --checkpoint CKPT --json fig6.json --png fig6.png

Tracking tasks set one command axis, spread evenly over the paper's range (v_x in [-1, 1] m/s, v_y in [-0.7, 0.7]
m/s, w in [-0.7, 0.7] rad/s), the others zero; errors and power are averaged after a 2 s settling time over all
robots (a robot that falls is reset and keeps counting; falls are reported beside). ``--push V`` adds random
pushes up to V m/s every 15 s (Table III). With a predictive preset (ours, no_wheel_vel) each robot runs the argmin
of its predicted gait powers (tau -> 0), reselected every decision interval, unless ``--sample-gaits``; the share of
each running gait is reported per task. Nothing learns: the estimator and the power predictor stay as saved in the
checkpoint. The protocols are registered in ``wqwarp/eval/protocols.py``.
"""

from __future__ import annotations

import sys

from wqwarp.cli.evaluate import main as protocol_main


def main(argv: list[str] | None = None) -> int:
    return protocol_main(argv, None, __doc__)


if __name__ == "__main__":
    sys.exit(main())
