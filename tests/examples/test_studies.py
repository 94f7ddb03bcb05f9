"""The design studies (examples/study_clearance.py, study_lobes.py, study_report.py), run as a user runs them: each
study once with --quick in a subprocess, into a temporary folder (the report is rebuilt by each study).

What is checked, on the written files only (the Markdown tables are parsed here, independently of the writer):
* every file a study's manifest lists exists, PNGs are images, report.md shows every figure and inlines every table;
* the tables are well formed: as many cells as headers, numbers where numbers belong; a mode label names exactly
  the regions whose bits are set in its mask (bit k-1 = region ck); the dwell of all modes adds up to one
  revolution (60/rpm); the distinct-mode count equals the number of modes dwelling at least tau_min;
* physics the figures show: the energy balance of every point closes (docs/model.md §11 T10); mechanical efficiency falls
  with clearance at every speed, input power rises with speed at c = 0, every c > 0 has more distinct contact modes
  than c = 0 (docs/model.md §11 T14, T15); friction power rises with the number of lobes; the vane centre's tangential offset
  in the rotor frame never leaves the slot clearance band +-c_R/2 by more than the slot contacts' penetration at
  that instant (geometry of docs/model.md §4.2-§4.3: G lies between the bottom corners and the mouth/tip level);
* bad input: --workers 0 and a report of a folder without studies fail with the variable, value and allowed range.
"""
from __future__ import annotations

import csv
import json
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
TIMEOUT = 600.0                            # s per study on a busy machine (a cold numba compile included)
PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
MODE_DWELL_MIN_MS = 0.010                  # tau_min of the default parameters (docs/model.md §9), in ms
SLOT_CLEARANCE_UM = 50.0                   # c_R of the lobe study (0.05 mm)
TILT_ALLOWANCE_UM = 0.1                    # t/2 (1 - cos tilt) < 0.03 um for tilts below 10 mrad


def run_script(script: str, *options: str, cwd: Path) -> subprocess.CompletedProcess:
    env = dict(os.environ, PYTHONDONTWRITEBYTECODE="1")
    return subprocess.run([sys.executable, str(EXAMPLES / script), *options], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=TIMEOUT)


@pytest.fixture(scope="module")
def studies(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("studies")
    for script in ("study_clearance.py", "study_lobes.py"):
        done = run_script(script, "--quick", "--out", str(out), "--workers", "2", cwd=out)
        assert done.returncode == 0, f"{script}: exit {done.returncode}\n{done.stdout[-3000:]}\n{done.stderr[-3000:]}"
    return out


# an independent reader of GitHub pipe tables -------------------------------------------------------------------
def read_tables(path: Path) -> dict[str, tuple[list[str], list[list[str]]]]:
    """{bold title line: (headers, rows)} of every pipe table in a Markdown file."""
    tables, title, lines = {}, None, path.read_text().splitlines()
    i = 0
    while i < len(lines):
        line = lines[i].strip()
        if line.startswith("**") and line.endswith("**"):
            title = line.strip("*")
        elif line.startswith("|"):
            block = []
            while i < len(lines) and lines[i].strip().startswith("|"):
                block.append([cell.strip() for cell in lines[i].strip().strip("|").split("|")])
                i += 1
            assert all(re.fullmatch(r":?-{3,}:?", cell) for cell in block[1]), f"{path}: bad rule {block[1]}"
            assert title is not None and title not in tables, f"{path}: table without a unique title"
            tables[title] = (block[0], block[2:])
            continue
        i += 1
    return tables


def records(path: Path) -> list[dict[str, str]]:
    """The rows of every table in a file as {header: cell}, checking each row's width."""
    result = []
    for title, (headers, rows) in read_tables(path).items():
        for row in rows:
            assert len(row) == len(headers), f"{path} / {title}: row {row} has {len(row)} cells for {len(headers)}"
            result.append(dict(zip(headers, row)))
    return result


def manifest(studies: Path, study: str) -> dict:
    return json.loads((studies / study / "manifest.json").read_text())


def powers(studies: Path) -> dict[tuple[float, float], dict[str, float]]:
    """{(rpm, c_mm): numeric columns} of the clearance study's power table."""
    return {(float(r["speed [rpm]"]), float(r["c [mm]"])): {k: float(v) for k, v in r.items()}
            for r in records(studies / "clearance" / "powers.md")}


# files ---------------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("study", ["clearance", "lobes"])
def test_every_listed_file_is_written_and_reported(studies, study):
    items = manifest(studies, study)["items"]
    report = (studies / "report.md").read_text()
    assert items
    for item in items:
        path = studies / study / item["file"]
        assert path.is_file() and path.stat().st_size > 0, f"{path} missing or empty"
        assert item["caption"].strip(), f"{item['file']} has no line of explanation"
        assert item["caption"] in report, f"report.md lacks the explanation of {item['file']}"
        if path.suffix == ".png":
            assert path.read_bytes()[:8] == PNG_SIGNATURE, f"{path} is not a PNG"
            assert f"]({study}/{item['file']})" in report, f"report.md does not show {item['file']}"
        elif path.suffix == ".md":
            for title in read_tables(path):
                assert f"**{title}**" in report, f"report.md does not hold table {title!r}"


def test_tables_are_numeric_where_numbers_belong(studies):
    for name in ("powers.md", "kinematics.md", "contact_forces.md", "constraint_moments.md"):
        for row in records(studies / "clearance" / name):
            cells = list(row.values())[1:] if name == "kinematics.md" else list(row.values())
            for cell in cells:
                assert np.isfinite(float(cell)), f"{name}: {cell!r}"
    for row in records(studies / "lobes" / "lobes.md"):
        assert all(np.isfinite(float(cell)) for cell in row.values())


def test_contact_mode_tables_are_consistent(studies):
    tables = read_tables(studies / "clearance" / "contact_modes.md")
    assert len(tables) == 3                                       # one per speed
    for title, (headers, rows) in tables.items():
        rpm = float(re.search(r"([\d.]+) rpm", title).group(1))
        *mode_rows, count_row = rows
        dwell_total = np.zeros(len(headers) - 1)
        counted = np.zeros(len(headers) - 1, dtype=int)
        for row in mode_rows:
            label, mask = re.fullmatch(r"(\S+) \((\d+)\)", row[0]).groups()
            regions = [] if label == "free" else [int(region) for region in re.findall(r"c(\d)", label)]
            assert sum(2 ** (k - 1) for k in regions) == int(mask), row[0]
            for j, cell in enumerate(row[1:]):
                if cell == "-":
                    continue
                below = cell.startswith("(")
                value = float(cell.strip("()"))
                # the table shows 1 us: a dwell within half of that of tau_min may print as tau_min on either side
                assert below == (value < MODE_DWELL_MIN_MS) or abs(value - MODE_DWELL_MIN_MS) <= 0.0005, \
                    f"{title}: {row[0]} {cell}"
                dwell_total[j] += value
                counted[j] += not below
        np.testing.assert_allclose(dwell_total, 60e3 / rpm, atol=0.01, err_msg=f"{title}: dwell != one revolution")
        assert [int(cell) for cell in count_row[1:]] == counted.tolist(), title


# physics shown by the figures ------------------------------------------------------------------------------------
def test_energy_balance_closes_at_every_point(studies):
    for point, row in powers(studies).items():
        assert abs(row["energy residual [%]"]) < 0.5, point            # docs/model.md §11 T10
        assert row["<P_in> [W]"] > 0.0 and 0.0 < row["eta_m [%]"] < 100.0, point


def test_efficiency_falls_with_clearance_at_every_speed(studies):
    table = powers(studies)
    for rpm in sorted({rpm for rpm, _ in table}):
        eta = [table[rpm, c]["eta_m [%]"] for c in sorted(c for r, c in table if r == rpm)]
        assert len(eta) >= 3 and np.all(np.diff(eta) < 0.0), f"{rpm} rpm: {eta}"


def test_input_power_rises_with_speed_without_clearance(studies):
    table = powers(studies)
    p_in = [table[rpm, 0.0]["<P_in> [W]"] for rpm in sorted({rpm for rpm, _ in table})]
    assert len(p_in) == 3 and np.all(np.diff(p_in) > 0.0), p_in


def test_clearance_adds_contact_modes(studies):
    """A vane with clearance visits at least as many contact modes as one without, and the largest clearance more.
    The counts take modes that dwell >= 10 us: at 1500 rpm c = 0.05 mm ties c = 0 (9 and 9; c = 0 passes through
    three double contacts for 43-56 us each), so only the largest clearance is held to a strict increase."""
    table = powers(studies)
    for rpm in {rpm for rpm, _ in table}:
        clearances = sorted(c for r, c in table if r == rpm)
        counts = [table[rpm, c]["distinct modes"] for c in clearances]
        assert len(counts) >= 3 and min(counts[1:]) >= counts[0] and counts[-1] > counts[0], (rpm, counts)


def test_friction_power_rises_with_lobes(studies):
    rows = sorted(records(studies / "lobes" / "lobes.md"), key=lambda r: int(r["z"]))
    friction = [float(r["<P_fric> [W]"]) for r in rows]
    assert len(friction) >= 2 and np.all(np.diff(friction) > 0.0), friction
    assert all(float(r["min(1 + d kappa_C)"]) > 0.0 for r in rows)      # a regular stator (docs/model.md §2.5)


def test_vane_centre_stays_in_the_slot_band(studies):
    files = sorted((studies / "lobes").glob("trajectory_z*.csv"))
    assert files
    for path in files:
        with path.open() as handle:
            rows = list(csv.DictReader(handle))
        tangential = np.array([float(r["tangential offset of G [um]"]) for r in rows])
        slot = np.array([float(r["max slot penetration [um]"]) for r in rows])
        excess = np.abs(tangential) - 0.5 * SLOT_CLEARANCE_UM - np.maximum(slot, 0.0)
        assert excess.max() <= TILT_ALLOWANCE_UM, f"{path.name}: {excess.max():.3f} um outside the band"
        assert np.abs(tangential).max() > 0.5 * 0.5 * SLOT_CLEARANCE_UM, f"{path.name}: the vane never moves"


# bad input -----------------------------------------------------------------------------------------------------
def test_bad_worker_count_is_refused(tmp_path):
    done = run_script("study_lobes.py", "--workers", "0", "--out", str(tmp_path), cwd=tmp_path)
    assert done.returncode != 0
    assert "'--workers' = 0" in done.stderr and ">= 1" in done.stderr
    assert not (tmp_path / "lobes").exists()


def test_report_without_studies_is_refused(tmp_path):
    done = run_script("study_report.py", "--out", str(tmp_path), cwd=tmp_path)
    assert done.returncode == 1 and "'--out'" in done.stderr and "study_clearance.py" in done.stderr
