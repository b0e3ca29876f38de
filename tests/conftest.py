"""Shared test settings: Warp quiet, CPU by default; ``WQWARP_TEST_DEVICE=cuda:0`` runs device tests on CUDA."""

import os

import pytest
import warp as wp

wp.config.quiet = True


@pytest.fixture(scope="session")
def device() -> str:
    return os.environ.get("WQWARP_TEST_DEVICE", "cpu")
