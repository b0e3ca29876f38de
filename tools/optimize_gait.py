"""Entry point of :mod:`wqwarp.cli.optimize_gait` (``python tools/optimize_gait.py --help`` says what it does)."""

import sys

from wqwarp.cli.optimize_gait import main

if __name__ == "__main__":
    sys.exit(main())
