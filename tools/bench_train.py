"""Entry point of :mod:`wqwarp.cli.bench_train` (``python tools/bench_train.py --help`` says what it does)."""

import sys

from wqwarp.cli.bench_train import main

if __name__ == "__main__":
    sys.exit(main())
