"""``slipnav calibrate``: a robot's parameters from its own sensor logs and a few hand measurements.

The procedure of a lab with a tape measure and a protractor (each manoeuvre starts with the robot held
still for STANDSTILL_PREFIX seconds, so that every log carries its own gyro and accelerometer biases):

- standstill (STANDSTILL_TIME): gyro and accelerometer biases and white noise; the gyro's Allan
  deviation gives the EKF's gyro variance R[0] (the white-noise level at tau = T_N);
- spot turns of whole revolutions, clockwise and counter-clockwise, the final heading measured by hand
  (sigma HEADING_STD): the gyro's scale ((1 + s) times the true turn = the integrated, de-biased gyro);
- UMBmark's bidirectional square (Borenstein & Feng 1996; clockwise and counter-clockwise, spot turns at
  the corners) and straight runs there and back, each final pose measured by hand (sigma POSITION_STD,
  HEADING_STD): with the spot turns' headings, each wheel's rolling radius and the track width, by
  nonlinear least squares of the encoders' dead reckoning against the measured poses;
- spins (SPIN_SEGMENTS spot turns of one revolution at SPIN_RATE of the gyro's range, alternately both
  ways, SPIN_PAUSE s held still after each): each accelerometer's scale error and misalignment, its
  de-biased reading (biases piecewise linear through the pauses) against the centripetal omega^2 p of
  the steady spin (gyro, calibrated; nominal mounting position p), one fit per segment, their mean and
  scatter (identify_accelerometers);
- slowly tightening circles (two left, two right) at constant speed (spiral_speed) into the friction
  limit: the tyres' peak acceleration a_peak, the median of the largest 0.5 s means of the tyres' force
  per unit mass (accelerometers corrected with their identified scale and misalignment;
  identify_peak_acceleration), its standard error from the four runs' scatter;
- coasting runs (COAST_RUNS): straight to 1 m/s, then the motors switched off (the plant's motor_enable
  input; simulated with the continuous plant, COAST_PLANT_TIME_STEP), the robot rolls out on its felt
  shoes: the drag per unit mass the navigation's mixing uses (drag_acceleration + drag_per_speed |v|),
  from the distance rolled (identify_drag; the wheels' inertia and bearing drag of the data sheet taken
  off).

Every fit is ``scipy.optimize.least_squares`` on residuals weighted by their standard deviations; the
standard errors come from its Jacobian, (J^T J)^-1 scaled by max(1, chi^2 / dof).

``slipnav calibrate --simulate ROBOT --seed N`` drives these manoeuvres open loop on the simulated robot
drawn from the tolerance preset by the seed (``Scenario.plant_parameters(seed, tolerances=True)``),
takes the "hand measurements" from the true final poses plus noise of the stated sigmas, and identifies
from the logs: nothing of the plant is read but through them. The true values are reported beside the
identified ones only to judge the identification.

Not identified (README.md: Calibration): the accelerometers' mounting position (the nominal one is
used), the wheels' inertia and bearing drag (data sheet), the tyres' shape factors. The stated standard
errors of the drag (encoder quantisation and the two runs' scatter) and of a_peak (the spirals' scatter)
understate their systematic errors (README.md: Calibration).
"""

from __future__ import annotations

import dataclasses as dc
import math

import numpy as np
from slipnav.scenarios.config import Scenario, ScenarioError
from slipnav.scenarios.model import RobotModel, SensorCalibration
from slipnav.studies.calibration_identify import (
    identify_accelerometers,
    identify_drag,
    identify_geometry,
    identify_gyro_scale,
    identify_peak_acceleration,
    identify_standstill,
)
from slipnav.studies.calibration_manoeuvres import Manoeuvre, simulate_manoeuvres
from slipnav.studies.calibration_session import read_session, write_session
from slipnav.systems.navigation.parameters import NavigationParameters

A_PEAK_MODEL_UNCERTAINTY = 0.02
"""Relative standard uncertainty of a_peak from the lumped tyre model (type B, added to the spirals'
scatter): the identified a_peak's errors against the simulated tyres (docs/results.md, section
calibration), which the four spirals' scatter does not show."""
DRAG_MODEL_UNCERTAINTY = 0.002
"""Relative standard uncertainty of each drag term from the coasting model (type B): the drag's errors
against the simulated shoes (docs/results.md, section calibration), which the fit's statistics (encoder
quantisation) understate."""


@dc.dataclass
class Calibration:
    """Identified values (SI, key -> value) and their standard errors; ``model`` the model to write."""

    values: dict
    standard_errors: dict
    model: RobotModel
    details: dict


def calibrate(manoeuvres: list[Manoeuvre], robot_name: str, base: RobotModel | None = None) -> Calibration:
    """Identify the robot from its manoeuvres (see the module docstring); ``base``: the nominal model."""
    base = base or RobotModel(robot=robot_name)
    robot = base.robot_parameters()
    T_N = base.T_N
    counts = base.sensor_parameters().encoder_counts_per_revolution
    kinds = {m.kind for m in manoeuvres}
    missing = {"standstill", "spot_turn", "straight", "square", "spin", "spiral", "coast"} - kinds
    if missing:
        raise ScenarioError(f"calibration needs the manoeuvres {sorted(missing)}: allowed a complete set")
    still = identify_standstill(next(m for m in manoeuvres if m.kind == "standstill"), T_N)
    scale, scale_se = identify_gyro_scale(manoeuvres, T_N, still["gyro_white_noise_std"])
    (r_R, r_L, b), (se_R, se_L, se_b), chi2 = identify_geometry(manoeuvres, robot, counts, T_N)
    position = base.sensor_parameters().accelerometer_position
    accel, accel_se, accel_segments = identify_accelerometers(
        manoeuvres, T_N, robot, (r_R, r_L, b), scale, counts, position
    )
    drag, drag_se, drag_chi2 = identify_drag(manoeuvres, T_N, robot, (r_R, r_L, b), counts)
    peaks = np.array(
        [
            identify_peak_acceleration(m, T_N, robot, (r_R, r_L, b), scale, counts, accel=accel)
            for m in manoeuvres
            if m.kind == "spiral"
        ]
    )
    a_peak, a_peak_se = spirals_peak(peaks)
    drag_se = np.hypot(drag_se, DRAG_MODEL_UNCERTAINTY * np.abs(drag))
    values = {
        "wheel_radius_R": r_R,
        "wheel_radius_L": r_L,
        "track_width": b,
        "gyro_scale_error": scale,
        "gyro_bias": still["gyro_bias"],
        "accel_bias": [float(v) for v in still["accel_bias"]],
        "gyro_white_noise_std": still["gyro_white_noise_std"],
        "accel_noise_std": [float(v) for v in still["accel_noise_std"]],
        "tyre_peak_acceleration": a_peak,
        "accel1_scale_error": accel[0],
        "accel1_misalignment": accel[1],
        "accel2_scale_error": accel[2],
        "accel2_misalignment": accel[3],
        "drag_acceleration": drag[0],
        "drag_per_speed": drag[1],
    }
    errors = {
        "wheel_radius_R": se_R,
        "wheel_radius_L": se_L,
        "track_width": se_b,
        "gyro_scale_error": scale_se,
        "gyro_bias": still["gyro_bias_se"],
        "tyre_peak_acceleration": a_peak_se,
        "accel1_scale_error": accel_se[0],
        "accel1_misalignment": accel_se[1],
        "accel2_scale_error": accel_se[2],
        "accel2_misalignment": accel_se[3],
        "drag_acceleration": drag_se[0],
        "drag_per_speed": drag_se[1],
    }
    model = calibrated_model(base, values, errors)
    details = {
        "geometry_chi2_per_dof": chi2,
        "accelerometer_segments": accel_segments,
        "drag_chi2_per_dof": drag_chi2,
        "peaks": peaks,
        "allan_tau": still["allan_tau"],
        "allan": still["allan_deviation"],
    }
    return Calibration(values=values, standard_errors=errors, model=model.validate(), details=details)


def spirals_peak(peaks: np.ndarray) -> tuple[float, float]:
    """The tyres' peak acceleration from the spirals' (a_peak, standard error) rows and its standard error."""
    # The spirals' median (robust to one spiral's odd reading); its standard error from their scatter
    # (the peak of a vibrating, sliding tyre varies from run to run more than one window's statistics
    # say: 1.4826 MAD, times 1.253 for a median), at least the windows' own.
    a_peak = float(np.median(peaks[:, 0]))
    spread = 1.4826 * float(np.median(np.abs(peaks[:, 0] - a_peak)))
    scatter = 1.253 * spread / math.sqrt(len(peaks)) if len(peaks) > 1 else 0.0
    a_peak_se = max(scatter, float(np.sqrt(np.mean(peaks[:, 1] ** 2) / len(peaks))))
    # Type B: the model errors no scatter shows, from validating against the simulated truth.
    a_peak_se = math.hypot(a_peak_se, A_PEAK_MODEL_UNCERTAINTY * a_peak)
    return a_peak, a_peak_se


def calibrated_model(base: RobotModel, values: dict, errors: dict) -> RobotModel:
    """``base`` with the identified ``values`` (calibrate's keys) and their standard ``errors``: the
    geometry as robot overrides, the sensors' errors as its SensorCalibration, the gyro's white noise as
    the EKF's R[0], the tyre peak and the drag in the mixing."""
    navigation = dc.replace(base.navigation)
    R = list(navigation.ekf.R)
    R[0] = values["gyro_white_noise_std"] ** 2
    navigation = dc.replace(
        navigation,
        ekf=dc.replace(navigation.ekf, R=R),
        mixing=dc.replace(
            navigation.mixing,
            tyre_peak_acceleration=values["tyre_peak_acceleration"],
            drag_acceleration=max(float(values["drag_acceleration"]), 0.0),
            drag_per_speed=max(float(values["drag_per_speed"]), 0.0),
        ),
    )
    return dc.replace(
        base,
        description="identified by slipnav calibrate (studies/calibration.py)",
        robot_overrides={
            **base.robot_overrides,
            "rolling_radius_R": values["wheel_radius_R"],
            "rolling_radius_L": values["wheel_radius_L"],
            "track_width": values["track_width"],
        },
        calibration=SensorCalibration(
            gyro_scale_error=values["gyro_scale_error"],
            gyro_bias=float(values["gyro_bias"]),
            accel1_scale_error=float(values["accel1_scale_error"]),
            accel2_scale_error=float(values["accel2_scale_error"]),
            accel1_misalignment=float(values["accel1_misalignment"]),
            accel2_misalignment=float(values["accel2_misalignment"]),
            accel_bias=[float(v) for v in values["accel_bias"]],
        ),
        navigation=navigation,
        standard_errors={k: float(v) for k, v in errors.items()},
    )


COMPARED = (
    ("wheel_radius_R", "wheel_radius_R", "rel"),
    ("wheel_radius_L", "wheel_radius_L", "rel"),
    ("track_width", "track_width", "rel"),
    ("gyro_scale_error", "gyro_scale_error", "abs"),
    ("tyre_peak_acceleration", "traction_limit_acceleration", "rel"),
    ("accel1_scale_error", "accel1_scale_error", "abs"),
    ("accel2_scale_error", "accel2_scale_error", "abs"),
    ("accel1_misalignment", "accel1_misalignment", "deg"),
    ("accel2_misalignment", "accel2_misalignment", "deg"),
    ("drag_acceleration", "drag_acceleration", "rel"),
    ("drag_per_speed", "drag_per_speed", "rel"),
)
"""(identified key, true key of simulate_manoeuvres' truth, error kind): a scale error's error is
absolute (a relative error of the scale 1 + s), a misalignment's in degrees ("deg"), the rest relative
(absolute where the true value is 0, e.g. Kurt3D's drag without shoes)."""


def compare(calibration: Calibration, truth: dict) -> dict:
    """key -> (identified, true, error (relative or absolute, 1), error / standard error)."""
    out = {}
    for key, true_key, kind in COMPARED:
        value, se, true = calibration.values[key], calibration.standard_errors[key], truth[true_key]
        error = value - true
        if kind == "deg":
            relative = math.degrees(error)
        elif kind == "rel":
            relative = error / true if true != 0.0 else error
        else:
            relative = error / (1.0 + true)
        out[key] = (value, true, relative, error / se if se > 0 else math.inf)
    return out


def simulated_calibration(
    robot_name: str, seed: int, session_dir=None, scenario: Scenario | None = None
) -> tuple[Calibration, dict]:
    """Drive and identify on the toleranced simulated ``robot_name`` of ``seed``: (calibration, truth).
    ``scenario``: instead, the robot its ``plant`` section makes (the truth; no tolerance preset) and its
    nominal robot as the belief. ``session_dir``: write the logs and measurements there as a calibration
    session and identify from reading it back (studies/calibration_session.py: the path of a real
    robot's logs)."""
    tolerances = scenario is None
    if scenario is None:
        scenario = Scenario(robot=robot_name, mode="trajectory", trajectory=None)
    robot_name = scenario.robot
    manoeuvres, truth = simulate_manoeuvres(scenario, seed, tolerances)
    if session_dir is not None:
        simulated = robot_name if tolerances else scenario.name
        description = f"slipnav calibrate --simulate {simulated} --seed {seed}"
        path = write_session(manoeuvres, session_dir, robot_name, description, scenario.rates())
        _, manoeuvres = read_session(path)
    base = RobotModel(
        robot=robot_name,
        robot_overrides=dict(scenario.robot_overrides),
        sensor_overrides=dict(scenario.sensor_overrides),
        navigation=NavigationParameters(),
    )
    base.T_N, base.T_C = scenario.T_N, scenario.T_C
    return calibrate(manoeuvres, robot_name, base), truth
