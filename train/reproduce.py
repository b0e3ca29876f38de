"""Reproduce the paper's evaluation in one command (``wqwarp.eval.reproduce``: the stages, budgets and options)."""

from __future__ import annotations

import sys

from wqwarp.eval.reproduce import main

if __name__ == "__main__":
    sys.exit(main())
