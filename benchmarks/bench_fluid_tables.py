"""Benchmark of the fluid-wide tables and the two-phase dome (docs/model.md §7.3.1, §7.3.2, §7.4.1): prints figures,
asserts nothing.

Run from anywhere:  python benchmarks/bench_fluid_tables.py [--quick] [--fluids R134a,CO2,...]

1. Per fluid (default R134a, R410A, R1234yf, R290, CO2; --quick: R134a): the declared input range and the
   fluid-wide envelope (thermo.fluid_envelope), the grid, build and cache-load time and file size of the property
   and nozzle tables over it, the saturation line's accepted end, refused cells.
2. Accuracy against HEOS: superheated states (random over the envelope, accepted by the table), and inside the dome
   (random T on the saturation line, quality 0.3-1): p, h (HEOS two-phase DmassT), c_v and (dp/dT)_rho (central
   differences of HEOS's u and p at fixed rho); the HEM nozzle flux from random wet upstream states against
   CoolProp's (p, s) expansion, and the flux step across the dew line.
3. A sweep over 10 random operating points of R134a inside its input range: the time to get the tables of all 10
   per operating point (property + nozzle table over `envelope_for` + the operating point, as a run does today)
   against once per fluid (the fluid-wide tables + the 10 operating points), each from an empty cache.
Tables go to temporary cache folders, never the user's.
"""
from __future__ import annotations

import argparse
import math
import os
import sys
import tempfile
import time
from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parents[1]

import numpy as np  # noqa: E402
from report import heading, table  # noqa: E402  (benchmarks/ is the script's folder)
from scipy.optimize import minimize_scalar  # noqa: E402

from rotary_vane.thermo.fluid import Fluid, coolprop  # noqa: E402
from rotary_vane.thermo.fluid_envelope import (fluid_envelope, fluid_grid, fluid_nozzle_grid,  # noqa: E402
                                               fluid_tables_for, input_range)
from rotary_vane.thermo.operating_point import operating_point_for  # noqa: E402
from rotary_vane.thermo.property_table import (STATUS_OK, envelope_for, property_table_for,  # noqa: E402
                                               property_table_path, table_quality, table_state)
from rotary_vane.thermo.real_gas_nozzle import nozzle_table_for, nozzle_table_path, real_gas_mass_flux  # noqa: E402

FLUIDS = ("R134a", "R410A", "R1234yf", "R290", "CO2")


def timed(function, *args, **kwargs):
    """(result, wall time, CPU time of this process): on a shared machine the CPU time is the undisturbed figure
    (the builds run in this process, single-threaded)."""
    start, cpu = time.perf_counter(), time.process_time()
    result = function(*args, **kwargs)
    return result, time.perf_counter() - start, time.process_time() - cpu


# 1. build -----------------------------------------------------------------------------------------------------
def build_figures(name: str, cache_dir: Path) -> dict:
    fluid = Fluid(name)
    envelope = fluid_envelope(fluid)
    grid = fluid_grid(envelope)
    nozzles_grid = fluid_nozzle_grid(envelope)
    properties, _, build = timed(property_table_for, fluid, envelope, *grid, cache_dir=cache_dir, two_phase=True)
    _, load, _ = timed(property_table_for, fluid, envelope, *grid, cache_dir=cache_dir, two_phase=True)
    nozzles, _, nozzle_build = timed(nozzle_table_for, fluid, envelope, *nozzles_grid, cache_dir=cache_dir,
                                     two_phase=True)
    _, nozzle_load, _ = timed(nozzle_table_for, fluid, envelope, *nozzles_grid, cache_dir=cache_dir, two_phase=True)
    return {"fluid": fluid, "inputs": input_range(fluid), "envelope": envelope, "grid": grid,
            "nozzle_grid": nozzles_grid, "properties": properties, "nozzles": nozzles,
            "build": build, "load": load, "nozzle_build": nozzle_build, "nozzle_load": nozzle_load,
            "file": property_table_path(fluid, envelope, *grid, cache_dir=cache_dir).stat().st_size,
            "nozzle_file": nozzle_table_path(fluid, envelope, *nozzles_grid, cache_dir=cache_dir).stat().st_size}


def report_builds(results: list[dict]) -> None:
    heading("1. fluid-wide envelope and tables (two_phase), temporary cache folder")
    rows = [[r["fluid"].name, f"{r['inputs'].suction_pressure_min / 1e6:.3g}-{r['inputs'].suction_pressure_max / 1e6:.3g}",
             f"{r['inputs'].discharge_pressure_max / 1e6:.3g}",
             f"{r['envelope'].temperature_min:.0f}-{r['envelope'].temperature_max:.0f}",
             f"{r['envelope'].density_min:.3g}-{r['envelope'].density_max:.3g}",
             f"{r['properties'].saturation_temperature_max:.1f} ({r['fluid'].critical_temperature:.1f})"]
            for r in results]
    print(table(["fluid", "p_s [MPa]", "p_d max [MPa]", "T [K]", "rho [kg/m^3]", "dome up to [K] (T_crit)"], rows))
    rows = [[r["fluid"].name, f"{r['grid'][0]} x {r['grid'][1]}", f"{r['build']:.1f}", f"{1e3 * r['load']:.0f}",
             f"{r['file'] / 1e6:.1f}",
             f"{int((~r['properties'].accurate_cell).sum())}/{r['properties'].accurate_cell.size}",
             f"{r['nozzle_grid'][0]} x {r['nozzle_grid'][1]}", f"{r['nozzle_build']:.1f}",
             f"{1e3 * r['nozzle_load']:.0f}", f"{r['nozzle_file'] / 1e6:.1f}",
             f"{int((~r['nozzles'].dome_accurate_cell).sum())}/{r['nozzles'].dome_accurate_cell.size}"]
            for r in results]
    print()
    print(table(["fluid", "property grid", "build CPU [s]", "load [ms]", "file [MB]", "refused cells",
                 "nozzle grid", "build CPU [s]", "load [ms]", "file [MB]", "refused HEM cells"], rows))


# 2. accuracy --------------------------------------------------------------------------------------------------
def superheated_errors(fluid: Fluid, properties, envelope, samples: int, rng):
    """Worst relative errors of p, h, c_v, (dp/dT)_rho at accepted single-phase states: over the whole rectangle,
    and at p <= p_max = 3 p_d,max (the rectangle also holds hot dense states up to several times p_max)."""
    high_pressure = 3.0 * input_range(fluid).discharge_pressure_max
    worst = np.zeros(4)
    below = np.zeros(4)
    accepted = 0
    while accepted < samples:
        temperature = rng.uniform(envelope.temperature_min, envelope.temperature_max)
        density = math.exp(rng.uniform(math.log(envelope.density_min), math.log(envelope.density_max)))
        state = table_state(temperature, density, properties)
        if state.status != STATUS_OK or table_quality(temperature, density, properties) < 1.0:
            continue
        accepted += 1
        e = fluid.properties(temperature, density)
        reference = np.array([e.pressure, e.enthalpy, e.isochoric_heat_capacity, e.pressure_temperature_derivative])
        errors = np.abs(np.array(state[:4]) / reference - 1.0)
        worst = np.maximum(worst, errors)
        if e.pressure <= high_pressure:
            below = np.maximum(below, errors)
    return worst, below


def dome_errors(fluid: Fluid, properties, samples: int, rng):
    """Worst relative errors of p, h, c_v, (dp/dT)_rho inside the dome, and how many states were refused."""
    CP = coolprop()
    heos = CP.AbstractState("HEOS", fluid.coolprop_name)
    worst = np.zeros(4)
    refused = 0
    step = 1e-4
    for _ in range(samples):
        temperature = rng.uniform(properties.saturation_temperature_min, properties.saturation_temperature_max)
        heos.update(CP.QT_INPUTS, rng.uniform(0.3, 1.0), temperature)
        density = heos.rhomass()
        state = table_state(temperature, density, properties)
        if state.status != STATUS_OK:
            refused += 1
            continue
        values = []
        for offset in (step, -step, 0.0):
            heos.update(CP.DmassT_INPUTS, density, temperature + offset)
            values.append((heos.umass(), heos.p(), heos.hmass()))
        reference = np.array([values[2][1], values[2][2], (values[0][0] - values[1][0]) / (2.0 * step),
                              (values[0][1] - values[1][1]) / (2.0 * step)])
        worst = np.maximum(worst, np.abs(np.array(state[:4]) / reference - 1.0))
    return worst, refused


def hem_flux(heos, pressure, enthalpy, entropy, ratio):
    CP = coolprop()
    heos.update(CP.PSmass_INPUTS, ratio * pressure, entropy)
    return heos.rhomass() * math.sqrt(2.0 * max(0.0, enthalpy - heos.hmass()))


def nozzle_errors(fluid: Fluid, nozzles, samples: int, rng):
    """Worst relative HEM flux error from wet upstream states (quality 0.5-1) and the largest relative step of the
    choked flux across the dew line; (error, step, refused)."""
    CP = coolprop()
    heos = CP.AbstractState("HEOS", fluid.coolprop_name)
    worst = largest_step = 0.0
    refused = 0
    for _ in range(samples):
        temperature = rng.uniform(nozzles.saturation_temperature_min, nozzles.saturation_temperature_max)
        heos.update(CP.QT_INPUTS, rng.uniform(0.5, 1.0), temperature)
        p0, h0, s0, rho0 = heos.p(), heos.hmass(), heos.smass(), heos.rhomass()
        ratio = rng.uniform(0.1, 0.99)
        lowest = max(0.06, fluid.dew_pressure(fluid.triple_temperature) / p0 + 1e-6)     # no solid states
        try:
            best = minimize_scalar(lambda r: -hem_flux(heos, p0, h0, s0, r), bounds=(lowest, 0.9999),
                                   method="bounded", options=dict(xatol=1e-10))
            expected = hem_flux(heos, p0, h0, s0, max(ratio, best.x))
        except ValueError:
            refused += 1                  # HEOS cannot follow this expansion: no reference, and the table's node
            continue                      # fails the same way (its cell is refused)
        flux, status = real_gas_mass_flux(temperature, rho0, p0, ratio * p0, nozzles)
        if status != STATUS_OK:
            refused += 1
            continue
        worst = max(worst, abs(flux / expected - 1.0))
        heos.update(CP.QT_INPUTS, 1.0, temperature)
        vapour = heos.rhomass()
        outside = real_gas_mass_flux(temperature, vapour * (1.0 - 1e-9), p0, 0.1 * p0, nozzles)
        inside = real_gas_mass_flux(temperature, vapour * (1.0 + 1e-9), p0, 0.1 * p0, nozzles)
        if inside[1] == STATUS_OK and outside[1] in (0, 8):
            largest_step = max(largest_step, abs(inside[0] / outside[0] - 1.0))
    return worst, largest_step, refused


def report_accuracy(results: list[dict], samples: int, rng) -> None:
    heading(f"2. accuracy against HEOS ({samples} states per column group; targets in the dome: p, h 1e-6, c_v 1e-4)")
    rows = []
    for r in results:
        fluid, properties = r["fluid"], r["properties"]
        gas, below = superheated_errors(fluid, properties, r["envelope"], samples, rng)
        dome, dome_refused = dome_errors(fluid, properties, samples, rng)
        nozzle, step, nozzle_refused = nozzle_errors(fluid, r["nozzles"], max(20, samples // 10), rng)
        rows.append([fluid.name] + [f"{e:.1e}" for e in gas] + [f"{below[0]:.1e}"] + [f"{e:.1e}" for e in dome]
                    + [str(dome_refused), f"{nozzle:.1e}", f"{step:.1e}", str(nozzle_refused)])
    print(table(["fluid", "gas p", "h", "c_v", "dp/dT", "p (p <= p_max)", "dome p", "h", "c_v", "dp/dT", "dome refused",
                 "HEM flux", "dew-line step", "refused"], rows))


# 3. sweep -----------------------------------------------------------------------------------------------------
def random_points(fluid: Fluid, count: int, rng):
    inputs = input_range(fluid)
    points = []
    for _ in range(count):
        suction = math.exp(rng.uniform(math.log(inputs.suction_pressure_min), math.log(inputs.suction_pressure_max)))
        temperature = fluid.saturation_temperature(suction) + rng.uniform(5.0, 20.0)
        discharge = rng.uniform(max(1.5 * suction, fluid.dew_pressure(303.15)), inputs.discharge_pressure_max)
        points.append((suction, temperature, discharge))
    return points


def per_point(fluid: Fluid, points, cache_dir: Path):
    for p_s, t_s, p_d in points:
        point = operating_point_for(fluid.name, p_s, t_s, p_d, cache_dir=cache_dir)
        property_table_for(point, point.envelope, cache_dir=cache_dir)
        nozzle_table_for(point, point.envelope, cache_dir=cache_dir)


def per_fluid(fluid: Fluid, points, cache_dir: Path):
    properties, _ = fluid_tables_for(fluid, cache_dir)
    for p_s, t_s, p_d in points:
        point = operating_point_for(fluid.name, p_s, t_s, p_d, cache_dir=cache_dir)
        assert table_state(t_s, point.suction_density, properties).status == STATUS_OK


def report_sweep(count: int, rng) -> None:
    fluid = Fluid("R134a")
    points = random_points(fluid, count, rng)
    heading(f"3. tables for {count} random R134a operating points inside the input range, empty caches")
    rows = []
    for label, function in (("per operating point (today)", per_point), ("once per fluid", per_fluid)):
        with tempfile.TemporaryDirectory() as folder:
            _, seconds, cpu = timed(function, fluid, points, Path(folder))
            size = sum(path.stat().st_size for path in Path(folder).iterdir())
        rows.append([label, f"{seconds:.1f}", f"{cpu:.1f}", f"{cpu / count:.1f}", f"{size / 1e6:.1f}"])
    print(table(["tables", "wall [s]", "CPU [s]", "CPU per point [s]", "cache [MB]"], rows))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="R134a only, fewer samples, 3 operating points")
    parser.add_argument("--fluids", default=None, help="comma-separated CoolProp names (default: all five)")
    args = parser.parse_args()
    names = args.fluids.split(",") if args.fluids else (FLUIDS[:1] if args.quick else FLUIDS)
    samples = 200 if args.quick else 1000
    CP = coolprop()
    print(f"python {sys.version.split()[0]}, CoolProp {CP.get_global_param_string('version')}, {os.cpu_count()} "
          f"CPUs, load average {os.getloadavg()[0]:.1f} (timings on a busy machine are inflated)")
    rng = np.random.default_rng(24)
    with tempfile.TemporaryDirectory() as folder:
        property_table_for(Fluid("R134a"), envelope_for(Fluid("R134a"), 0.2928e6, 283.15, 1.3179e6), 8, 8,
                           cache_dir=Path(folder))        # numba compile / cache load of the build kernels
        results = [build_figures(name, Path(folder)) for name in names]
        report_builds(results)
        report_accuracy(results, samples, rng)
    report_sweep(3 if args.quick else 10, rng)


if __name__ == "__main__":
    main()
