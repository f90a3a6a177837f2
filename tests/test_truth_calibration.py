"""Calibration from a log and its ground truth (studies/truth_calibration.py): the fits recover the
radii, the track and the gyro's scale and bias of a hand-made robot, and the command writes the model."""

import math

import numpy as np
import pytest
from slipnav.scenarios.importers import truth_text
from slipnav.scenarios.model import RobotModel, load_model, model_text
from slipnav.scenarios.sensor_log import SensorLog, write_sensor_log
from slipnav.studies.cli import main
from slipnav.studies.truth_calibration import TruthCalibrationError, calibrate_from_truth

T_N = 0.002
R_R, R_L, TRACK = 0.0352, 0.0346, 0.25
GYRO_SCALE, GYRO_BIAS = 0.02, 0.01


def hand_made_robot(duration=30.0):
    """Log columns and truth of a robot on rolling tyres (no slip) driving v = 0.4 + 0.2 sin(0.5 t)
    m/s, omega = 0.8 sin(0.3 t) + 0.3 sin(1.1 t) rad/s: wheel angles from R_R, R_L, TRACK (one
    millionth of a turn per count), a gyro with GYRO_SCALE and GYRO_BIAS, the pose at 100 Hz."""
    t = T_N * np.arange(int(duration / T_N))
    v = 0.4 + 0.2 * np.sin(0.5 * t)
    omega = 0.8 * np.sin(0.3 * t) + 0.3 * np.sin(1.1 * t)
    heading = np.concatenate([[0.0], np.cumsum(0.5 * (omega[1:] + omega[:-1]) * T_N)])
    x = np.concatenate(
        [[0.0], np.cumsum(0.5 * (v[1:] * np.cos(heading[1:]) + v[:-1] * np.cos(heading[:-1])) * T_N)]
    )
    y = np.concatenate(
        [[0.0], np.cumsum(0.5 * (v[1:] * np.sin(heading[1:]) + v[:-1] * np.sin(heading[:-1])) * T_N)]
    )
    step = 2.0 * math.pi / 1e6
    wheel = {"R": (v + 0.5 * TRACK * omega) / R_R, "L": (v - 0.5 * TRACK * omega) / R_L}
    angle = {k: np.concatenate([[0.0], np.cumsum(0.5 * (w[1:] + w[:-1]) * T_N)]) for k, w in wheel.items()}
    columns = {
        "t": t,
        "gyro": (1.0 + GYRO_SCALE) * omega + GYRO_BIAS,
        "enc_R": angle["R"] / step,
        "enc_L": angle["L"] / step,
    }
    every = 5  # 100 Hz
    truth = {"t": t[::every], "x": x[::every], "y": y[::every], "yaw": heading[::every]}
    return columns, truth


def model():
    return RobotModel(
        robot="tinyphoon", sensor_overrides={"encoder_counts_per_revolution": 1000000}
    ).validate()


def test_the_fits_recover_a_hand_made_robot():
    columns, truth = hand_made_robot()
    fit = calibrate_from_truth(columns, truth, model())
    assert fit.rolling_radius_R == pytest.approx(R_R, rel=2e-3)
    assert fit.rolling_radius_L == pytest.approx(R_L, rel=2e-3)
    assert fit.track_width == pytest.approx(TRACK, rel=2e-3)
    assert fit.gyro_scale_error == pytest.approx(GYRO_SCALE, abs=2e-3)
    assert fit.gyro_bias == pytest.approx(GYRO_BIAS, abs=1e-3)
    for name, error in fit.standard_errors.items():  # the estimates lie within a few standard errors
        assert error > 0.0, name
    assert abs(fit.track_width - TRACK) < 5.0 * fit.standard_errors["track_width"] + 1e-4


def test_the_gyro_fit_reads_angles_so_a_lag_and_noise_do_not_bias_its_scale():
    """The gyro 40 ms late against the truth, with 0.02 rad/s of white noise (a navX's): fit 3 compares
    the gyro's integral with the heading change, which a lag shifts by at most omega times the lag at
    the ends, so the scale stays within 0.2 % and the bias within 0.05 deg/s of the hand-made ones, the
    scale within three of its standard errors."""
    columns, truth = hand_made_robot(60.0)
    lag = int(round(0.04 / T_N))
    gyro = np.concatenate([np.full(lag, columns["gyro"][0]), columns["gyro"][:-lag]])
    columns["gyro"] = gyro + 0.02 * np.random.default_rng(5).standard_normal(len(gyro))
    fit = calibrate_from_truth(columns, truth, model())
    assert fit.gyro_scale_error == pytest.approx(GYRO_SCALE, abs=2e-3)
    assert fit.gyro_bias == pytest.approx(GYRO_BIAS, abs=math.radians(0.05))
    assert abs(fit.gyro_scale_error - GYRO_SCALE) < 3.0 * fit.standard_errors["gyro_scale_error"] + 1e-4


def test_a_truth_that_covers_too_little_of_the_log_is_a_clear_error():
    columns, truth = hand_made_robot()
    short = {k: v[:10] for k, v in truth.items()}  # 0.05 s of truth
    with pytest.raises(TruthCalibrationError, match="--truth covers"):
        calibrate_from_truth(columns, short, model())


def test_the_command_writes_a_model_the_fits_describe(tmp_path, capsys):
    columns, truth = hand_made_robot(20.0)
    for name in ("acc1_t", "acc1_n", "acc2_t", "acc2_n"):
        columns[name] = np.zeros_like(columns["t"])
    columns["enc_R"], columns["enc_L"] = np.round(columns["enc_R"]), np.round(columns["enc_L"])
    log = tmp_path / "robot.sensors.csv"
    write_sensor_log(SensorLog(columns, {"T_N": T_N, "encoder_counts_per_revolution": 1000000}), log)
    (tmp_path / "robot.model.yaml").write_text(model_text(model()))
    (tmp_path / "robot.truth.csv").write_text(truth_text({**truth, "quality": np.ones_like(truth["t"])}))
    argv = [
        "calibrate",
        str(log),
        "--truth",
        str(tmp_path / "robot.truth.csv"),
        "--out",
        str(tmp_path / "out"),
    ]
    assert main(argv) == 0
    written = load_model(tmp_path / "out" / "robot.calibrated.model.yaml")
    robot = written.robot_parameters()
    assert robot.track_width == pytest.approx(TRACK, rel=2e-3)
    assert robot.radius_R == pytest.approx(R_R, rel=2e-3) and robot.radius_L == pytest.approx(R_L, rel=2e-3)
    assert written.calibration.gyro_scale_error == pytest.approx(GYRO_SCALE, abs=2e-3)
    assert capsys.readouterr().out.strip().splitlines()[-1].startswith("calibration model=")


@pytest.mark.parametrize(
    "extra, phrase",
    [
        (["--model", "m.yaml"], "--model applies with"),
        (["--truth", "t.csv", "--seed", "1"], "--seed with --truth"),
    ],
)
def test_calibrate_against_truth_mistakes_exit_2(extra, phrase, capsys):
    assert main(["calibrate", *(["log.csv"] if "--truth" in extra else []), *extra]) == 2
    err = capsys.readouterr().err
    assert phrase in err and len(err.strip().splitlines()) == 1
