"""tools/studies/compare_physics.py: the trajectory summary (means after the settling second, RMS difference)."""

from __future__ import annotations

import importlib
import os
import sys

import numpy as np
import pytest

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))  # tools/ imports from the root


def _tool():
    return importlib.import_module("tools.studies.compare_physics")


def test_summary_means_and_rms_after_the_settling_second():
    tool = _tool()
    t = np.arange(1, 101) * 0.02  # 2 s at 50 Hz
    a = [dict(t=x, **{q: 1.0 for q in tool.QUANTITIES}) for x in t]
    b = [
        dict(t=x, **{q: (1.0 if x <= 1.0 else 1.0 + (0.3 if i % 2 else -0.1)) for q in tool.QUANTITIES})
        for i, x in enumerate(t)
    ]
    out = tool.compare({"mujoco_cpu": a, "featherstone": b}, ["mujoco_cpu", "featherstone"])
    kept = [(0.3 if i % 2 else -0.1) for i, x in enumerate(t) if x > 1.0]
    for q in tool.QUANTITIES:
        assert out[q]["mean_mujoco_cpu"] == pytest.approx(1.0)
        assert out[q]["mean_featherstone"] == pytest.approx(1.0 + np.mean(kept))
        assert out[q]["rms_featherstone_vs_mujoco_cpu"] == pytest.approx(np.sqrt(np.mean(np.square(kept))))
