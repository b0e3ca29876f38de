"""Learning curves of training runs from their console logs (the ``train/ppo_newton.py`` progress lines that
``train/reproduce.py`` commits as ``docs/results/<budget>/<preset>_s<seed>_train.log.gz``), for A/B comparisons at
equal samples when a run folder (its ``metrics.jsonl`` and event files, read by ``tools/time_to_skill.py``) did not
outlive its session.

Usage::

    python tools/studies/train_log_curves.py docs/results/cpu/ours_s1_train.log runs/ab/ours_pcost_s1.log \\
        --at 500,1000,2000,3000 --window 100 --skill vy=0.15,wz=0.3 --json curves.json

A ``.jsonl`` argument is read as a run's ``metrics.jsonl`` (or the every-10th-row copies the studies commit). A log
committed gzipped is read as it is (``X.gz``, or ``X`` when only ``X.gz`` exists).
Per log and ``--at`` iteration: the mean over the progress lines of the ``--window`` iterations up to it of the mean
episode reward, the training tracking errors (|error| of v_x, v_y, w under the training command distribution, with
exploration noise and domain randomisation) and the training power (p_cost over legs and wheels, likewise). Per
``--skill`` axis=threshold: the first iteration whose windowed error is below it. Training metrics, not evaluation.
"""

from __future__ import annotations

import re
import sys

from wqwarp.cli.args import UsageError, doc_parser, entry_point

LINE = re.compile(
    r"\] (\d+)/(\d+) ETA [0-9:]+ \| reward\s+(-?[\d.]+) \| err vx ([\d.]+) vy ([\d.]+) wz ([\d.]+) \| "
    r"power\s+([\d.]+) W \(legs\s+([\d.]+), wheels\s+([\d.]+)\)"
)
KEYS = ("reward", "err_vx", "err_vy", "err_wz", "power", "power_legs", "power_wheels")


JSONL_KEYS = {
    "reward": "mean_reward",
    "err_vx": "Metrics/vx_error",
    "err_vy": "Metrics/vy_error",
    "err_wz": "Metrics/wz_error",
    "power": "Metrics/p_cost",
    "power_legs": "Metrics/p_cost_legs",
    "power_wheels": "Metrics/p_cost_wheels",
}
"""The same numbers in a run's ``metrics.jsonl`` (``wqwarp.rl.progress``; the studies commit every 10th row)."""


def read_log(path: str) -> dict[int, dict[str, float]]:
    """Iteration -> the progress line's numbers (the last line of an iteration wins; a resumed run continues); a
    ``.jsonl`` file is read as a run's ``metrics.jsonl`` rows instead; either may be gzipped (``.gz``,
    :func:`wqwarp.utils.io.open_text`)."""
    from wqwarp.utils.io import open_text

    rows: dict[int, dict[str, float]] = {}
    with open_text(path, errors="replace") as f:
        text = f.read()
    if path.removesuffix(".gz").endswith(".jsonl"):
        import json

        for line in text.splitlines():
            try:
                r = json.loads(line)
                rows[int(r["iteration"])] = {k: float(r[v]) for k, v in JSONL_KEYS.items()}
            except (ValueError, KeyError, TypeError):
                continue  # a line cut short, or a row without these metrics
        return rows
    for m in LINE.finditer(text.replace("\r", "\n")):
        rows[int(m.group(1))] = dict(zip(KEYS, map(float, m.groups()[2:]), strict=True))
    return rows


def windowed(rows: dict[int, dict[str, float]], at: int, window: int) -> dict[str, float] | None:
    """Mean of every key over the rows with iteration in (at - window, at]; None without rows there."""
    hit = [r for it, r in rows.items() if at - window < it <= at]
    if not hit:
        return None
    return {k: sum(r[k] for r in hit) / len(hit) for k in KEYS} | {"lines": len(hit)}


def first_below(rows: dict[int, dict[str, float]], key: str, threshold: float, window: int) -> int | None:
    """First iteration whose windowed ``key`` is below ``threshold``."""
    for it in sorted(rows):
        w = windowed(rows, it, window)
        if w is not None and it >= window and w[key] < threshold:
            return it
    return None


@entry_point
def main(argv=None) -> int:
    ap = doc_parser(__doc__)
    ap.add_argument("logs", nargs="+", help="console logs of train/ppo_newton.py")
    ap.add_argument("--at", default="500,1000,2000,2999", help="iterations to report (comma-separated)")
    ap.add_argument("--window", type=int, default=100, help="iterations averaged up to each point (default 100)")
    ap.add_argument("--skill", default="", help="axis=threshold pairs, e.g. vy=0.15,wz=0.3: first iteration below")
    ap.add_argument("--json", default=None, help="also write the table here")
    args = ap.parse_args(argv)
    try:
        at = [int(x) for x in args.at.split(",") if x.strip()]
        skill = {k.strip(): float(v) for k, v in (p.split("=") for p in args.skill.split(",") if p.strip())}
    except ValueError:
        raise UsageError(f"--at {args.at!r} / --skill {args.skill!r}: need integers / axis=number pairs") from None
    if bad := [k for k in skill if f"err_{k}" not in KEYS]:
        raise UsageError(f"--skill axes {bad}: choose from vx, vy, wz")
    if args.window < 1:
        raise UsageError("--window must be >= 1")
    ap.check_outputs(args.json)
    out = {"window": args.window, "logs": {}}
    for path in args.logs:
        try:
            rows = read_log(path)
        except OSError as e:
            raise UsageError(f"cannot read {path}: {e}") from None
        if not rows:
            raise UsageError(f"{path} has no progress lines of train/ppo_newton.py")
        table = {it: windowed(rows, it, args.window) for it in at}
        firsts = {k: first_below(rows, f"err_{k}", t, args.window) for k, t in skill.items()}
        out["logs"][path] = {"points": table, "first_below": firsts, "last_iteration": max(rows)}
        print(f"\n{path} (last iteration {max(rows)})")
        print(
            f"{'iteration':>9} {'reward':>8} {'err vx':>7} {'err vy':>7} {'err wz':>7} {'power':>7} {'legs':>7} "
            f"{'wheels':>7}"
        )
        for it, w in table.items():
            if w is None:
                print(f"{it:>9} {'-':>8}")
                continue
            print(
                f"{it:>9} {w['reward']:8.1f} {w['err_vx']:7.3f} {w['err_vy']:7.3f} {w['err_wz']:7.3f} "
                f"{w['power']:7.1f} {w['power_legs']:7.1f} {w['power_wheels']:7.1f}"
            )
        for k, it in firsts.items():
            print(f"  first iteration with windowed err {k} < {skill[k]:g}: {it if it is not None else 'never'}")
    if args.json:
        from wqwarp.utils.provenance import write_result_json

        write_result_json(args.json, out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
