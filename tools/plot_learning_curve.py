"""Entry point of :mod:`wqwarp.cli.plot_learning_curve` (``--help`` says what it does)."""

import sys

from wqwarp.cli.plot_learning_curve import main

if __name__ == "__main__":
    sys.exit(main())
