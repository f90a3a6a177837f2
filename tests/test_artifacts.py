"""Honest summaries and safe artifacts: completion on the true pose, the path error to the path's
segments, artifact names, atomic writes and Ctrl-C."""

import json
import math

import numpy as np
import pytest
from slipnav.scenarios import artifacts, plots, runner
from slipnav.scenarios.completion import judge_completion, path_projection
from slipnav.scenarios.config import load_scenario
from slipnav.scenarios.trajectories import Arc, PathConfig, build_path
from slipnav.studies.cli import main

from tests.shared import scenario_run

# Tinyphoon on tyres with mu = 0.15 (traction 1.2 m/s^2, shoes' drag 0.5 m/s^2) cannot follow a 4.5 m/s^2
# acceleration; the controller's progress reaches the end anyway and the robot stops about 1 m short.
TOO_SLIPPERY = """
description: "too slippery for the trajectory"
robot_overrides: {tyre_friction: 0.15}
trajectory:
  segments:
    - !Straight {length: 1.0, v_end: 3.0}
    - !Straight {length: 0.6, v_end: 0.0}
settle_time: 0.3
"""


def test_path_distance_is_measured_to_the_segments():
    """A point off the middle of a segment: the perpendicular distance, not the distance to a vertex."""
    px, py = np.array([0.0, 2.0, 2.0]), np.array([0.0, 0.0, 1.0])  # 2 m east, then 1 m north
    x, y = np.array([0.5, 1.0, 2.3, 2.5]), np.array([0.1, -0.2, 0.5, 1.4])
    distance, progress = path_projection(x, y, px, py)
    # By hand: 0.1 and 0.2 below the first segment (feet at s = 0.5 and 1.0); 0.3 east of the second
    # (foot at s = 2 + 0.5); the last point lies beyond the end (2, 1): its distance to the end point.
    np.testing.assert_allclose(distance, [0.1, 0.2, 0.3, math.hypot(0.5, 0.4)], atol=1e-12)
    np.testing.assert_allclose(progress, [0.5, 1.0, 2.5, 3.0], atol=1e-12)
    nearest_vertex = np.min(np.hypot(x[:, None] - px[None], y[:, None] - py[None]), axis=1)
    assert nearest_vertex[0] > 0.5  # the old nearest-vertex measure on this polyline


def test_projection_follows_the_track_on_a_closed_circle():
    """On a full circle the start is also the end; the windowed search keeps the progress at 0 there."""
    circle = build_path(PathConfig(segments=[Arc(radius=2.0, angle_deg=360.0)]))
    s = np.linspace(0.0, circle.length, 4000)
    x = np.interp(s, circle.s, circle.x) + 0.01 * np.cos(s)
    y = np.interp(s, circle.s, circle.y)
    distance, progress = path_projection(x, y, circle.x, circle.y)
    assert progress[0] < 0.02 and progress[-1] > circle.length - 0.02
    assert np.all(np.diff(progress) > -1e-3)
    assert np.max(distance) <= 0.0101
    judged = judge_completion(s, x[:10], y[:10], circle.x, circle.y, 0.136)  # only the first 10 samples
    assert judged["completed"] is False  # next to the end point, but not along the path


def test_robot_that_stops_short_is_not_completed(tmp_path, capsys):
    scenario = tmp_path / "slippery.yaml"
    scenario.write_text(TOO_SLIPPERY)
    assert main(["run", str(scenario), "--out", str(tmp_path), "--no-figures"]) == 0
    err = capsys.readouterr().err
    assert "slipnav: warning: slippery did not complete" in err and "(completed: false)" in err
    summary = json.loads((tmp_path / "slippery-seed0.summary.json").read_text())
    assert summary["completed"] is False and summary["completion_time_s"] is None
    assert summary["controller_completion_time_s"] is not None  # the controller thought it was done
    assert summary["end_distance_m"] > 0.5 and summary["end_distance_m"] > summary["completion_tolerance_m"]
    assert summary["path_length_m"] - summary["end_progress_m"] > 0.5
    assert summary["completion_tolerance_m"] == pytest.approx(2 * 0.068)  # max(0.05 m, 2 track widths)


def test_corner_completes_near_the_end():
    result = scenario_run("corner")  # the default corner, shared (tests/shared.py)
    s, a = result.summary, result.arrays
    assert s["completed"] is True and s["end_distance_m"] < s["completion_tolerance_m"]
    k = int(round(s["completion_time_s"] / float(a["T_N"])))
    end = result.reference.x[-1], result.reference.y[-1]
    assert math.hypot(a["true_x"][k] - end[0], a["true_y"][k] - end[1]) <= s["completion_tolerance_m"]
    assert 2.0 < s["completion_time_s"] <= s["controller_completion_time_s"]


def _run(tmp_path, *flags):
    return main(["run", "corner", "--out", str(tmp_path), "--duration", "0.2", *flags])


def test_artifact_names_carry_seed_and_switches(tmp_path):
    assert _run(tmp_path, "--seed", "3", "--no-figures", "--open-loop") == 0
    assert _run(tmp_path, "--seed", "3", "--no-figures", "--no-slip-control") == 0
    assert _run(tmp_path, "--no-figures") == 0
    names = sorted(p.name for p in tmp_path.iterdir())
    assert names == [
        f"corner-{stem}.{suffix}"
        for stem in ("seed0", "seed3-no-slip-control", "seed3-open-loop")
        for suffix in ("model.yaml", "npz", "sensors.csv", "summary.json")
    ]


@pytest.mark.parametrize("where", ["npz", "sensors", "figures", "summary"])
def test_interrupted_write_leaves_the_previous_run_untouched(where, tmp_path, monkeypatch, capsys):
    """Ctrl-C while writing: exit 130, one line, no new file, the previous run's files as they were."""
    previous = {}
    for name in ("corner-seed0.npz", "corner-seed0.summary.json", "corner-seed0.path.png"):
        (tmp_path / name).write_text(f"previous run: {name}")
        previous[name] = f"previous run: {name}"

    def interrupt(*args, **kwargs):
        raise KeyboardInterrupt

    if where == "npz":
        monkeypatch.setattr(artifacts.np, "savez", interrupt)
    elif where == "sensors":
        monkeypatch.setattr(artifacts, "sensor_log_chunks", interrupt)
    elif where == "figures":
        real = plots.write_figures

        def half_the_figures(a, reference, out_dir, name):
            real(a, reference, out_dir, name)  # every figure written into the staging folder ...
            raise KeyboardInterrupt  # ... then Ctrl-C before any rename

        monkeypatch.setattr(plots, "write_figures", half_the_figures)
    else:
        monkeypatch.setattr(artifacts.json, "dumps", interrupt)
    assert _run(tmp_path) == 130
    assert capsys.readouterr().err == "slipnav: interrupted\n"
    assert {p.name: p.read_text() for p in tmp_path.iterdir()} == previous  # staging folder removed too


def test_a_run_whose_estimate_becomes_non_finite_stops_with_status_3(tmp_path, monkeypatch, capsys):
    """The mixer's v_t turned NaN from sample 1000 (t = 2 s) on: the run stops at the next 0.1 s check,
    writes its artifact up to there, says why in the summary and on stderr, and exits with status 3."""
    from slipnav.systems.navigation.mixing import mixer

    real, calls = mixer.mix_checked, [0]

    def broken(*args):
        calls[0] += 1
        out, check, state = real(*args)
        if calls[0] > 1000:
            out = np.array(out, float)
            out[0] = math.nan
        return out, check, state

    monkeypatch.setattr(mixer, "mix_checked", broken)  # the VelocityMixer calls it once a sample
    assert main(["run", "corner", "--out", str(tmp_path), "--no-figures"]) == 3
    err = capsys.readouterr().err
    assert err.startswith("slipnav: error: corner stopped early: the navigation estimate became non-finite")
    summary = json.loads((tmp_path / "corner-seed0.summary.json").read_text())
    assert summary["aborted"].startswith("the navigation estimate became non-finite at t = 2.000 s")
    assert summary["duration_s"] == pytest.approx(2.0) and summary["completed"] is False
    arrays = np.load(tmp_path / "corner-seed0.npz")
    assert len(arrays["t"]) == 1001 and np.isnan(arrays["est_v_t"][-1])
    assert np.all(np.isfinite(arrays["est_v_t"][:-1]))


def test_a_run_records_the_covariance_health_and_its_arrays_are_views_of_one_buffer():
    """P symmetric positive definite over a run (summary); the artifact rows share the drained buffer
    (no copies) and equal what the loggers logged on the T_N grid."""
    result = runner.run_scenario(load_scenario("corner"), duration=1.5)
    s, a = result.summary, result.arrays
    assert s["aborted"] is None
    assert 0.0 < s["covariance_min_eigenvalue"] < s["covariance_max_eigenvalue"] < 1.0
    assert s["covariance_max_asymmetry"] == 0.0
    buffer = a["true_x"].base
    assert buffer is not None and buffer.ndim == 2
    assert all(a[key].base is buffer for key in ("est_x", "meas_gyro", "cmd_R", "C1", "progress"))
    np.testing.assert_allclose(a["t"], np.arange(751) * 0.002, atol=1e-12)


def test_figures_of_a_long_run_plot_every_kth_sample():
    n = 2 * artifacts.FIGURE_SAMPLES + 1
    arrays = {"t": np.arange(n) * 0.002, "est_x": np.arange(n, dtype=float), "T_N": np.array(0.002)}
    shown = artifacts.figure_arrays(arrays)
    assert len(shown["t"]) == math.ceil(n / 3) and shown["est_x"][1] == 3.0 and shown["T_N"] == 0.002
    short = {key: value[: artifacts.FIGURE_SAMPLES] if value.ndim else value for key, value in arrays.items()}
    assert artifacts.figure_arrays(short) is short


def test_path_projection_memory_is_bounded_on_a_60_lap_square():
    """A 60-lap 1 m square (48 000 vertices) and 400 000 track points: the search's working memory
    stays a few MB beyond its two outputs (a dense search would need 400 000 x 48 000 x 8 B = 154 GB)."""
    import tracemalloc

    corners = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0], [0.0, 0.0]])
    u = np.linspace(0.0, 1.0, 201)[:-1, None]
    lap = np.vstack([a + u * (b - a) for a, b in zip(corners[:-1], corners[1:], strict=True)])
    path = np.vstack([lap] * 60 + [corners[:1]])
    s = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(path, axis=0).T))])
    along = np.linspace(0.0, s[-1], 400_000)
    x, y = np.interp(along, s, path[:, 0]) + 0.003, np.interp(along, s, path[:, 1])
    tracemalloc.start()
    distance, progress = path_projection(x, y, path[:, 0], path[:, 1])
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert peak - distance.nbytes - progress.nbytes < 5e6
    np.testing.assert_allclose(progress[-1], 240.0, rtol=1e-12)  # 60 laps of 4 m, matched lap by lap
    assert np.all(np.diff(progress) > -1e-9) and np.max(distance) < 0.0031
