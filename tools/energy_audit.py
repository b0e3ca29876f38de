"""Entry point of :mod:`wqwarp.cli.energy_audit` (``python tools/energy_audit.py --help`` says what it does)."""

import sys

from wqwarp.cli.energy_audit import main

if __name__ == "__main__":
    sys.exit(main())
