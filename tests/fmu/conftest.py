"""Fixtures shared by the tests of the built FMUs: the compressor FMU, the FMUs built with the refrigeration system
compressor's periodic map shipped, and a host environment with its own numba cache for each test module (so that no
module's kernels are found in another's cache)."""
import json
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


# the refrigeration system's compressor (fmu_src/systems/: the FMU's defaults with no rotor inertia, the motor's)
SYSTEM_COMPRESSOR_MAP = {"rotor_inertia": 0.0, "pressure_table_speed": 1500.0}


@pytest.fixture(scope="session")
def map_fmus(tmp_path_factory) -> Path:
    """The FMUs built once per session with `build --map` for SYSTEM_COMPRESSOR_MAP: the compressor ships its
    real-gas periodic map over speed x p_s x p_d (192 detailed runs on the build's worker processes, minutes), which
    every test of that parameter set then loads instead of building it again in its own FMU process."""
    folder = tmp_path_factory.mktemp("map_fmus")
    (folder / "params.json").write_text(json.dumps(SYSTEM_COMPRESSOR_MAP))
    return H.build_fmu(folder / "fmu", timeout=7200, options=("--map", str(folder / "params.json"))).parent
