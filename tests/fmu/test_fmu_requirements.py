"""The FMU's stated requirements suffice: a host environment made from exactly the FMU's
`resources/requirements.txt` plus fmpy, with nothing of this project installed, runs the FMU with every pressure
model (docs/model.md §12).

The environment is a fresh virtual environment made from `sys.executable` under pytest's temporary folder, with its
own empty kernel cache; pip installs into it from the package index (slow: about 1-2 min with a warm pip cache).
"""
import html
import json
import subprocess
import sys
import zipfile

import pytest

import fmu_helpers as H

pytestmark = pytest.mark.slow

PRESSURE_MODELS = ("polytropic", "ideal_gas_table", "real_gas")
HOST = """
import json, sys
sys.path.append(sys.argv[2])
import fmu_helpers as H
report = {"imported": sorted(m for m in ("rotary_vane", "scipy", "matplotlib") if m in sys.modules)}
for model in sys.argv[3:]:
    run = H.simulate(sys.argv[1], stop_time=0.05, output_interval=1e-3,
                     start_values={**H.OPERATING_POINT, "pressure_model": model},
                     output=["shaft_torque_mean", "input_power", "discharge_mass_flow"])
    columns = run["columns"]
    report[model] = {"end": columns["time"][-1], "input_power": columns["input_power"][-1],
                     "mass_flow": columns["discharge_mass_flow"][-1], "statuses": run["statuses"]}
report["imported_after"] = sorted(m for m in ("rotary_vane", "scipy", "matplotlib") if m in sys.modules)
print(json.dumps(report))
"""


def fmu_text(fmu, member):
    with zipfile.ZipFile(fmu) as archive:
        return archive.read(member).decode()


def test_requirements_txt_alone_runs_the_fmu_with_every_pressure_model(built_fmus, tmp_path):
    fmu = built_fmus / f"{H.MODEL}.fmu"
    requirements = [line for line in fmu_text(fmu, "resources/requirements.txt").splitlines() if line.strip()]
    names = {line.split(">")[0].split("=")[0].split("<")[0].strip().lower() for line in requirements}
    assert {"numpy", "numba", "pythonfmu", "coolprop"} <= names, requirements
    documentation = html.unescape(fmu_text(fmu, "documentation/index.html"))
    assert all(line in documentation for line in requirements), "documentation/index.html lists other requirements"

    environment = tmp_path / "host-env"
    subprocess.run([sys.executable, "-m", "venv", str(environment)], check=True, timeout=300)
    python = str(environment / "bin" / "python")
    (tmp_path / "requirements.txt").write_text("\n".join(requirements) + "\n")
    install = subprocess.run([python, "-m", "pip", "install", "--quiet", "-r", str(tmp_path / "requirements.txt"),
                              "fmpy"], capture_output=True, text=True, timeout=1200)
    assert install.returncode == 0, install.stderr[-3000:]
    listed = subprocess.run([python, "-m", "pip", "list", "--format=json"], capture_output=True, text=True,
                            check=True, timeout=120)
    installed = {entry["name"].lower() for entry in json.loads(listed.stdout)}
    assert "rotary-vane-compressor" not in installed, installed
    # scipy is required since the real-gas nozzle table is built at run time (brentq) when it is not cached
    assert ("scipy" in installed) == ("scipy" in names), (names, installed)

    env = H.host_environment(**{H.CACHE_ENVIRONMENT_VARIABLE: str(tmp_path / "empty-kernel-cache")})
    done = subprocess.run([python, "-c", HOST, str(fmu), str(H.TESTS_DIR), *PRESSURE_MODELS], cwd=tmp_path, env=env,
                          capture_output=True, text=True, timeout=1500)
    assert done.returncode == 0, done.stderr[-5000:]
    report = json.loads(done.stdout.strip().splitlines()[-1])
    # nothing outside the requirements: not the project as installed, not matplotlib (scipy only as listed)
    unlisted = [m for m in report["imported_after"] if m.lower() not in names]
    assert unlisted == [], f"the host imported {unlisted}, which the requirements do not list"
    for model in PRESSURE_MODELS:
        run = report[model]
        assert run["end"] == pytest.approx(0.05), (model, run)
        assert run["statuses"] == ["OK"], (model, run)
        assert 100.0 < run["input_power"] < 2000.0, (model, run)       # first revolution reported at 0.04 s
    assert report["real_gas"]["mass_flow"] > 0.0
