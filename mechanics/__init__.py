"""Vane dynamics with clearance: geometry, contact, equations of motion and the time loop (docs/model.md §1-§6, §8)."""
from pathlib import Path

from ..kernels.compile_cache import install as _install_compile_cache

_install_compile_cache(Path(__file__).parent, __name__)       # before any kernel is defined

from .errors import ContactLawWarning, IntegrationError  # noqa: E402
from .parameters import REFERENCE_NUMERICS, CompressorParameters, declarations
from .simulation import History, Simulation, SimulationState
from .loop.speed import SpeedLaw, constant_speed, cycloidal_ramp, linear_ramp

__all__ = ["REFERENCE_NUMERICS", "CompressorParameters", "ContactLawWarning", "declarations", "History", "IntegrationError",
           "Simulation", "SimulationState", "SpeedLaw", "constant_speed", "cycloidal_ramp", "linear_ramp"]
