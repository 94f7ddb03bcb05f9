"""The default tolerances against a tight reference (docs/model.md §8.2, README "Speed"): the defaults (rtol 3e-5,
h_max 20 us) are the cheapest setting that keeps the per-revolution figures users read within 0.05 % (powers,
eta_m, mass flow) and 1 % (peak contact force) of an rtol = 1e-9 run. Checked where the motion repeats itself
(c = 0 and 0.05 mm; at 0.2 mm it is chaotic and no tolerance reproduces a 20-revolution mean better than a few
1e-4, benchmarks/bench_tolerances.py), for both pressure models, with Dormand-Prince (the default integrator)."""
import math

import numpy as np
import pytest

from rotary_vane.mechanics import CompressorParameters, Simulation, constant_speed
from rotary_vane.mechanics.performance import revolutions

WARM_UP, DURATION = 0.2, 0.6           # s: 10 revolutions averaged after 5 of warm-up
RELATIVE = {"input_power": 5e-4, "output_power": 5e-4, "friction_power": 5e-4, "mechanical_efficiency": 5e-4,
            "max_contact_force": 1e-2, "discharge_mass_flow": 5e-4}
TEMPERATURE = 0.01                     # K, discharge temperature


def means(clearance, model, **numerics):
    params = CompressorParameters(slot_clearance=clearance, stator_clearance=clearance, pressure_model=model,
                                  **numerics)
    simulation = Simulation(params, constant_speed(1500.0))
    simulation.advance(DURATION)
    summaries = [s for s in revolutions(simulation) if s.start_time >= WARM_UP]
    assert len(summaries) >= 9
    names = [*RELATIVE, "discharge_temperature"]
    return {name: float(np.mean([getattr(s, name) for s in summaries])) for name in names}


@pytest.mark.parametrize("model", ["ideal_gas_table", "real_gas"])
@pytest.mark.parametrize("clearance", [0.0, 0.05e-3])
def test_default_tolerances_keep_the_figures_within_their_bounds(clearance, model, check):
    default = means(clearance, model)
    reference = means(clearance, model, relative_tolerance=1e-9)
    for name, bound in RELATIVE.items():
        if not math.isfinite(reference[name]):          # the real-gas figures under the pressure table
            assert model == "ideal_gas_table" and name == "discharge_mass_flow"
            continue
        check(f"{model} c = {clearance * 1e3:g} mm: {name} vs rtol 1e-9",
              abs(default[name] / reference[name] - 1.0), bound)
    if model == "real_gas":
        check(f"real_gas c = {clearance * 1e3:g} mm: discharge temperature vs rtol 1e-9 [K]",
              abs(default["discharge_temperature"] - reference["discharge_temperature"]), TEMPERATURE)


@pytest.mark.slow
@pytest.mark.parametrize("clearance", [0.0, 0.05e-3])
def test_ark548_at_the_default_tolerances_keeps_the_real_gas_figures_within_their_bounds(clearance, check):
    """The chamber states implicit (integrator = "ark548", docs/model.md §8.2) at the default tolerances, against
    the same rtol 1e-9 Dormand-Prince run (measured: powers within 1.2e-4, peak force within 0.05 %)."""
    default = means(clearance, "real_gas", integrator="ark548")
    reference = means(clearance, "real_gas", relative_tolerance=1e-9)
    for name, bound in RELATIVE.items():
        check(f"ark548 c = {clearance * 1e3:g} mm: {name} vs rtol 1e-9", abs(default[name] / reference[name] - 1.0),
              bound)
    check(f"ark548 c = {clearance * 1e3:g} mm: discharge temperature vs rtol 1e-9 [K]",
          abs(default["discharge_temperature"] - reference["discharge_temperature"]), TEMPERATURE)
