"""slipnav import: the alignment's estimators on synthetic data with known answers, the phil-turtlebot
adapter on the real files (skipped without ../shared/datasets), import -> log -> replay."""

import math
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation
from slipnav.scenarios import alignment as al
from slipnav.scenarios.evaluate import evaluate_arrays
from slipnav.scenarios.importers import write_import
from slipnav.scenarios.model import load_model
from slipnav.scenarios.replay import replay_log
from slipnav.scenarios.sensor_log import SensorLog, read_sensor_log
from slipnav.studies.cli import main
from slipnav.systems.robot.faults import SENSOR_CHANNELS

DATASETS = Path(__file__).resolve().parents[1].parent / "shared" / "datasets"
TURTLEBOT = DATASETS / "phil-turtlebot2-vicon"
needs_turtlebot = pytest.mark.skipif(
    not (TURTLEBOT / "trial_2").is_dir(),
    reason=f"the TurtleBot dataset is not at {TURTLEBOT} (../shared/datasets beside the repository; "
    "docs/robot-logs.md says where to obtain it)",
)


def _yaw_rate(t):
    return 0.8 * np.sin(0.7 * t) + 0.5 * np.sin(2.3 * t + 1.0)


def test_lag_and_gyro_axis_are_recovered():
    t_ref = np.arange(0.0, 30.0, 0.01)
    t = np.arange(0.0, 30.0, 0.02) + 0.003
    lag = 0.037
    gyro = np.column_stack([0.1 * np.sin(5 * t), -_yaw_rate(t - lag), np.cos(t)])
    fit = al.select_gyro_axis(t_ref, _yaw_rate(t_ref), t, gyro)
    assert (fit["axis"], fit["sign"]) == (1, -1)
    assert fit["lag_s"] == pytest.approx(lag, abs=1e-3)
    assert fit["correlation"] > 0.999


def _synthetic_motion(angle, offset, wobble):
    """A robot driving and turning with a Vicon object rocking about its base: the object's frames
    (N, 3, 3), origins (N, 3), and the wheels' speed."""
    step = 0.01
    t = np.arange(0.0, 40.0, step)
    heading = np.cumsum(_yaw_rate(t)) * step
    speed = 0.2 + 0.15 * np.sin(0.3 * t)
    speed[(t > 10) & (t < 15)] = 0.0  # a turn on the spot
    centre = np.column_stack([np.cumsum(speed * np.cos(heading)), np.cumsum(speed * np.sin(heading))]) * step
    pitch = wobble * np.sin(3.1 * t)
    robot = Rotation.from_euler("zy", np.column_stack([heading, pitch]))
    obj = robot * Rotation.from_euler("z", -angle)  # the robot's forward axis at +angle in the object's frame
    rotation = obj.as_matrix()
    origin = np.column_stack([centre, np.full(len(t), 0.035)]) - rotation @ np.asarray(offset)
    return t, step, rotation, origin, speed, heading, centre


@pytest.mark.parametrize("wobble", [0.0, 0.03])
def test_frame_alignment_recovers_a_synthetic_offset(wobble):
    angle, offset = math.radians(104.3), (0.012, -0.004, -0.42 if wobble else 0.0)
    t, step, rotation, origin, speed, heading, centre = _synthetic_motion(angle, offset, wobble)
    rate = al.smooth(rotation.reshape(-1, 9), step, 0.2, 1).reshape(-1, 3, 3)
    velocity = al.smooth(origin, step, 0.2, 1)
    k = slice(20, -20)
    fit = al.fit_truth_offset(rotation[k], rate[k], velocity[k], speed[k])
    assert math.degrees(fit["angle"]) == pytest.approx(104.3, abs=0.05)
    assert np.allclose(fit["offset"], offset, atol=1e-3)
    fitted_heading, fitted_centre = al.truth_pose(rotation, origin, fit["angle"], fit["offset"])
    assert np.max(np.abs(fitted_heading - heading)) < 1e-3
    assert np.max(np.hypot(*(fitted_centre - centre).T)) < 1e-3


def test_accelerometer_rotation_and_vertical_axis():
    rng = np.random.default_rng(0)
    n = 3000
    a_t, a_n = rng.normal(0, 0.3, n), rng.normal(0, 0.3, n)
    w, wd = rng.normal(0, 1, n), rng.normal(0, 1, n)
    lever, bias, angle = (0.05, -0.1), (0.1, -0.05), math.radians(90.0 + 3.0)
    body = np.column_stack(
        [a_t - w**2 * lever[0] - wd * lever[1] + bias[0], a_n + wd * lever[0] - w**2 * lever[1] + bias[1]]
    )
    reading = al.rotate(-angle, body) + rng.normal(0, 0.05, (n, 2))
    fit = al.fit_accelerometer_rotation(reading, a_t, a_n, w, wd)
    assert math.degrees(fit["angle"]) == pytest.approx(93.0, abs=0.5)
    assert fit["quarter_turns"] == 1
    assert np.allclose(fit["lever"], lever, atol=0.01) and np.allclose(fit["bias"], bias, atol=0.01)
    assert al.vertical_axis(np.column_stack([reading, np.full(n, -9.8)])) == (2, -1)
    assert al.horizontal_axes(2, 1) == (0, 1) and al.horizontal_axes(2, -1) == (1, 0)


def test_longest_hold_is_the_longest_run_of_equal_readings_in_time():
    t = np.array([0.0, 0.02, 0.04, 0.06, 0.08, 0.10, 0.13, 0.15])
    values = np.array([1.0, 1.0, 2.0, 3.0, 3.0, 3.0, 4.0, 4.0])
    assert al.longest_hold(t, values) == pytest.approx(0.04)  # 3.0 from 0.06 to 0.10
    assert al.longest_hold(t, np.arange(8.0)) == 0.0


def test_fresh_counts_interpolate_bursts_and_hold_standstills():
    t = np.arange(0.0, 2.0, 0.024)
    true = np.where(t < 1.0, 100.0 * t, 100.0)  # drives 1 s at 100 counts/s, then stands
    polled = 100.0 * np.floor(t / 0.072) * 0.072  # a new count every third message
    polled = np.minimum(polled, 100.0)
    knots_t, knots, interval = al.fresh_counts(t, polled[:, None])
    assert interval == pytest.approx(0.072, abs=1e-9)
    grid = np.arange(0.1, 1.9, 0.002)
    counts = al.on_grid(grid, knots_t, knots, "interpolate")[:, 0]
    assert np.max(np.abs(counts - np.interp(grid, t, true))) < 8.0  # within one update's counts
    assert np.all(np.diff(counts) >= 0) and counts[-1] == 100.0
    held = al.on_grid(grid, t, polled, "hold")
    assert np.all(np.isin(held, polled))
    assert np.array_equal(al.unwrap_counter([65530, 65535, 4, 10]), [65530, 65535, 65540, 65546])


def test_centred_mean_by_hand():
    x = np.array([0.0, 3.0, 6.0, 9.0, 30.0])
    np.testing.assert_allclose(al.centred_mean(x, 3), [1.0, 3.0, 6.0, 15.0, 23.0])  # the ends held
    pair = al.centred_mean(np.column_stack([x, -x]), 3)
    np.testing.assert_allclose(pair[:, 1], [-1.0, -3.0, -6.0, -15.0, -23.0])
    assert np.array_equal(al.centred_mean(x, 1), x)
    ramp = 0.002 * np.arange(100)  # a steady speed keeps its angle: the mean of a line is the line
    np.testing.assert_allclose(al.centred_mean(ramp, 21)[10:-10], ramp[10:-10], atol=1e-12)


@pytest.fixture(scope="module")
def trial_2():
    from slipnav.scenarios.import_turtlebot import import_trial

    return import_trial(TURTLEBOT / "trial_2")


@needs_turtlebot
def test_turtlebot_import_estimates_clocks_axes_and_the_truth_frame(trial_2):
    r = trial_2.report
    assert r["gyro"]["yaw_axis"] == "+z" and r["clocks"]["navx"]["yaw_rate_correlation"] > 0.99
    assert r["accelerometer"]["mapping"] == "forward = -y, left = +x, up = +z"
    assert abs(r["accelerometer"]["fitted_angle_deg"] - 90.0) < 10.0
    assert 0.0 < r["clocks"]["navx"]["lag_behind_vicon_s"] < 0.1
    assert r["clocks"]["kobuki"]["yaw_rate_correlation"] > 0.99
    o = r["truth_offset"]
    assert 100.0 < o["forward_axis_in_object_frame_deg"] < 110.0
    assert o["axle_centre_horizontal_distance_m"] < 0.03 and o["velocity_residual_rms_m_s"] < 0.01
    assert r["encoders"]["counts_per_tick"] == pytest.approx(3.0, rel=1e-9)
    c = trial_2.log.columns
    assert np.array_equal(c["acc1_t"], c["acc2_t"]) and np.array_equal(c["acc1_n"], c["acc2_n"])
    assert np.all(c["enc_R"] == np.round(c["enc_R"]))
    assert r["log"]["rows"] == len(c["t"]) and 45.0 < r["log"]["duration_s"] < 48.0
    # the navX reports one reading for up to 0.1 s (five 50 Hz messages): the model allows twice that
    assert 0.09 < r["imu_stream"]["longest_hold_s"] < 0.11
    assert trial_2.model.sensor_parameters().inertial_hold_time == 2.0 * r["imu_stream"]["longest_hold_s"]


@needs_turtlebot
def test_turtlebot_import_writes_a_log_replay_reads_and_replays(trial_2, tmp_path):
    files = write_import(trial_2, tmp_path)
    assert [f.name for f in files] == [
        f"{trial_2.name}.{suffix}" for suffix in ("sensors.csv", "model.yaml", "truth.csv", "import.json")
    ]
    model = load_model(files[1])
    assert model.sensor_parameters().encoder_counts_per_revolution == 7735
    assert model.robot_parameters().wheel_radius == 0.035 and model.robot_parameters().track_width == 0.23
    log = read_sensor_log(files[0], model.T_N)
    for name, values in trial_2.log.columns.items():
        assert np.array_equal(log.columns[name], values), name
    lines = [line for line in files[2].read_text().splitlines() if not line.startswith("#")]
    assert lines[0] == "t,x,y,yaw,quality" and len(lines) == 4790
    assert all(line.endswith(",1") and line.count(",") == 4 for line in lines[1:])
    short = SensorLog({k: v[:2500] for k, v in log.columns.items()}, dict(log.metadata))  # 5 s
    result = replay_log(short, model, "short")
    errors = result.summary["final_position_error_m"]
    assert errors["odometry"] < 0.05 and errors["gyrodometry"] < 0.05
    assert np.isfinite(result.arrays["est_x"]).all()
    hold = trial_2.model.sensor_parameters().inertial_hold_time
    assert model.sensor_parameters().inertial_hold_time == hold
    for channel in SENSOR_CHANNELS:  # nothing flagged: the device's own holds are no frozen sensor
        assert not np.any(result.arrays[f"health_{channel}"]), channel
    # no slip on this trial: with the angles averaged over four fresh-count intervals (about 0.2 s) the
    # stamps' jitter stays below the slip detector's threshold
    assert 0.15 < trial_2.report["encoders"]["angle_average_s"] < 0.3
    assert np.mean(result.arrays["C1"] < 0.75) < 0.05


@needs_turtlebot
def test_turtlebot_trial_2_fused_heading_follows_the_gyro(trial_2):
    """The whole of trial 2 (48 s, 427 deg of turning) with the import's data-sheet model: one IMU gives no
    third yaw witness, so the calibration does not take the wheels' straight-line yaw for a gyro bias
    change, and the navX's slow bias drift keeps b_g where the standstill put it. The fused heading ends
    within 4 deg and its ATE at most Gyrodometry's, whose odometric heading ends 12 deg off."""
    result = replay_log(trial_2.log, trial_2.model, "trial_2")
    estimates = evaluate_arrays(result.arrays, trial_2.truth)["estimates"]
    fused, gyrodometry = estimates["fused"], estimates["gyrodometry"]
    assert abs(fused["final_heading_error_deg"]) < 4.0 and abs(gyrodometry["final_heading_error_deg"]) > 8.0
    assert fused["ate_m"] <= gyrodometry["ate_m"]
    assert result.arrays["gyro_bias_changes"][-1] == 0
    assert not any(np.any(result.arrays[f"health_{channel}"]) for channel in SENSOR_CHANNELS)


@needs_turtlebot
def test_import_command_line(tmp_path, capsys):
    trial = TURTLEBOT / "trial_2"
    assert main(["import", "phil-turtlebot", str(trial), "--out", str(tmp_path), "--resample", "hold"]) == 0
    out = capsys.readouterr().out
    assert "phil-turtlebot-trial_2: " in out and "(hold)" in out and "forward = -y" in out


@pytest.mark.parametrize(
    "argv, phrase",
    [
        (["import", "warthog", "."], "ADAPTER='warthog' is unknown: allowed phil-turtlebot, norlab-warthog"),
        (["import", "phil-turtlebot", "/nonexistent"], "TRIAL_DIR='/nonexistent' is not a folder"),
        (["import", "phil-turtlebot", "."], "holds 0 files kobuki_data_*.csv: allowed one"),
        (["import", "phil-turtlebot", str(TURTLEBOT), "--resample", "cubic"], "--resample='cubic'"),
    ],
)
def test_import_mistakes_exit_2_with_one_line(argv, phrase, capsys, tmp_path):
    assert main([*argv, "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("slipnav: error: ") and phrase in err and err.count("\n") == 1


WARTHOG = DATASETS / "norlab-warthog-doughnut"


@pytest.mark.skipif(
    not WARTHOG.is_dir(),
    reason=f"the Warthog dataset is not at {WARTHOG} (../shared/datasets beside the repository)",
)
def test_warthog_import_finds_the_antennas_and_replays_without_accelerometers():
    import datetime as dt

    from slipnav.scenarios.import_warthog import gps_minus_utc, import_trial

    assert gps_minus_utc(dt.date(2022, 9, 8)) == 18 and gps_minus_utc(dt.date(2016, 1, 1)) == 17
    result = import_trial(WARTHOG)
    r = result.report
    assert r["gyro"]["yaw_axis"] == "+z" and r["clocks"]["gyro"]["yaw_rate_correlation"] > 0.99
    assert 0.0 < r["clocks"]["gyro"]["lag_behind_gnss_s"] < 0.3
    t = r["truth"]
    assert (
        0.6 < t["baseline_m"] < 1.0 and t["mounting_angle_spread_deg"] < 5.0 and t["epochs_all_fixed"] > 2000
    )
    assert r["files"]["middle"].endswith("reach_raw_202209081406.pos")
    c = result.log.columns
    assert np.all(np.isnan(c["acc1_t"])) and np.all(c["enc_L"] == np.round(c["enc_L"]))
    short = SensorLog({k: v[:2500] for k, v in c.items()}, dict(result.log.metadata))  # 5 s
    replayed = replay_log(short, result.model, "short")
    assert np.isfinite(replayed.arrays["est_x"]).all() and np.isfinite(replayed.arrays["gyro_x"]).all()
    # the model states no accelerometer: their empty columns are not judged, nothing is flagged
    assert result.model.sensor_parameters().accelerometer_sets == 0
    assert replayed.summary["sensor_faults"] == 0
    assert not any(replayed.arrays[key].any() for key in replayed.arrays if key.startswith("health_"))


@needs_turtlebot
def test_turtlebot_trial_calibrates_against_its_truth(trial_2):
    """The Kobuki's effective track on trial 2's curves is near its data sheet's 230 mm (233 mm), the
    rolling radii near 35 mm, the navX's yaw scale within 1 % (studies/truth_calibration.py)."""
    from slipnav.studies.truth_calibration import calibrate_from_truth

    table = trial_2.truth
    seen = table["quality"] > 0
    truth = {key: table[key][seen] for key in ("t", "x", "y", "yaw")}
    fit = calibrate_from_truth(trial_2.log.columns, truth, trial_2.model)
    assert 0.225 < fit.track_width < 0.24 and fit.standard_errors["track_width"] < 0.003
    assert abs(fit.rolling_radius_R - 0.035) < 0.001 and abs(fit.rolling_radius_L - 0.035) < 0.001
    assert abs(fit.gyro_scale_error) < 0.01
