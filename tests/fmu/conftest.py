"""Fixtures shared by the tests of the built FMUs: the compressor FMU, and a host environment with its own numba
cache for each test module (so that no module's kernels are found in another's cache)."""
import os
from pathlib import Path

import pytest

import fmu_helpers as H


@pytest.fixture(scope="module")
def fmu(built_fmus) -> Path:
    """RotaryVaneCompressor.fmu built once per session from this checkout (or the file named by the environment
    variable RVC_FMU_UNDER_TEST, to test a given build)."""
    if os.environ.get("RVC_FMU_UNDER_TEST"):
        return Path(os.environ["RVC_FMU_UNDER_TEST"]).resolve()
    return built_fmus / f"{H.MODEL}.fmu"


@pytest.fixture(scope="module")
def env(tmp_path_factory) -> dict:
    """Host environment with a private numba cache for this module."""
    return H.host_environment(**{H.CACHE_ENVIRONMENT_VARIABLE: str(tmp_path_factory.mktemp("numba_cache"))})
