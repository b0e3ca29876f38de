"""Which of the paper's claims move when the same seeds are trained again? Two results pages' claims
(``results.json`` of ``train/reproduce.py``'s report, e.g. before and after some runs were replaced by retrained
ones), compared cell by cell: each comparison's estimate, 95 % interval, seeds and verdict in both, which
verdicts differ where both have data, and which comparisons have data only after.

Usage::

    git show 9d29e9b:docs/results/cpu/results.json > before.json
    python tools/studies/claims_moved.py --before before.json --after docs/results/cpu/results.json \\
        [--json PATH]

A verdict that changes when only the training runs behind it are drawn again (same code, seeds and budget) rests on
the run, not on the method: the table says which claims three seeds decide either way. Nothing is simulated here.
"""

from __future__ import annotations

import json
import os
import sys

from wqwarp.cli.args import UsageError, add_result_options, doc_parser, entry_point


def read_claims(path: str, option: str) -> dict[str, dict]:
    """``{"claim id | comparison": cell}`` of a results.json; UsageError naming the problem."""
    if not os.path.isfile(path):
        raise UsageError(f"{option}: no such file: {path}")
    with open(path, encoding="utf-8") as f:
        claims = json.load(f).get("claims")
    if not claims:
        raise UsageError(f"{option}: {path} holds no claims (a results.json of train/reproduce.py's report)")
    return {
        f"{c['id']} | {cell['label']}": {"claim": c["claim"], "measure": c["measure"], **cell}
        for c in claims
        for cell in c["cells"]
    }


def compare(before: dict, after: dict) -> dict:
    keep = ("estimate", "ci95", "n", "verdict")
    rows = {}
    for key in list(before) + [k for k in after if k not in before]:
        b, a = before.get(key) or {}, after.get(key) or {}
        rows[key] = {
            "claim": (a or b)["claim"],
            "measure": (a or b)["measure"],
            "before": {k: b.get(k) for k in keep},
            "after": {k: a.get(k) for k in keep},
        }
    data = {side: [k for k, r in rows.items() if r[side]["estimate"] is not None] for side in ("before", "after")}
    both = [k for k in data["before"] if k in data["after"]]
    for k, r in rows.items():
        r["moved"] = k in both and r["before"]["verdict"] != r["after"]["verdict"]
    return {
        "cells": rows,
        "moved": [k for k in both if rows[k]["moved"]],
        "compared": len(both),
        "only_after": [k for k in data["after"] if k not in data["before"]],
    }


def _fmt(c: dict) -> str:
    if c["estimate"] is None:
        return "-"
    ci = f" [{c['ci95'][0]:.3g}, {c['ci95'][1]:.3g}]" if c["ci95"] else ""
    return f"{c['estimate']:.3g}{ci} ({c['n']} seeds) {c['verdict']}"


@entry_point
def main(argv: list[str] | None = None) -> int:
    ap = doc_parser(__doc__)
    ap.add_argument("--before", required=True, help="the earlier results.json")
    ap.add_argument("--after", required=True, help="the later results.json")
    add_result_options(ap, plot=None)
    args = ap.parse_args(sys.argv[1:] if argv is None else argv)
    ap.check_outputs(args.json)
    result = compare(read_claims(args.before, "--before"), read_claims(args.after, "--after"))
    print(f"{len(result['moved'])} of {result['compared']} comparisons with data in both changed their verdict:")
    for key in result["moved"]:
        r = result["cells"][key]
        print(f"  {key}: {_fmt(r['before'])} -> {_fmt(r['after'])}")
    if result["only_after"]:
        print(f"with data only after: {', '.join(result['only_after'])}")
    if args.json:
        from wqwarp.utils.provenance import write_result_json

        write_result_json(args.json, result)
    return 0


if __name__ == "__main__":
    sys.exit(main())
