"""Animations in the browser (scenarios/animation.py): ``slipnav run --animate``, ``slipnav animate``.

The page's scene is read back two ways: by decoding the Meshcat commands StaticHtml embeds (base64
msgpack: the objects and the recorded animation), and by opening the page in headless Chromium (Debian's
chromium and chromedriver, driven by selenium), where the viewer's three.js scene must hold the robots
and play the recorded poses. The browser test skips when chromium, chromedriver or selenium is absent.
"""

import base64
import math
import re
import shutil
import tempfile
from html.parser import HTMLParser

import msgpack
import numpy as np
import pytest
from slipnav.scenarios import animation
from slipnav.scenarios.animation import (
    FRAMES_PER_SECOND,
    MAX_FRAMES,
    SCENE_PATHS,
    animation_html,
    frame_samples,
    load_run,
    wheel_slip_speeds,
)
from slipnav.studies import cli
from slipnav.studies.cli import main

from tests.shared import shared_runs

DURATION = 3.0
"""s of the corner: 1 s standstill, then 2 s driving into the corner."""
FRAMES = math.ceil(DURATION * FRAMES_PER_SECOND) + 1


@pytest.fixture(scope="module")
def corner(tmp_path_factory):
    """A short corner run written with --animate: (npz path, html path)."""
    out = tmp_path_factory.mktemp("animate")
    argv = ["run", "corner", "--duration", str(DURATION), "--no-figures", "--animate", "--out", str(out)]
    with shared_runs(cli):  # test_paper_mode's 3 s default corner (tests/shared.py)
        assert main(argv) == 0
    return out / "corner-seed0.npz", out / "corner-seed0.html"


def commands(page: str) -> list[dict]:
    """The Meshcat commands StaticHtml embedded in ``page``, decoded."""
    blobs = re.findall(r'fetch\("data:application/octet-binary;base64,([^"]+)"\)', page)
    return [msgpack.unpackb(base64.b64decode(b), raw=False, strict_map_key=False) for b in blobs]


def tracks(page: str) -> dict:
    """{(path, property): [(frame, value), ...]} of the page's recorded animation, and its fps."""
    (recording,) = [c for c in commands(page) if c["type"] == "set_animation"]
    found, fps = {}, set()
    for animation_of_path in recording["animations"]:
        fps.add(animation_of_path["clip"]["fps"])
        for track in animation_of_path["clip"]["tracks"]:
            keys = [(k["time"], k["value"]) for k in track["keys"]]
            found[(animation_of_path["path"], track["name"].lstrip("."))] = keys
    (found["fps"],) = fps
    return found


class _References(HTMLParser):
    """Every src/href of the page's tags (script text is not parsed for tags)."""

    def __init__(self):
        super().__init__()
        self.references = []

    def handle_starttag(self, tag, attrs):
        self.references += [(tag, value) for name, value in attrs if name in ("src", "href") and value]


def test_run_animate_writes_one_self_contained_page_under_20_mb(corner):
    npz, page_path = corner
    assert page_path.stat().st_size < 20e6
    page = page_path.read_text()
    parser = _References()
    parser.feed(page)
    assert all(value.startswith(("data:", "#")) for _, value in parser.references), parser.references
    assert not any(tag == "script" for tag, _ in parser.references)  # every script inline
    assert all(url.startswith("data:") for url in re.findall(r'fetch\("([^"]+)"', page))
    assert "<title>corner-seed0</title>" in page and "id='slipnav-legend'" in page


def test_page_holds_the_robots_lines_and_the_downsampled_recording(corner):
    npz, page_path = corner
    page = page_path.read_text()
    objects = {c["path"] for c in commands(page) if c["type"] == "set_object"}
    for robot, parts in (
        ("truth", "body nose wheel_R wheel_L slip_R/bar slip_L/bar side_slip/bar"),
        ("estimate", "body nose wheel_R wheel_L side_slip/bar"),
    ):
        for part in parts.split():
            assert f"{SCENE_PATHS[robot]}/{part}" in objects, (robot, part)
    assert f"{SCENE_PATHS['estimate']}/slip_R/bar" not in objects  # per-wheel slip is not estimated
    for name in ("reference_path", "truth_trace", "estimate_trace", "reference_point"):
        assert SCENE_PATHS[name] in objects, name

    recorded = tracks(page)
    assert recorded["fps"] == FRAMES_PER_SECOND
    a = load_run(npz)
    frames = np.round(np.arange(FRAMES) / FRAMES_PER_SECOND / 0.002).astype(int)  # nearest 2 ms sample
    for robot, prefix in (("truth", "true"), ("estimate", "est")):
        positions = recorded[(SCENE_PATHS[robot], "position")]
        assert [k for k, _ in positions] == list(range(FRAMES)), robot
        assert len(recorded[(SCENE_PATHS[robot], "quaternion")]) == FRAMES
        xy = np.array([value[:2] for _, value in positions])
        np.testing.assert_allclose(xy[:, 0], a[f"{prefix}_x"][frames], atol=1e-12)
        np.testing.assert_allclose(xy[:, 1], a[f"{prefix}_y"][frames], atol=1e-12)
        assert (SCENE_PATHS[robot], "visible") not in recorded  # the pose is finite throughout
    gain = float(a["track_width"]) / (animation.ARROW_SPEED_FRACTION * float(a["V_m"]))
    slip_R, _ = wheel_slip_speeds(a)
    arrow = np.array([value[0] for _, value in recorded[(f"{SCENE_PATHS['truth']}/slip_R", "scale")]])
    assert len(arrow) == FRAMES
    moving = np.abs(slip_R[frames] * gain) > 1e-5
    np.testing.assert_allclose(arrow[moving], slip_R[frames][moving] * gain, rtol=1e-12)
    assert np.max(np.abs(slip_R[frames])) > 0.01  # the corner's wheels do slip, visibly


def test_frame_rate_is_lowered_for_long_runs_and_a_single_sample_is_one_frame():
    t = np.arange(0.0, 3600.0, 0.002)
    frames, fps = frame_samples(t, FRAMES_PER_SECOND)
    assert len(frames) == MAX_FRAMES and fps < FRAMES_PER_SECOND and frames[-1] == len(t) - 1
    frames, fps = frame_samples(np.array([0.0]), FRAMES_PER_SECOND)
    assert list(frames) == [0] and fps == FRAMES_PER_SECOND


def test_missing_truth_and_a_lost_estimate(corner):
    """A replayed log without truth has no true robot; an estimate that turns non-finite is hidden from
    then on (an aborted run's artifact ends so)."""
    a = load_run(corner[0])
    for key in [k for k in a if k.startswith("true_")]:
        a[key] = np.full_like(a[key], np.nan)
    lost = a["t"] > 2.51
    a["est_x"] = np.where(lost, np.nan, a["est_x"])
    page, count, _ = animation_html(a, "replay")
    objects = {c["path"] for c in commands(page) if c["type"] == "set_object"}
    assert not any(p.startswith(SCENE_PATHS["truth"] + "/") for p in objects)
    assert SCENE_PATHS["truth_trace"] not in objects
    visible = [value for _, value in tracks(page)[(SCENE_PATHS["estimate"], "visible")]]
    assert len(visible) == count
    assert visible == [k / FRAMES_PER_SECOND <= 2.51 for k in range(count)]


def _bad_cases(tmp_path, npz):
    not_npz = tmp_path / "x.npz"
    not_npz.write_text("no zip")
    partial = tmp_path / "partial.npz"
    np.savez(partial, t=np.arange(3.0))
    return [
        (["animate", str(tmp_path / "missing.npz")], "RUN.npz="),
        (["animate", str(not_npz)], "RUN.npz="),
        (["animate", str(partial)], "lacks the keys track_width"),
        (["animate", str(npz), "--fps", "0"], "--fps=0.0"),
        (["animate", str(npz), "--fps", "nan"], "--fps=nan"),
        (["animate", str(npz), "--fps", "fast"], "--fps"),
        (["animate", str(npz), "--out", str(tmp_path / "a.png")], "--out="),
        (["animate", str(npz), "--out", str(tmp_path)], "--out="),
        (["animate", str(npz), "--out", str(not_npz / "a.html")], "--out="),
        (["animate"], "RUN.npz"),
    ]


@pytest.mark.parametrize("index", range(10))
def test_animate_mistakes_exit_2_with_one_line_before_meshcat_starts(
    index, corner, tmp_path, capsys, monkeypatch
):
    def refuse():
        raise AssertionError("Meshcat was started for a bad input")

    monkeypatch.setattr(animation, "_loopback_meshcat", refuse)
    argv, message = _bad_cases(tmp_path, corner[0])[index]
    try:
        status = main(argv)
    except SystemExit as e:  # argparse's own mistakes
        status = e.code
    assert status == 2, argv
    err = capsys.readouterr().err
    assert err.startswith("slipnav: error: ") and err.count("\n") == 1, err
    assert message in err, err
    assert not list(tmp_path.glob("*.html"))


def test_animate_writes_beside_the_npz(corner, tmp_path, capsys):
    npz = tmp_path / "copy.npz"
    shutil.copy(corner[0], npz)
    assert main(["animate", str(npz), "--fps", "10"]) == 0
    assert capsys.readouterr().out.strip() == str(tmp_path / "copy.html")
    recorded = tracks((tmp_path / "copy.html").read_text())
    assert recorded["fps"] == 10 and len(recorded[(SCENE_PATHS["truth"], "position")]) == 31


# -- the page in a real browser ------------------------------------------------------------------------

CHROMIUM, CHROMEDRIVER = shutil.which("chromium"), shutil.which("chromedriver")
CHROMIUM_FLAGS = (
    "--headless=new --no-sandbox --disable-gpu --disable-dev-shm-usage --disable-quic --no-first-run "
    "--disable-background-networking --disable-component-update --disable-sync --enable-unsafe-swiftshader "
    "--window-size=1000,700"
).split()
"""No network: without the background-networking flags Chromium reaches for Google's hosts at start."""


@pytest.fixture
def browser():
    """Headless Chromium under chromedriver (both Debian's), its console log kept."""
    if CHROMIUM is None or CHROMEDRIVER is None:
        pytest.skip("needs Debian's chromium and chromium-driver (apt-get install chromium chromium-driver)")
    webdriver = pytest.importorskip("selenium.webdriver", reason="needs selenium (pip install -e '.[test]')")
    from selenium.webdriver.chrome.service import Service

    options = webdriver.ChromeOptions()
    options.binary_location = CHROMIUM
    for flag in CHROMIUM_FLAGS:
        options.add_argument(flag)
    profile = tempfile.mkdtemp(prefix="slipnav-chromium-")
    options.add_argument(f"--user-data-dir={profile}")
    options.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    driver = webdriver.Chrome(service=Service(CHROMEDRIVER), options=options)
    driver.set_page_load_timeout(30)
    try:
        yield driver
    finally:
        driver.quit()
        shutil.rmtree(profile, ignore_errors=True)


SCENE_SCRIPT = """
const node = (path) => viewer.scene_tree.find(path.split('/').filter((s) => s));
const meshes = (path) => node(path).object.children.filter((c) => c.type === 'Mesh').length;
const parts = ['body', 'nose', 'wheel_R', 'wheel_L', 'slip_R/bar', 'side_slip/bar'];
viewer.animator.pause();
viewer.animator.seek(arguments[0]);
const truth = node(arguments[1]).object;
return {
  truth_meshes: parts.map((p) => meshes(arguments[1] + '/' + p)),
  estimate_meshes: meshes(arguments[2] + '/body'),
  actions: viewer.animator.actions.length,
  position: [truth.position.x, truth.position.y, truth.position.z],
  legend: document.getElementById('slipnav-legend') !== null,
};
"""


def test_page_loads_in_chromium_without_errors_and_plays_the_robot(browser, corner):
    from selenium.webdriver.support.ui import WebDriverWait

    npz, page = corner
    browser.get(page.as_uri())
    WebDriverWait(browser, 20).until(
        lambda d: d.execute_script(
            "return typeof viewer !== 'undefined' && viewer.animator.actions.length > 0"
        )
    )
    k = 75  # frame 75: 2.5 s, driving into the corner
    scene = browser.execute_script(
        SCENE_SCRIPT, k / FRAMES_PER_SECOND, SCENE_PATHS["truth"], SCENE_PATHS["estimate"]
    )
    assert scene["truth_meshes"] == [1] * 6 and scene["estimate_meshes"] == 1, scene
    assert scene["actions"] == 7 and scene["legend"], scene  # each robot, its arrows, the reference point
    a = load_run(npz)
    sample = round(k / FRAMES_PER_SECOND / 0.002)
    np.testing.assert_allclose(scene["position"], [a["true_x"][sample], a["true_y"][sample], 0.0], atol=1e-6)
    severe = [entry for entry in browser.get_log("browser") if entry["level"] == "SEVERE"]
    assert not severe, severe
