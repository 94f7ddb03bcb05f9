"""Compressor rating map: the detailed real-gas model over a grid of evaporating and condensing temperatures,
fitted with the AHRI 540 ten-coefficient polynomials for mass flow [lbm/h] and input power [W].

The fit uses a grid of dew points (evaporating x condensing); the cell centres of that grid are run too but held
out of the fit, and the fit's error there is reported. Writes, under out/rating_map/ by default:

* coefficients.json   C1..C10 for mass flow and power, units, the operating conditions, RMS/worst/held-out errors;
* coefficients.csv    the same coefficients as a table;
* points.csv          every detailed-model point with the polynomial's value and its relative error;
* rating_map.png      mass flow and power vs condensing temperature per evaporating temperature (points:
                      detailed model, lines: polynomial) and the relative residuals.

Usage:  python -m rotary_vane.examples.rating_map [--fluid R134a] [--speed 1500] [--superheat 10]
        [--evaporating -15 10 6] [--condensing 30 60 7] [--workers 2 | --scheduler tcp://...]
"""
from __future__ import annotations

import argparse
import csv
import dataclasses
import json
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt            # noqa: E402
import numpy as np                         # noqa: E402

from rotary_vane.examples.cli_types import number_parser, whole_number_parser   # noqa: E402
from rotary_vane.mechanics import CompressorParameters                        # noqa: E402
from rotary_vane.mechanics.reduced.periodic_map import MapSettings                    # noqa: E402
from rotary_vane.mechanics.reduced.rating import (COEFFICIENTS, evaluate_ahri, fahrenheit, fit_report,   # noqa: E402
                                                  rating_map)

QUANTITIES = {"mass_flow": "lbm/h", "power": "W"}


def grids(evaporating, condensing):
    """(fit points, held-out points) in K: the grid, and the centres of its cells."""
    e = np.linspace(*evaporating[:2], int(evaporating[2])) + 273.15
    c = np.linspace(*condensing[:2], int(condensing[2])) + 273.15
    fit = [(a, b) for a in e for b in c]
    held = [(a, b) for a in 0.5 * (e[1:] + e[:-1]) for b in 0.5 * (c[1:] + c[:-1])]
    return fit, held


def parse_arguments(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--fluid", default="R134a", help="CoolProp fluid name")
    parser.add_argument("--speed", type=number_parser("rpm"), default=1500.0, help="shaft speed [rpm]")
    parser.add_argument("--superheat", type=number_parser("K"), default=10.0, help="suction superheat [K]")
    parser.add_argument("--evaporating", type=float, nargs=3, default=(-15.0, 10.0, 6),
                        metavar=("FIRST", "LAST", "COUNT"), help="evaporating dew points [°C]")
    parser.add_argument("--condensing", type=float, nargs=3, default=(30.0, 60.0, 7),
                        metavar=("FIRST", "LAST", "COUNT"), help="condensing dew points [°C]")
    parser.add_argument("--clearance", type=number_parser("m", low_inclusive=True), default=0.0,
                        help="slot and stator clearance [m]")
    parser.add_argument("--workers", type=whole_number_parser(1), default=2, help="worker processes")
    parser.add_argument("--scheduler", default=None, help="address of a running dask scheduler (else a "
                                                          "LocalCluster of --workers processes)")
    parser.add_argument("--out", type=Path, default=Path("out") / "rating_map")
    args = parser.parse_args(argv)
    for name in ("evaporating", "condensing"):
        count = getattr(args, name)[2]
        if count < 4 or count != int(count):
            parser.error(f"--{name} COUNT = {count:g} is invalid: allowed a whole number >= 4")
    return args


def figure(path: Path, points, held, reports):
    fig, axes = plt.subplots(2, 2, figsize=(12, 8), sharex=True)
    for column, (quantity, unit) in enumerate(QUANTITIES.items()):
        coefficients = reports[quantity].coefficients
        evaporating = sorted({p["evaporating"] for p in points})
        dense = np.linspace(min(p["condensing"] for p in points), max(p["condensing"] for p in points), 100)
        for index, e in enumerate(evaporating):
            colour = f"C{index}"
            row = [p for p in points if p["evaporating"] == e]
            axes[0, column].plot(fahrenheit([p["condensing"] for p in row]), [p[quantity] for p in row], "o",
                                 color=colour, label=f"S = {fahrenheit(e):.0f} °F")
            axes[0, column].plot(fahrenheit(dense), evaluate_ahri(coefficients, fahrenheit(np.full_like(dense, e)),
                                                                   fahrenheit(dense)), "-", color=colour)
        for marker, group, label in (("o", points, "fitted"), ("x", held, "held out")):
            s = fahrenheit([p["evaporating"] for p in group])
            d = fahrenheit([p["condensing"] for p in group])
            error = 100.0 * (evaluate_ahri(coefficients, s, d) / np.array([p[quantity] for p in group]) - 1.0)
            axes[1, column].plot(d, error, marker, label=label, linestyle="none")
        report = reports[quantity]
        axes[0, column].set_ylabel(f"{quantity.replace('_', ' ')} [{unit}]")
        axes[0, column].set_title(f"{quantity.replace('_', ' ')}: detailed model (points), AHRI 540 fit (lines)")
        axes[1, column].set_ylabel("fit / detailed - 1 [%]")
        axes[1, column].set_title(f"RMS {100 * report.rms_error:.3f} %, worst {100 * report.worst_error:.3f} %, "
                                  f"held-out worst {100 * report.held_out_error:.3f} %")
        axes[1, column].set_xlabel("condensing (discharge dew point) D [°F]")
        axes[1, column].axhline(0.0, color="k", linewidth=0.5)
        axes[0, column].legend(fontsize=7)
        axes[1, column].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv=None) -> int:
    args = parse_arguments(argv)
    base = CompressorParameters(fluid=args.fluid, pressure_model="real_gas", slot_clearance=args.clearance,
                                stator_clearance=args.clearance)
    fit_points, held_points = grids(args.evaporating, args.condensing)
    settings = MapSettings(table_speed_rpm=args.speed)
    from dask.distributed import Client, LocalCluster
    cluster = None if args.scheduler else LocalCluster(n_workers=args.workers, threads_per_worker=1,
                                                       processes=True, dashboard_address=None)
    with Client(args.scheduler or cluster) as client:
        print(f"running {len(fit_points) + len(held_points)} points of the detailed real-gas model on "
              f"{len(client.scheduler_info()['workers'])} dask workers", file=sys.stderr, flush=True)
        results = rating_map(base, fit_points + held_points, args.superheat, args.speed, settings, client=client)
    if cluster is not None:
        cluster.close()
    points, held = results[:len(fit_points)], results[len(fit_points):]
    reports = {q: fit_report(points, held, q) for q in QUANTITIES}
    args.out.mkdir(parents=True, exist_ok=True)
    summary = dict(fluid=args.fluid, speed_rpm=args.speed, superheat_K=args.superheat, clearance_m=args.clearance,
                   settings=dataclasses.asdict(settings), polynomial="AHRI 540: X = C1 + C2 S + C3 D + C4 S^2 + "
                   "C5 S D + C6 D^2 + C7 S^3 + C8 D S^2 + C9 S D^2 + C10 D^3, S and D dew points in °F",
                   fitted_points=len(points), held_out_points=len(held))
    for quantity, unit in QUANTITIES.items():
        report = reports[quantity]
        summary[quantity] = dict(unit=unit, coefficients=dict(zip(COEFFICIENTS, report.coefficients.tolist())),
                                 rms_error=report.rms_error, worst_error=report.worst_error,
                                 held_out_worst_error=report.held_out_error)
        print(f"{quantity:9s} [{unit}]: RMS {100 * report.rms_error:.4f} %, worst {100 * report.worst_error:.4f} %,"
              f" held-out worst {100 * report.held_out_error:.4f} %")
    (args.out / "coefficients.json").write_text(json.dumps(summary, indent=1))
    with open(args.out / "coefficients.csv", "w", newline="") as handle:
        writer = csv.writer(handle)
        writer.writerow(["quantity", "unit", *COEFFICIENTS])
        for quantity, unit in QUANTITIES.items():
            writer.writerow([quantity, unit, *(f"{c:.10e}" for c in reports[quantity].coefficients)])
    with open(args.out / "points.csv", "w", newline="") as handle:
        writer = csv.writer(handle)
        writer.writerow(["role", "evaporating_F", "condensing_F", "mass_flow_lbm_h", "mass_flow_fit_error",
                         "power_W", "power_fit_error", "discharge_temperature_K", "seconds"])
        for role, group in (("fitted", points), ("held_out", held)):
            for p in group:
                s, d = fahrenheit(p["evaporating"]), fahrenheit(p["condensing"])
                errors = {q: float(evaluate_ahri(reports[q].coefficients, s, d)[0] / p[q] - 1.0) for q in QUANTITIES}
                writer.writerow([role, f"{s:.3f}", f"{d:.3f}", f"{p['mass_flow']:.6g}", f"{errors['mass_flow']:.3e}",
                                 f"{p['power']:.6g}", f"{errors['power']:.3e}", f"{p['discharge_temperature']:.2f}",
                                 f"{p['seconds']:.2f}"])
    figure(args.out / "rating_map.png", points, held, reports)
    print(args.out / "rating_map.png")
    return 0


if __name__ == "__main__":
    sys.exit(main())
