"""Compressor rating maps from the detailed real-gas model, fitted with the AHRI 540 ten-coefficient polynomial.

For a fluid, a speed and a suction superheat, `rating_map` runs the detailed model (pressure_model real_gas) to
periodic steady state at each (evaporating, condensing) dew-point temperature of a grid, in parallel (dask client
or worker processes), and `fit_ahri` fits, for mass flow and input power, AHRI Standard 540's polynomial

    X = C1 + C2 S + C3 D + C4 S^2 + C5 S D + C6 D^2 + C7 S^3 + C8 D S^2 + C9 S D^2 + C10 D^3

with S, D the suction and discharge dew-point temperatures in °F, X the mass flow in lbm/h or the power in W (the
units AHRI 540 uses), by linear least squares.
"""
from __future__ import annotations

import dataclasses
import math
from concurrent.futures import ProcessPoolExecutor

import numpy as np

from ...thermo.fluid import Fluid

from ..parameters import CompressorParameters
from .periodic_map import MapSettings, run_speed_point

LBM_PER_KG = 1.0 / 0.45359237
SECONDS_PER_HOUR = 3600.0
COEFFICIENTS = tuple(f"C{k}" for k in range(1, 11))


def fahrenheit(kelvin):
    """T[°F] = (T[K] - 273.15) 9/5 + 32."""
    return (np.asarray(kelvin, dtype=float) - 273.15) * 1.8 + 32.0


def ahri_terms(suction_f, discharge_f) -> np.ndarray:
    """The ten AHRI 540 terms [1, S, D, S^2, S D, D^2, S^3, D S^2, S D^2, D^3], one row per point."""
    s = np.asarray(suction_f, dtype=float).ravel()
    d = np.asarray(discharge_f, dtype=float).ravel()
    return np.column_stack([np.ones_like(s), s, d, s * s, s * d, d * d, s ** 3, d * s * s, s * d * d, d ** 3])


def fit_ahri(suction_f, discharge_f, values) -> np.ndarray:
    """Least-squares C1..C10. The terms are scaled column by column before solving (S^3 ~ 1e5 beside 1)."""
    terms = ahri_terms(suction_f, discharge_f)
    if terms.shape[0] < terms.shape[1]:
        raise ValueError(f"{terms.shape[0]} points cannot fix the 10 AHRI 540 coefficients: allowed >= 10 points")
    scale = np.max(np.abs(terms), axis=0)
    scaled, *_ = np.linalg.lstsq(terms / scale, np.asarray(values, dtype=float).ravel(), rcond=None)
    return scaled / scale


def evaluate_ahri(coefficients, suction_f, discharge_f) -> np.ndarray:
    """X(S, D) of the polynomial."""
    return ahri_terms(suction_f, discharge_f) @ np.asarray(coefficients, dtype=float)


def rating_parameters(base: CompressorParameters, evaporating: float, condensing: float,
                      superheat: float) -> CompressorParameters:
    """Real-gas parameters at dew points `evaporating` and `condensing` [K] and suction superheat [K]:
    p_s = p_dew(T_e), T_s = T_e + superheat, p_d = p_dew(T_c)."""
    if not (math.isfinite(superheat) and superheat > 0.0):
        raise ValueError(f"'superheat' = {superheat!r} K is invalid: allowed a finite value > 0 K")
    if not condensing > evaporating:
        raise ValueError(f"'condensing' = {condensing!r} K is invalid: allowed a temperature above the "
                         f"evaporating temperature {evaporating!r} K")
    fluid = Fluid(base.fluid)
    return dataclasses.replace(base, pressure_model="real_gas", suction_pressure=fluid.dew_pressure(evaporating),
                               suction_temperature=evaporating + superheat,
                               discharge_pressure=fluid.dew_pressure(condensing))


def rating_point(base: CompressorParameters, evaporating: float, condensing: float, superheat: float,
                 speed_rpm: float, settings: MapSettings) -> dict:
    """Mass flow [lbm/h] and input power [W] of the detailed model at one rating point (dew points in K)."""
    params = rating_parameters(base, evaporating, condensing, superheat)
    point = run_speed_point(params, speed_rpm, settings)
    figures = point["figures"]
    return dict(evaporating=evaporating, condensing=condensing,
                mass_flow=figures["discharge_mass_flow"] * LBM_PER_KG * SECONDS_PER_HOUR,
                power=figures["input_power"], mass_flow_scatter=point["figure_scatter"]["discharge_mass_flow"]
                * LBM_PER_KG * SECONDS_PER_HOUR, power_scatter=point["figure_scatter"]["input_power"],
                discharge_temperature=figures["discharge_temperature"], seconds=point["seconds"])


def rating_map(base: CompressorParameters, points, superheat: float, speed_rpm: float,
               settings: MapSettings | None = None, client=None, workers: int = 1) -> list[dict]:
    """rating_point at every (evaporating, condensing) pair of `points` [K], on a dask client or processes."""
    settings = settings or MapSettings(table_speed_rpm=speed_rpm)
    for evaporating, condensing in points:      # every point validated before any work starts
        rating_parameters(base, evaporating, condensing, superheat)
    arguments = [(base, e, c, superheat, speed_rpm, settings) for e, c in points]
    if client is not None:
        return client.gather(client.map(rating_point, *zip(*arguments), pure=False))
    if workers <= 1:
        return [rating_point(*a) for a in arguments]
    with ProcessPoolExecutor(max_workers=workers) as pool:
        return list(pool.map(rating_point, *zip(*arguments)))


@dataclasses.dataclass(frozen=True)
class FitReport:
    """Coefficients and errors of one AHRI fit; errors relative to the detailed model's value."""
    coefficients: np.ndarray
    rms_error: float            # RMS of relative residuals at the fitted points
    worst_error: float          # max |relative residual| at the fitted points
    held_out_error: float       # max |relative error| at the held-out points (NaN if none)


def fit_report(fit_points: list[dict], held_out: list[dict], quantity: str) -> FitReport:
    """Fit `quantity` ('mass_flow' or 'power') on `fit_points`, evaluate at `held_out`."""
    def arrays(points):
        return (fahrenheit([p["evaporating"] for p in points]), fahrenheit([p["condensing"] for p in points]),
                np.array([p[quantity] for p in points]))
    s, d, values = arrays(fit_points)
    coefficients = fit_ahri(s, d, values)
    residual = evaluate_ahri(coefficients, s, d) / values - 1.0
    held = math.nan
    if held_out:
        s_h, d_h, values_h = arrays(held_out)
        held = float(np.max(np.abs(evaluate_ahri(coefficients, s_h, d_h) / values_h - 1.0)))
    return FitReport(coefficients, float(np.sqrt(np.mean(residual ** 2))), float(np.max(np.abs(residual))), held)
