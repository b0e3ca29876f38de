"""The main job: train the paper's residual PPO policy on the wheeled Go1 (``python train/ppo_newton.py --help``; the
command lives in ``wqwarp.cli.train``)."""

import sys

from wqwarp.cli.train import main

if __name__ == "__main__":
    sys.exit(main())
