"""tools/gait_trace.py: the CSV has exactly the documented columns and the gait's behaviour; bad input exits 2."""

from __future__ import annotations

import csv
import os
import subprocess
import sys

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
TOOL = os.path.join(ROOT, "tools", "gait_trace.py")


def _run(*args):
    return subprocess.run([sys.executable, TOOL, *args], capture_output=True, text=True, cwd=ROOT)


def test_trot_trace_columns_and_values(tmp_path):
    out, png = tmp_path / "trot.csv", tmp_path / "trot.png"
    r = _run(
        "--gait", "trotting", "--vx", "0.5", "--wz", "0.3", "--seconds", "2", "--csv", str(out), "--plot", str(png)
    )
    assert r.returncode == 0, r.stderr
    with open(out) as f:
        rows = list(csv.reader(f))
    header = rows[0]
    assert header == (
        ["t"]
        + [f"phase_{i}" for i in range(4)]
        + [f"swing_{i}" for i in range(4)]
        + [f"foot_z_{i}" for i in range(4)]
        + [f"wheel_vel_{i}" for i in range(4)]
        + [f"q_target_{i}" for i in range(12)]
    )
    data = np.array(rows[1:], dtype=float)
    assert data.shape == (100, 29)
    np.testing.assert_allclose(data[:, 0], np.arange(1, 101) * 0.02, atol=1e-6)
    phase, swing, z, wv = data[:, 1:5], data[:, 5:9], data[:, 9:13], data[:, 13:17]
    np.testing.assert_allclose(phase[:, 0], phase[:, 3], atol=1e-6)  # FR and RL in phase
    np.testing.assert_allclose(phase[:, 1], phase[:, 2], atol=1e-6)  # FL and RR in phase
    assert z.max() == np.float64(-0.1) or abs(z.max() + 0.1) < 2e-3  # apex -h_b + h_s
    assert abs(z.min() + 0.2) < 1e-6
    assert swing.sum(1).max() == 2
    # Eq. (3) with a positive yaw command: right wheels (FR, RR) faster than left wheels (FL, RL).
    assert np.all(wv[:, 0] > wv[:, 1]) and np.all(wv[:, 2] > wv[:, 3])
    np.testing.assert_allclose(wv.mean(1), 0.5 / 0.075, rtol=1e-3)
    assert png.stat().st_size > 1000


def test_bad_arguments_exit_2_without_writing(tmp_path):
    assert _run("--gait", "galloping", "--csv", str(tmp_path / "a.csv")).returncode == 2
    r = _run("--gait", "trotting", "--csv", str(tmp_path / "missing_dir" / "a.csv"))
    assert r.returncode == 2 and "does not exist" in r.stderr
    assert not any(tmp_path.iterdir())


def test_plot_eval_draws_fig4_and_rejects_bad_input(tmp_path):
    import json

    res = {
        "preset": "no_predictor",
        "results": [{"task": t, "mse": m, "mean_p_cost": p} for t, m, p in (("vx", 0.01, 100.0), ("vy", 0.1, 60.0))],
    }
    f = tmp_path / "eval.json"
    f.write_text(json.dumps(res))
    out = tmp_path / "fig4.png"
    tool = os.path.join(ROOT, "tools", "plot_eval.py")
    r = subprocess.run([sys.executable, tool, str(f), "--out", str(out)], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert out.stat().st_size > 1000
    bad = tmp_path / "bad.json"
    bad.write_text("{")
    r = subprocess.run(
        [sys.executable, tool, str(bad), "--out", str(tmp_path / "x.png")], capture_output=True, text=True
    )
    assert r.returncode == 2 and "cannot read" in r.stderr
