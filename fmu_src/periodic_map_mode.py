"""The compressor FMU's `periodic_map` fidelity: the detailed model's periodic steady state, tabulated at
initialization over a speed grid (mechanics.reduced.periodic_map), interpolated and integrated at run time.

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
from ..mechanics.reduced.periodic_map import MapSettings, build_map, cache_key, default_cache_dir
from ..mechanics.contact.regions import REGION_COUNT
from ..mechanics.loop.speed import RPM

FIDELITIES = ("detailed", "periodic_map")
SHIPPED_TABLES = Path(__file__).resolve().parent.parent / "periodic_maps"    # inside an FMU built with --map
# FMU output -> table channel (the output column behind it, mechanics.loop.outputs)
OUTPUT_CHANNEL = {output.name: output.source for output in fmu_outputs() if output.per == STEP}
CONTACT_CHANNELS = tuple(f"normal_force_{k}" for k in range(1, REGION_COUNT + 1))


def map_table_for(params, operating_rpm: float):
    """The table of `params` with speeds from 10 % to 120 % of `operating_rpm`: shipped in the FMU if one was built
    for exactly these parameters and sources, else from the user's cache, else built now (in this process)."""
    settings = MapSettings(table_speed_rpm=operating_rpm)
    shipped = SHIPPED_TABLES / f"{cache_key(params, None, settings)}.npz"
    folder = SHIPPED_TABLES if shipped.exists() else default_cache_dir()
    return build_map(params, operating_rpm=operating_rpm, settings=settings, workers=1, cache_dir=folder)


class PeriodicMapRun:
    """The state of a periodic-map run: time, rotor angle and speed, cumulative shaft work."""

    def __init__(self, params, operating_rpm: float, speed_rpm: float, initial_angle: float):
        self.table = map_table_for(params, operating_rpm)
        self.rotor_inertia = params.rotor_inertia
        self.time = 0.0
        self.angle = float(initial_angle)
        self.speed_rpm = float(speed_rpm)
        self.work = 0.0
        self.acceleration = 0.0
        self.contact_mode = 0           # bit k-1: tabulated normal force of region ck > 0

    def get_state(self) -> dict:
        return dict(time=self.time, angle=self.angle, speed_rpm=self.speed_rpm, work=self.work,
                    acceleration=self.acceleration)

    def set_state(self, state: dict) -> None:
        for name, value in state.items():
            setattr(self, name, value)

    def advance(self, step: float, speed_rpm: float, interpolate: bool) -> tuple[float, float]:
        """Advance by `step` [s] with the speed ramped (interpolate) or jumped and held; (work, angle) of the step."""
        start_speed = self.speed_rpm if interpolate else speed_rpm
        jump = 0.0 if interpolate else 0.5 * self.rotor_inertia * ((speed_rpm * RPM) ** 2
                                                                   - (self.speed_rpm * RPM) ** 2)
        angle = 0.5 * (start_speed + speed_rpm) * RPM * step
        mean_rpm = 0.5 * (start_speed + speed_rpm)
        work = (jump + self.table.torque_integral(self.angle, self.angle + angle, mean_rpm)
                + 0.5 * self.rotor_inertia * ((speed_rpm * RPM) ** 2 - (start_speed * RPM) ** 2))
        self.acceleration = (speed_rpm - start_speed) * RPM / step
        self.time += step
        self.angle += angle
        self.speed_rpm = float(speed_rpm)
        self.work += work
        return work, angle

    def outputs(self) -> dict[str, float]:
        """End-of-step outputs and per-revolution figures at the current angle and speed."""
        channels = self.table.values(self.angle, self.speed_rpm)
        values = {name: channels[channel] for name, channel in OUTPUT_CHANNEL.items()}
        values["shaft_torque"] += self.rotor_inertia * self.acceleration
        for name, value in self.table.figures_at(self.speed_rpm).items():
            values[name] = value if math.isfinite(value) else 0.0   # real-gas figures under the tables: 0, as detailed
        self.contact_mode = sum(1 << k for k, channel in enumerate(CONTACT_CHANNELS) if channels[channel] > 0.0)
        return values


def check_fidelity(value) -> str:
    if value not in FIDELITIES:
        raise ValueError(f"parameter 'fidelity' = {short_repr(value)} is invalid: allowed one of "
                         f"{', '.join(FIDELITIES)}")
    return value

