"""Entry point of :mod:`wqwarp.cli.bench` (``python tools/bench.py --help`` says what it does)."""

import sys

from wqwarp.cli.bench import main

if __name__ == "__main__":
    sys.exit(main())
