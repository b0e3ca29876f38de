"""Crash safety: training killed with SIGKILL between checkpoints loses at most one checkpoint interval, leaves every
file loadable, and resumes; a resumed runner holds everything the checkpoint saved."""

from __future__ import annotations

import contextlib
import io
import json
import os
import signal
import subprocess
import sys
import time

import torch
from helpers import task_runner

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
TRAIN = os.path.join(ROOT, "train", "ppo_newton.py")


def _iterations_logged(log) -> int:
    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

    acc = EventAccumulator(str(log), size_guidance={"scalars": 0})
    acc.Reload()  # tolerates a record cut short by the kill
    return max(e.step for e in acc.Scalars("Loss/value")) + 1


def test_sigkill_between_checkpoints_loses_at_most_one_interval_and_resumes(tmp_path):
    log = tmp_path / "run"
    args = ["--num-envs", "8", "--num-steps-per-env", "8", "--save-interval", "3", "--log-dir", str(log), "--no-export"]
    proc = subprocess.Popen(
        [sys.executable, TRAIN, "--max-iterations", "500", *args],
        cwd=ROOT,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        deadline = time.time() + 300
        while not (log / "model_6.pt").exists():
            assert proc.poll() is None, proc.stderr.read()[-2000:]
            assert time.time() < deadline, "no checkpoint within 300 s"
            time.sleep(0.2)
        time.sleep(1.0)
    finally:
        proc.send_signal(signal.SIGKILL)
        proc.wait()
    assert proc.returncode == -signal.SIGKILL
    ckpts = sorted(int(f[6:-3]) for f in os.listdir(log) if f.startswith("model_") and f.endswith(".pt"))
    assert ckpts[:3] == [0, 3, 6]
    for k in ckpts:  # every checkpoint is whole (written to a temporary file, then renamed)
        ckpt = torch.load(log / f"model_{k}.pt", weights_only=False)
        assert ckpt["iter"] == k and "estimator_state_dict" in ckpt and "rng" in ckpt["infos"]
    assert json.loads((log / "config.json").read_text())["train"]["save_interval"] == 3
    last = ckpts[-1]
    assert _iterations_logged(log) - 1 - last <= 3  # at most one checkpoint interval of work lost

    r = subprocess.run(
        [
            sys.executable,
            TRAIN,
            "--max-iterations",
            str(last + 3),
            "--resume",  # the new total
            str(log / f"model_{last}.pt"),
            *args,
        ],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert r.returncode == 0, r.stderr[-2000:]
    assert torch.load(log / f"model_{last + 2}.pt", weights_only=False)["iter"] == last + 2


def _runner(seed: int):
    return task_runner("ours-paper", num_envs=8, seed=seed, steps_per_env=8)


def test_resume_restores_networks_optimisers_schedule_and_random_state(tmp_path):
    a = _runner(1)
    with contextlib.redirect_stdout(io.StringIO()):
        a.learn(3)
    path = str(tmp_path / "m.pt")
    a.save(path)
    rng, env_rng, sel_rng = torch.get_rng_state(), a.env.gen.get_state(), a.env.gait_selector.gen.get_state()
    b = _runner(2)  # other seed, other initialisation
    torch.manual_seed(123)
    b.load(path, restore_rng=True)
    for x, y in (
        (a.alg.actor, b.alg.actor),
        (a.alg.critic, b.alg.critic),
        (a.env.estimator, b.env.estimator),
        (a.env.gait_selector.predictor, b.env.gait_selector.predictor),
    ):
        for (k, p), q in zip(x.state_dict().items(), y.state_dict().values(), strict=True):
            assert torch.equal(p, q), k  # weights and observation normalisers
    opt_a, opt_b = a.alg.optimizer.state_dict(), b.alg.optimizer.state_dict()
    assert all(torch.equal(opt_a["state"][k]["exp_avg"], opt_b["state"][k]["exp_avg"]) for k in opt_a["state"])
    assert b.env.gait_selector.iteration == a.env.gait_selector.iteration == 3
    assert b.env.gait_selector.temperature == a.env.gait_selector.temperature
    assert b.current_learning_iteration == a.current_learning_iteration
    assert torch.equal(torch.get_rng_state(), rng) and torch.equal(b.env.gen.get_state(), env_rng)
    assert torch.equal(b.env.gait_selector.gen.get_state(), sel_rng)
    c = _runner(2)  # evaluation-style load: the random state stays the evaluation's own
    torch.manual_seed(123)
    before = torch.get_rng_state()
    c.load(path)
    assert torch.equal(torch.get_rng_state(), before) and not torch.equal(c.env.gen.get_state(), env_rng)
