"""wqwarp.eval.stats: intervals over seeds against hand values and against simulation of their coverage."""

import math

import numpy as np
import pytest

from wqwarp.eval.stats import T_975, diff_ci, mean_ci, paired, per_seed_stat, ratio_ci, t_975, verdict


def test_the_t_quantile_is_the_table_then_an_expansion_that_joins_it():
    assert t_975(1) == 12.706 and t_975(2) == 4.303 and t_975(30) == 2.042
    assert abs(t_975(31) - 2.040) < 1e-3 and abs(t_975(60) - 2.000) < 1e-3 and abs(t_975(120) - 1.980) < 1e-3
    assert all(a > b for a, b in zip(T_975[:-1], T_975[1:], strict=True))  # monotone
    with pytest.raises(ValueError, match=">= 1"):
        t_975(0)


def test_the_mean_interval_by_hand():
    s = mean_ci([1.0, 2.0, 3.0, None])  # None: a seed without that record
    half = 4.303 * 1.0 / math.sqrt(3)
    assert s["mean"] == 2.0 and s["std"] == 1.0 and s["n"] == 3
    assert s["ci95"] == pytest.approx([2.0 - half, 2.0 + half])
    assert mean_ci([5.0]) == {"mean": 5.0, "std": 0.0, "n": 1, "ci95": None} and mean_ci([None]) is None


def test_the_mean_interval_covers_the_true_mean_95_percent_of_the_time():
    rng = np.random.default_rng(0)
    for n in (3, 5):
        hits = 0
        for _ in range(4000):
            lo, hi = mean_ci(list(rng.normal(1.0, 2.0, n)))["ci95"]
            hits += lo <= 1.0 <= hi
        assert 0.935 < hits / 4000 < 0.965, n


def test_a_paired_ratio_is_the_geometric_mean_of_the_seeds_ratios():
    r = ratio_ci([1.0, 2.0], [2.0, 4.0])  # 0.5 on both seeds: no spread
    assert r["ratio"] == pytest.approx(0.5) and r["ci95"] == pytest.approx([0.5, 0.5]) and r["n"] == 2
    r = ratio_ci([1.0, 4.0, 2.0], [2.0, 2.0, 2.0])  # ratios 0.5, 2, 1: logs -ln2, ln2, 0
    half = 4.303 * math.log(2) / math.sqrt(3)
    assert r["ratio"] == pytest.approx(1.0) and r["ci95"] == pytest.approx([math.exp(-half), math.exp(half)])
    assert r["per_seed"] == [0.5, 2.0, 1.0]
    with pytest.raises(ValueError, match="positive"):
        ratio_ci([1.0, -1.0], [1.0, 1.0])
    with pytest.raises(ValueError):
        ratio_ci([1.0], [1.0, 2.0])  # seeds must pair


def test_a_claim_holds_only_when_the_whole_interval_is_on_its_side():
    assert verdict([0.3, 0.9], 1.0, "below") == "holds"
    assert verdict([0.3, 1.1], 1.0, "below") == "undecided"
    assert verdict([1.0, 1.4], 1.0, "below") == "does not hold"
    assert verdict([1.2, 1.4], 1.0, "above") == "holds" and verdict([0.2, 1.0], 1.0, "above") == "does not hold"
    assert verdict(None, 1.0, "below") == "undecided"


def test_per_seed_values_pair_two_methods_on_the_seeds_they_share():
    a = per_seed_stat([(11, 1.0), (12, 3.0), (13, None)])  # seed 13 without a record
    b = per_seed_stat([(12, 2.0), (13, 5.0), (11, 4.0)])
    assert a["n"] == 2 and a["mean"] == 2.0 and a["per_seed"] == {"11": 1.0, "12": 3.0}
    assert paired(a, b) == (["11", "12"], [1.0, 3.0], [4.0, 2.0]) and paired(a, None) == ([], [], [])
    d = diff_ci([1.0, 3.0], [4.0, 2.0])  # differences -3, 1: mean -1, sd 2*sqrt(2)
    half = 12.706 * 2 * math.sqrt(2) / math.sqrt(2)
    assert d["mean"] == -1.0 and d["per_seed"] == [-3.0, 1.0] and d["ci95"] == pytest.approx([-1 - half, -1 + half])
    assert per_seed_stat([(1, None)]) is None and diff_ci([None], [1.0]) is None
