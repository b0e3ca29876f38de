"""Shared test settings: Warp quiet; device tests run on every available device (Newton's ``get_test_devices``
style: Warp's CPU device, and ``cuda:0`` where CUDA is present); ``WQWARP_TEST_DEVICE=cpu`` or ``=cuda:0,cuda:1``
chooses the devices explicitly."""

import os

import pytest
import warp as wp

wp.config.quiet = True


def test_devices() -> list[str]:
    """Devices the device-parametrised tests run on."""
    chosen = os.environ.get("WQWARP_TEST_DEVICE")
    if chosen:
        return [d.strip() for d in chosen.split(",") if d.strip()]
    return ["cpu"] + (["cuda:0"] if wp.is_cuda_available() else [])


@pytest.fixture(scope="session", params=test_devices())
def device(request) -> str:
    """One test device per parametrisation: simulator, env and kernel tests run on each."""
    return request.param


def _cuda_params() -> list:
    cuda = [d for d in test_devices() if d.startswith("cuda")]
    return cuda or [pytest.param(None, marks=pytest.mark.skip(reason="needs CUDA (none available or chosen)"))]


@pytest.fixture(scope="session", params=_cuda_params())
def cuda_device(request) -> str:
    """Each CUDA device among :func:`test_devices`, for the tests of the CUDA path only; they skip without one."""
    return request.param


def _save_untrained_checkpoint(path: str, cfg) -> str:
    """Write the checkpoint an untrained run of ``cfg`` (a ``wqwarp.rl.config.EnvConfig``) would save, as
    ``train/ppo_newton.py`` does (configuration, policy, estimator, predictor, layout); returns ``path``."""
    from helpers import quiet_runner

    quiet_runner(cfg).save(str(path))
    return str(path)


@pytest.fixture(scope="session")
def save_checkpoint():
    """``save_checkpoint(path, cfg) -> path``: an untrained checkpoint of the env config ``cfg``."""
    return _save_untrained_checkpoint
