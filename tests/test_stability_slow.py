"""Slow (``pytest -m slow``): 1e5 robot-steps of random extreme actions and commands never let a non-finite value
through (the divergence guard, tools/studies/stability_fuzz.py)."""

from __future__ import annotations

import os
import sys

import pytest

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


@pytest.mark.slow
def test_extreme_random_actions_and_commands_stay_finite():
    from tools.studies.stability_fuzz import fuzz

    res = fuzz(100_000, 128, "ours", "auto", 0.005, 4, seed=3)
    c = res["counts"]
    assert c["robot_steps"] >= 100_000
    assert c["nonfinite_obs"] == 0 and c["nonfinite_rewards"] == 0 and c["nonfinite_logs"] == 0
    assert c["contact_terminations"] > 0  # the actions are extreme enough to make robots fall
    assert len(res["events"]) == min(c["unstable"], 50)
