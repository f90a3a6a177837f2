"""What proprioception cannot tell apart (docs/truth-and-belief.md, "Twin robots").

A gyro whose sensitivity is 1 % low and a track 1/0.99 - 1 = 1.01 % wider than the tape measure's both
scale the ratio of the gyro's yaw rate to the odometric one by 0.99, and nothing else the sensors see
tells them apart: the encoders are the same to a count, the gyro to well under its noise, and the
accelerometers differ by 1 % of the centripetal acceleration, inside their own sensitivity tolerance (2 %).
Whatever the navigation does with those data, it ends both runs on the same heading, while the true
headings differ by 1 % of the turn. Odometry-only is exact on the first twin and Gyrodometry on the
second, so no estimator can be below both baselines on every robot of the tolerance preset.
"""

import math

import numpy as np
import pytest
from slipnav.scenarios.config import scenario_from_yaml
from slipnav.scenarios.metrics import final_position_error
from slipnav.scenarios.runner import run_scenario
from slipnav.scenarios.tolerances import TOLERANCE_PRESET

GYRO_SCALE = -0.01
TRACK_TWIN = 1.0 / (1.0 + GYRO_SCALE) - 1.0  # the track that scales the odometric yaw rate alike
TURN_DEG = 180.0

TWIN = """
description: "Kurt3D: a 180 deg cosine turn at 1 m/s, well inside the tyres' grip"
robot: kurt3d
mode: trajectory
trajectory:
  segments:
    - !Straight {length: 1.0, v_end: 1.0}
    - !CosineTurn {angle_deg: 180, length: 3.0}
    - !Straight {length: 1.0, v_end: 0.0}
settle_time: 0.5
navigation:
  mixing: {a3: 200.0, b3: 0.4, gyro_turn_rate: 0.05, tyre_peak_acceleration: 7.85,
           tyre_stiffness_factor: 12.0, drag_acceleration: 0.0, drag_per_speed: 0.0}
"""


def twin_run(deviation: str):
    scenario = scenario_from_yaml(TWIN + f"plant: {{deviations: {{{deviation}}}}}\n", name="twin")
    return scenario, run_scenario(scenario, seed=0, open_loop=True).arrays


@pytest.fixture(scope="module")
def twins():
    scenario, low_gyro = twin_run(f"gyro_scale: {GYRO_SCALE}")
    _, wide_track = twin_run(f"track_width: {TRACK_TWIN!r}")
    return scenario, low_gyro, wide_track


@pytest.fixture(scope="module")
def distance_twins():
    _, large_radii = twin_run("wheel_radius_R: 0.01, wheel_radius_L: 0.01")
    _, sensitive = twin_run("gyro_scale: 0.01, accel1_scale: 0.01, accel2_scale: 0.01")
    return large_radii, sensitive


def end_gap(a: dict, b: dict, prefix: str) -> float:
    x, y = f"{prefix}_x", f"{prefix}_y"
    return math.hypot(a[x][-1] - b[x][-1], a[y][-1] - b[y][-1])


def assert_same_data(scenario, a: dict, b: dict) -> None:
    sensors = scenario.plant_parameters(0)[1]
    n = min(len(a["t"]), len(b["t"]))
    count = 2.0 * math.pi / sensors.encoder_counts_per_revolution
    for side in ("R", "L"):
        assert np.max(np.abs(a[f"meas_enc_{side}"][:n] - b[f"meas_enc_{side}"][:n])) <= 1.01 * count
    assert np.max(np.abs(a["meas_gyro"][:n] - b["meas_gyro"][:n])) < 0.1 * sensors.gyro_noise_std
    # the accelerometers differ by 1 % of the centripetal acceleration, inside their sensitivity tolerance
    for axis in ("a_t1", "a_n1", "a_t2", "a_n2"):
        difference = np.max(np.abs(a[f"meas_{axis}"][:n] - b[f"meas_{axis}"][:n]))
        assert difference < TOLERANCE_PRESET.accel1_scale * np.max(np.abs(a[f"meas_{axis}"][:n]))


def heading_error_deg(a: dict, prefix: str) -> float:
    return math.degrees(abs(a[f"{prefix}_phi"][-1] - a["true_phi"][-1]))


def test_a_low_gyro_and_a_wide_track_give_the_sensors_the_same_data(twins):
    scenario, a, b = twins
    assert_same_data(scenario, a, b)
    # while the robots really turn by angles 1 % apart
    true_difference = math.degrees(a["true_phi"][-1] - b["true_phi"][-1])
    assert true_difference == pytest.approx(-GYRO_SCALE * TURN_DEG, rel=0.05)


def test_no_estimator_beats_both_baselines_on_both_twins(twins):
    _, a, b = twins
    true_difference = math.degrees(abs(a["true_phi"][-1] - b["true_phi"][-1]))
    # the fusion reads the same data twice and ends on the same heading (within 3 % of the twins' gap) ...
    assert math.degrees(abs(a["est_phi"][-1] - b["est_phi"][-1])) < 0.03 * true_difference
    # ... so on one twin at least it is half the gap off
    worst = max(heading_error_deg(a, "est"), heading_error_deg(b, "est"))
    assert worst > 0.45 * true_difference
    # each baseline is exact on one twin: odometry on the low gyro, Gyrodometry's turn on the wide track
    assert heading_error_deg(a, "odo") < 0.05 * true_difference
    assert heading_error_deg(b, "gyro") < 0.15 * true_difference
    # and in position: the fused estimate ends above odometry-only on the low-gyro twin
    assert final_position_error(a, "est") > 2.0 * final_position_error(a, "odo")


def test_large_radii_and_sensitive_inertial_sensors_are_twins_too(twins, distance_twins):
    scenario = twins[0]
    large_radii, sensitive = distance_twins
    assert_same_data(scenario, large_radii, sensitive)
    gap = end_gap(large_radii, sensitive, "true")
    assert gap > 0.005 * 5.0  # the large wheels carry the robot 1 % further
    assert end_gap(large_radii, sensitive, "est") < 0.2 * gap
    # odometry-only is exact on the sensitive twin, the fusion is not
    assert final_position_error(sensitive, "est") > 2.0 * final_position_error(sensitive, "odo")
