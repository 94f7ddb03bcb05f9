"""Benchmark of the real-gas nozzle table (docs/model.md §7.4, thermo/real_gas_nozzle.py): prints figures, asserts
nothing.

Run from anywhere:  python benchmarks/bench_nozzle.py [--quick] [--calls N]

1. Evaluation inside numba (R134a, docs/model.md §7.1 envelope): ns per `real_gas_mass_flux` call over random
   upstream states and pressure ratios, along a chamber-like path, and as a dependent chain (each call waits for the
   previous result: latency, not throughput); `signed_real_gas_nozzle_flow`; the ideal-gas
   `control_volume.signed_nozzle_flow` beside it; the table rebuilt from its arrays inside numba on every call
   (the rebuild costs ~60 ns: do it once per kernel entry, not per flow);
   the cost of 7 paths x 2 evaluations per step.
2. Per fluid (R134a, CO2, R410A, Air; --quick: R134a): build and cache-load time, file size, memory, refused cells,
   the share of the property table's accepted states that the nozzle table refuses, and the worst relative error
   against CoolProp's equilibrium isentropic expansion (PS flashes, G maximised numerically) where upstream and
   throat are gas beyond the margin; the worst difference from equilibrium where the throat is flagged (status 8).
3. Real against ideal gas for R134a at the default duty: the flux of the real-gas table over the ideal-gas nozzle
   with the suction k and R that Level 1 uses today, for the paths of the machine.
Tables go to a temporary cache folder, never the user's.
"""
from __future__ import annotations

import argparse
import math
import sys
import tempfile
from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parents[1]

import numba  # noqa: E402
import numpy as np  # noqa: E402
from report import best_of, build_and_load_times, heading, table  # noqa: E402  (benchmarks/ is the script's folder)
from scipy.optimize import minimize_scalar  # noqa: E402

from rotary_vane.thermo.control_volume import signed_nozzle_flow  # noqa: E402
from rotary_vane.thermo.fluid import Fluid, coolprop, typical_operating_point  # noqa: E402
from rotary_vane.thermo.nozzle import isentropic_nozzle_mass_flow  # noqa: E402
from rotary_vane.thermo.property_table import (STATUS_OK, envelope_for, property_table_for,  # noqa: E402
                                               table_status)
from rotary_vane.thermo.real_gas_nozzle import (STATUS_THROAT_NEAR_SATURATION, nozzle_table_arrays,  # noqa: E402
                                                nozzle_table_for, nozzle_table_from_arrays, nozzle_table_path,
                                                real_gas_mass_flux, signed_real_gas_nozzle_flow)

PATHS_PER_STEP = 7             # suction L/T, discharge, valley leaks, tip leak, slot sides (issue 14)
EVALUATIONS_PER_PATH = 2
FLUIDS = ("R134a", "CO2", "R410A", "Air")


# 1. numba ----------------------------------------------------------------------------------------------------
@numba.njit
def flux_loop(temperatures, densities, pressures, downstream, nozzle_table):
    total = 0.0
    for k in range(temperatures.size):
        flux, status = real_gas_mass_flux(temperatures[k], densities[k], pressures[k], downstream[k], nozzle_table)
        total += flux + status
    return total


@numba.njit
def flux_chain(temperatures, densities, pressures, downstream, nozzle_table):
    total = 0.0
    for k in range(temperatures.size):     # the next call's input depends (negligibly) on the previous result
        flux, status = real_gas_mass_flux(temperatures[k], densities[k] + 1e-300 * total, pressures[k],
                                          downstream[k], nozzle_table)
        total += flux + status
    return total


@numba.njit
def signed_loop(temperatures, densities, pressures, downstream, nozzle_table):
    total = 0.0
    for k in range(temperatures.size):
        flow, status = signed_real_gas_nozzle_flow(0.7, 2e-5, temperatures[k], densities[k], pressures[k], 300.0,
                                                   20.0, downstream[k], nozzle_table)
        total += flow + status
    return total


@numba.njit
def ideal_loop(temperatures, densities, pressures, downstream, gamma, gas_constant):
    total = 0.0
    for k in range(temperatures.size):
        total += signed_nozzle_flow(0.7, 2e-5, pressures[k], temperatures[k], downstream[k], 300.0, gamma,
                                    gas_constant)
    return total


@numba.njit
def _one_from_arrays(arrays, temperature, density, pressure, pressure_down):
    return signed_real_gas_nozzle_flow(0.7, 2e-5, temperature, density, pressure, 300.0, 20.0, pressure_down,
                                       nozzle_table_from_arrays(*arrays))


@numba.njit
def rebuilt_loop(temperatures, densities, pressures, downstream, arrays):
    total = 0.0
    for k in range(temperatures.size):
        flux, status = _one_from_arrays(arrays, temperatures[k], densities[k], pressures[k], downstream[k])
        total += flux + status
    return total


@numba.njit
def bare_loop(temperatures, densities, pressures, downstream):
    total = 0.0
    for k in range(temperatures.size):
        total += temperatures[k] * densities[k] + pressures[k] * downstream[k]
    return total


def chamber_path(fluid: Fluid, calls: int, rng):
    """Compression cycles between the suction state and the isentropic discharge state (neighbouring calls are
    close, as in a time loop), each flowing to a downstream pressure between 0.3 and 1.1 times its own."""
    p_s, t_s, p_d = typical_operating_point(fluid)
    suction_density = fluid.density(t_s, p_s)
    end = fluid.state_at_pressure_entropy(p_d, fluid.properties(t_s, suction_density).entropy)
    phase = 0.5 * (1.0 - np.cos(np.linspace(0.0, 40.0 * math.pi, calls)))
    temperatures = t_s + phase * (end.temperature - t_s)
    densities = np.exp(np.log(suction_density) + phase * (np.log(end.density) - np.log(suction_density)))
    pressures = np.array([fluid.properties(t, r).pressure for t, r in zip(temperatures[::1000], densities[::1000])])
    pressures = np.interp(np.arange(calls), np.arange(calls)[::1000], pressures)
    downstream = pressures * (0.7 + 0.4 * np.cos(np.linspace(0.0, 60.0 * math.pi, calls)))
    return temperatures, densities, pressures, downstream


def numba_costs(fluid: Fluid, nozzle_table, envelope, calls: int, rng) -> dict:
    random_t = rng.uniform(envelope.temperature_min, envelope.temperature_max, calls)
    random_rho = np.exp(rng.uniform(math.log(envelope.density_min), math.log(envelope.density_max), calls))
    random_p = random_rho * fluid.gas_constant * random_t * 0.9
    random_down = random_p * rng.uniform(0.05, 1.1, calls)
    path = chamber_path(fluid, calls, rng)
    arrays = nozzle_table_arrays(nozzle_table)
    gamma = fluid.ideal_gas_exponent(typical_operating_point(fluid)[1])
    for function, extra in ((flux_loop, (nozzle_table,)), (flux_chain, (nozzle_table,)),
                            (signed_loop, (nozzle_table,)), (rebuilt_loop, (arrays,)),
                            (ideal_loop, (gamma, fluid.gas_constant)), (bare_loop, ())):
        function(*(a[:10] for a in path), *extra)                       # compile
    statuses = [real_gas_mass_flux(t, r, p, d, nozzle_table)[1] for t, r, p, d in zip(*(a[::997] for a in path))]
    return {
        "random": best_of(flux_loop, random_t, random_rho, random_p, random_down, nozzle_table) / calls,
        "path": best_of(flux_loop, *path, nozzle_table) / calls,
        "chain": best_of(flux_chain, *path, nozzle_table) / calls,
        "signed": best_of(signed_loop, *path, nozzle_table) / calls,
        "rebuilt": best_of(rebuilt_loop, *path, arrays) / calls,
        "ideal": best_of(ideal_loop, *path, gamma, fluid.gas_constant) / calls,
        "bare": best_of(bare_loop, *path) / calls,
        "path_ok": statuses.count(STATUS_OK) / len(statuses),
    }


def report_numba(costs: dict, calls: int) -> None:
    heading(f"1. evaluation inside numba, R134a (docs/model.md §7.1 envelope), {calls:.0e} calls, best of 5")
    rows = [["real_gas_mass_flux, random states and ratios over the envelope", f"{1e9 * costs['random']:.1f}"],
            ["real_gas_mass_flux, chamber-like path", f"{1e9 * costs['path']:.1f}"],
            ["real_gas_mass_flux, same path as a dependent chain (latency)", f"{1e9 * costs['chain']:.1f}"],
            ["signed_real_gas_nozzle_flow, same path", f"{1e9 * costs['signed']:.1f}"],
            ["  the same, the table rebuilt by nozzle_table_from_arrays on every call", f"{1e9 * costs['rebuilt']:.1f}"],
            ["control_volume.signed_nozzle_flow (ideal gas), same path", f"{1e9 * costs['ideal']:.1f}"],
            ["bare loop (read the four inputs; no table)", f"{1e9 * costs['bare']:.1f}"]]
    print(table(["case", "ns/call"], rows))
    per_step = PATHS_PER_STEP * EVALUATIONS_PER_PATH * costs["signed"]
    print(f"status 0 on {100 * costs['path_ok']:.0f} % of the path; per time step ({PATHS_PER_STEP} paths x "
          f"{EVALUATIONS_PER_PATH} = {PATHS_PER_STEP * EVALUATIONS_PER_PATH} signed flows): {1e9 * per_step:.0f} ns")


# 2. per fluid ----------------------------------------------------------------------------------------------------
class Equilibrium:
    """CoolProp's own isentropic expansion (PS flashes with phase determination) and its choked maximum."""

    def __init__(self, name, temperature, density):
        CP = coolprop()
        self.state = CP.AbstractState("HEOS", name)
        self.state.update(CP.DmassT_INPUTS, density, temperature)
        self.pressure, self.enthalpy, self.entropy = self.state.p(), self.state.hmass(), self.state.smass()

    def expand(self, pressure):
        CP = coolprop()
        self.state.update(CP.PSmass_INPUTS, pressure, self.entropy)
        flux = self.state.rhomass() * math.sqrt(max(0.0, 2.0 * (self.enthalpy - self.state.hmass())))
        return flux, self.state.T(), self.state.phase() == CP.iphase_twophase

    def flux(self, ratio):
        """(G, throat T, throat p, throat two-phase)."""
        result = minimize_scalar(lambda r: -self.expand(r * self.pressure)[0], bounds=(0.3, 0.99), method="bounded",
                                 options={"xatol": 1e-9})
        throat = max(ratio, result.x) * self.pressure
        flux, temperature, two_phase = self.expand(throat)
        return flux, temperature, throat, two_phase


def accuracy(fluid: Fluid, envelope, nozzle_table, samples: int, rng) -> dict:
    worst = worst_flagged = 0.0
    compared = flagged = 0
    for _ in range(samples):
        temperature = rng.uniform(envelope.temperature_min, envelope.temperature_max)
        density = math.exp(rng.uniform(math.log(envelope.density_min), math.log(envelope.density_max)))
        ratio = rng.uniform(0.02, 1.0) if rng.random() < 0.5 else 1.0 - 10.0 ** rng.uniform(-3.0, -0.5)
        if fluid.vapour_quality(temperature, density) is not None:
            continue
        try:
            reference = Equilibrium(fluid.name, temperature, density)
            if fluid.superheat(temperature, reference.pressure) < envelope.superheat_margin:
                continue
            exact, throat_t, throat_p, two_phase = reference.flux(ratio)
            throat_superheat = -1.0 if two_phase else fluid.superheat(throat_t, throat_p)
        except ValueError:
            continue
        flux, status = real_gas_mass_flux(temperature, density, reference.pressure, ratio * reference.pressure,
                                          nozzle_table)
        if status == STATUS_THROAT_NEAR_SATURATION:
            flagged += 1
            worst_flagged = max(worst_flagged, abs(flux / exact - 1.0))
        elif status == STATUS_OK and throat_superheat >= envelope.superheat_margin:
            compared += 1
            worst = max(worst, abs(flux / exact - 1.0))
    return {"worst": worst, "compared": compared, "flagged": flagged, "worst_flagged": worst_flagged}


def refused_share(fluid: Fluid, envelope, nozzle_table, cache_dir: Path, rng, count=20000) -> float:
    """Share of the property table's accepted states that the nozzle table refuses (status 1-7)."""
    property_table = property_table_for(fluid, envelope, cache_dir=cache_dir)
    t = rng.uniform(envelope.temperature_min, envelope.temperature_max, count)
    rho = np.exp(rng.uniform(math.log(envelope.density_min), math.log(envelope.density_max), count))
    accepted = refused = 0
    for temperature, density in zip(t, rho):
        if table_status(temperature, density, property_table) != STATUS_OK:
            continue
        accepted += 1
        status = real_gas_mass_flux(temperature, density, 1e6, 0.5e6, nozzle_table)[1]
        refused += status not in (STATUS_OK, STATUS_THROAT_NEAR_SATURATION)
    return refused / max(accepted, 1)


def fluid_figures(name: str, cache_dir: Path, samples: int, rng) -> dict:
    fluid = Fluid(name)
    envelope = envelope_for(fluid, *typical_operating_point(fluid))
    nozzle_table, build, load = build_and_load_times(nozzle_table_for, fluid, envelope, cache_dir=cache_dir)
    path = nozzle_table_path(fluid, envelope, cache_dir=cache_dir)
    memory = sum(v.nbytes for v in nozzle_table if isinstance(v, np.ndarray))
    return {"name": name, "envelope": envelope, "build": build, "load": load, "file": path.stat().st_size,
            "memory": memory, "grid": nozzle_table.shape_factor.shape,
            "refused_cells": int((~nozzle_table.accurate_cell).sum()),
            "refused_share": refused_share(fluid, envelope, nozzle_table, cache_dir, rng),
            **accuracy(fluid, envelope, nozzle_table, samples, rng)}


def report_fluids(figures: list[dict], samples: int) -> None:
    heading(f"2. per fluid: build, size, refusals, accuracy against CoolProp's equilibrium expansion "
            f"({samples} random upstream states and ratios)")
    rows = [[f["name"], f"{f['envelope'].temperature_min:.0f}-{f['envelope'].temperature_max:.0f} K, "
             f"{f['envelope'].density_min:.3g}-{f['envelope'].density_max:.3g} kg/m3",
             "x".join(str(n) for n in f["grid"]), f"{f['build']:.1f}", f"{1e3 * f['load']:.0f}",
             f"{f['file'] / 1e6:.2f}", f"{f['memory'] / 1e6:.2f}",
             f"{f['refused_cells']}", f"{100 * f['refused_share']:.2f} %",
             f"{f['compared']}", f"{f['worst']:.1e}", f"{f['flagged']}", f"{f['worst_flagged']:.1e}"]
            for f in figures]
    print(table(["fluid", "envelope (T, rho)", "grid", "build s", "load ms", "file MB", "memory MB",
                 "refused cells", "refused of accepted", "compared", "worst error", "flagged", "flagged vs equil."],
                rows))
    print("refused cells lie inside the dome (gas branch not evaluable) or next to the critical point; "
          "'refused of accepted' counts states the property table accepts; 'flagged vs equil.' is the gas-branch "
          "(metastable) flux against the equilibrium two-phase expansion where the throat is within the margin")


# 3. real vs ideal --------------------------------------------------------------------------------------------
def report_real_over_ideal(cache_dir: Path) -> None:
    fluid = Fluid("R134a")
    p_s, t_s, p_d = typical_operating_point(fluid)
    envelope = envelope_for(fluid, p_s, t_s, p_d)
    nozzle_table = nozzle_table_for(fluid, envelope, cache_dir=cache_dir)
    gamma, gas_constant = fluid.ideal_gas_exponent(t_s), fluid.gas_constant       # what Level 1 uses today
    suction_density = fluid.density(t_s, p_s)
    entropy = fluid.properties(t_s, suction_density).entropy
    cases = [("suction port: suction state -> 0.95 p_s", t_s, suction_density, p_s, 0.95 * p_s),
             ("leak at mid-compression (0.6 MPa) -> p_s", None, None, 0.6e6, p_s),
             ("discharge: 1.1 p_d -> p_d", None, None, 1.1 * p_d, p_d),
             ("valley leak: p_d -> p_s (choked)", None, None, p_d, p_s)]
    rows = []
    for label, temperature, density, pressure, downstream in cases:
        if temperature is None:
            state = fluid.state_at_pressure_entropy(pressure, entropy)
            temperature, density = state.temperature, state.density
        flux, status = real_gas_mass_flux(temperature, density, pressure, downstream, nozzle_table)
        ideal = isentropic_nozzle_mass_flow(1.0, 1.0, pressure, temperature, downstream, gamma, gas_constant)
        z = pressure / (density * gas_constant * temperature)
        rows.append([label, f"{temperature:.1f}", f"{z:.3f}", f"{flux:.0f}", f"{ideal:.0f}", f"{flux / ideal:.4f}",
                     str(status)])
    heading("3. R134a at the default duty: real-gas flux over the ideal-gas nozzle with the suction k, R "
            f"(k = {gamma:.4f}, R = {gas_constant:.2f} J/(kg K)), upstream on the suction isentrope")
    print(table(["path", "T_up K", "Z_up", "G real", "G ideal", "real/ideal", "status"], rows))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="R134a only, fewer calls and samples")
    parser.add_argument("--calls", type=int, default=None, help="numba calls per measurement (default 1e6)")
    args = parser.parse_args()
    calls = args.calls or (200_000 if args.quick else 1_000_000)
    samples = 150 if args.quick else 600
    rng = np.random.default_rng(1)
    print(f"python {sys.version.split()[0]}, numba {numba.__version__}, CoolProp "
          f"{coolprop().get_global_param_string('version')}")
    with tempfile.TemporaryDirectory() as folder:
        cache_dir = Path(folder)
        figures = [fluid_figures(name, cache_dir, samples, rng) for name in (FLUIDS[:1] if args.quick else FLUIDS)]
        fluid = Fluid("R134a")
        envelope = envelope_for(fluid, *typical_operating_point(fluid))
        costs = numba_costs(fluid, nozzle_table_for(fluid, envelope, cache_dir=cache_dir), envelope, calls, rng)
        report_numba(costs, calls)
        report_fluids(figures, samples)
        report_real_over_ideal(cache_dir)


if __name__ == "__main__":
    main()
