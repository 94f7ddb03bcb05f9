"""Fixtures shared by the tests and the session guard: the reference formulas (tests/reference_formulas.py) as
fixtures, a kernel evaluation at a given state, tolerance bookkeeping, the FMUs built once per session, and the check
that every subprocess runs `sys.executable`.
"""
import math
import os
import re
import shutil
import subprocess
import sys
import tempfile
from types import SimpleNamespace

import numpy as np
import pytest

from reference_formulas import (HarmonicPitch, VaneGeometry, cross, effective_modulus_reference, perp,
                                reference_contacts, reference_forces, reference_friction_coefficient,
                                reference_slot_bottom, reference_slot_mouth, reference_tip, rot,
                                speed_law_reference)


@pytest.fixture(scope="session")
def reference():
    """Independent reference implementations (closed forms of docs/model.md, numpy/scipy)."""
    return SimpleNamespace(HarmonicPitch=HarmonicPitch, speed_law=speed_law_reference,
                           effective_modulus=effective_modulus_reference)


@pytest.fixture(scope="session")
def contact_reference():
    """Independent docs/model.md §4-§6.2 reference: detection per region and the generalized forces."""
    return SimpleNamespace(VaneGeometry=VaneGeometry, slot_mouth=reference_slot_mouth,
                           slot_bottom=reference_slot_bottom, tip=reference_tip, contacts=reference_contacts,
                           forces=reference_forces, friction_coefficient=reference_friction_coefficient,
                           rot=rot, perp=perp, cross=cross)


def evaluate_at(sim, t, vane_state, onset=None):
    """The kernel RHS of a Simulation (`Simulation.evaluate`) at time t and vane state (x3, y3, phi3, vx3, vy3,
    phi_dot3), with the stored approach velocities `onset` (one per memory slot of mechanics.contact.regions; none
    stored if omitted). The closest-point warm start is 0
    (a start at atan2(T) for the offset convention; any start is valid, the Brent safeguard covers the rest).
    Returns (status, dydt, outputs as a dict)."""
    from rotary_vane.mechanics.loop.layout import MEM_LOBE_START, MEM_ONSET_VELOCITY, MEMORY_SIZE
    from rotary_vane.mechanics.contact.regions import MEMORY_SLOTS
    from rotary_vane.mechanics.loop.speed import rotor_motion

    y = sim.state.copy()
    y[:6] = vane_state
    memory = np.zeros(MEMORY_SIZE)
    theta = rotor_motion(t, sim.speed_law)[0]
    lobe = 2 * math.pi / sim.params.lobes
    memory[MEM_LOBE_START] = math.floor(theta / lobe) * lobe
    memory[MEM_ONSET_VELOCITY:MEM_ONSET_VELOCITY + MEMORY_SLOTS] = (0.0,) * MEMORY_SLOTS if onset is None else onset
    return sim.evaluate(t, y, memory)


@pytest.fixture(scope="session")
def kernel():
    return SimpleNamespace(evaluate_at=evaluate_at)


# ------------------------------------------------------------------------------------------------------------
# Tolerance bookkeeping: `check(label, worst, limit)` asserts worst <= limit and remembers the largest value per
# label; with TEST_MARGINS=1 in the environment the observed worst values are listed at the end of the run.

_MARGINS = {}


def _check(label, worst, limit):
    worst = float(worst)
    previous = _MARGINS.get(label)
    if previous is None or not worst <= previous[0]:
        _MARGINS[label] = (worst, limit)
    assert worst <= limit, f"{label}: {worst:.3e} exceeds the limit {limit:.3e}"


@pytest.fixture(scope="session")
def check():
    return _check


def pytest_terminal_summary(terminalreporter):
    if os.environ.get("TEST_MARGINS") and _MARGINS:
        terminalreporter.section("observed worst values / limits")
        for label, (worst, limit) in sorted(_MARGINS.items()):
            terminalreporter.write_line(f"{label:70s} {worst:10.3e} / {limit:.3e}")


@pytest.fixture(scope="session")
def built_fmus(tmp_path_factory):
    """All FMUs and system files of this checkout, built once per test session into a temporary folder."""
    import fmu_helpers
    return fmu_helpers.build_fmu(tmp_path_factory.mktemp("built_fmus")).parent


@pytest.fixture(scope="session", autouse=True)
def temporary_folder_of_the_session(tmp_path_factory):
    """Every temporary file this session makes, in this process (tempfile) and in the processes it starts (TMPDIR),
    goes into one folder under pytest's own, removed when the session ends. fmpy's `extract` unpacks each FMU into a
    new 40 MB folder that nothing removes; before this, a default run and its slow run left thousands of them and
    filled the disk of the machine CI runs on."""
    folder = tmp_path_factory.mktemp("tmpdir")
    saved = os.environ.get("TMPDIR"), tempfile.tempdir
    os.environ["TMPDIR"] = tempfile.tempdir = str(folder)
    yield folder
    if saved[0] is None:
        os.environ.pop("TMPDIR")
    else:
        os.environ["TMPDIR"] = saved[0]
    tempfile.tempdir = saved[1]
    shutil.rmtree(folder, ignore_errors=True)


PYTHON_NAME = re.compile(r"python[0-9.]*$")


@pytest.fixture(scope="session", autouse=True)
def every_subprocess_python_is_this_one(tmp_path_factory):
    """Fail any test that starts a Python interpreter other than `sys.executable` (the virtual environment's), even
    behind a wrapper such as valgrind: another interpreter lacks what the README installs on a fresh machine, and a
    machine whose base Python happens to have the packages would hide that. The one exception is an environment a
    test made itself from `sys.executable` under the session's temporary folder (the FMU requirements test)."""
    original = subprocess.Popen.__init__
    own_environments = str(tmp_path_factory.getbasetemp()) + os.sep

    def checked(self, args, *rest, **kwargs):
        argv = [args] if isinstance(args, (str, os.PathLike)) else list(args)
        for word in map(str, argv[:8]):
            if (PYTHON_NAME.search(os.path.basename(word)) and os.sep in word and word != sys.executable
                    and not word.startswith(own_environments)):
                raise AssertionError(f"a test started the interpreter {word!r}, not sys.executable "
                                     f"({sys.executable!r}): on a fresh machine it lacks the project's packages")
        original(self, args, *rest, **kwargs)

    subprocess.Popen.__init__ = checked
    yield
    subprocess.Popen.__init__ = original
