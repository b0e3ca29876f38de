"""The README's status table from a reproduction's results: one row per claim of the paper, the default tasks'
numbers as means and 95 % intervals over the training seeds, and each claim's verdict (``wqwarp.eval.status``).

Usage::

    python tools/readme_status.py                 # print the table built from docs/results/cpu/results.json
    python tools/readme_status.py --write         # put it into README.md between its two marker lines
    python tools/readme_status.py --check         # exit 1 when README.md's table is not the one the results build

The table sits in the README between the lines ``<!-- status table: ... -->`` and ``<!-- end of the status table
-->``; ``--write`` replaces only what lies between them, atomically, so the rest of the README is never touched.
"""

from __future__ import annotations

import json
import os
import sys

from wqwarp.cli.args import UsageError, doc_parser, entry_point, repo_path


@entry_point
def main(argv: list[str] | None = None) -> int:
    ap = doc_parser(__doc__)
    ap.add_argument(
        "--results",
        default=repo_path("docs/results/cpu/results.json"),
        help="results.json of a reproduction (train/reproduce.py; default docs/results/cpu/results.json)",
    )
    ap.add_argument("--readme", default=repo_path("README.md"), help="the README holding the table (default README.md)")
    mode = ap.add_mutually_exclusive_group()
    mode.add_argument("--write", action="store_true", help="replace the README's table with the one built")
    mode.add_argument("--check", action="store_true", help="exit 1 when the README's table differs from the one built")
    args = ap.parse_args(sys.argv[1:] if argv is None else argv)
    from wqwarp.eval.status import replace_block, status_table
    from wqwarp.utils.io import write_text_atomic

    if not os.path.isfile(args.results):
        raise UsageError(f"--results {args.results}: no such file (run train/reproduce.py first)")
    with open(args.results, encoding="utf-8") as f:
        try:
            summary = json.load(f)
        except json.JSONDecodeError as e:
            raise UsageError(f"--results {args.results}: not JSON ({e})") from None
    if "presets" not in summary or "seeds" not in summary:
        raise UsageError(f"--results {args.results}: not a reproduction's results.json (no presets and seeds)")
    if "claims" not in summary:
        raise UsageError(
            f"--results {args.results}: written before the claims and per-seed values existed; rebuild it with "
            "python train/reproduce.py --stages report (same --budget, --work and --seeds)"
        )
    table = status_table(summary)
    if not (args.write or args.check):
        print(table)
        return 0
    if not os.path.isfile(args.readme):
        raise UsageError(f"--readme {args.readme}: no such file")
    with open(args.readme, encoding="utf-8") as f:
        text = f.read()
    try:
        new = replace_block(text, table)
    except ValueError as e:
        raise UsageError(f"--readme {args.readme}: {e}") from None
    if args.check:
        if new != text:
            print(f"{args.readme}: its status table is not the one {args.results} builds (--write updates it)")
            return 1
        print(f"{args.readme}: status table up to date")
        return 0
    if new != text:
        write_text_atomic(args.readme, new)
    print(f"{args.readme}: status table {'written' if new != text else 'already up to date'}")
    return 0
