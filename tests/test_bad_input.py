"""Bad input at the entry points: one line naming the problem, exit code 2, nothing existing overwritten and no
partial file left. (Range checks of each option are tested beside their tools; these are the shared cases: a broken
or missing robot asset, a truncated or foreign checkpoint, an unwritable output.)"""

from __future__ import annotations

import contextlib
import importlib
import io
import os
import subprocess
import sys

import pytest
import torch

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)  # train/ and tools/ import as modules from the repository root


def _script(rel: str):
    """The module of an entry point ``train/x.py`` or ``tools/studies/y.py``, imported by name (its ``main``)."""
    return importlib.import_module(rel[: -len(".py")].replace("/", "."))


def _exit_code(main, argv) -> tuple[int, str]:
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        try:
            code = main(argv)
        except SystemExit as e:
            code = e.code
    return code, err.getvalue()


@pytest.fixture(scope="module")
def bad_files(tmp_path_factory, save_checkpoint):
    from wqwarp.rl.presets import make_preset

    d = tmp_path_factory.mktemp("bad")
    cfg = make_preset("ours")
    cfg.sim.num_envs = 4
    good = save_checkpoint(d / "model_0.pt", cfg)
    data = open(good, "rb").read()
    (d / "truncated.pt").write_bytes(data[: len(data) // 2])
    torch.save({"weights": torch.zeros(3)}, d / "foreign.pt")
    (d / "noise.pt").write_bytes(b"not a checkpoint at all")
    (d / "broken.usda").write_text("#usda 1.0\n( this is not USD\n")
    (d / "a_file").write_text("x")
    return d


@pytest.mark.parametrize("name", ["truncated.pt", "foreign.pt", "noise.pt"])
def test_resume_from_a_broken_checkpoint(bad_files, name, tmp_path):
    main = _script("train/ppo_newton.py").main
    code, err = _exit_code(
        main,
        [
            "--num-envs",
            "4",
            "--max-iterations",
            "1",
            "--resume",
            str(bad_files / name),
            "--log-dir",
            str(tmp_path / "run"),
            "--no-export",
        ],
    )
    assert code == 2 and err.count("\n") == 1 and name in err, err
    assert not (tmp_path / "run").exists()  # refused before anything is written


@pytest.mark.parametrize("name", ["truncated.pt", "foreign.pt", "noise.pt"])
def test_evaluate_a_broken_checkpoint(bad_files, name, tmp_path):
    main = _script("train/evaluate.py").main
    out = tmp_path / "eval.json"
    out.write_text("previous results")
    code, err = _exit_code(
        main,
        [
            "--checkpoint",
            str(bad_files / name),
            "--tasks",
            "vx",
            "--num-envs",
            "2",
            "--seconds",
            "3",
            "--json",
            str(out),
        ],
    )
    assert code == 2 and err.strip().startswith("error:") and err.count("\n") == 1 and name in err, err
    assert out.read_text() == "previous results"  # nothing existing overwritten
    assert sorted(os.listdir(tmp_path)) == ["eval.json"]  # and no partial file


@pytest.mark.parametrize("asset", ["missing.usda", "broken.usda"])
def test_a_missing_or_broken_robot_asset(bad_files, asset, tmp_path, monkeypatch):
    monkeypatch.setenv("WQWARP_ROBOT_USD", str(bad_files / asset))
    main = _script("train/ppo_newton.py").main
    code, err = _exit_code(main, ["--num-envs", "4", "--max-iterations", "1", "--log-dir", str(tmp_path / "run")])
    assert code == 2 and asset in err and "robot asset" in err and err.count("\n") == 1, err
    assert not (tmp_path / "run").exists()


def test_an_unwritable_log_dir(bad_files):
    main = _script("train/ppo_newton.py").main
    code, err = _exit_code(
        main, ["--num-envs", "4", "--max-iterations", "1", "--log-dir", str(bad_files / "a_file" / "run")]
    )
    assert code == 2 and "cannot be written" in err and err.count("\n") == 1, err
    code, err = _exit_code(main, ["--num-envs", "4", "--max-iterations", "1", "--log-dir", str(bad_files / "a_file")])
    assert code == 2 and "is a file" in err, err
    assert (bad_files / "a_file").read_text() == "x"


def test_export_usd_to_an_unwritable_place_and_from_a_broken_checkpoint(bad_files, tmp_path):
    main = _script("tools/export_usd.py").main
    code, err = _exit_code(main, ["--out", str(bad_files / "a_file" / "x.usda"), "--num-envs", "1", "--seconds", "0.1"])
    assert code == 2 and err.strip().startswith("error:"), err
    out = tmp_path / "roll.usda"
    code, err = _exit_code(
        main,
        ["--checkpoint", str(bad_files / "truncated.pt"), "--out", str(out), "--num-envs", "1", "--seconds", "0.1"],
    )
    assert code == 2 and "truncated.pt" in err and not out.exists(), err


SCRIPTS = sorted(
    f"{folder}/{f}"
    for folder in ("train", "tools", "tools/studies")
    for f in os.listdir(os.path.join(ROOT, folder))
    if f.endswith(".py") and f != "__init__.py"
)


@pytest.mark.parametrize("script", SCRIPTS)
def test_every_entry_point_reports_a_usage_error_in_one_line(script):
    code, err = _exit_code(_script(script).main, ["--no-such-option", "7"])
    assert code == 2, (code, err)
    # one line: the unknown option, or first the required options that are missing
    assert err.count("\n") == 1 and "error:" in err and ("--no-such-option" in err or "required" in err), err


USAGE_ERRORS = [
    ("tools/bench.py", ["--sizes", "0"], "--sizes"),
    ("tools/energy_audit.py", ["--seconds", "0"], "--seconds"),
    ("tools/export_usd.py", ["--out", "x.usda", "--num-envs", "0"], "--num-envs"),
    ("tools/gait_report.py", ["no_such_run"], "no such run directory"),
    ("tools/plot_learning_curve.py", ["no_such_run", "--out", "x.png"], "no such run directory"),
    ("tools/render_rollout.py", ["--checkpoint", "no_such.pt", "--out", "x.gif"], "no such checkpoint"),
    ("tools/studies/train_log_curves.py", ["train.log", "--window", "0"], "--window"),
    ("tools/studies/wheel_step_response.py", ["--gains", "2,10"], "--gains"),
]
"""A command, options that parse but that it refuses (a :class:`wqwarp.cli.args.UsageError`), and what its message
names."""


@pytest.mark.parametrize(("script", "argv", "names"), USAGE_ERRORS, ids=[s for s, _, _ in USAGE_ERRORS])
def test_a_refused_option_is_one_error_line_and_exit_2(script, argv, names, tmp_path):
    r = subprocess.run(
        [sys.executable, os.path.join(ROOT, script), *argv], cwd=tmp_path, capture_output=True, text=True, timeout=120
    )
    lines = r.stderr.splitlines()
    assert r.returncode == 2 and len(lines) == 1 and lines[0].startswith("error: ") and names in lines[0], r.stderr
    assert not os.listdir(tmp_path)  # nothing written


def test_evaluate_into_an_unwritable_place(bad_files):
    main = _script("train/evaluate.py").main
    code, err = _exit_code(
        main,
        [
            "--checkpoint",
            str(bad_files / "model_0.pt"),
            "--tasks",
            "vx",
            "--num-envs",
            "2",
            "--seconds",
            "3",
            "--json",
            str(bad_files / "a_file" / "eval.json"),
        ],
    )
    assert code == 2 and err.count("\n") == 1 and "eval.json" in err, err
