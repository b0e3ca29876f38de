"""Entry point of :mod:`wqwarp.cli.time_to_skill` (``python tools/time_to_skill.py --help`` says what it does)."""

import sys

from wqwarp.cli.time_to_skill import main

if __name__ == "__main__":
    sys.exit(main())
