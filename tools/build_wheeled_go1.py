"""Entry point of :mod:`wqwarp.cli.build_asset` (``python tools/build_wheeled_go1.py --help`` says what it does)."""

import sys

from wqwarp.cli.build_asset import main

if __name__ == "__main__":
    sys.exit(main())
