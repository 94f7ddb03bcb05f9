"""The compressor FMU's `periodic_map` fidelity: the detailed model's periodic steady state, tabulated at
initialization over a speed grid (mechanics.reduced.periodic_map) or, for the real-gas model, over speed x suction
pressure x discharge pressure (mechanics.reduced.fluid_map, docs/model.md §12.4), interpolated and integrated at run
time.

Real gas: the run follows shaft_speed, suction_pressure, discharge_pressure and the suction state (enthalpy, or
temperature converted on the table's suction states). Over a step the rates (shaft work, drawn and delivered mass
and enthalpy) are integrated exactly over the angle turned at the step's mean speed, pressures and suction
enthalpy (the inputs' means when they move linearly, their end values when held), so the cumulative flow outputs
are sums of the step increments, as the detailed model's; a pressure outside the table's box or a suction state
outside its range raises ValueError naming the input before anything changes (the FMU answers fmi2Discard).

Per communication step of length h the rotor angle follows the speed input held or moved linearly over the step,
theta_1 = theta_0 + (omega_0 + omega_1) h / 2, and the shaft work is the exact integral of the interpolated
torque over the angle turned, at the step's mean speed, plus the rotor's kinetic energy change
1/2 J2 (omega_1^2 - omega_0^2) (docs/model.md §6.4). Every other output is the table's value at (theta_1, speed_1).
Below the lowest grid speed (10 % of pressure_table_speed) the waveform and figures of the lowest grid speed are
used, and above the highest (120 %) those of the highest: the table holds, never extrapolates.
"""
from __future__ import annotations

import math
from pathlib import Path

from ..mechanics.loop.outputs import STEP, fmu_outputs
from ..mechanics.parameters import short_repr
from ..mechanics.reduced.fluid_map import MASS_RATES, build_fluid_map, fluid_cache_key, system_grid
from ..mechanics.reduced.periodic_map import MapSettings, build_map, cache_key, default_cache_dir
from ..mechanics.contact.regions import REGION_COUNT
from ..mechanics.loop.speed import RPM

FIDELITIES = ("detailed", "periodic_map")
SHIPPED_TABLES = Path(__file__).resolve().parent.parent / "periodic_maps"    # inside an FMU built with --map
# FMU output -> table channel (the output column behind it, mechanics.loop.outputs)
OUTPUT_CHANNEL = {output.name: output.source for output in fmu_outputs() if output.per == STEP}
CONTACT_CHANNELS = tuple(f"normal_force_{k}" for k in range(1, REGION_COUNT + 1))
FLOWS = tuple(name for pair in MASS_RATES.items() for name in pair)   # drawn/delivered mass and enthalpy
FOLLOWS_FLUID = "real_gas"                                              # the pressure model whose map follows p_s, p_d


def map_table_for(params, operating_rpm: float):
    """The table of `params` with speeds from 10 % to 120 % of `operating_rpm`: shipped in the FMU if one was built
    for exactly these parameters and sources, else from the user's cache, else built now (in this process)."""
    settings = MapSettings(table_speed_rpm=operating_rpm)
    shipped = SHIPPED_TABLES / f"{cache_key(params, None, settings)}.npz"
    folder = SHIPPED_TABLES if shipped.exists() else default_cache_dir()
    return build_map(params, operating_rpm=operating_rpm, settings=settings, workers=1, cache_dir=folder)


def fluid_map_table_for(params, operating_rpm: float):
    """The fluid table of `params` on system_grid: shipped in the FMU if built for exactly these parameters and
    sources, else from the user's cache, else built now (in this process: minutes, docs/model.md §12.4)."""
    settings = system_grid(params, operating_rpm)
    shipped = SHIPPED_TABLES / f"{fluid_cache_key(params, settings)}.npz"
    folder = SHIPPED_TABLES if shipped.exists() else default_cache_dir()
    return build_fluid_map(params, settings, workers=1, cache_dir=folder)


def ship_table(params, operating_rpm: float) -> None:
    """Build the table the periodic_map fidelity of `params` uses into SHIPPED_TABLES (fmu_src.build --map)."""
    if params.pressure_model == FOLLOWS_FLUID:
        build_fluid_map(params, system_grid(params, operating_rpm), cache_dir=SHIPPED_TABLES)
    else:
        build_map(params, operating_rpm=operating_rpm, settings=MapSettings(table_speed_rpm=operating_rpm),
                  cache_dir=SHIPPED_TABLES)


class PeriodicMapRun:
    """The state of a periodic-map run: time, rotor angle and speed, cumulative shaft work; for the real-gas model
    also the cumulative flows and the boundary inputs of the last step."""

    def __init__(self, params, operating_rpm: float, speed_rpm: float, initial_angle: float, boundary: dict):
        self.follows_fluid = params.pressure_model == FOLLOWS_FLUID
        self.table = (fluid_map_table_for if self.follows_fluid else map_table_for)(params, operating_rpm)
        self.rotor_inertia = params.rotor_inertia
        self.time = 0.0
        self.angle = float(initial_angle)
        self.speed_rpm = float(speed_rpm)
        self.work = 0.0
        self.acceleration = 0.0
        self.flows = dict.fromkeys(FLOWS, 0.0)
        self.point = (0.0, 0.0, 0.0)                   # p_s, p_d, h_s of the last step
        self.contact_mode = 0           # bit k-1: tabulated normal force of region ck > 0
        if self.follows_fluid:
            self.point = self.boundary_point(boundary)

    def get_state(self) -> dict:
        return dict(time=self.time, angle=self.angle, speed_rpm=self.speed_rpm, work=self.work,
                    acceleration=self.acceleration, suction_pressure=self.point[0],
                    discharge_pressure=self.point[1], suction_enthalpy=self.point[2], **self.flows)

    def set_state(self, state: dict) -> None:
        state = dict(state)
        self.point = tuple(state.pop(name) for name in ("suction_pressure", "discharge_pressure",
                                                         "suction_enthalpy"))
        for name in FLOWS:
            self.flows[name] = state.pop(name)
        for name, value in state.items():
            setattr(self, name, value)

    def boundary_point(self, boundary: dict) -> tuple[float, float, float]:
        """(p_s, p_d, h_s) of the inputs (h_s from T_s on the table's suction states); ValueError naming an input
        outside the table's box or suction states."""
        p_s, p_d = boundary["suction_pressure"], boundary["discharge_pressure"]
        error = self.table.box_error(p_s, p_d)
        if error is not None:
            raise ValueError(error)
        h_s = boundary.get("suction_enthalpy")
        if h_s is None:
            h_s = self.table.suction_enthalpy_at(p_s, boundary["suction_temperature"])
        self.table.suction_correction(p_s, h_s)           # refuses a suction state outside the table's
        return (p_s, p_d, h_s)

    def advance(self, step: float, speed_rpm: float, interpolate: bool, boundary: dict | None = None
                ) -> tuple[float, float]:
        """Advance by `step` [s] with the speed (and the boundary inputs) ramped (interpolate) or jumped and held;
        (work, angle) of the step. Nothing changes if a boundary input is refused (ValueError)."""
        start_speed = self.speed_rpm if interpolate else speed_rpm
        jump = 0.0 if interpolate else 0.5 * self.rotor_inertia * ((speed_rpm * RPM) ** 2
                                                                   - (self.speed_rpm * RPM) ** 2)
        angle = 0.5 * (start_speed + speed_rpm) * RPM * step
        mean_rpm = 0.5 * (start_speed + speed_rpm)
        if self.follows_fluid:
            point = self.boundary_point(boundary)
            mean = tuple(0.5 * (a + b) for a, b in zip(self.point, point)) if interpolate else point
            integrals = self.table.rate_integrals(self.angle, self.angle + angle, mean_rpm, *mean)
            shaft = integrals["shaft_work"]
        else:
            point, integrals = self.point, {}
            shaft = self.table.torque_integral(self.angle, self.angle + angle, mean_rpm)
        work = jump + shaft + 0.5 * self.rotor_inertia * ((speed_rpm * RPM) ** 2 - (start_speed * RPM) ** 2)
        self.acceleration = (speed_rpm - start_speed) * RPM / step
        self.time += step
        self.angle += angle
        self.speed_rpm = float(speed_rpm)
        self.work += work
        self.point = point
        for name in self.flows if self.follows_fluid else ():
            self.flows[name] += integrals[name]
        return work, angle

    def delivered_enthalpy_per_mass(self) -> float:
        """The table's delivered enthalpy / delivered mass over a revolution at the current point (0 if it
        delivers nothing): the step-mean discharge enthalpy of a step that delivered nothing."""
        revolution = self.table.rate_integrals(0.0, 2.0 * math.pi, self.speed_rpm, *self.point)
        mass = revolution["delivered_mass"]
        return revolution["delivered_enthalpy"] / mass if mass > 0.0 else 0.0

    def outputs(self) -> dict[str, float]:
        """End-of-step outputs and per-revolution figures at the current angle, speed (and pressures)."""
        where = (self.speed_rpm, *self.point[:2]) if self.follows_fluid else (self.speed_rpm,)
        channels = self.table.values(self.angle, *where)
        values = {name: channels[channel] for name, channel in OUTPUT_CHANNEL.items()}
        values["shaft_torque"] += self.rotor_inertia * self.acceleration
        for name, value in self.table.figures_at(*where).items():
            values[name] = value if math.isfinite(value) else 0.0   # real-gas figures under the tables: 0, as detailed
        self.contact_mode = sum(1 << k for k, channel in enumerate(CONTACT_CHANNELS) if channels[channel] > 0.0)
        return values


def check_fidelity(value) -> str:
    if value not in FIDELITIES:
        raise ValueError(f"parameter 'fidelity' = {short_repr(value)} is invalid: allowed one of "
                         f"{', '.join(FIDELITIES)}")
    return value

