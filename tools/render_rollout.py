"""Entry point of :mod:`wqwarp.cli.render` (``python tools/render_rollout.py --help`` says what it does)."""

import sys

from wqwarp.cli.render import main

if __name__ == "__main__":
    sys.exit(main())
