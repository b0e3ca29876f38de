"""Shared test settings: Warp quiet, CPU by default; ``WQWARP_TEST_DEVICE=cuda:0`` runs device tests on CUDA."""

import os

import pytest
import warp as wp

wp.config.quiet = True


@pytest.fixture(scope="session")
def device() -> str:
    return os.environ.get("WQWARP_TEST_DEVICE", "cpu")


def _save_untrained_checkpoint(path: str, cfg) -> str:
    """Write the checkpoint an untrained run of ``cfg`` (a ``wqwarp.config.EnvConfig``) would save, as
    ``train/ppo_newton.py`` does (configuration, policy, estimator, predictor, layout); returns ``path``."""
    import contextlib
    import io

    from wqwarp.config import TrainConfig
    from wqwarp.env import WheeledGo1Env
    from wqwarp.runner import WqRunner

    with contextlib.redirect_stdout(io.StringIO()):  # rsl-rl prints the networks
        runner = WqRunner(WheeledGo1Env(cfg), TrainConfig().rsl_rl_dict(), log_dir=None, device="cpu")
    runner.save(str(path))
    return str(path)


@pytest.fixture(scope="session")
def save_checkpoint():
    """``save_checkpoint(path, cfg) -> path``: an untrained checkpoint of the env config ``cfg``."""
    return _save_untrained_checkpoint
