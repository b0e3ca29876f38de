"""Entry point of :mod:`wqwarp.cli.readme_status` (``python tools/readme_status.py --help`` says what it does)."""

import sys

from wqwarp.cli.readme_status import main

if __name__ == "__main__":
    sys.exit(main())
