"""Slow (excluded from CI; run with ``pytest -m slow``): a short real training run learns to track v_x."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


@pytest.mark.slow
def test_short_training_run_tracks_forward_speed(tmp_path):
    log = tmp_path / "run"
    r = subprocess.run(
        [
            sys.executable,
            os.path.join(ROOT, "train", "ppo_newton.py"),
            "no_predictor",
            "--num-envs",
            "128",
            "--max-iterations",
            "300",
            "--log-dir",
            str(log),
            "--no-export",
        ],
        capture_output=True,
        text=True,
        cwd=ROOT,
        timeout=3600,
    )
    assert r.returncode == 0, r.stderr[-2000:]
    from wqwarp.eval.loading import make_policy_runner
    from wqwarp.eval.tracking import run_task

    runner = make_policy_runner(str(log / "model_299.pt"), "no_predictor", num_envs=32)
    res = run_task(runner, "vx", seconds=10.0)
    # Measured after the energy fixes (wheel kp 0.5, authors' stance): with the increment reading 0.037 m/s and 78 %
    # upright after 300 iterations (v_x at 1000 iterations: 95 %; docs/experiments.md); the offset default passes too.
    # Tracking is what is learned by now; staying upright at +-1 m/s keeps improving with more iterations.
    assert res.mean_abs_error < 0.15 and res.upright >= 0.6
