"""Per-lobe and per-revolution figures from the time loop's lobe records (docs/model.md §4.6, §6.4).

The loop lands on every valley and writes one record per lobe (mechanics.loop.windows): the output rows at its start
and end, and what accumulated over it. Means are exact work differences (the work integrals are states), a
revolution is z consecutive lobes ending at a multiple of 2 pi, and sums, maxima and dwells of lobes add up.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .contact.modes import MODE_COUNT, distinct_modes
from .loop.outputs import O, OUTPUT_SIZE
from .contact.regions import REGION_COUNT, SLOT_REGIONS, TIP_REGIONS
from .loop.windows import (ACC_DWELL, ACC_GAP_MOMENT, ACC_LAW_EXCESS, ACC_MAX_FORCE, ACC_MAX_TILT, ACC_STATOR_MOMENT,
                           MASKS, MODE_KEYS, RECORD_ACCUMULATORS, RECORD_END, RECORD_LOBE, RECORD_START)


@dataclass(frozen=True)
class WindowSummary:
    """Figures over one window [start_time, end_time] of whole lobes (docs/model.md §6.4; each of
    mechanics.loop.outputs.FIGURES is an attribute)."""
    start_time: float
    end_time: float
    input_power: float            # <P_in> [W]
    output_power: float           # <P_out> [W]
    friction_power: float         # <P_fric> [W]
    damping_power: float          # <P_damp> [W]
    mechanical_efficiency: float  # eta_m = <P_out>/<P_in>
    energy_residual: float        # (W_in - W_out - W_fric - W_damp - dKE - dPE - W_switch - J2 int(omega theta_ddot)) / W_in
    indicated_power: float        # <-sum_chambers p dV/dt>, leading, trailing and back chambers [W]
    gap_power: float              # <sum_sigma p_sigma gap_sigma>, the open gaps' sweep [W]
    storage_power: float          # (dKE + dPE + 1/2 J2 d(omega^2)) / duration [W]
    contact_switch_power: float   # W_switch / duration = (W_el - dPE) / duration [W]
    ledger_residual: float        # (W_in - W_ind - W_gap - W_fric - W_damp - stored - W_switch) / W_in
    driving_torque: float         # <T_d> = W_in / angle turned [N m]
    stator_torque: float          # <lambda3 + M_gas,stator> [N m]
    gap_torque: float             # <M_gap>, pressure moment on the gaps no body carries [N m]
    max_normal_force: tuple       # max F_n per region, in the order of mechanics.contact.regions.REGIONS [N]
    max_tilt: float               # max |phi3 - theta| [rad]
    contact_law_excess: float     # largest penetration beyond a force law's validity limit [m]
    mode_dwell: dict              # mode mask -> cumulative dwell [s]
    distinct_modes: tuple         # masks with dwell >= tau_min
    mode_dwell_extended: dict     # extended mode key (mask + c1/c2 candidate types, mechanics.loop.windows) -> [s]
    distinct_modes_extended: tuple
    # chamber gas (real gas; NaN for the pressure tables), docs/model.md §6.4, §7
    suction_mass_flow: float = math.nan     # net mass from the suction side / duration [kg/s]
    discharge_mass_flow: float = math.nan   # mass through the discharge valve / duration [kg/s]
    back_chamber_mass_flow: float = math.nan   # net mass from the back chamber (slot side faces) / duration [kg/s]
    discharge_enthalpy: float = math.nan    # mass-weighted enthalpy of the discharged gas [J/kg]
    gas_mass_residual: float = math.nan     # (dm_chambers - m_suction + m_discharge - m_back) / m_discharge
    gas_energy_residual: float = math.nan   # (dU_chambers - E_suction + E_discharge - E_back - W_chambers) / W_chambers
    discharge_temperature: float = math.nan   # T(p_d, discharge_enthalpy) [K]
    volumetric_efficiency: float = math.nan   # delivered mass / (rho_s z L A_lobe)
    isentropic_efficiency: float = math.nan   # m_dot_d (h_2s - h_1) / <P_in>

    @property
    def max_contact_force(self) -> float:
        """Largest normal force of any region [N]."""
        return max(self.max_normal_force)

    @property
    def max_slot_force(self) -> float:
        """Largest normal force of the regions on the rotor (slot mouth, walls and bottom) [N]."""
        return max(self.max_normal_force[i] for i in SLOT_REGIONS)

    @property
    def max_tip_force(self) -> float:
        """Largest normal force of the regions on the stator (the tip) [N]."""
        return max(self.max_normal_force[i] for i in TIP_REGIONS)

    @property
    def mode_count(self) -> int:
        """Distinct contact modes, a mode being the set of touching regions (docs/model.md §4.6)."""
        return len(self.distinct_modes)

    @property
    def mode_count_extended(self) -> int:
        """Distinct contact modes, a mode being the set of touching regions and the c1/c2 candidate types."""
        return len(self.distinct_modes_extended)

    @property
    def torque_balance_error(self) -> float:
        """|<T_d> - <lambda3 + M_gas,stator>| / |<T_d>| (docs/model.md §11)."""
        return abs(self.driving_torque - self.stator_torque) / abs(self.driving_torque)

    @property
    def torque_balance_error_with_gaps(self) -> float:
        """|<T_d> - <lambda3 + M_gas,stator + M_gap>| / |<T_d>|: the balance with every pressure boundary."""
        return abs(self.driving_torque - self.stator_torque - self.gap_torque) / abs(self.driving_torque)


def _dwell_dict(dwell: np.ndarray) -> dict[int, float]:
    return {int(key): float(dwell[key]) for key in np.flatnonzero(dwell)}


def summarise_records(records: np.ndarray, rotor_inertia: float, min_dwell: float, reference=None) -> WindowSummary:
    """WindowSummary of consecutive complete lobe records (rows of the mechanics.loop.windows record layout); with the
    real-gas `reference` (thermo.gas_reference.GasReference) also the compressor figures it defines."""
    start = records[0, RECORD_START:RECORD_START + OUTPUT_SIZE]
    end = records[-1, RECORD_END:RECORD_END + OUTPUT_SIZE]
    accumulators = records[:, RECORD_ACCUMULATORS:]
    duration = end[O.time] - start[O.time]
    work = {name: end[getattr(O, name)] - start[getattr(O, name)]
            for name in ("work_in", "work_out", "work_friction", "work_damping", "work_elastic", "work_indicated",
                         "work_gap")}
    kinetic = end[O.kinetic_energy] - start[O.kinetic_energy]
    elastic = end[O.contact_energy] - start[O.contact_energy]
    rotor = 0.5 * rotor_inertia * (end[O.rotor_speed] ** 2 - start[O.rotor_speed] ** 2)
    stored = kinetic + elastic + rotor
    switches = work["work_elastic"] - elastic     # the elastic forces' work that no potential stores
    residual = (work["work_in"] - work["work_out"] - work["work_friction"] - work["work_damping"] - stored
                - switches)
    indicated, gap = work["work_indicated"], work["work_gap"]
    ledger = work["work_in"] - indicated - gap - work["work_friction"] - work["work_damping"] - stored - switches
    angle_turned = end[O.rotor_angle] - start[O.rotor_angle]
    extended = accumulators[:, ACC_DWELL:ACC_DWELL + MODE_KEYS].sum(axis=0)
    by_mask = extended.reshape(-1, MASKS).sum(axis=0)
    assert by_mask.size == MODE_COUNT
    dwell = _dwell_dict(by_mask)
    dwell_extended = _dwell_dict(extended)
    return WindowSummary(
        start_time=float(start[O.time]), end_time=float(end[O.time]),
        input_power=work["work_in"] / duration, output_power=work["work_out"] / duration,
        friction_power=work["work_friction"] / duration, damping_power=work["work_damping"] / duration,
        mechanical_efficiency=work["work_out"] / work["work_in"], energy_residual=residual / work["work_in"],
        indicated_power=float(indicated / duration), gap_power=float(gap / duration),
        storage_power=float(stored / duration), contact_switch_power=float(switches / duration),
        ledger_residual=float(ledger / work["work_in"]),
        driving_torque=work["work_in"] / angle_turned,
        stator_torque=float(accumulators[:, ACC_STATOR_MOMENT].sum() / duration),
        gap_torque=float(accumulators[:, ACC_GAP_MOMENT].sum() / duration),
        max_normal_force=tuple(float(f) for f in accumulators[:, ACC_MAX_FORCE:ACC_MAX_FORCE + REGION_COUNT]
                               .max(axis=0)),
        max_tilt=float(accumulators[:, ACC_MAX_TILT].max()),
        contact_law_excess=float(accumulators[:, ACC_LAW_EXCESS].max()),
        mode_dwell=dwell, distinct_modes=tuple(distinct_modes(dwell, min_dwell)),
        mode_dwell_extended=dwell_extended, distinct_modes_extended=tuple(distinct_modes(dwell_extended, min_dwell)),
        **_gas_figures(start, end, duration, work["work_in"] / duration, reference))


def _gas_figures(start: np.ndarray, end: np.ndarray, duration: float, input_power: float, reference) -> dict:
    """Real-gas flow, enthalpy and work figures of a window, and its mass and energy balance residuals
    (docs/model.md §11): the chamber contents change by what crossed their boundary."""
    change = {name: end[getattr(O, name)] - start[getattr(O, name)]
              for name in ("chamber_mass", "chamber_internal_energy", "mass_suction", "mass_discharge",
                           "energy_suction", "energy_discharge", "work_chambers", "mass_back_chamber",
                           "energy_back_chamber")}
    if not math.isfinite(change["mass_discharge"]):
        return {}
    delivered = change["mass_discharge"]
    discharge_enthalpy = change["energy_discharge"] / delivered if delivered > 0.0 else math.nan
    figures = ({} if reference is None else
               reference.figures(delivered / duration, discharge_enthalpy, duration, input_power))
    return dict(
        **figures,
        suction_mass_flow=change["mass_suction"] / duration, discharge_mass_flow=delivered / duration,
        back_chamber_mass_flow=change["mass_back_chamber"] / duration, discharge_enthalpy=discharge_enthalpy,
        gas_mass_residual=(change["chamber_mass"] - change["mass_suction"] + delivered
                           - change["mass_back_chamber"]) / delivered if delivered > 0.0 else math.nan,
        gas_energy_residual=(change["chamber_internal_energy"] - change["energy_suction"]
                             + change["energy_discharge"] - change["energy_back_chamber"]
                             - change["work_chambers"]) / change["work_chambers"])


def complete(records: np.ndarray) -> np.ndarray:
    """The records of lobes that started on a valley (a run started inside a lobe has an incomplete first one)."""
    return records[np.isfinite(records[:, RECORD_START + O.time])]


def revolution_groups(records: np.ndarray, lobes: int) -> list[np.ndarray]:
    """Groups of z consecutive complete lobe records that make a revolution (ending at a multiple of 2 pi)."""
    records = complete(records)
    groups = []
    for i in range(lobes - 1, len(records)):
        ending = int(records[i, RECORD_LOBE])
        group = records[i - lobes + 1:i + 1]
        if ending % lobes == 0 and np.array_equal(group[:, RECORD_LOBE], np.arange(ending - lobes + 1, ending + 1)):
            groups.append(group)
    return groups


def revolutions(simulation) -> list[WindowSummary]:
    """Per-revolution summaries of a simulation's lobe records (docs/model.md §6.4)."""
    p = simulation.params
    return [summarise_records(group, p.rotor_inertia, p.mode_dwell_time, simulation.gas_reference)
            for group in revolution_groups(simulation.lobe_records, p.lobes)]


def lobes(simulation) -> list[WindowSummary]:
    """Per-lobe summaries (2 pi / z of rotor angle each), for the z-fold periodicity check (docs/model.md §11)."""
    p = simulation.params
    return [summarise_records(record[None, :], p.rotor_inertia, p.mode_dwell_time, simulation.gas_reference)
            for record in complete(simulation.lobe_records)]
