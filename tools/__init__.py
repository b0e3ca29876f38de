"""Developer tools (asset build, benchmarks, user commands' entry points; the code lives in :mod:`wqwarp.cli`) and,
in ``tools/studies/``, one-off studies. Importable from the repository root (``tools.studies.gradient_study``) for
the tests; run as scripts (``python tools/bench.py --help``)."""
