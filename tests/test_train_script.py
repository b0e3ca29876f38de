"""train/ppo_newton.py and train/evaluate.py end to end in subprocesses, with a tiny budget."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest
import torch

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def _run(script, *args, timeout=600):
    return subprocess.run(
        [sys.executable, os.path.join(ROOT, "train", script), *args],
        capture_output=True,
        text=True,
        cwd=ROOT,
        timeout=timeout,
    )


def test_train_writes_checkpoint_resumes_and_evaluates(tmp_path):
    log = tmp_path / "run"
    r = _run("ppo_newton.py", "--num-envs", "8", "--max-iterations", "2", "--log-dir", str(log), "--save-interval", "1")
    assert r.returncode == 0, r.stderr[-2000:]
    assert (log / "model_0.pt").is_file() and (log / "model_1.pt").is_file()
    assert (log / "export" / "policy.pt2").is_file() and (log / "export" / "policy.onnx").is_file()
    assert [json.loads(line)["iteration"] for line in (log / "metrics.jsonl").read_text().splitlines()] == [1, 2]
    assert any(f.startswith("events.out.tfevents") for f in os.listdir(log))
    record = json.loads((log / "config.json").read_text())  # the resolved tree and the command line beside the run
    assert record["command"].startswith("train/ppo_newton.py --num-envs 8 --max-iterations 2")
    assert record["task"] == "ours" and record["env"]["sim"]["num_envs"] == 8 and record["train"]["max_iterations"] == 2
    assert record["overrides"] == {"env.sim.num_envs": 8, "train.max_iterations": 2, "train.save_interval": 1}
    ckpt = torch.load(log / "model_1.pt", weights_only=False)
    assert ckpt["infos"]["num_actions"] == 20 and "estimator_state_dict" in ckpt
    assert ckpt["infos"]["train_cfg"]["save_interval"] == 1  # the PPO settings travel with the checkpoint
    before = (log / "model_1.pt").read_bytes()

    # Resumed with no option but the new total: the run goes on in its folder with its own non-default options
    # (8 robots, a checkpoint every iteration), listed as it starts.
    r = _run("ppo_newton.py", "--resume", str(log / "model_1.pt"), "--max-iterations", "4", "--no-export")
    assert r.returncode == 0, r.stderr[-2000:]
    assert "resumed from" in r.stdout and "options over it: train.max_iterations 4" in r.stdout, r.stdout
    assert (log / "model_2.pt").is_file() and (log / "model_3.pt").is_file()
    assert (log / "model_1.pt").read_bytes() == before  # the checkpoint resumed from is never rewritten
    resumed = torch.load(log / "model_3.pt", weights_only=False)
    assert resumed["iter"] == 3 and resumed["infos"]["env_cfg"]["sim"]["num_envs"] == 8
    assert json.loads((log / "config.json").read_text()) == record  # the first record kept, the resume's beside it
    assert json.loads((log / "config_resume_1.json").read_text())["overrides"] == {"train.max_iterations": 4}

    # The exported onboard policy runs on a history of observations.
    policy = torch.export.load(str(log / "export" / "policy.pt2")).module()
    meta = json.loads((log / "export" / "policy.json").read_text())
    outs = policy(torch.zeros(2, meta["history_length"], meta["proprio_dim"]))  # ours: + predictor (+ tracking head)
    actions, power = outs[0], outs[1]
    assert actions.shape == (2, 20) and torch.isfinite(actions).all() and power.shape == (2, 3)
    assert meta["outputs"][:2] == ["actions", "predicted_power"] and len(outs) == len(meta["outputs"])

    # A fresh run into the same directory is refused (nothing already written is overwritten).
    r = _run("ppo_newton.py", "--num-envs", "8", "--max-iterations", "1", "--log-dir", str(log))
    assert r.returncode == 2 and "already holds checkpoints" in r.stderr

    # Another task's id beside --resume is refused: the checkpoint's configuration is the run's.
    r = _run("ppo_newton.py", "baseline", "--log-dir", str(tmp_path / "other"), "--resume", str(log / "model_3.pt"))
    assert r.returncode == 2 and "was trained as ours, not as task baseline" in r.stderr, r.stderr
    assert r.stderr.count("\n") == 1 and not (tmp_path / "other").exists()
    # ... and so is a resume past its total.
    r = _run("ppo_newton.py", "--resume", str(log / "model_3.pt"))
    assert r.returncode == 2 and "already reached its 4 iterations" in r.stderr and not (log / "model_4.pt").exists()

    out_json = tmp_path / "eval.json"
    r = _run(
        "evaluate.py",
        "--checkpoint",
        str(log / "model_3.pt"),
        "--tasks",
        "vx",
        "--num-envs",
        "4",
        "--seconds",
        "3",
        "--json",
        str(out_json),
    )
    assert r.returncode == 0, r.stderr[-2000:]
    res = json.loads(out_json.read_text())["results"][0]
    assert res["task"] == "vx" and 0.0 <= res["upright"] <= 1.0 and res["mean_p_cost"] > 0

    # The paper's Fig. 5 for the checkpoint: per-segment numbers agree with the recorded time series.
    seq = tmp_path / "seq.json"
    r = subprocess.run(
        [
            sys.executable,
            os.path.join(ROOT, "tools", "gait_sequence.py"),
            "--checkpoint",
            str(log / "model_3.pt"),
            "--robots",
            "1",
            "--segments",
            "0.5,0,0:0.5;0,0,0.4:0.5",
            "--json",
            str(seq),
        ],
        capture_output=True,
        text=True,
        cwd=ROOT,
        timeout=600,
    )
    assert r.returncode == 0, r.stderr[-2000:]
    d = json.loads(seq.read_text())
    ser = d["series_robot0"]
    assert len(ser["t"]) == 50 and len(d["segments"]) == 2
    for k, seg in enumerate(d["segments"]):
        part = ser["p_cost"][25 * k : 25 * (k + 1)]
        assert seg["mean_p_cost"] == pytest.approx(sum(part) / 25, rel=1e-3, abs=1e-3)
        assert min(ser["p_elec"][25 * k : 25 * (k + 1)]) > 0.0 and seg["mean_p_elec"] > 0.0
        assert sum(seg["gait_usage"].values()) == pytest.approx(1.0)
        running = ser["gait_running"][25 * k : 25 * (k + 1)]
        assert seg["gait_usage"]["driving"] == pytest.approx(running.count("driving") / 25)
    r = subprocess.run(
        [
            sys.executable,
            os.path.join(ROOT, "tools", "gait_sequence.py"),
            "--checkpoint",
            str(log / "model_3.pt"),
            "--segments",
            "0.5,0:1",
        ],
        capture_output=True,
        text=True,
        cwd=ROOT,
        timeout=600,
    )
    assert r.returncode == 2 and "bad segment" in r.stderr

    # The trained policy plays into a USD rollout (tools/export_usd.py --checkpoint).
    usd = tmp_path / "policy.usda"
    r = subprocess.run(
        [
            sys.executable,
            os.path.join(ROOT, "tools", "export_usd.py"),
            "--out",
            str(usd),
            "--checkpoint",
            str(log / "model_3.pt"),
            "--num-envs",
            "2",
            "--seconds",
            "1",
            "--command",
            "0.5,0,0",
        ],
        capture_output=True,
        text=True,
        cwd=ROOT,
        timeout=600,
    )
    assert r.returncode == 0, r.stderr[-2000:]
    from pxr import Usd

    stage = Usd.Stage.Open(str(usd))
    attr = stage.GetPrimAtPath("/World/robot_0").GetAttribute("wqwarp:command")
    assert len(attr.GetTimeSamples()) == 51 and tuple(attr.Get(10)) == pytest.approx((0.5, 0.0, 0.0))


def test_bad_arguments_exit_2(tmp_path):
    r = _run("ppo_newton.py", "--num-envs", "0", "--log-dir", str(tmp_path / "x"))
    assert r.returncode == 2 and "SimConfig.num_envs must be >= 1" in r.stderr and r.stderr.count("\n") == 1
    r = _run("ppo_newton.py", "--resume", str(tmp_path / "missing.pt"), "--log-dir", str(tmp_path / "y"))
    assert r.returncode == 2 and "no such checkpoint" in r.stderr
    r = _run("ppo_newton.py", "--help")
    assert r.returncode == 0 and "ours-paper" in r.stdout and "--resume" in r.stdout and "torchrun" in r.stdout
