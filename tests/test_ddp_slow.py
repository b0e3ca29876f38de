"""Slow (excluded from CI; ``pytest -m slow``): multi-process PPO on CPU with torchrun (gloo), as on K GPUs."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys

import pytest
import torch

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


@pytest.mark.slow
def test_torchrun_two_cpu_processes_train_identical_networks(tmp_path):
    torchrun = shutil.which("torchrun") or os.path.join(os.path.dirname(sys.executable), "torchrun")
    log = tmp_path / "ddp"
    r = subprocess.run(
        [
            torchrun,
            "--nproc_per_node=2",
            os.path.join(ROOT, "train", "ppo_newton.py"),
            "--device",
            "cpu",
            "--num-envs",
            "8",
            "--max-iterations",
            "4",
            "--num-steps-per-env",
            "8",
            "--save-interval",
            "1",
            "--log-dir",
            str(log),
            "--no-export",
        ],
        capture_output=True,
        text=True,
        cwd=ROOT,
        timeout=900,
    )
    assert r.returncode == 0, r.stdout[-2000:] + r.stderr[-3000:]
    m = re.search(r"ranks in sync \(largest parameter difference to rank 0\): (.*)", r.stdout)
    assert m, r.stdout[-2000:]
    diffs = dict(kv.split() for kv in m.group(1).split(", "))
    assert set(diffs) == {"actor", "critic", "estimator", "predictor"}
    assert all(float(v) <= 1e-5 for v in diffs.values()), diffs
    assert "x 2 processes" in r.stdout and r.stdout.count("environment ready") == 1  # rank 0 talks, rank 1 not
    ckpt = torch.load(log / "model_3.pt", weights_only=False)
    assert ckpt["iter"] == 3
    # The ranks collected different data (seed + rank): the networks moved away from their common start.
    first = torch.load(log / "model_0.pt", weights_only=False)
    est, est0 = ckpt["estimator_state_dict"], first["estimator_state_dict"]
    moved = [k for k in est if not torch.equal(est[k], est0[k])]
    assert moved
