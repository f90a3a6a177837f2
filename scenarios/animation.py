"""A run as a 3-D animation in the browser: ``slipnav animate RUN.npz [--out RUN.html]``, ``slipnav run
SCENARIO --animate``.

Drake's Meshcat draws the run's artifact arrays (docs/artifacts.md) and records them as a Meshcat
animation, exported by ``Meshcat.StaticHtml`` into one self-contained HTML file (the viewer's scripts and
the scene inline, nothing fetched). The Meshcat server listens on the loopback interface only
(``localhost``, a port the operating system picks) while the scene is built, and stops when the HTML is
written; no browser connects to it.

The scene, in metres, z up, the ground at z = 0 (paths in ``SCENE_PATHS``):

- the true robot (blue) and the fused estimate S(21) (orange, translucent): each a body box with a white
  nose at its front and two wheels of the robot's track width and wheel radius;
- on the true robot, a red arrow above each wheel along the heading: the wheel's longitudinal slip speed
  r θ̇ minus the ground speed of its contact point, v_t ± ω b/2 (forward: the wheel spins faster than the
  ground passes); on both robots a purple arrow sideways: the lateral velocity v_n (true, estimated). An
  arrow of one track width stands for ``ARROW_SPEED_FRACTION`` × V_m;
- the reference point (green sphere) and the reference path it traced (green line), the truth's trace
  (blue line) and the estimate's trace (orange line).

Frames sample the run at ``fps`` frames per second of simulated time (default ``FRAMES_PER_SECOND``; a
run longer than ``MAX_FRAMES`` frames at that rate gets a lower rate), each frame the sample nearest its
time, the last frame the last sample; the player shows them in real time and interpolates between them.
A body is hidden in frames where its pose is not finite (an aborted run's last samples) and absent when
its pose is never finite (a replayed log without truth).
"""

from __future__ import annotations

import html
import logging
import math
import os
import zipfile
from pathlib import Path as FilePath

import numpy as np
from pydrake.geometry import Box, Cylinder, Meshcat, MeshcatParams, Rgba, Sphere
from pydrake.math import RigidTransform, RotationMatrix
from slipnav.scenarios.artifacts import artifact_stem, check_output_directory
from slipnav.scenarios.config import ScenarioError

FRAMES_PER_SECOND = 30.0
"""Default frames per second of simulated time (a 4.3 s corner: 129 frames)."""
FPS_RANGE = (1.0, 120.0)
MAX_FRAMES = 20_000
"""Most frames an animation holds (about 10 MB of HTML); a longer run's frame rate is lowered to fit."""
MAX_LINE_POINTS = 20_000
"""Most points of a drawn line (path, traces): a longer run's lines take every k-th sample."""
ARROW_SPEED_FRACTION = 0.05
"""A slip arrow one track width long stands for this fraction of the wheel-speed limit V_m (m/s)."""

REFERENCE_RADIUS = 0.15
"""Radius of the reference point's sphere in track widths (it rests on the ground)."""

SCENE_PATHS = {
    "truth": "/slipnav/truth",
    "estimate": "/slipnav/estimate",
    "reference_point": "/slipnav/reference_point",
    "reference_path": "/slipnav/reference_path",
    "truth_trace": "/slipnav/truth_trace",
    "estimate_trace": "/slipnav/estimate_trace",
}
"""Meshcat paths of the scene's objects; a robot's parts lie below its path: body, nose, wheel_R,
wheel_L, slip_R, slip_L (truth only) and side_slip, each arrow's bar below it."""

POSES = {"truth": "true", "estimate": "est"}
"""Robot -> npz key prefix of its pose (x, y, phi) and lateral velocity (v_n)."""
REQUIRED_KEYS = (
    "t",
    "track_width",
    "V_m",
    "true_x",
    "true_y",
    "true_phi",
    "est_x",
    "est_y",
    "est_phi",
    "ref_x",
    "ref_y",
)
"""npz keys the animation needs (every run's and replay's npz has them, NaN where not known)."""
OPTIONAL_KEYS = (
    "true_v_n",
    "est_v_n",
    "true_wheel_R",
    "true_wheel_L",
    "true_v_t",
    "true_omega",
    "plant_track_width",
    "plant_wheel_radius_R",
)
"""Keys drawn where the npz has them (a replay's lacks the ``plant_*`` scalars)."""

COLOURS = {
    "truth": (0.15, 0.35, 0.85, 1.0),
    "estimate": (0.95, 0.55, 0.10, 0.4),
    "reference": (0.10, 0.60, 0.20, 1.0),
    "wheel_slip": (0.85, 0.10, 0.10, 1.0),
    "side_slip": (0.55, 0.15, 0.75, 1.0),
}
"""RGBA of each object (the legend shows the same)."""


def load_run(path) -> dict:
    """The arrays the animation draws (REQUIRED_KEYS, OPTIONAL_KEYS) of a run's (or a replay's) npz at
    ``path``; raises ScenarioError naming RUN.npz when the file is missing, not an npz, lacks one of
    REQUIRED_KEYS or has no finite, increasing time axis ``t`` (s)."""
    name = f"RUN.npz={str(path)!r}"
    try:
        data = np.load(path)
    except FileNotFoundError:
        raise ScenarioError(f"{name} does not exist: allowed a run's npz (slipnav run writes one)") from None
    except (OSError, ValueError, EOFError, zipfile.BadZipFile) as e:
        reason = getattr(e, "strerror", None) or "not an npz file"
        raise ScenarioError(f"{name} cannot be read ({reason}): allowed a run's npz") from None
    if not isinstance(data, np.lib.npyio.NpzFile):
        raise ScenarioError(f"{name} holds a single array, not an npz: allowed a run's npz")
    with data:
        arrays = {key: np.asarray(data[key]) for key in data.files if key in REQUIRED_KEYS + OPTIONAL_KEYS}
    missing = [key for key in REQUIRED_KEYS if key not in arrays]
    if missing:
        raise ScenarioError(
            f"{name} lacks the keys {', '.join(missing)}: allowed a run's npz (docs/artifacts.md)"
        )
    t = arrays["t"]
    if t.ndim != 1 or len(t) < 1 or not np.all(np.isfinite(t)) or np.any(np.diff(t) <= 0):
        raise ScenarioError(f"{name} has no finite, increasing time axis t: allowed a run's npz")
    return arrays


def check_fps(fps: float) -> float:
    """``fps`` when it lies in FPS_RANGE; else ScenarioError naming --fps."""
    low, high = FPS_RANGE
    if not (isinstance(fps, int | float) and low <= fps <= high):
        raise ScenarioError(f"--fps={fps} is out of range: allowed {low:g} .. {high:g} frames per second")
    return float(fps)


def check_animation_output(out) -> FilePath:
    """``out`` as a Path when it names an .html file in a writable directory (created if missing); else
    ScenarioError naming --out."""

    out = FilePath(out)
    if out.suffix.lower() not in (".html", ".htm"):
        raise ScenarioError(f"--out={str(out)!r} is not an .html file name: allowed FILE.html")
    if out.is_dir():
        raise ScenarioError(f"--out={str(out)!r} is a directory: allowed FILE.html")
    try:
        check_output_directory(out.parent)
    except ScenarioError as e:
        reason = str(e).split(" ", 1)[1]  # "--out='DIR' is a file: ..." -> "is a file: ..."
        raise ScenarioError(f"--out={str(out)!r}: its directory {str(out.parent)!r} {reason}") from None
    return out


def frame_samples(t: np.ndarray, fps: float, max_frames: int = MAX_FRAMES) -> tuple[np.ndarray, float]:
    """(sample index of each frame, frames per second): frame k shows the sample nearest
    t[0] + k / fps, the last frame the last sample; ``fps`` is lowered so that at most ``max_frames``
    frames cover the run."""
    duration = float(t[-1] - t[0])
    fps = min(fps, (max_frames - 1) / duration) if duration > 0 else fps
    count = math.ceil(duration * fps - 1e-9) + 1
    times = np.minimum(t[0] + np.arange(count) / fps, t[-1])
    after = np.clip(np.searchsorted(t, times), 1, len(t) - 1) if len(t) > 1 else np.zeros(count, int)
    before = np.maximum(after - 1, 0)
    nearer = np.where(np.abs(t[before] - times) <= np.abs(t[after] - times), before, after)
    return nearer.astype(int), fps


def wheel_slip_speeds(a: dict) -> tuple[np.ndarray, np.ndarray]:
    """Each wheel's longitudinal slip speed (m/s): its circumferential speed r θ̇ minus the ground speed of
    its contact point, v_t + ω b/2 (right wheel) and v_t - ω b/2 (left), b the real track width
    (``plant_track_width``; the nominal ``track_width`` in a replay). NaN where the npz lacks them."""
    n = len(a["t"])
    keys = ("true_wheel_R", "true_wheel_L", "true_v_t", "true_omega")
    if not all(k in a for k in keys):
        return np.full(n, np.nan), np.full(n, np.nan)
    half = 0.5 * float(a.get("plant_track_width", a["track_width"]))
    ground = a["true_omega"] * half
    return a["true_wheel_R"] - (a["true_v_t"] + ground), a["true_wheel_L"] - (a["true_v_t"] - ground)


def _rgba(name: str):

    return Rgba(*COLOURS[name])


def _add_arrow(meshcat, path: str, axis: int, thickness: float, colour: str, X_parent) -> None:
    """An arrow of unit length along ``axis`` (0: x, 1: y) from the origin of ``path``, placed at
    ``X_parent``; its length follows the scale of ``path`` along that axis."""

    size = [thickness] * 3
    size[axis] = 1.0
    offset = [0.0, 0.0, 0.0]
    offset[axis] = 0.5
    meshcat.SetTransform(path, X_parent)
    meshcat.SetObject(f"{path}/bar", Box(*size), _rgba(colour))
    meshcat.SetTransform(f"{path}/bar", RigidTransform(offset))


def _add_robot(meshcat, path: str, colour: str, b: float, r: float, wheel_arrows: bool) -> None:
    """A robot of track width ``b`` and wheel radius ``r`` (m) at ``path``: body box, white nose, two
    wheels, the side-slip arrow and (``wheel_arrows``) a slip arrow above each wheel."""

    height, clearance = 0.4 * b, 0.1 * r
    body_z = clearance + height / 2
    meshcat.SetObject(f"{path}/body", Box(0.9 * b, 0.75 * b, height), _rgba(colour))
    meshcat.SetTransform(f"{path}/body", RigidTransform([0.0, 0.0, body_z]))
    meshcat.SetObject(f"{path}/nose", Box(0.12 * b, 0.3 * b, 0.3 * height), Rgba(1, 1, 1, COLOURS[colour][3]))
    meshcat.SetTransform(f"{path}/nose", RigidTransform([0.42 * b, 0.0, clearance + height]))
    axle = RotationMatrix.MakeXRotation(math.pi / 2)  # the cylinder's axis (z) along the body's y
    wheel_colour = Rgba(*(0.3 * c for c in COLOURS[colour][:3]), COLOURS[colour][3])
    for side, y in (("R", -b / 2), ("L", b / 2)):
        meshcat.SetObject(f"{path}/wheel_{side}", Cylinder(r, 0.15 * b), wheel_colour)
        meshcat.SetTransform(f"{path}/wheel_{side}", RigidTransform(axle, [0.0, y, r]))
        if wheel_arrows:
            X = RigidTransform([0.0, y, 2 * r + 0.05 * b])
            _add_arrow(meshcat, f"{path}/slip_{side}", 0, 0.06 * b, "wheel_slip", X)
    X = RigidTransform([0.0, 0.0, clearance + height + 0.05 * b])
    _add_arrow(meshcat, f"{path}/side_slip", 1, 0.06 * b, "side_slip", X)


def _add_line(meshcat, path: str, x, y, colour: str, width: float, z: float) -> bool:
    """The finite points of (x, y) as a line at ``path``, ``z`` (m) above the ground (at most
    MAX_LINE_POINTS of them); False when there are fewer than two."""
    keep = np.isfinite(x) & np.isfinite(y)
    x, y = np.asarray(x)[keep], np.asarray(y)[keep]
    if len(x) < 2:
        return False
    stride = -(-len(x) // MAX_LINE_POINTS)
    points = np.vstack([x[::stride], y[::stride], np.full(len(x[::stride]), z)])
    if stride > 1:
        points = np.hstack([points, [[x[-1]], [y[-1]], [z]]])
    meshcat.SetLine(path, points, width, _rgba(colour))
    return True


def _arrow_scale(values, gain: float) -> np.ndarray:
    """Arrow lengths (m) of ``values`` times ``gain``, 0 where not finite, at least 1e-5 m in magnitude
    (a zero scale makes three.js's matrices singular)."""
    length = np.where(np.isfinite(values), values * gain, 0.0)
    return np.where(length < 0, np.minimum(length, -1e-5), np.maximum(length, 1e-5))


def _record_robot(meshcat, path: str, a: dict, prefix: str, frames, times, gain: float) -> None:
    """The robot at ``path`` in every frame: pose from ``<prefix>_x, _y, _phi``, side-slip arrow from
    ``<prefix>_v_n``, the wheel slip arrows (truth) from wheel_slip_speeds; hidden where the pose is not
    finite."""

    x, y, phi = (a[f"{prefix}_{q}"][frames] for q in ("x", "y", "phi"))
    finite = np.isfinite(x) & np.isfinite(y) & np.isfinite(phi)
    side = _arrow_scale(a.get(f"{prefix}_v_n", np.full(len(a["t"]), np.nan))[frames], gain)
    slips = [_arrow_scale(s[frames], gain) for s in wheel_slip_speeds(a)] if prefix == "true" else None
    last = RigidTransform()
    for k, time in enumerate(times):
        if finite[k]:
            last = RigidTransform(RotationMatrix.MakeZRotation(phi[k]), [x[k], y[k], 0.0])
        meshcat.SetTransform(path, last, time)
        if not finite.all():
            meshcat.SetProperty(path, "visible", bool(finite[k]), time)
        meshcat.SetProperty(f"{path}/side_slip", "scale", [1.0, side[k], 1.0], time)
        if slips is not None:
            meshcat.SetProperty(f"{path}/slip_R", "scale", [slips[0][k], 1.0, 1.0], time)
            meshcat.SetProperty(f"{path}/slip_L", "scale", [slips[1][k], 1.0, 1.0], time)


def _has_pose(a: dict, prefix: str) -> bool:
    return bool(np.any(np.isfinite(a[f"{prefix}_x"]) & np.isfinite(a[f"{prefix}_y"])))


def _camera(meshcat, a: dict) -> None:
    """Look down at the drawn paths' centre from the south (-y), far enough to see them whole."""
    xs = np.concatenate([a[f"{p}_x"][np.isfinite(a[f"{p}_x"])] for p in ("true", "est", "ref")])
    ys = np.concatenate([a[f"{p}_y"][np.isfinite(a[f"{p}_y"])] for p in ("true", "est", "ref")])
    if len(xs) == 0 or len(ys) == 0:
        return
    cx, cy = (xs.min() + xs.max()) / 2, (ys.min() + ys.max()) / 2
    span = max(xs.max() - xs.min(), ys.max() - ys.min(), 10 * float(a["track_width"]))
    meshcat.SetCameraPose([cx, cy - 0.8 * span, 0.9 * span], [cx, cy, 0.0])


def _loopback_meshcat():
    """A Meshcat server on localhost at a port the operating system picks (its start-up line not logged);
    the server stops when the object is freed."""

    logger = logging.getLogger("drake")
    level = logger.level
    logger.setLevel(logging.WARNING)
    try:
        return Meshcat(MeshcatParams(host="localhost", port=0))
    finally:
        logger.setLevel(level)


def _scene(meshcat, a: dict) -> list[str]:
    """The static objects (robots, lines, reference point) into ``meshcat``; returns the robots drawn."""

    b = float(a["track_width"])
    r = float(a.get("plant_wheel_radius_R", 0.22 * b))
    robots = [name for name, prefix in POSES.items() if _has_pose(a, prefix)]
    for name in robots:
        _add_robot(meshcat, SCENE_PATHS[name], name, b, r, wheel_arrows=name == "truth")
    _add_line(meshcat, SCENE_PATHS["reference_path"], a["ref_x"], a["ref_y"], "reference", 2.0, 1e-3)
    _add_line(meshcat, SCENE_PATHS["truth_trace"], a["true_x"], a["true_y"], "truth", 3.0, 3e-3)
    _add_line(meshcat, SCENE_PATHS["estimate_trace"], a["est_x"], a["est_y"], "estimate", 1.5, 2e-3)
    if _has_pose(a, "ref"):
        meshcat.SetObject(SCENE_PATHS["reference_point"], Sphere(REFERENCE_RADIUS * b), _rgba("reference"))
    _camera(meshcat, a)
    return robots


def animation_html(a: dict, title: str, fps: float = FRAMES_PER_SECOND) -> tuple[str, int, float]:
    """(the HTML page, frames, frames per second) of the run's arrays ``a`` (docs/artifacts.md keys) as a
    Meshcat animation (module docstring), titled ``title``."""

    frames, fps = frame_samples(a["t"], fps)
    times = (np.arange(len(frames)) + 0.5) / fps  # mid-frame: Meshcat floors time * fps to frame k
    gain = float(a["track_width"]) / (ARROW_SPEED_FRACTION * float(a["V_m"]))
    meshcat = _loopback_meshcat()
    robots = _scene(meshcat, a)
    meshcat.StartRecording(frames_per_second=fps, set_visualizations_while_recording=False)
    for name in robots:
        _record_robot(meshcat, SCENE_PATHS[name], a, POSES[name], frames, times, gain)
    if _has_pose(a, "ref"):
        point, radius = SCENE_PATHS["reference_point"], REFERENCE_RADIUS * float(a["track_width"])
        for k, time in enumerate(times):
            x, y = a["ref_x"][frames[k]], a["ref_y"][frames[k]]
            if np.isfinite(x) and np.isfinite(y):
                meshcat.SetTransform(point, RigidTransform([x, y, radius]), time)
    meshcat.StopRecording()
    meshcat.PublishRecording()
    page = meshcat.StaticHtml()
    del meshcat  # stops the server
    return _with_legend(page, title, a, len(frames), fps), len(frames), fps


def _swatch(name: str) -> str:
    r, g, b, _ = (round(255 * c) for c in COLOURS[name])
    return f"<span style='color:rgb({r},{g},{b})'>&#9632;</span>"


def _with_legend(page: str, title: str, a: dict, count: int, fps: float) -> str:
    """``page`` titled ``title`` with a fixed legend in its lower left corner (colours, arrow scale)."""
    duration = float(a["t"][-1] - a["t"][0])
    per_width = ARROW_SPEED_FRACTION * float(a["V_m"])
    legend = (
        "<div id='slipnav-legend' style='position:fixed;left:8px;bottom:8px;max-width:46em;padding:6px;"
        "background:rgba(255,255,255,0.85);font:12px sans-serif;pointer-events:none'>"
        f"<b>{html.escape(title)}</b>: {duration:.2f} s simulated, {count} frames at {fps:.3g} per second, "
        "played in real time (Open Controls: Animations)<br>"
        f"{_swatch('truth')} true robot and trace &nbsp; {_swatch('estimate')} fused estimate and trace "
        f"&nbsp; {_swatch('reference')} reference point and path<br>"
        f"{_swatch('wheel_slip')} wheel slip speed (r&theta;&#775; minus ground speed) &nbsp; "
        f"{_swatch('side_slip')} lateral velocity v<sub>n</sub>: one track width = {per_width:.3g} m/s"
        "</div>"
    )
    page = page.replace("<title>Drake MeshCat</title>", f"<title>{html.escape(title)}</title>", 1)
    head, tail = page.rsplit("</body>", 1)
    return f"{head}{legend}\n</body>{tail}"


def write_animation(a: dict, out, title: str, fps: float = FRAMES_PER_SECOND) -> FilePath:
    """Write the animation of the run's arrays ``a`` to ``out`` (an .html file) via a temporary file in
    its directory and a rename: no half-written page. Returns the path."""
    out = FilePath(out)
    page, _, _ = animation_html(a, title, fps)
    partial = out.with_name(f".{out.name}.{os.getpid()}.partial")
    try:
        partial.write_text(page, encoding="utf-8")
        os.replace(partial, out)
    except BaseException:
        partial.unlink(missing_ok=True)
        raise
    return out


def animate_file(run, out=None, fps: float = FRAMES_PER_SECOND) -> FilePath:
    """``slipnav animate``: the npz ``run`` as an animation in ``out`` (default: beside it, ``.html`` for
    ``.npz``). Every mistake (RUN.npz, --out, --fps) raises ScenarioError before Meshcat starts, and so
    does a failed write (naming --out)."""
    fps = check_fps(fps)
    out = check_animation_output(out if out is not None else FilePath(run).with_suffix(".html"))
    arrays = load_run(run)
    try:
        return write_animation(arrays, out, FilePath(run).stem, fps)
    except OSError as e:
        raise ScenarioError(f"--out={str(out)!r} cannot be written: {e.strerror or e}") from None


def write_run_animation(result, out_dir) -> FilePath:
    """``slipnav run --animate``: the run's animation as ``out_dir/<stem>.html`` beside its artifact
    (stem: artifacts.artifact_stem), at FRAMES_PER_SECOND."""

    stem = artifact_stem(result)
    return write_animation(result.arrays, FilePath(out_dir) / f"{stem}.html", stem)
