"""The reproduction page's Fig. 5 claims and issue 22's targets, checked on evaluation records of any runs: for an
A/B outside ``train/reproduce.py`` (e.g. every method trained with one more reward term), with the same checks and
the same wording as ``docs/RESULTS.md`` (``wqwarp.eval.report``), so that a variant's headline is read as the
reproduction's is.

Usage::

    python tools/studies/headline_checks.py \\
        --tracking ours=docs/studies/residual_energy/ours_pcost0.01_s1_tracking.json \\
        --tracking no_predictor=docs/studies/residual_energy/no_predictor_pcost0.01_s1_tracking.json \\
        --json docs/studies/residual_energy/headline_pcost0.01_s1.json

Each ``--tracking PRESET=FILE[,FILE...]`` names the tracking-protocol records (``train/evaluate.py --json``, one per
seed) of one method; ``--nominal FILE`` the zero-residual record of ``ours`` (``--zero-residual``). The checks that
need a record not given are left out (e.g. the driving floor, which needs the reproduction's energy map). Nothing is
trained or evaluated here: the numbers are the records'.
"""

from __future__ import annotations

import os
import shutil
import sys
import tempfile

from wqwarp.cli.args import UsageError, add_result_options, doc_parser, entry_point


def parse_tracking(items: list[str]) -> dict[str, list[str]]:
    """``["ours=a.json,b.json", ...]`` -> {"ours": ["a.json", "b.json"]}; ValueError naming the bad item."""
    from wqwarp.rl.presets import PRESET_ORDER

    out: dict[str, list[str]] = {}
    for item in items:
        preset, sep, files = item.partition("=")
        paths = [f for f in files.split(",") if f]
        if not sep or preset not in PRESET_ORDER or not paths:
            raise ValueError(
                f"--tracking {item!r}: want PRESET=FILE[,FILE...] with a preset of {', '.join(PRESET_ORDER)}"
            )
        if preset in out:
            raise ValueError(f"--tracking names {preset} twice (give its seeds' files in one, comma-separated)")
        for f in paths:
            if not os.path.isfile(f):
                raise ValueError(f"--tracking {preset}: no such file: {f}")
        out[preset] = paths
    return out


def checks(tracking: dict[str, list[str]], nominal: str | None = None) -> dict:
    """The report's summary of these records (``wqwarp.eval.report.collect``) and its Fig. 5 and target lines."""
    from wqwarp.eval.report import _ordering_checks, _target_checks, collect

    seeds = list(range(1, max(len(v) for v in tracking.values()) + 1))
    with tempfile.TemporaryDirectory() as work:
        ev = os.path.join(work, "eval")
        os.makedirs(ev)
        for preset, files in tracking.items():
            for seed, f in zip(seeds, files, strict=False):
                shutil.copyfile(f, os.path.join(ev, f"{preset}_s{seed}_tracking.json"))
        if nominal:
            shutil.copyfile(nominal, os.path.join(ev, "ours_s1_nominal.json"))
        summary = collect(work, list(tracking), seeds)
    return {
        "inputs": {p: [os.path.abspath(f) for f in fs] for p, fs in tracking.items()}
        | ({"nominal": os.path.abspath(nominal)} if nominal else {}),
        "fig5_claims": _ordering_checks(summary),
        "targets": _target_checks(summary),
    }


@entry_point
def main(argv: list[str] | None = None) -> int:
    ap = doc_parser(__doc__)
    ap.add_argument(
        "--tracking",
        action="append",
        default=[],
        metavar="PRESET=FILE[,FILE...]",
        help="tracking records of one method, one file per seed (repeat per method; ours and "
        "no_predictor for the headline)",
    )
    ap.add_argument(
        "--nominal",
        default=None,
        metavar="FILE",
        help="zero-residual record of ours (train/evaluate.py --zero-residual), for the residual's energy targets",
    )
    add_result_options(ap, plot=None)
    args = ap.parse_args(argv)
    try:
        tracking = parse_tracking(args.tracking)
        if not tracking:
            raise ValueError("give at least one --tracking PRESET=FILE")
        if args.nominal and not os.path.isfile(args.nominal):
            raise ValueError(f"--nominal: no such file: {args.nominal}")
    except ValueError as e:
        raise UsageError(str(e)) from None
    ap.check_outputs(args.json)
    out = checks(tracking, args.nominal)
    for line in out["fig5_claims"] + out["targets"]:
        print(line)
    if args.json:
        from wqwarp.utils.provenance import write_result_json

        write_result_json(args.json, out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
