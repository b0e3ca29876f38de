"""A real package: ``pip install .`` (not editable) into a fresh virtual environment ships ``wqwarp``,
``wqwarp.kernels`` and the robot asset, and the main job trains from another directory with that install."""

from __future__ import annotations

import os
import site
import subprocess
import sys
import venv

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def test_non_editable_install_trains_from_another_directory(tmp_path):
    env_dir = tmp_path / "venv"
    venv.EnvBuilder(with_pip=False).create(env_dir)
    py = str(env_dir / "bin" / "python")
    new_site = subprocess.run(
        [py, "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
        capture_output=True,
        text=True,
        check=True,
    ).stdout.strip()
    # The dependencies (torch, warp, newton, ...) come from this interpreter's site-packages, appended after the new
    # environment's own: a path line in a .pth file does not run that folder's .pth files, so this checkout's
    # editable install of wqwarp stays invisible and only the copy installed below can be imported.
    with open(os.path.join(new_site, "deps.pth"), "w", encoding="utf-8") as f:
        f.write("\n".join(site.getsitepackages()) + "\n")
    r = subprocess.run(
        [sys.executable, "-m", "pip", "install", "-q", "--no-deps", "--target", new_site, ROOT],
        capture_output=True,
        text=True,
        cwd=tmp_path,
    )
    assert r.returncode == 0, r.stderr[-2000:]
    work = tmp_path / "elsewhere"
    work.mkdir()
    probe = (
        "import wqwarp, wqwarp.kernels, wqwarp.robot.constants as C, os; "
        "print(wqwarp.__file__); print(C.WHEELED_GO1_USD); print(os.path.isfile(C.WHEELED_GO1_USD))"
    )
    out = subprocess.run([py, "-c", probe], capture_output=True, text=True, cwd=work, check=True).stdout.split()
    assert out[0].startswith(new_site) and out[1].startswith(new_site) and out[2] == "True", out
    r = subprocess.run(
        [
            py,
            os.path.join(ROOT, "train", "ppo_newton.py"),
            "--num-envs",
            "4",
            "--max-iterations",
            "1",
            "--num-steps-per-env",
            "4",
            "--log-dir",
            str(work / "run"),
            "--no-export",
        ],
        capture_output=True,
        text=True,
        cwd=work,
        timeout=600,
    )
    assert r.returncode == 0, r.stderr[-3000:]
    assert (work / "run" / "model_0.pt").is_file()
