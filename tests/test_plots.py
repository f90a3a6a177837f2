"""Figures of a run (scenarios/plots.py, issue 19): named axes, open or closed loop in every title, the
truth visible under the estimates, the position error against time, the reference on the run's own
progress."""

import math

import matplotlib.pyplot as plt
import numpy as np
import pytest
from slipnav.scenarios import plots
from slipnav.scenarios.runner import write_artifacts

from tests.shared import scenario_run


@pytest.fixture(scope="module")
def corner():
    return scenario_run("corner")


@pytest.fixture(scope="module")
def corner_open():
    return scenario_run("corner", open_loop=True)


@pytest.fixture(scope="module")
def circle():
    return scenario_run("circle")


def written_figures(result, tmp_path, monkeypatch) -> dict:
    """write_figures of a run, with each figure kept open: {suffix: Figure}."""
    kept = []
    monkeypatch.setattr(plt, "close", kept.append)
    files = plots.write_figures(result.arrays, result.reference, tmp_path, "run")
    suffixes = [f.name.split(".")[1] for f in files]
    return dict(zip(suffixes, kept, strict=True))


def labels(fig) -> list[str]:
    return [ax.get_ylabel() for ax in fig.axes]


def test_every_title_says_open_or_closed_loop_and_every_axis_is_named(
    corner, corner_open, tmp_path, monkeypatch
):
    closed = written_figures(corner, tmp_path, monkeypatch)
    (tmp_path / "open").mkdir()
    opened = written_figures(corner_open, tmp_path / "open", monkeypatch)
    assert set(closed) == {"path", "error", "speeds", "navigation", "control", "slip"}
    assert set(opened) == {"path", "error", "speeds", "navigation", "slip"}  # no controller, no control
    for figures, kind in ((closed, "(closed loop)"), (opened, "(open loop (feed-forward))")):
        for fig in figures.values():
            assert fig.axes[0].get_title().startswith(f"run {kind}: ")
            assert all(label for label in labels(fig)), labels(fig)
    # control: delta_K and Pi_K - K (its twin), V1 and the wheels, each axis with its unit
    assert labels(closed["control"]) == [
        "step size $\\delta_K$ (1)",
        "$V_1$ (m$^2$)",
        "wheel speed (m/s)",
        "$\\Pi_K - K$ (control samples)",
    ]
    # slip: a ratio and a speed no longer share an axis
    assert labels(closed["slip"]) == ["slip ratio (1)", "slip speed (m/s)", "side-slip angle (deg)"]
    ratio, speed = closed["slip"].axes[:2]
    assert [line.get_label() for line in ratio.lines] == ["slip ratio R", "slip ratio L"]
    assert all("v_t" in line.get_label() for line in speed.lines) and len(speed.lines) == 2
    assert labels(closed["error"]) == ["position error (m)", "heading error (deg)"]
    monkeypatch.undo()
    plt.close("all")


def test_the_truth_is_a_wide_band_under_the_estimates(corner):
    fig, ax = plt.subplots()
    plots.plot_path(corner.arrays, corner.reference, ax)
    lines = {line.get_label(): (i, line) for i, line in enumerate(ax.lines)}
    (i_true, true), (i_fused, fused) = lines["true"], lines["fused estimate"]
    assert i_true < i_fused  # drawn first: the estimate stays visible on top of it
    assert true.get_linewidth() >= 4 * fused.get_linewidth() and true.get_alpha() < 1.0
    plt.close(fig)


def test_the_error_figure_is_written_by_the_runner_and_ends_at_the_summary_error(corner, tmp_path):
    written = write_artifacts(corner, tmp_path)
    assert tmp_path / "corner-seed0.error.png" in written
    assert (tmp_path / "corner-seed0.error.png").stat().st_size > 10_000
    fig, axes = plt.subplots(2, 1)
    plots.plot_position_error(corner.arrays, axes)
    final = {line.get_label(): line.get_ydata()[-1] for line in axes[0].lines}
    summary = corner.summary["final_position_error_m"]
    assert final["fused estimate"] == pytest.approx(summary["fused"], rel=1e-12)
    assert final["odometry only"] == pytest.approx(summary["odometry"], rel=1e-12)
    assert final["Gyrodometry"] == pytest.approx(summary["gyrodometry"], rel=1e-12)
    # the figure shows what the final number hides: the fused error along the run peaks above its end
    assert max(axes[0].lines[0].get_ydata()) > 1.5 * summary["fused"]
    plt.close(fig)


def test_speeds_reference_follows_the_progress_slip_control_reached(corner):
    """Slip control retimes the corner (Pi_K - K ~ -11 samples): the true speed is close to the reference
    at Pi_K times delta_K, far from the reference on nominal time."""
    a, ref = corner.arrays, corner.reference
    v, omega, _ = plots.retimed_reference(a, ref)
    nominal_v = np.interp(a["t"] - float(a["start_time"]), ref.t, ref.v)
    nominal_omega = np.interp(a["t"] - float(a["start_time"]), ref.t, ref.omega)

    def rms(x):
        return float(np.sqrt(np.mean(x**2)))

    assert rms(a["true_v_t"] - v) < 0.1  # m/s (measured 0.056)
    assert rms(a["true_v_t"] - nominal_v) > 0.2  # (measured 0.225)
    assert rms(a["true_omega"] - omega) < 0.5 * rms(a["true_omega"] - nominal_omega)  # 0.15 vs 0.36 rad/s


def test_speeds_of_a_path_run_show_the_commanded_speed_and_the_circle_yaw_rate(circle):
    """max_speed mode: u = (v_R + v_L)/2 of the commands and kappa_r u with kappa_r = 1/(2 m) on the
    circle; its full speed is I(24)'s V_m / (1 + b kappa_r) = 4.1 / 1.1 m/s."""
    a = circle.arrays
    u, omega, _ = plots.retimed_reference(a, circle.reference)
    moving = u > 0.0
    assert omega[moving] == pytest.approx(0.5 * u[moving], rel=1e-9)
    assert np.max(u) == pytest.approx(4.1 / 1.1, rel=1e-3)
    assert plots.retimed_reference({**a, "V1": np.full_like(a["V1"], math.nan)}, circle.reference) is None
