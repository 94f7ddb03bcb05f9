"""What this project installs can neither overwrite nor be shadowed by another distribution: one import package,
`rotary_vane`, owns `thermo/`, `mechanics/`, `fmu_src/` and `examples/` (pyproject.toml's package-dir mapping).

Checked the way a user would meet a collision: PyPI's `thermo` (Chemical Engineering Design Library, often
installed next to CoolProp) in the same environment, imported first, then the README's "Using the library" snippet
run from a neutral folder; and the wheel's top-level entries. Both need the package index (slow).
"""
import os
import re
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

pytestmark = pytest.mark.slow

PROJECT_DIR = Path(__file__).resolve().parents[2]


def readme_library_snippet() -> str:
    readme = (PROJECT_DIR / "README.md").read_text(encoding="utf-8")
    section = readme.split("## Using the library", 1)[1]
    return re.search(r"```python\n(.*?)```", section, re.DOTALL).group(1)


def test_the_wheel_installs_one_top_level_package(tmp_path):
    built = subprocess.run([sys.executable, "-m", "pip", "wheel", "--quiet", "--no-deps", "-w", str(tmp_path),
                            str(PROJECT_DIR)], capture_output=True, text=True, timeout=600)
    assert built.returncode == 0, built.stderr[-3000:]
    (wheel,) = tmp_path.glob("*.whl")
    with zipfile.ZipFile(wheel) as archive:
        names = archive.namelist()
    top_level = {name.split("/")[0] for name in names}
    assert {entry for entry in top_level if not entry.endswith(".dist-info")} == {"rotary_vane"}, sorted(top_level)
    for package in ("kernels", "thermo", "mechanics", "mechanics/geometry", "mechanics/contact", "mechanics/gas",
                    "mechanics/loop", "mechanics/reduced", "fmu_src", "examples"):
        assert f"rotary_vane/{package}/__init__.py" in names


def test_readme_library_snippet_runs_beside_pypi_thermo(tmp_path):
    site = tmp_path / "pypi-thermo"
    installed = subprocess.run([sys.executable, "-m", "pip", "install", "--quiet", "--no-deps", "--target", str(site),
                                "thermo", "fluids", "chemicals", "pandas", "python-dateutil", "tzdata"],
                               capture_output=True, text=True, timeout=600)
    assert installed.returncode == 0, installed.stderr[-3000:]
    neutral = tmp_path / "neutral"
    neutral.mkdir()
    script = ("from thermo import Chemical\nassert abs(Chemical('water').MW - 18.015) < 0.01\n"
              + readme_library_snippet()
              + "\nimport thermo, rotary_vane.thermo\nprint('PYPI', thermo.__file__)\nprint('OURS', rotary_vane.thermo.__file__)\n")
    done = subprocess.run([sys.executable, "-c", script], cwd=neutral, env={**os.environ, "PYTHONPATH": str(site)},
                          capture_output=True, text=True, timeout=900)
    assert done.returncode == 0, done.stderr[-3000:]
    files = dict(line.split(" ", 1) for line in done.stdout.splitlines() if line.startswith(("PYPI ", "OURS ")))
    assert files["PYPI"].startswith(str(site))
    assert Path(files["OURS"]).resolve().parent.name == "thermo" and not files["OURS"].startswith(str(site))
