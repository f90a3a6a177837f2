"""Calibration from a real robot's log and its ground truth (``slipnav calibrate LOG --truth TRUTH``):
the rolling radii, the effective track and the gyro's scale and bias that make the sensors agree with
the truth, written as a model for the robot's other logs.

On the log's T_N grid, over the samples the truth covers, every signal passes the same Savitzky-Golay
filter (SMOOTHING s, alignment.smooth), so that their lags match:

- the truth's speed along its heading v = x' cos(yaw) + y' sin(yaw) and its yaw rate omega = yaw';
- each wheel's rate w = theta' (its counts times the encoder step);
- the gyro.

Three linear least-squares fits, on the samples where a wheel turns faster than MOVING_WHEEL_RATE:

1. v = (r_R w_R + r_L w_L) / 2: the rolling radii r_R, r_L;
2. omega = (r_R w_R - r_L w_L) / b: the effective track b (a Kobuki's wheels turn the robot less than
   its data-sheet track says: the tyres' width and the casters' scrub);
3. the gyro's integral against the truth's heading change, int gyro dt = (1 + s_g) (yaw - yaw_0) +
   b_g t + c over every sample the truth covers (unsmoothed): the gyro's scale error s_g and its bias b_g
   on the day (a record). Angles, not rates: a residual lag between the gyro's and the truth's clocks
   shifts a rate by the yaw acceleration times the lag, which a rate fit takes for scale, while the
   heading a turn adds is the same whenever it is read.

Each estimate's standard error is the fit's (residual variance times the normal equations' inverse),
with the samples' correlation counted: the residuals of neighbouring samples are not independent, so the
variance is scaled by the samples per independent one, the filter's window in fits 1 and 2, and in fit 3
(1 + rho) / (1 - rho) for the residuals' lag-one autocorrelation rho (an AR(1) model's effective count).
"""

import dataclasses as dc
import math
import sys
from pathlib import Path as FilePath

import numpy as np
from slipnav.scenarios import alignment as al
from slipnav.scenarios.artifacts import check_output_directory
from slipnav.scenarios.evaluate import read_truth, truth_on
from slipnav.scenarios.model import RobotModel, write_model
from slipnav.scenarios.replay import log_name, read_log
from slipnav.scenarios.typed_yaml import ScenarioError

SMOOTHING = 0.2
"""Window (s) of the Savitzky-Golay filter every signal passes before the fits."""
MOVING_WHEEL_RATE = 0.5
"""A sample enters the fits while a wheel turns faster than this (rad/s; a Kobuki wheel at 2 cm/s)."""


class TruthCalibrationError(ScenarioError):
    """A log and truth that cannot calibrate the model: the message names the input and the reason."""


@dc.dataclass(frozen=True)
class TruthCalibration:
    """What the fits found (module docstring): estimates and their standard errors (SI units), the
    samples used."""

    rolling_radius_R: float
    rolling_radius_L: float
    track_width: float
    gyro_scale_error: float
    gyro_bias: float
    standard_errors: dict
    samples: int


def _fit(design: np.ndarray, target: np.ndarray, correlated: float) -> tuple[np.ndarray, np.ndarray]:
    """Least squares target = design @ theta: (theta, standard errors), the residual variance scaled by
    ``correlated`` samples per independent one."""
    theta, *_ = np.linalg.lstsq(design, target, rcond=None)
    residual = target - design @ theta
    dof = max(len(target) - design.shape[1], 1)
    variance = float(residual @ residual) / dof * correlated
    covariance = variance * np.linalg.inv(design.T @ design)
    return theta, np.sqrt(np.diag(covariance))


def smoothed_signals(columns: dict, truth: dict, encoder_step: float, T_N: float) -> dict:
    """The truth's v and omega, the wheels' rates and the gyro on the log's grid, smoothed alike, and the
    samples whose whole filter window the truth covers (``use``)."""
    t = np.asarray(columns["t"], float)
    pose, covered = truth_on(t, truth)
    window = int(round(SMOOTHING / T_N)) | 1
    use = np.convolve(~covered, np.ones(window), mode="same") == 0  # the whole window covered
    x_dot = al.smooth(pose[:, 0], T_N, SMOOTHING, deriv=1)
    y_dot = al.smooth(pose[:, 1], T_N, SMOOTHING, deriv=1)
    yaw = al.smooth(pose[:, 2], T_N, SMOOTHING)
    signals = {
        "v": x_dot * np.cos(yaw) + y_dot * np.sin(yaw),
        "omega": al.smooth(pose[:, 2], T_N, SMOOTHING, deriv=1),
        "w_R": al.smooth(encoder_step * np.asarray(columns["enc_R"], float), T_N, SMOOTHING, deriv=1),
        "w_L": al.smooth(encoder_step * np.asarray(columns["enc_L"], float), T_N, SMOOTHING, deriv=1),
        "gyro": al.smooth(np.asarray(columns["gyro"], float), T_N, SMOOTHING),
    }
    finite = np.all(np.isfinite(np.column_stack(list(signals.values()))), axis=1)
    signals["use"] = use & finite
    signals["window"] = float(window)
    return signals


def integrated_gyro_fit(columns: dict, truth: dict, T_N: float) -> tuple:
    """Fit 3 of the module docstring: ((1 + s_g, b_g), their standard errors) from the gyro's running
    integral against the truth's unwrapped heading on the samples the truth covers."""
    t = np.asarray(columns["t"], float)
    pose, covered = truth_on(t, truth)
    gyro = np.asarray(columns["gyro"], float)
    use = covered & np.isfinite(gyro)
    angle = np.cumsum(np.where(np.isfinite(gyro), gyro, 0.0)) * T_N
    design = np.column_stack([pose[:, 2] - pose[use, 2][0], t, np.ones_like(t)])[use]
    theta, errors = _fit(design, angle[use], 1.0)
    residual = angle[use] - design @ theta
    rho = float(np.clip(np.corrcoef(residual[:-1], residual[1:])[0, 1], 0.0, 1.0 - 1e-9))
    return theta[:2], errors[:2] * math.sqrt((1.0 + rho) / (1.0 - rho))


def calibrate_from_truth(columns: dict, truth: dict, model: RobotModel) -> TruthCalibration:
    """The fits of the module docstring on a sensor log's ``columns`` (t, gyro, enc_R, enc_L on the
    model's T_N grid) against ``truth`` (evaluate.read_truth's seen rows on the log's clock)."""
    encoder_step = model.sensor_parameters().encoder_step
    s = smoothed_signals(columns, truth, encoder_step, model.T_N)
    moving = s["use"] & (np.maximum(np.abs(s["w_R"]), np.abs(s["w_L"])) > MOVING_WHEEL_RATE)
    samples = int(np.sum(moving))
    if samples < 3 * s["window"]:
        raise TruthCalibrationError(
            f"--truth covers {samples} samples of the log with a wheel turning faster than "
            f"{MOVING_WHEEL_RATE} rad/s: allowed at least {int(3 * s['window'])} (three filter windows)"
        )
    w_R, w_L, v, omega, gyro = (s[k][moving] for k in ("w_R", "w_L", "v", "omega", "gyro"))
    half, half_error = _fit(np.column_stack([w_R, w_L]), v, s["window"])  # v = r_R/2 w_R + r_L/2 w_L
    r_R, r_L = 2.0 * half
    difference = r_R * w_R - r_L * w_L
    inverse_track, inverse_error = _fit(difference[:, None], omega, s["window"])
    if not inverse_track[0] > 0.0:
        raise TruthCalibrationError("--truth: the wheels' yaw rate does not follow the truth's: no track")
    (gain, bias), (gain_error, bias_error) = integrated_gyro_fit(columns, truth, model.T_N)
    track = 1.0 / inverse_track[0]
    errors = {
        "rolling_radius_R": 2.0 * float(half_error[0]),
        "rolling_radius_L": 2.0 * float(half_error[1]),
        "track_width": float(inverse_error[0]) * track * track,
        "gyro_scale_error": float(gain_error),
        "gyro_bias": float(bias_error),
    }
    return TruthCalibration(
        float(r_R), float(r_L), float(track), float(gain) - 1.0, float(bias), errors, samples
    )


def calibrated_model(model: RobotModel, fit: TruthCalibration, source: str) -> RobotModel:
    """``model`` with the fitted radii, track and gyro calibration, their standard errors, and a
    description naming ``source``."""
    robot = {
        **model.robot_overrides,
        "rolling_radius_R": fit.rolling_radius_R,
        "rolling_radius_L": fit.rolling_radius_L,
        "track_width": fit.track_width,
    }
    calibration = dc.replace(
        model.calibration, gyro_scale_error=fit.gyro_scale_error, gyro_bias=fit.gyro_bias
    )
    description = f"{model.description}; calibrated against the truth of {source} ({fit.samples} samples)"
    return dc.replace(
        model,
        robot_overrides=robot,
        calibration=calibration,
        description=description.lstrip("; "),
        standard_errors={**model.standard_errors, **fit.standard_errors},
    ).validate()


def fit_summary(fit: TruthCalibration) -> str:
    """One line: the estimates with their standard errors."""
    e = fit.standard_errors
    return (
        f"r_R {1000 * fit.rolling_radius_R:.2f} +- {1000 * e['rolling_radius_R']:.2f} mm, "
        f"r_L {1000 * fit.rolling_radius_L:.2f} +- {1000 * e['rolling_radius_L']:.2f} mm, "
        f"track {1000 * fit.track_width:.1f} +- {1000 * e['track_width']:.1f} mm, "
        f"gyro scale {100 * fit.gyro_scale_error:+.2f} +- {100 * e['gyro_scale_error']:.2f} %, "
        f"bias {math.degrees(fit.gyro_bias):+.3f} deg/s ({fit.samples} samples)"
    )


def calibrate_truth_command(log_path, truth_path, model_path=None, out_dir="runs", stream=None):
    """``slipnav calibrate LOG --truth TRUTH [--model MODEL] [--out DIR]``: read the log, its model (the
    ``--model``, else the log's companion, else the nominal robot of its ``# robot:``) and the truth, fit
    (calibrate_from_truth), write ``DIR/<log stem>.calibrated.model.yaml``; print its path, the fits
    and ``calibration model=<path>``. Returns the TruthCalibration."""
    stream = stream or sys.stdout
    log, model, _ = read_log(log_path, model_path)
    truth = read_truth(truth_path)
    fit = calibrate_from_truth(log.columns, truth, model)
    stem = log_name(log_path)
    out = check_output_directory(out_dir)
    path = write_model(
        calibrated_model(model, fit, FilePath(truth_path).name), out / f"{stem}.calibrated.model.yaml"
    )
    print(path, file=stream)
    print(f"  {fit_summary(fit)}", file=stream)
    print(f"calibration model={path}", file=stream)
    return fit
