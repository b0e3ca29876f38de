"""Reproduce the paper's evaluation in one command (the command: ``wqwarp.cli.reproduce``; its stages and budgets:
``wqwarp.eval.reproduce``)."""

from __future__ import annotations

import sys

from wqwarp.cli.reproduce import main

if __name__ == "__main__":
    sys.exit(main())
