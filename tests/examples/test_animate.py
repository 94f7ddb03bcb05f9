"""Tests of the animations examples/animate.py (issue 6, "Animations").

Drawn geometry against closed forms: the vane outline encloses t l_r + pi rho^2/2 (docs/model.md §2.1), the rotor outline
the disc minus the slot and the cap it cuts from the rim (§2.2), the leading and trailing chambers together fill
the lobe area of docs/model.md §2.5 (168.81 mm^2 for z = 3) and the leading one shrinks as the vane advances (§1.1); the
drawn machine has the valley gap k c_S and the slot width t + k c_R. Contact arrows of a simulated revolution
point from the other body into the vane on the side their region names (§1.3) and start on the vane outline
(within the penetration).

Outputs: the GIF has the requested frame count and size and its frames differ; the MP4 (when an ffmpeg is found)
decodes to the same count and size; the 3D page loads no script from the network and, in headless Chromium
(skipped when chromium or playwright is absent), plays: screenshots taken apart in time differ after Play and
are equal after Pause. Outside CI the screenshots are kept in out/animate/ for a person to look at.
"""
from __future__ import annotations

import importlib.util
import math
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from PIL import Image, ImageChops

from rotary_vane.mechanics import CompressorParameters
from rotary_vane.mechanics.loop.machine import machine_from_parameters

PROJECT_DIR = Path(__file__).resolve().parents[2]
ANIMATE_SCRIPT = PROJECT_DIR / "examples" / "animate.py"
CLEARANCE = 0.05e-3                # m, c_R = c_S
LOBE_AREA_Z3 = 168.81e-6           # m^2, docs/model.md §2.5 table, z = 3, c_S = 0 (Green's theorem, [P])
CHROMIUM_ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                 "--disable-background-networking", "--disable-component-update", "--disable-sync"]


def load_animate():
    spec = importlib.util.spec_from_file_location("animate", ANIMATE_SCRIPT)
    module = importlib.util.module_from_spec(spec)
    sys.modules["animate"] = module
    spec.loader.exec_module(module)
    return module


animate = load_animate()


def signed_area(points: np.ndarray) -> float:
    """Shoelace area of a closed polygon given without repeating its first point (> 0 counter-clockwise)."""
    x, y = points[:, 0], points[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))


def polygon_area(points: np.ndarray) -> float:
    return abs(signed_area(points))


def distance_to_polyline(point: np.ndarray, outline: np.ndarray) -> float:
    """Shortest distance from a point to the closed polyline through `outline`."""
    a = outline
    b = np.roll(outline, -1, axis=0)
    ab = b - a
    s = np.clip(np.einsum("ij,ij->i", point - a, ab) / np.einsum("ij,ij->i", ab, ab), 0.0, 1.0)
    return float(np.min(np.hypot(*(a + s[:, None] * ab - point).T)))


@pytest.fixture(scope="module")
def params() -> CompressorParameters:
    return CompressorParameters(slot_clearance=CLEARANCE, stator_clearance=CLEARANCE)


@pytest.fixture(scope="module")
def revolution(params):
    """24 frames over the second revolution at 1500 rpm (every 15 deg)."""
    return animate.simulate_frames(params, 1500.0, 24, revolutions=1.0, settle_revolutions=1.0)


# drawn geometry ---------------------------------------------------------------------------------------------
def test_vane_outline_encloses_the_stadium_area(params):
    m = machine_from_parameters(params)
    t, rho = params.vane_thickness, params.tip_radius
    expected = t * (params.vane_length - rho) + 0.5 * math.pi * rho ** 2            # docs/model.md §2.1: A_r + A_s
    outline = animate.vane_outline(m, np.array([0.004, -0.02, 0.7]), arc_points=2001)
    assert polygon_area(outline) == pytest.approx(expected, rel=1e-6)


def test_rotor_outline_is_the_disc_minus_the_slot(params):
    m = machine_from_parameters(params)
    r, w, r_m, r_sb = params.rotor_radius, params.slot_width, params.mouth_radius, params.slot_bottom_radius
    half_angle = math.asin(0.5 * w / r)
    rim_cap = 0.5 * r ** 2 * (2.0 * half_angle - math.sin(2.0 * half_angle))      # circular segment beyond R_m
    expected = math.pi * r ** 2 - w * (r_m - r_sb) - rim_cap
    assert polygon_area(animate.rotor_outline(m, 1.3, arc_points=20001)) == pytest.approx(expected, rel=1e-7)


def test_chambers_fill_the_lobe_and_the_leading_one_shrinks():
    """Signed areas: the polygons meet at the tip centre T inside the vane, so next to a valley the thin trailing
    chamber's polygon is a sliver under the vane traced clockwise; the signed areas still add up to the lobe."""
    m = machine_from_parameters(CompressorParameters())                             # zero clearance
    lobe = 2.0 * math.pi / 3
    leading_areas = []
    for phase in np.linspace(0.05, 0.95, 7) * lobe:
        theta = 2.0 * lobe + phase                                                  # third lobe
        pose = np.array([*animate.reference_centre(m, theta), theta])
        tip = pose[:2] + m.tip_centre * np.array([math.cos(theta), math.sin(theta)])
        leading, trailing = animate.chamber_polygons(m, theta, tip, arc_points=2000)
        assert signed_area(leading) + signed_area(trailing) == pytest.approx(LOBE_AREA_Z3, rel=1e-4)
        leading_areas.append(signed_area(leading))
    assert np.all(np.diff(leading_areas) < 0.0)
    assert leading_areas[0] > 0.9 * LOBE_AREA_Z3 and leading_areas[-1] < 0.1 * LOBE_AREA_Z3


def test_drawn_machine_exaggerates_the_clearances(params):
    k = 12.0
    m = animate.drawn_machine(params, k)
    valley = animate.stator_curve(m, np.array([0.0, 2.0 * math.pi / 3]))
    # docs/model.md §2.5: at a valley |S| = R_r + c_S; drawn with k c_S. docs/model.md §2.2: w = t + c_R, drawn t + k c_R.
    assert np.hypot(*valley.T) - params.rotor_radius == pytest.approx([k * CLEARANCE] * 2, abs=1e-12)
    assert 2.0 * m.half_slot_width == pytest.approx(params.vane_thickness + k * CLEARANCE, abs=1e-15)


@pytest.mark.parametrize("factor", [0.5, float("nan"), 40.0])
def test_bad_exaggeration_is_refused(params, factor):
    with pytest.raises(ValueError, match="'exaggeration'"):                      # 40 x 0.05 mm > 1 mm allowed
        animate.drawn_machine(params, factor)


def test_bad_frame_request_is_refused(params):
    with pytest.raises(ValueError, match="'frames' = 1"):
        animate.simulate_frames(params, 1500.0, 1)
    with pytest.raises(ValueError, match="'rpm' = 0"):
        animate.simulate_frames(params, 0.0, 10)


def test_contact_arrows_push_into_the_vane_from_their_side(params, revolution):
    m = machine_from_parameters(params)
    drawn = animate.drawn_machine(params, 20.0)
    seen = set()
    for i in range(len(revolution)):
        theta = revolution.column("rotor_angle")[i]
        e_r = np.array([math.cos(theta), math.sin(theta)])
        e_theta = np.array([-e_r[1], e_r[0]])
        pose = revolution.pose[i]
        shown = animate.drawn_pose(drawn, theta, pose, 20.0)
        for contact in animate.contact_forces(m, pose, revolution.outputs[i]):
            seen.add(contact.region)
            n = contact.normal
            if contact.region in (5, 6):                  # stator on the tip pushes inwards
                assert n @ e_r < -0.7
            else:                                          # c1/c3 leading wall pushes back, c2/c4 forward
                assert np.sign(n @ e_theta) == (-1.0 if contact.region in (1, 3) else 1.0)
            point = animate.carried_with_vane(contact.point, pose, shown)
            depth = revolution.column(f"penetration_{contact.region}")[i]      # an edge point P sits delta deep
            assert distance_to_polyline(point, animate.vane_outline(drawn, shown, 201)) < depth + 1e-7
    assert {2, 5, 6} <= seen                               # the regions loaded in every lobe at 1500 rpm


# 2D files ---------------------------------------------------------------------------------------------------
def frame_pixels(path: Path) -> list[np.ndarray]:
    with Image.open(path) as gif:
        frames = []
        for k in range(gif.n_frames):
            gif.seek(k)
            frames.append(np.asarray(gif.convert("RGB"), dtype=np.int16))
        return frames


def assert_frames_differ(frames: list[np.ndarray]) -> None:
    for a, b in zip(frames, frames[1:]):
        changed = np.any(np.abs(a - b) > 24, axis=2).mean()
        assert changed > 0.002, f"consecutive frames differ in only {changed:.2%} of the pixels"


@pytest.fixture(scope="module")
def short_run(params):
    return animate.simulate_frames(params, 1500.0, 6, revolutions=1.0 / 3.0, settle_revolutions=1.0)


def test_gif_alone_without_ffmpeg(short_run, tmp_path):
    paths = animate.write_2d(short_run, tmp_path, exaggeration=20.0, fps=5.0, size=(320, 288), ffmpeg=None)
    assert paths == [tmp_path / "compressor_2d.gif"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["compressor_2d.gif"]
    with Image.open(paths[0]) as gif:
        assert (gif.n_frames, gif.size, gif.info["duration"]) == (6, (320, 288), 200)
    assert_frames_differ(frame_pixels(paths[0]))


def test_mp4_decodes_to_the_frames(short_run, tmp_path):
    ffmpeg = animate.find_ffmpeg()
    if ffmpeg is None:
        pytest.skip("no ffmpeg: neither on PATH nor from the imageio-ffmpeg package")
    paths = animate.write_2d(short_run, tmp_path, fps=5.0, size=(320, 288), ffmpeg=ffmpeg)
    assert [p.name for p in paths] == ["compressor_2d.gif", "compressor_2d.mp4"]
    raw = subprocess.run([ffmpeg, "-v", "error", "-i", str(paths[1]), "-f", "rawvideo", "-pix_fmt", "rgb24", "-"],
                         capture_output=True, check=True).stdout
    frame_size = 320 * 288 * 3
    assert len(raw) == 6 * frame_size
    video = [np.frombuffer(raw[k * frame_size:(k + 1) * frame_size], np.uint8).reshape(288, 320, 3)
             .astype(np.int16) for k in range(6)]
    assert_frames_differ(video)
    gif = frame_pixels(paths[0])
    assert max(np.abs(v - g).mean() for v, g in zip(video, gif)) < 8.0         # same pictures (lossy codecs)


def test_command_line_refuses_bad_input_before_running(capsys):
    for argv, name in ((["--exaggeration", "0.5"], "'exaggeration'"), (["--clearance", "-1"], "slot_clearance")):
        with pytest.raises(SystemExit) as stop:
            animate.parse_arguments(argv)
        assert stop.value.code == 2 and name in capsys.readouterr().err


# 3D page ----------------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def page(revolution, tmp_path_factory):
    pytest.importorskip("plotly", reason="plotly is not installed (needed for the 3D page)")
    return animate.write_3d(revolution, tmp_path_factory.mktemp("page") / "compressor_3d.html", fps=4.0)


def test_page_is_self_contained(page):
    html = page.read_text()
    assert re.search(r"<script[^>]*\bsrc\s*=", html, re.IGNORECASE) is None       # every script is inline
    assert re.search(r"<link[^>]*\bhref\s*=\s*[\"']?(https?:)?//", html, re.IGNORECASE) is None
    assert "Plotly.newPlot" in html and 'animate' in html


def screenshot_folder(tmp_path: Path) -> Path:
    """out/animate/ when run by hand (for a person to look at), the test's temporary folder under CI."""
    if os.environ.get("CI"):
        return tmp_path
    folder = PROJECT_DIR / "out" / "animate"
    folder.mkdir(parents=True, exist_ok=True)
    return folder


def test_page_plays_in_headless_chromium(page, tmp_path):
    chromium = shutil.which("chromium") or shutil.which("chromium-browser")
    if chromium is None:
        pytest.skip("chromium is not installed (Debian: apt-get install -y chromium)")
    sync_api = pytest.importorskip("playwright.sync_api", reason="playwright is not installed (pip install playwright)")
    folder = screenshot_folder(tmp_path)
    outside = []
    with sync_api.sync_playwright() as playwright:
        context = playwright.chromium.launch_persistent_context(
            str(tmp_path / "profile"), executable_path=chromium, headless=True, args=CHROMIUM_ARGS,
            viewport={"width": 1000, "height": 750})
        try:
            browser_page = context.new_page()
            browser_page.route(re.compile(r"^(?!file:|data:|blob:)"),
                               lambda route: (outside.append(route.request.url), route.abort()))
            browser_page.goto(page.as_uri())
            browser_page.wait_for_selector(".gl-container canvas", state="attached", timeout=60_000)
            browser_page.wait_for_timeout(1500)
            assert not browser_page.get_by_text("WebGL is not supported").is_visible()
            browser_page.locator("g.updatemenu-button", has_text="Play").click()
            shots = []
            for k in range(2):
                browser_page.wait_for_timeout(1000)
                shots.append(folder / f"playing_{k}.png")
                browser_page.screenshot(path=shots[-1])
            browser_page.locator("g.updatemenu-button", has_text="Pause").click()
            browser_page.wait_for_timeout(1000)
            for k in range(2):
                shots.append(folder / f"paused_{k}.png")
                browser_page.screenshot(path=shots[-1])
                browser_page.wait_for_timeout(800)
        finally:
            context.close()
    assert outside == []
    scene = (0, 40, 1000, 640)                             # the 3D view: no slider, buttons or angle readout
    images = [Image.open(path).convert("RGB").crop(scene) for path in shots]
    playing = ImageChops.difference(images[0], images[1]).convert("L").point(lambda v: 255 if v > 24 else 0)
    assert np.count_nonzero(np.asarray(playing)) > 2000, "the 3D view did not change while playing"
    paused = ImageChops.difference(images[2], images[3]).getbbox()
    assert paused is None, f"the 3D view changed while paused, in {paused}"
