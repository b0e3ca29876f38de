"""Do the lateral falls under pushes come from commands past the training range? An A/B of push records
(``train/evaluate.py --protocol push --json``): arm A trained on lateral commands in [-0.7, 0.7] m/s (the task's),
arm B on a wider range, the same seeds, evaluated alike (Table III's v_y setting commands [-1, 1] m/s).

Usage::

    python tools/studies/lateral_range.py --a 11=A_s11_push.json,12=A_s12_push.json \\
        --b 11=B_s11_push.json,12=B_s12_push.json [--limit 0.7] [--json PATH]
    python tools/studies/lateral_range.py --a 11=A_s11_push.json,12=A_s12_push.json,13=A_s13_push.json

Per arm, seed and push level of the v_y setting: the share upright, the falls split by the fallen robot's lateral
command (within ``--limit`` or past it), and over the seeds the paired difference B - A of the share upright with
its 95 % interval (``wqwarp.eval.stats``). Without ``--b``, arm A alone: its falls split by command on every seed
given, and their totals (where do the task's own lateral falls come from). Nothing is simulated here: the numbers
are the records'.
"""

from __future__ import annotations

import json
import os
import sys

from wqwarp.cli.args import UsageError, add_result_options, doc_parser, entry_point


def read_arm(spec: str, option: str) -> dict[str, dict]:
    """``SEED=FILE,...`` -> {seed: {max_push: v_y push row}}; UsageError naming the problem."""
    out = {}
    for part in (p.strip() for p in spec.split(",") if p.strip()):
        seed, sep, path = part.partition("=")
        if not sep or not seed.isdigit() or not path:
            raise UsageError(f"{option} {part!r}: want SEED=FILE")
        if not os.path.isfile(path):
            raise UsageError(f"{option} seed {seed}: no such file: {path}")
        with open(path, encoding="utf-8") as f:
            rows = [r for r in json.load(f).get("results", []) if r.get("task") == "vy" and r.get("max_push")]
        if not rows:
            raise UsageError(
                f"{option} seed {seed}: {path} holds no v_y push result (train/evaluate.py --protocol push)"
            )
        out[seed] = {f"{r['max_push']:g}": r for r in rows}
    if not out:
        raise UsageError(f"{option}: no SEED=FILE given")
    return out


def fall_split(row: dict, limit: float) -> dict:
    """Falls of one record split by the fallen robot's lateral command: within |v_y| <= ``limit`` or past it."""
    cmds = [c[1] if isinstance(c, list | tuple) else c for c in row.get("fallen_commands") or []]
    past = sum(abs(float(c)) > limit + 1e-6 for c in cmds)
    return {"falls": int(row.get("falls", len(cmds))), "fallen_within": len(cmds) - past, "fallen_past": past}


def compare(a: dict, b: dict, limit: float) -> dict:
    from wqwarp.eval.stats import diff_ci

    seeds = [s for s in a if s in b] if b else list(a)
    levels = sorted({lvl for arm in (a, b) for rows in arm.values() for lvl in rows}, key=float)
    arms = {"A": a, "B": b} if b else {"A": a}
    out: dict = {"seeds": seeds, "limit": limit, "levels": {}}
    for lvl in levels:
        per_seed = {}
        for s in seeds:
            rows = {arm: records[s].get(lvl) for arm, records in arms.items()}
            if None in rows.values():
                continue
            per_seed[s] = {arm: {"upright": float(r["upright"]), **fall_split(r, limit)} for arm, r in rows.items()}
        paired = list(per_seed)
        diff = (
            diff_ci([per_seed[s]["B"]["upright"] for s in paired], [per_seed[s]["A"]["upright"] for s in paired])
            if b
            else None
        )
        totals = {
            arm: {k: sum(per_seed[s][arm][k] for s in paired) for k in ("falls", "fallen_within", "fallen_past")}
            for arm in arms
        }
        out["levels"][lvl] = {"per_seed": per_seed, "falls_total": totals, "upright_B_minus_A": diff}
    return out


@entry_point
def main(argv: list[str] | None = None) -> int:
    ap = doc_parser(__doc__)
    ap.add_argument("--a", required=True, help="arm A's push records, SEED=FILE,... (the task's lateral range)")
    ap.add_argument(
        "--b", help="arm B's push records, SEED=FILE,... (the wider lateral range); without it, arm A's falls alone"
    )
    ap.add_argument("--limit", type=float, default=0.7, help="arm A's lateral training range [m/s] (default 0.7)")
    add_result_options(ap, plot=None)
    args = ap.parse_args(sys.argv[1:] if argv is None else argv)
    if not args.limit > 0:
        raise UsageError(f"--limit {args.limit}: must be > 0")
    ap.check_outputs(args.json)
    result = compare(read_arm(args.a, "--a"), read_arm(args.b, "--b") if args.b else {}, args.limit)
    if not result["seeds"]:
        raise UsageError("--a and --b share no seed")
    for lvl, block in result["levels"].items():
        print(f"push {lvl} m/s, v_y setting (commands [-1, 1] m/s):")
        for s, arms in block["per_seed"].items():
            cells = "; ".join(
                f"{arm} {100 * r['upright']:.0f} % upright, falls {r['fallen_within']} within / "
                f"{r['fallen_past']} past {args.limit:g} m/s"
                for arm, r in arms.items()
            )
            print(f"  seed {s}: {cells}")
        for arm, t in block["falls_total"].items():
            print(f"  {arm}, all seeds: falls {t['fallen_within']} within / {t['fallen_past']} past {args.limit:g} m/s")
        d = block["upright_B_minus_A"]
        if d:
            ci = f" [{100 * d['ci95'][0]:+.1f}, {100 * d['ci95'][1]:+.1f}]" if d["ci95"] else ""
            print(f"  B - A upright: {100 * d['mean']:+.1f} pt{ci} over {d['n']} seed(s)")
    if args.json:
        from wqwarp.utils.provenance import write_result_json

        write_result_json(args.json, result)
    return 0


if __name__ == "__main__":
    sys.exit(main())
