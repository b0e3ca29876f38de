"""Entry point of :mod:`wqwarp.cli.gait_trace` (``python tools/gait_trace.py --help`` says what it does)."""

import sys

from wqwarp.cli.gait_trace import main

if __name__ == "__main__":
    sys.exit(main())
