"""tools/render_rollout.py: a GIF with one panel per robot, frames that show something and change; bad input exits 2
and writes nothing. Offscreen OpenGL through EGL (mesa's software renderer on a machine without a GPU)."""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
TOOL = os.path.join(ROOT, "tools", "render_rollout.py")


def _run(*args, env=None):
    return subprocess.run([sys.executable, TOOL, *args], capture_output=True, text=True, cwd=ROOT, env=env)


@pytest.fixture(scope="module")
def checkpoint(tmp_path_factory, save_checkpoint) -> str:
    """An untrained 'ours' checkpoint (configuration, policy, estimator, predictor), as train/ppo_newton.py saves."""
    from wqwarp.rl.presets import make_preset

    cfg = make_preset("ours")
    cfg.sim.num_envs = 2
    return save_checkpoint(tmp_path_factory.mktemp("ckpt") / "model_0.pt", cfg)


def _frames(path) -> list[np.ndarray]:
    from PIL import Image

    with Image.open(path) as im:
        assert im.format == "GIF"
        out = []
        for i in range(im.n_frames):
            im.seek(i)
            out.append(np.asarray(im.convert("RGB"), dtype=np.float32))
    return out


def test_gif_has_a_panel_per_robot_and_moving_frames(checkpoint, tmp_path):
    out = tmp_path / "run.gif"
    w, h = 128, 96
    r = _run(
        "--checkpoint",
        checkpoint,
        "--out",
        str(out),
        "--robots",
        "2",
        "--segments",
        "0.6,0,0:0.5;0,0,0.8:0.5",
        "--fps",
        "25",
        "--width",
        str(w),
        "--height",
        str(h),
        "--seed",
        "3",
    )
    assert r.returncode == 0, r.stderr
    assert "100%" in r.stdout and "MUJOCO_GL=" in r.stdout
    assert sorted(os.listdir(tmp_path)) == ["run.gif"]  # no temporary file left beside it
    frames = _frames(out)
    assert len(frames) == 25  # 1 s at 25 fps: one frame every second 50 Hz policy step
    assert all(f.shape == (h, 2 * w, 3) for f in frames)  # two panels side by side
    for f in frames:
        for panel in (f[:, :w], f[:, w:]):
            assert panel.std() > 25.0  # ground, sky, robot and text: not a blank or black image (~55)
            assert panel[h // 2 :].std() > 20.0  # the scene below the overlay is not uniform either (~50)
    # Every frame differs from the one before (the clock in the overlay at least), and the scene under the overlay
    # changes over the second: the robot moves and the camera follows it over the checker ground.
    assert all(np.abs(a - b).mean() > 0.3 for a, b in zip(frames, frames[1:], strict=False))  # >= ~1.2
    assert np.abs(frames[0][h // 2 :, :w] - frames[-1][h // 2 :, :w]).mean() > 5.0  # ~28
    assert np.abs(frames[-1][:, :w] - frames[-1][:, w:]).mean() > 3.0  # each panel its own robot (~14)


def test_bad_input_exits_2_and_writes_nothing(checkpoint, tmp_path, capsys, monkeypatch):
    from wqwarp.cli.render import main

    def run(*args):
        code = main(list(args))
        return code, capsys.readouterr().err

    ok = ["--checkpoint", checkpoint, "--out", str(tmp_path / "a.gif")]
    cases = [
        (["--checkpoint", checkpoint, "--out", str(tmp_path / "x.avi")], "extension"),
        (["--checkpoint", str(tmp_path / "missing.pt"), "--out", str(tmp_path / "a.gif")], "no such checkpoint"),
        ([*ok, "--command", "0.5,0"], "--command"),
        ([*ok, "--command", "fast,0,0"], "--command"),
        ([*ok, "--segments", "0.5,0,0:-1"], "--segments"),
        ([*ok, "--robots", "0"], "--robots"),
        ([*ok, "--fps", "7"], "--fps"),
        (["--checkpoint", checkpoint, "--out", str(tmp_path / "no_dir" / "a.gif")], "does not exist"),
    ]
    for args, words in cases:
        code, err = run(*args)
        lines = err.strip().splitlines()
        assert code == 2 and len(lines) == 1 and lines[0].startswith("error: ") and words in lines[0], (args, err)
    monkeypatch.setitem(sys.modules, "imageio", None)  # as if not installed: .mp4 says how to get it
    code, err = run("--checkpoint", checkpoint, "--out", str(tmp_path / "a.mp4"))
    assert code == 2 and "pip install imageio imageio-ffmpeg" in err and ".gif" in err, err
    assert not any(tmp_path.iterdir())
    # A file that is no checkpoint fails after the output was opened: the existing video stays as it was.
    bad = tmp_path / "model_9.pt"
    bad.write_bytes(b"not a checkpoint")
    old = tmp_path / "old.gif"
    old.write_bytes(b"GIF89a previous video")
    code, err = run("--checkpoint", str(bad), "--out", str(old), "--robots", "1", "--seconds", "0.2")
    assert code == 2 and err.startswith("error: ") and "model_9.pt" in err, err
    assert old.read_bytes() == b"GIF89a previous video"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["model_9.pt", "old.gif"]
