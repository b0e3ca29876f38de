"""Entry point of :mod:`wqwarp.cli.export_usd` (``python tools/export_usd.py --help`` says what it does)."""

import sys

from wqwarp.cli.export_usd import main

if __name__ == "__main__":
    sys.exit(main())
