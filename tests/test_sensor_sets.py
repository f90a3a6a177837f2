"""A configurable accelerometer set (SensorParameters.accelerometer_sets: 0, 1 or 2): the plant's absent
set reads NaN; the checks judge only the sets present, read an absent set 2 across the pair from set 1
(S(3)'s rotational terms, by hand) and raise nothing on a fault-free robot with one set or none; a
belief with more sets than the robot carries flags the missing ones."""

import dataclasses as dc
import math
from pathlib import Path as FilePath

import numpy as np
import pytest
from slipnav.scenarios.config import load_scenario
from slipnav.scenarios.model import load_model
from slipnav.scenarios.runner import run_scenario
from slipnav.studies.cli import main
from slipnav.systems.health import (
    JUMP,
    NONFINITE,
    SATURATED,
    STUCK,
    SensorHealthParameters,
    health_flags,
    health_initial_state,
    health_step,
    yaw_pair_witness,
)
from slipnav.systems.robot.sensors import SensorParameters, sensor_update

from tests.test_faults import GEOMETRY, check, stream

HEALTH_KEYS = ("accel1_t", "accel1_n", "accel2_t", "accel2_n", "gyro", "encoder_R", "encoder_L")


@pytest.mark.parametrize("sets", [3, -1, 1.5, True, "two"])
def test_a_set_count_out_of_range_is_named(sets):
    with pytest.raises(ValueError, match=r"accelerometer_sets=.* allowed 0, 1 or 2"):
        SensorParameters(accelerometer_sets=sets)


def test_the_plant_reads_nan_on_an_absent_set():
    internal, state = [0.0] * 9, [0.0, 0.0, 0.0, 1.0, 0.0, 0.5, 0.0, 0.0]
    for sets, finite in ((2, 4), (1, 2), (0, 0)):
        params = SensorParameters(accelerometer_sets=sets)
        _, accel, gyro, _ = sensor_update(internal, state, (0.3, 0.5, 0.0), [0.0] * 14, params, 0.002)
        assert sum(math.isfinite(a) for a in accel) == finite and all(math.isnan(a) for a in accel[finite:])
        assert math.isfinite(gyro[0])


def test_one_set_reads_set_two_across_the_pair():
    """A turn at v = 1 m/s, omega = 3 rad/s with set 1 at (0.02, 0.015): set 2's columns hold garbage and
    are not read; its output is set 1's less the pair's rotational difference (-2 omega^2 x, -2 omega^2 y),
    the reading at (-x, -y): a_t2 = omega^2 x = 0.18, a_n2 = v omega + omega^2 y = 3.135 m/s^2 (mean over
    the samples: the angular-acceleration terms of the gyro's noise average out)."""
    one = dc.replace(GEOMETRY, accelerometer_sets=1)
    rows = stream(1000, 1.0, 3.0)
    rows[:, 2:4] = np.nan
    out, codes = check(rows, geometry=one)
    assert not codes.any()
    np.testing.assert_array_equal(out[:, [0, 1, 4, 5, 6]], rows[:, [0, 1, 4, 5, 6]])
    assert np.mean(out[:, 2]) == pytest.approx(9 * 0.02, abs=0.01)
    assert np.mean(out[:, 3]) == pytest.approx(3.0 + 9 * 0.015, abs=0.01)
    rows[:, 2:4] = 1e6  # a log's columns of an absent set: not judged
    out_again, codes = check(rows, geometry=one)
    assert not codes.any() and np.array_equal(out_again, out)


def test_no_set_reads_zero_and_blinds_the_slip_detector():
    """Without accelerometers the four channels output 0 with no flag; the navigation measures no
    acceleration: an inertial fault (the tyre-model check rests, the yaw calibration does not learn) and
    S(11) blind, on every sample."""
    none = dc.replace(GEOMETRY, accelerometer_sets=0)
    rows = stream(300, 1.0, 1.0)
    rows[:, 0:4] = np.nan
    out, codes = check(rows, geometry=none)
    assert not codes.any() and not out[:, 0:4].any()
    assert health_flags(codes[-1], False, 0) == [1.0, 0.0, 1.0]
    assert health_flags(codes[-1], False, 1) == [0.0, 0.0, 0.0]
    two_excluded = [NONFINITE, 0, NONFINITE, 0, 0, 0, 0]
    assert health_flags(two_excluded, False, 2)[2] == 1.0
    assert health_flags([NONFINITE] + [0] * 6, False, 1)[2] == 1.0  # the one tangential axis out


def _run(sets_robot: int, sets_model: int):
    scenario = load_scenario("corner")
    scenario = dc.replace(
        scenario,
        sensor_overrides={**scenario.sensor_overrides, "accelerometer_sets": sets_model},
        plant=dc.replace(scenario.plant, sensor_overrides={"accelerometer_sets": sets_robot}),
    )
    artifacts = run_scenario(scenario, seed=0)
    flagged = {key: int(np.count_nonzero(artifacts.arrays[f"health_{key}"])) for key in HEALTH_KEYS}
    return artifacts.summary, flagged


@pytest.mark.parametrize("sets", [1, 0])
def test_a_robot_with_fewer_sets_runs_without_flags_and_beats_odometry(sets):
    """The corner with one set or none, in the plant and the model alike: no channel flagged, no
    perturbation, and the fused final error below odometry-only's (one set: also below Gyrodometry's,
    the accelerometer still sees the tyres' slip)."""
    summary, flagged = _run(sets, sets)
    assert not any(flagged.values()) and not summary.get("perturbations")
    final = summary["final_position_error_m"]
    assert final["fused"] < final["odometry"]
    if sets == 1:
        assert final["fused"] < final["gyrodometry"]


def test_a_model_that_believes_in_a_missing_set_flags_it():
    """The robot carries one set, the model believes in two: set 2's NaN readings are flagged non-finite on
    every sample and replaced; nothing else is flagged."""
    summary, flagged = _run(1, 2)
    samples = round(summary["duration_s"] / 0.002)
    assert flagged["accel2_t"] == flagged["accel2_n"] >= samples
    assert not any(flagged[key] for key in HEALTH_KEYS if not key.startswith("accel2"))


def test_an_interpolated_encoder_stream_steps_its_speed_within_its_hold_time():
    """Wheel angles interpolated between readings 0.2 s apart: the speed steps at each reading, here by
    0.6 m/s (a 3 m/s^2 acceleration over 0.2 s). Against max_wheel_acceleration T_N (150 m/s^2 x 2 ms =
    0.3 m/s) that is a jump; with the stream's encoder_hold_time of 0.2 s it is 30 m/s of allowance, and
    nothing is flagged."""
    n, segment = 1000, 100  # samples, samples per reading
    speed = 1.0 + 0.6 * (np.arange(n) // segment % 2)  # m/s, alternating between readings
    theta = np.cumsum(speed) * 0.002 / GEOMETRY.radius_R
    rows = stream(n, 1.0, 0.0)
    rows[:, 5] = rows[:, 6] = theta
    _, codes = check(rows)
    assert codes[segment, 5] == codes[segment, 6] == JUMP
    _, codes = check(rows, geometry=dc.replace(GEOMETRY, encoder_hold_time=0.2))
    assert not codes.any()


def test_an_encoder_reading_repeated_within_its_hold_time_is_not_stuck():
    """An interpolated stream whose right wheel's reading repeats once (the wheel lags its reading by
    0.1 s, then catches up at twice the speed): still for 50 samples while the left wheel and the gyro
    say it turns at 1 m/s. With a fresh count every sample the stop is a jump (1 m/s in one sample); with
    a 10 ms hold the stop is within the jump test's allowance but the stillness outlasts stuck_samples
    beyond the hold (stuck from sample 409); with the stream's 0.2 s hold nothing is flagged."""
    rows = stream(1000, 1.0, 0.0)
    theta = rows[:, 5].copy()
    step = theta[1] - theta[0]
    lagged = theta.copy()
    lagged[400:450] = theta[399]  # the reading at 0.8 s repeated to 0.9 s
    lagged[450:500] = theta[399] + 2 * step * np.arange(1, 51)  # caught up by 1.0 s
    rows[:, 5] = lagged
    _, codes = check(rows)
    assert codes[400, 5] == JUMP
    _, codes = check(rows, geometry=dc.replace(GEOMETRY, encoder_hold_time=0.01))
    assert codes[409, 5] == STUCK and not codes[:409].any()
    _, codes = check(rows, geometry=dc.replace(GEOMETRY, encoder_hold_time=0.2))
    assert not codes.any()


def test_a_quantised_gyro_at_rest_is_no_rail_but_a_quantised_clip_is():
    """A gyro of one count q = 0.061 deg/s at rest, read as a stream interpolated between 50 Hz readings
    that alternate between -q and +q: its magnitude returns to q again and again with none larger
    between, which the clip test reads as a rail for a continuous sensor; with the count stated
    (gyro_resolution) the readings span one count below q, fewer than CLIP_MIN_COUNTS, and nothing is
    flagged. The same gyro on a 0.5 rad/s turn with noise of 10 counts clipped 5 counts above the turn's
    rate still is a rail: its readings span 20 counts and more below it."""
    q = math.radians(4000.0 / 65536)
    n = 1000
    levels = np.where(np.arange(n // 10 + 1) % 2 == 0, -q, q)  # a reading every 10 samples
    gyro = np.interp(np.arange(n), 10 * np.arange(len(levels)), levels)
    rows = stream(n, 0.0, 0.0)
    rows[:, 4] = gyro
    _, codes = check(rows, v0=0.0)
    assert np.any(codes[:, 4] == SATURATED)
    counted = dc.replace(GEOMETRY, gyro_resolution=q)
    _, codes = check(rows, v0=0.0, geometry=counted)
    assert not codes.any()
    rows = stream(n, 1.0, 0.5)
    noisy = 0.5 + 10 * q * np.random.default_rng(1).standard_normal(n)
    rows[:, 4] = np.minimum(np.round(noisy / q) * q, 0.5 + 5 * q)
    _, codes = check(rows, geometry=counted)
    assert np.any(codes[:, 4] == SATURATED)
    assert not codes[:, [0, 1, 2, 3, 5, 6]].any()


@pytest.mark.parametrize("sets", [1, 0])
def test_a_log_with_fewer_sets_replays_bit_for_bit_without_flags(tmp_path, sets):
    """A corner run whose robot carries one accelerometer set or none writes a sensor log with NaN in the
    absent columns and a model that states the set count; ``slipnav replay`` of that log raises no flag
    and reproduces the run's estimate bit for bit."""
    text = (FilePath(__file__).parents[1] / "scenarios" / "builtin" / "corner.yaml").read_text()
    scenario = tmp_path / "corner_sets.yaml"
    scenario.write_text(text + f"sensor_overrides: {{accelerometer_sets: {sets}}}\n")
    assert main(["run", str(scenario), "--out", str(tmp_path), "--no-figures", "--duration", "2.0"]) == 0
    name = "corner_sets-seed0"
    assert load_model(tmp_path / f"{name}.model.yaml").sensor_parameters().accelerometer_sets == sets
    log = tmp_path / f"{name}.sensors.csv"
    assert main(["replay", str(log), "--out", str(tmp_path), "--no-figures"]) == 0
    run, replay = np.load(tmp_path / f"{name}.npz"), np.load(tmp_path / f"{name}-replay.npz")
    assert np.isnan(run["meas_a_t2"]).all() and np.isnan(run["meas_a_n1"]).all() == (sets == 0)
    for key in ("est_x", "est_y", "est_phi", "C1"):
        np.testing.assert_array_equal(replay[key], run[key], err_msg=key)
    assert not any(replay[key].any() for key in replay.files if key.startswith("health_"))


def test_the_pair_witnesses_the_yaw_rate_only_as_two_healthy_sensors():
    """yaw_pair_witness, sample by sample: two noisy sensors, finite and not excluded, witness the yaw
    rate; one IMU copied into both sets (pair_copied), a non-finite reading, or a robot whose checks know
    one set do not, whatever the data sheet says of the sets."""

    def witnessed(rows, geometry=GEOMETRY):
        state, seen = health_initial_state(geometry, 1.0), []
        for row in rows:
            state, _, _ = health_step(state, row, SensorHealthParameters(), geometry)
            seen.append(yaw_pair_witness(state))
        return np.array(seen)

    rows = stream(200, 1.0, 2.0)
    assert witnessed(rows).all()
    copied = rows.copy()
    copied[:, 2:4] = copied[:, 0:2]
    assert not witnessed(copied).any()
    lost = rows.copy()
    lost[100, 1] = np.nan
    seen = witnessed(lost)
    assert not seen[100] and seen[:100].all()
    assert not witnessed(rows, dc.replace(GEOMETRY, accelerometer_sets=1)).any()
