"""Statistics over training seeds: the mean and its 95 % confidence interval, a paired ratio's interval, and the
verdict of a claim from an interval.

The unit is the seed: each training seed gives one value (its policy's MSE or power on a task, averaged over the
evaluation's robots); robots of one policy are not independent samples of the method. Intervals are Student-t
intervals over the seeds (two-sided 95 %), so two seeds give a wide interval (t = 12.7) and three a usable one
(t = 4.3). A ratio of two methods trained on the same seeds (``ours`` / the fixed trot, seed by seed) is judged on
the per-seed log ratios, so the interval is of the geometric mean ratio and stays positive.
"""

from __future__ import annotations

import math
import statistics
from collections.abc import Sequence
from typing import Literal

T_975 = (
    12.706, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365, 2.306, 2.262, 2.228,
    2.201, 2.179, 2.160, 2.145, 2.131, 2.120, 2.110, 2.101, 2.093, 2.086,
    2.080, 2.074, 2.069, 2.064, 2.060, 2.056, 2.052, 2.048, 2.045, 2.042,
)  # fmt: skip
"""The 97.5 % quantile of Student's t for 1-30 degrees of freedom (any statistics table)."""
Z_975 = 1.959964
"""The 97.5 % quantile of the standard normal."""

Verdict = Literal["holds", "does not hold", "undecided"]


def t_975(df: int) -> float:
    """Student-t 97.5 % quantile for ``df`` >= 1 degrees of freedom: the table to 30, then the Cornish-Fisher
    expansion (within 0.001 of the exact value from 30 on)."""
    if df < 1:
        raise ValueError(f"degrees of freedom must be >= 1, got {df}")
    if df <= len(T_975):
        return T_975[df - 1]
    z = Z_975
    return z + (z**3 + z) / (4 * df) + (5 * z**5 + 16 * z**3 + 3 * z) / (96 * df**2)


def mean_ci(values: Sequence[float | None]) -> dict | None:
    """Mean, sample standard deviation, count and the 95 % interval ``ci95`` [lo, hi] of the mean of the non-None
    ``values`` (one per seed); ``ci95`` None for a single value. None when there is no value."""
    v = [float(x) for x in values if x is not None]
    if not v:
        return None
    mean = statistics.fmean(v)
    if len(v) == 1:
        return {"mean": mean, "std": 0.0, "n": 1, "ci95": None}
    std = statistics.stdev(v)
    half = t_975(len(v) - 1) * std / math.sqrt(len(v))
    return {"mean": mean, "std": std, "n": len(v), "ci95": [mean - half, mean + half]}


def ratio_ci(a: Sequence[float], b: Sequence[float]) -> dict | None:
    """The ratio a / b of two methods trained on the same seeds (``a[i]``, ``b[i]``: seed i): the geometric mean of
    the per-seed ratios, its 95 % interval from the t interval of the log ratios (``ci95`` None for one seed), the
    per-seed ratios and the count. None without a pair of positive values."""
    pairs = [(float(x), float(y)) for x, y in zip(a, b, strict=True) if x is not None and y is not None]
    if any(x <= 0 or y <= 0 for x, y in pairs):
        raise ValueError(f"a ratio's interval needs positive values, got {pairs}")
    if not pairs:
        return None
    logs = mean_ci([math.log(x / y) for x, y in pairs])
    ci = None if logs["ci95"] is None else [math.exp(logs["ci95"][0]), math.exp(logs["ci95"][1])]
    return {"ratio": math.exp(logs["mean"]), "ci95": ci, "per_seed": [x / y for x, y in pairs], "n": len(pairs)}


def verdict(ci: Sequence[float] | None, bound: float, claim: Literal["below", "above"]) -> Verdict:
    """Whether an interval supports "the quantity is ``claim`` ``bound``": ``holds`` when the whole interval is on
    the claimed side, ``does not hold`` when the whole interval is on the other side (the bound itself counts as
    the other side), else ``undecided`` (also for no interval, a single seed)."""
    if ci is None:
        return "undecided"
    lo, hi = ci
    if claim == "below":
        return "holds" if hi < bound else "does not hold" if lo >= bound else "undecided"
    if claim == "above":
        return "holds" if lo > bound else "does not hold" if hi <= bound else "undecided"
    raise ValueError(f"claim must be 'below' or 'above', not {claim!r}")


def per_seed_stat(pairs: Sequence[tuple[int | str, float | None]]) -> dict | None:
    """:func:`mean_ci` of ``(seed, value)`` pairs with the values kept by seed (``per_seed``, keys the seeds as
    strings, as JSON has them), so that two methods are paired seed by seed later; None without a value."""
    kept = {str(s): float(v) for s, v in pairs if v is not None}
    out = mean_ci(list(kept.values()))
    return None if out is None else {**out, "per_seed": kept}


def paired(a: dict | None, b: dict | None) -> tuple[list[str], list[float], list[float]]:
    """The seeds two :func:`per_seed_stat` results share, with their values in the same order."""
    if not a or not b:
        return [], [], []
    seeds = [s for s in a["per_seed"] if s in b["per_seed"]]
    return seeds, [a["per_seed"][s] for s in seeds], [b["per_seed"][s] for s in seeds]


def diff_ci(a: Sequence[float], b: Sequence[float]) -> dict | None:
    """The difference a - b of two methods trained on the same seeds (``a[i]``, ``b[i]``: seed i): :func:`mean_ci`
    of the per-seed differences, with them as ``per_seed``; None without a pair. For shares near a bound (100 %
    upright) where a ratio says little."""
    d = [float(x) - float(y) for x, y in zip(a, b, strict=True) if x is not None and y is not None]
    out = mean_ci(d)
    return None if out is None else {**out, "per_seed": d}
