"""Reference trajectories and paths (scenarios/trajectories.py) against their closed forms."""

import math

import numpy as np
import pytest
from slipnav.scenarios.config import load_scenario
from slipnav.scenarios.run_plan import reference_for
from slipnav.scenarios.trajectories import (
    Arc,
    CosineTurn,
    PathConfig,
    Pause,
    SpotTurn,
    Straight,
    TrajectoryConfig,
    TrajectoryError,
    build_path,
    build_trajectory,
    check_trajectory_size,
    trajectory_along_path,
    trajectory_extent,
    trajectory_path,
)


def test_corner_trajectory_closed_form():
    L1, L2, L3, v = 0.8, 1.2, 0.8, 1.6
    cfg = TrajectoryConfig(
        segments=[
            Straight(length=L1, v_end=v),
            CosineTurn(angle_deg=90, length=L2),
            Straight(length=L3, v_end=0.0),
        ]
    )
    tr = build_trajectory(cfg, 0.02)
    assert tr.duration == pytest.approx(2 * L1 / v + L2 / v + 2 * L3 / v, abs=0.02)
    assert tr.length == pytest.approx(L1 + L2 + L3, abs=1e-6)
    assert tr.phi[-1] == pytest.approx(math.pi / 2, abs=1e-6)
    # Linear acceleration v^2 / (2 L1) on the first straight.
    first = tr.t < 2 * L1 / v - 0.05
    np.testing.assert_allclose(np.diff(tr.v[first]) / 0.02, v**2 / (2 * L1), rtol=1e-6)
    # Cosine curvature: peak 2*angle/L at mid-turn, zero at both ends.
    assert np.max(tr.kappa) == pytest.approx(2 * (math.pi / 2) / L2, rel=1e-3)
    # Closed-form end point of the turn: integral of (cos phi, sin phi) ds with phi(s) from kappa(s).
    s = np.linspace(0, L2, 200001)
    phi = (math.pi / 2 / L2) * (s - L2 / (2 * math.pi) * np.sin(2 * math.pi * s / L2))
    x_turn = L1 + np.trapezoid(np.cos(phi), s)
    y_turn = np.trapezoid(np.sin(phi), s)
    assert tr.x[-1] == pytest.approx(x_turn, abs=1e-5)
    assert tr.y[-1] == pytest.approx(y_turn + L3, abs=1e-5)
    v_R, v_L = tr.wheel_speeds(0.068)
    np.testing.assert_allclose((v_R - v_L) / 0.068, tr.omega)


def test_square_closes_and_demands_high_acceleration():
    tr, _ = reference_for(load_scenario("square"))
    # Four (1 m side + 90 deg turn) close the loop; the 5 cm run-up and run-out lie on the first side.
    assert tr.x[-1] == pytest.approx(0.1, abs=1e-6) and tr.y[-1] == pytest.approx(0.0, abs=1e-6)
    assert tr.phi[-1] == pytest.approx(2 * math.pi, abs=1e-9)
    assert tr.length == pytest.approx(4 * 1.0 + 4 * 0.3 + 0.1, abs=1e-9)
    peak_accel = np.max(np.abs(np.diff(tr.v))) / tr.T_C
    assert peak_accel > 1.3 * 0.7 * 9.81 * 0.8  # beyond the traction limit: wheels must slip
    # Sinusoidal bump v0 + (v_peak - v0) sin^2: peak acceleration pi (v_peak - v0) / T, T = 2 L/(v0 + v_peak).
    assert peak_accel == pytest.approx(math.pi * (2.2 - 0.3) / (2 * 1.0 / 2.5), rel=0.01)
    # The turns are sinusoidal in yaw rate at 0.3 m/s: peak kappa = 2 * (pi/2) / 0.3.
    assert np.max(tr.kappa) == pytest.approx(math.pi / 0.3, rel=1e-3)


def test_circle_path_and_its_open_loop_trajectory():
    path = build_path(PathConfig(segments=[Arc(radius=2.0, angle_deg=360)]))
    assert path.length == pytest.approx(4 * math.pi, rel=1e-9)
    assert path.max_abs_curvature == pytest.approx(0.5)
    np.testing.assert_allclose(path.pose(path.length), [0.0, 0.0, 2 * math.pi], atol=1e-6)
    np.testing.assert_allclose(path.pose(math.pi), [2.0, 2.0, math.pi / 2], atol=1e-6)
    tr = trajectory_along_path(path, 2.0, 0.02)
    assert tr.duration == pytest.approx(2 * math.pi, abs=0.05)
    np.testing.assert_allclose(tr.omega[:-2], 1.0)


def test_long_path_has_turns_of_different_radii():
    scenario = load_scenario("long_path")
    path = build_path(scenario.path)
    radii = {round(1.0 / abs(k), 3) for k in np.unique(np.round(path.kappa, 6)) if k != 0}
    assert radii == {2.5, 3.0, 4.0, 5.0}
    assert path.max_abs_curvature < 1.0 / (0.5 * scenario.robot_parameters().track_width)  # I(7)


@pytest.mark.parametrize(
    "segments, message",
    [
        ([Straight(length=-1.0, v_end=1.0)], r"segments\[0\].*length=-1.0.*allowed"),
        ([Straight(length=1.0)], r"segments\[0\].*stands still"),
        ([Straight(length=1.0, v_end=1.0), SpotTurn()], r"segments\[1\].*at rest"),
        ([Arc(radius=1.0, angle_deg=0.0, v_end=1.0)], r"segments\[0\].*angle_deg"),
        ([Straight(length=1.0, v_end=1.0, v_peak=2.0)], r"v_end or v_peak"),
        ([Pause(duration=-1.0)], r"duration=-1.0"),
    ],
)
def test_bad_segments_name_the_segment(segments, message):
    with pytest.raises(TrajectoryError, match=message):
        build_trajectory(TrajectoryConfig(segments=segments), 0.02)


def test_path_rejects_timed_segments():
    with pytest.raises(TrajectoryError, match=r"path.segments\[0\].*Straight, Arc and CosineTurn"):
        build_path(PathConfig(segments=[SpotTurn()]))


def test_repetitions_are_built_one_after_the_other():
    """A repeated lap (the square, then about 1 s at rest) is built a repetition at a time: the T_C grid runs
    on without a gap or a double sample at the joints, each lap repeats the first one moved by the first
    lap's end pose, the arc length goes on, and the closed loop's path skips the Pause (4.1 m a lap)."""
    square = load_scenario("square").trajectory
    rolling = trajectory_extent(square)[0]
    pause = 0.02 * math.ceil(rolling / 0.02) - rolling + 1.0  # a lap of whole control periods
    lap = [*square.segments, Pause(duration=pause)]
    one = build_trajectory(TrajectoryConfig(segments=lap), 0.02)
    three = build_trajectory(TrajectoryConfig(segments=lap, repeat=3), 0.02)
    np.testing.assert_allclose(np.diff(three.t), 0.02, atol=1e-9)
    n = len(one.t) - 1  # the single lap's grid ends on its own last sample
    assert len(three.t) in (3 * n + 1, 3 * n + 2)
    for k in (1, 2):
        part = slice(k * n, (k + 1) * n)
        np.testing.assert_allclose(three.v[part], one.v[:n], atol=1e-9)
        np.testing.assert_allclose(three.omega[part], one.omega[:n], atol=1e-9)
        np.testing.assert_allclose(three.s[part], one.s[:n] + k * one.s[-1], atol=1e-9)
        # the lap turns by 2 pi: each one is the first moved by its end point, 0.1 m along x
        np.testing.assert_allclose(three.x[part], one.x[:n] + k * one.x[-1], atol=1e-9)
        np.testing.assert_allclose(three.y[part], one.y[:n] + k * one.y[-1], atol=1e-9)
        np.testing.assert_allclose(three.phi[part], one.phi[:n] + k * one.phi[-1], atol=1e-9)
    path = trajectory_path(TrajectoryConfig(segments=lap, repeat=3))
    assert path.length == pytest.approx(3 * one.s[-1], abs=3e-3)
    with pytest.raises(TrajectoryError, match=r"SpotTurn.*or a Pause"):
        rolling = [Straight(1.0, v_end=1.0), Straight(1.0, v_end=0.0)]
        trajectory_path(TrajectoryConfig(segments=[*rolling, SpotTurn()]))


def test_a_trajectory_longer_than_four_hours_is_refused():
    """Four hours of repetitions at most (MAX_TRAJECTORY_DURATION); one repetition's 0.1 ms grid at most
    MAX_TRAJECTORY_SAMPLES (500 s)."""
    lap = [Straight(1.0, v_end=1.0), Straight(1.0, v_end=0.0), Pause(duration=58.0)]  # 62 s a lap
    check_trajectory_size(TrajectoryConfig(segments=lap, repeat=232))  # 4 h less 16 s
    with pytest.raises(TrajectoryError, match=r"allowed up to 14400 s"):
        check_trajectory_size(TrajectoryConfig(segments=lap, repeat=233))
    with pytest.raises(TrajectoryError, match=r"one repetition takes 504 s .*allowed up to 500 s"):
        check_trajectory_size(TrajectoryConfig(segments=[*lap[:2], Pause(duration=500.0)], repeat=2))
