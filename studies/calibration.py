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
- slowly tightening circles (two left, two right) at constant speed into the friction limit: the tyres'
  peak acceleration a_peak, the mean of the tops of parabolas fitted to the tyres' force per unit mass
  around its maximum (identify_peak_acceleration), its standard error from the four runs' scatter.

Every fit is ``scipy.optimize.least_squares`` on residuals weighted by their standard deviations; the
standard errors come from its Jacobian, (J^T J)^-1 scaled by max(1, chi^2 / dof).

``slipnav calibrate --simulate ROBOT --seed N`` drives these manoeuvres open loop on the simulated robot
drawn from the tolerance preset by the seed (``Scenario.plant_parameters(seed, tolerances=True)``),
takes the "hand measurements" from the true final poses plus noise of the stated sigmas, and identifies
from the logs: nothing of the plant is read but through them. The true values are reported beside the
identified ones only to judge the identification.

Not identified (README.md: Calibration): the accelerometers' scale and misalignment and the drag.
"""

from __future__ import annotations

import dataclasses as dc
import math

import numpy as np
from scipy.optimize import least_squares
from slipnav.diagrams.open_loop import build_open_loop_diagram
from slipnav.diagrams.robot import make_simulator
from slipnav.scenarios.config import Scenario, ScenarioError
from slipnav.scenarios.model import RobotModel, SensorCalibration
from slipnav.scenarios.runner import collect_arrays
from slipnav.scenarios.sensor_log import SensorLog, sensor_log_from_arrays
from slipnav.scenarios.tolerances import plant_record
from slipnav.systems.navigation import NavigationParameters
from slipnav.systems.rates import SampleRates

STANDSTILL_PREFIX = 1.0
"""s the robot is held still at the start of every manoeuvre (its biases)."""
STANDSTILL_TIME = 30.0
"""s of the standstill log (noise and Allan deviation)."""
POSITION_STD = 0.001
"""m: hand measurement of a final position (tape measure against floor marks)."""
HEADING_STD = math.radians(0.25)
"""rad: hand measurement of a final heading (protractor / a line on the floor over the robot's length)."""
MEASUREMENT_STREAM = 17
"""Second entropy word of the simulated hand measurements' random stream (seed, 17)."""


@dc.dataclass
class Manoeuvre:
    """One calibration run: its sensor log, what was measured by hand, and how it was driven.

    Args:
        kind: ``standstill``, ``spot_turn``, ``straight``, ``square``, ``spiral``.
        log: the sensor log.
        measured_pose: the hand-measured final pose (x, y, phi) relative to the start pose (phi unwrapped:
            the whole revolutions are counted, the remainder measured), or None.
        pose_std: (position, heading) standard deviations of the measurement.
        speed: the manoeuvre's cruise speed (m/s).
    """

    kind: str
    log: SensorLog
    measured_pose: tuple | None = None
    pose_std: tuple = (POSITION_STD, HEADING_STD)
    speed: float = 0.0
    turns: float = 0.0


# ---------------------------------------------------------------------------------------------------
# Wheel-speed profiles (rows at T_C: [v_R, v_L] m/s)


def _trapezoid(distance: float, speed: float, acceleration: float, T_C: float) -> np.ndarray:
    """Speed samples at T_C covering ``distance`` with a trapezoid (or triangle) of the given limits."""
    distance = abs(distance)
    ramp = speed / acceleration
    if acceleration * ramp * ramp > distance:  # triangle
        ramp = math.sqrt(distance / acceleration)
        speed = acceleration * ramp
        cruise = 0.0
    else:
        cruise = (distance - acceleration * ramp * ramp) / speed
    total = 2.0 * ramp + cruise
    t = np.arange(0.0, total + T_C, T_C)
    v = np.minimum(np.minimum(acceleration * t, speed), acceleration * np.maximum(total - t, 0.0))
    return np.maximum(v, 0.0)


def _still(seconds: float, T_C: float) -> np.ndarray:
    return np.zeros((int(round(seconds / T_C)), 2))


def straight_rows(length: float, speed: float, acceleration: float, T_C: float) -> np.ndarray:
    v = _trapezoid(length, speed, acceleration, T_C) * math.copysign(1.0, length)
    return np.column_stack([v, v])


def spot_turn_rows(angle: float, track: float, wheel_speed: float, acceleration: float, T_C: float):
    """Turn on the spot by ``angle`` (rad, + counter-clockwise) with the nominal track."""
    w = _trapezoid(0.5 * track * angle, wheel_speed, acceleration, T_C) * math.copysign(1.0, angle)
    return np.column_stack([w, -w])


def spiral_rows(speed: float, a_limit: float, track: float, T_C: float, turn_time: float = 6.0, direction=1):
    """Accelerate straight to ``speed``, then a turn (``direction`` 1 left, -1 right) whose curvature
    grows linearly to 1.4 times a_limit / speed^2 over ``turn_time``, then stop."""
    up = _trapezoid(10.0, speed, 2.0, T_C)
    up = up[: int(np.argmax(up >= speed)) + 1]
    rows = [np.column_stack([up, up]), np.full((int(0.5 / T_C), 2), speed)]
    t = np.arange(0.0, turn_time, T_C)
    kappa = direction * 1.4 * a_limit / speed**2 * t / turn_time
    rows.append(np.column_stack([speed * (1 + 0.5 * kappa * track), speed * (1 - 0.5 * kappa * track)]))
    down = np.linspace(1.0, 0.0, int(1.0 / T_C))[:, None] * rows[-1][-1]
    rows.append(down)
    return np.vstack(rows)


def manoeuvre_plan(robot, T_C: float) -> list[tuple[str, np.ndarray, float, float]]:
    """(kind, wheel-speed rows, cruise speed, revolutions) of every manoeuvre for the nominal ``robot``;
    distances scale with its track width (Tinyphoon: 1 m square sides, 3 m straights)."""
    b = robot.track_width
    scale = max(1.0, b / 0.068 / 3.0)
    side, straight = 1.0 * scale, 3.0 * scale
    v_lin, a_lin = min(0.5, 0.2 * robot.wheel_speed_limit), 1.0
    # Spot turns below 60 % of the gyro's 300 deg/s range.
    w_turn = min(0.3, 0.6 * math.radians(300.0) * b / 2.0)
    plan = [("standstill", _still(STANDSTILL_TIME, T_C), 0.0, 0.0)]
    for direction in (1, -1, 1, -1):
        plan.append(
            ("spot_turn", spot_turn_rows(direction * 3 * 2 * math.pi, b, w_turn, 1.0, T_C), w_turn, 3.0)
        )
    for length in (straight, -straight, straight, -straight):
        plan.append(("straight", straight_rows(length, 2 * v_lin, a_lin, T_C), 2 * v_lin, 0.0))
    for direction in (-1, 1):  # UMBmark: clockwise, counter-clockwise
        legs = []
        for _ in range(4):
            legs += [straight_rows(side, v_lin, a_lin, T_C), _still(0.2, T_C)]
            legs += [spot_turn_rows(direction * math.pi / 2, b, w_turn, 1.0, T_C), _still(0.2, T_C)]
        plan.append(("square", np.vstack(legs), v_lin, 0.0))
    a_limit = robot.traction_limit_acceleration
    v_spiral = min(1.5, 0.4 * robot.wheel_speed_limit)
    for direction in (1, -1, 1, -1):
        plan.append(("spiral", spiral_rows(v_spiral, a_limit, b, T_C, direction=direction), v_spiral, 0.0))
    return plan


# ---------------------------------------------------------------------------------------------------
# Simulation of the manoeuvres on the toleranced robot


def simulate_manoeuvres(scenario: Scenario, seed: int) -> tuple[list[Manoeuvre], dict]:
    """Drive manoeuvre_plan open loop on ``scenario``'s robot drawn with the tolerance preset by ``seed``;
    returns the manoeuvres (logs and simulated hand measurements) and the true values (to judge only)."""
    rates = scenario.rates()
    robot = scenario.robot_parameters()  # nominal: the commands are planned with it
    plant, sensors, _ = scenario.plant_parameters(seed, tolerances=True)
    rng = np.random.default_rng([int(seed), MEASUREMENT_STREAM])
    manoeuvres = []
    for i, (kind, rows, speed, turns) in enumerate(manoeuvre_plan(robot, rates.T_C)):
        if kind != "standstill":
            rows = np.vstack([_still(STANDSTILL_PREFIX, rates.T_C), rows, _still(0.5, rates.T_C)])
        run_seed = (int(seed) * 64 + i) % 2**31
        built = build_open_loop_diagram(
            robot,
            sensors,
            rates,
            rows,
            np.zeros((len(rows), 3)),
            run_seed,
            plant_time_step=scenario.plant_time_step,
            plant=plant,
        )
        simulator = make_simulator(built.diagram, run_seed, robot.speed_loop_period)
        simulator.AdvanceTo((len(rows) - 1) * rates.T_C)
        arrays = collect_arrays(built.loggers, simulator.get_context(), plant)
        log = sensor_log_from_arrays(
            arrays,
            sensors.encoder_counts_per_revolution,
            {"robot": robot.name, "T_N": rates.T_N, "T_C": rates.T_C, "seed": run_seed, "scenario": kind},
        )
        for key in ("true_x", "true_y", "true_phi", "true_v_t", "true_v_n", "true_omega"):
            log.columns.pop(key, None)  # a lab has no motion capture: only the hand measurements
        true_end = (arrays["true_x"][-1], arrays["true_y"][-1], arrays["true_phi"][-1])
        measured = None
        if kind != "standstill":
            noise = rng.standard_normal(3) * [POSITION_STD, POSITION_STD, HEADING_STD]
            measured = tuple(float(v + e) for v, e in zip(true_end, noise, strict=True))
        manoeuvres.append(Manoeuvre(kind, log, measured, speed=speed, turns=turns))
    truth = plant_record(plant, sensors)
    truth["traction_limit_acceleration"] = plant.traction_limit_acceleration
    return manoeuvres, truth


# ---------------------------------------------------------------------------------------------------
# Identification


def _fit(residuals, x0, **kwargs):
    """least_squares and the standard errors of its solution ((J^T J)^-1 scaled by max(1, chi^2/dof))."""
    result = least_squares(residuals, x0, method="lm", x_scale="jac", **kwargs)
    J = result.jac
    dof = max(len(result.fun) - len(x0), 1)
    chi2 = float(result.fun @ result.fun)
    cov = np.linalg.inv(J.T @ J) * max(1.0, chi2 / dof)
    return result.x, np.sqrt(np.diag(cov)), chi2 / dof


def allan_deviation(samples: np.ndarray, T_N: float, taus: int = 12) -> tuple[np.ndarray, np.ndarray]:
    """Overlapping Allan deviation at tau = 2^j T_N (j = 0 .. while 2 tau fits 9 times in the record)."""
    x = np.cumsum(np.asarray(samples, float)) * T_N
    x = np.concatenate([[0.0], x])
    out_tau, out_dev = [], []
    for j in range(taus):
        m = 2**j
        if 2 * m * 9 > len(samples):
            break
        d = x[2 * m :] - 2.0 * x[m:-m] + x[: -2 * m]
        tau = m * T_N
        out_tau.append(tau)
        out_dev.append(math.sqrt(np.mean(d * d) / (2.0 * tau * tau)))
    return np.array(out_tau), np.array(out_dev)


def standstill_biases(log: SensorLog, seconds: float, T_N: float) -> tuple[np.ndarray, np.ndarray]:
    """Mean and its standard error of [gyro, a_t1, a_n1, a_t2, a_n2] over the first ``seconds``."""
    n = int(round(seconds / T_N))
    data = np.column_stack([log.gyro[:n], log.accelerometers[:n]])
    return np.nanmean(data, axis=0), np.nanstd(data, axis=0) / math.sqrt(n)


def identify_standstill(m: Manoeuvre, T_N: float) -> dict:
    """Biases, white noise and the gyro's Allan deviation from the standstill log."""
    data = np.column_stack([m.log.gyro, m.log.accelerometers])
    mean = np.nanmean(data, axis=0)
    std = np.nanstd(data, axis=0)
    taus, adev = allan_deviation(m.log.gyro, T_N)
    # Standard error of a mean over the record: the Allan deviation at the longest tau bounds the drift.
    se = np.maximum(std / math.sqrt(len(data)), 0.0)
    return {
        "gyro_bias": mean[0],
        "gyro_bias_se": se[0],
        "accel_bias": mean[1:],
        "accel_bias_se": se[1:],
        "gyro_noise_std": std[0],
        "accel_noise_std": std[1:],
        "gyro_white_noise_std": float(adev[0]),
        "allan_tau": taus,
        "allan_deviation": adev,
    }


def _turn_data(m: Manoeuvre, T_N: float):
    """(integrated de-biased gyro, its standard deviation, duration) of a manoeuvre after its prefix."""
    n = int(round(STANDSTILL_PREFIX / T_N))
    bias, bias_se = standstill_biases(m.log, STANDSTILL_PREFIX, T_N)
    g = m.log.gyro[n:]
    duration = len(g) * T_N
    integral = float(np.nansum(g - bias[0]) * T_N)
    return integral, float(bias_se[0] * duration), duration


def identify_gyro_scale(manoeuvres: list[Manoeuvre], T_N: float, noise_std: float) -> tuple[float, float]:
    """Gyro scale error s from the spot turns: integral of (gyro - bias) = (1 + s) * measured turn."""
    rows = []
    for m in manoeuvres:
        if m.kind != "spot_turn":
            continue
        integral, bias_part, duration = _turn_data(m, T_N)
        sigma = math.sqrt(HEADING_STD**2 + bias_part**2 + noise_std**2 * T_N * duration)
        rows.append((integral, m.measured_pose[2], sigma))
    data = np.array(rows)

    def residuals(p):
        return (data[:, 0] - (1.0 + p[0]) * data[:, 1]) / data[:, 2]

    x, se, _ = _fit(residuals, [0.0])
    return float(x[0]), float(se[0])


def _smooth(x: np.ndarray, n: int) -> np.ndarray:
    return np.convolve(x, np.ones(n) / n, mode="same") if n > 1 else x


def _increments(counts: np.ndarray, step: float) -> np.ndarray:
    """(K, 2) wheel-angle increments of the valid rows (a missing row is spanned by the next valid one)."""
    good = np.all(np.isfinite(counts), axis=1)
    return np.diff(counts[good] * step, axis=0)


def creep_speeds(d: np.ndarray, r_R: float, r_L: float, b: float, robot, T_N: float) -> np.ndarray:
    """(K, 2) slip speeds r theta_dot - v of the right and left tyre (m/s) that the nominal robot's tyres
    need to push it along the wheel motion ``d`` (angle increments): the body's inertia plus the felt
    shoes' drag and yaw moment (systems.plant.shoe_force with the nominal shoes), each wheel's force
    through the inverse of the nominal tyre curve (mixing.tyre_slip) at the slip's reference speed
    max(|v|, slip_speed_floor). Rubber tyres creep ahead of the body whenever they push: ~0.7 % of the
    distance at cruise for Tinyphoon's shoes, which a calibration that ignored it would put into the
    radii. The nominal robot is the belief (data sheet), never the plant."""
    p = robot
    n = max(int(round(0.02 / T_N)), 1)
    v_R, v_L = _smooth(r_R * d[:, 0] / T_N, n), _smooth(r_L * d[:, 1] / T_N, n)
    v, omega = 0.5 * (v_R + v_L), (v_R - v_L) / b
    a_t, omega_dot = np.gradient(v, T_N), np.gradient(omega, T_N)
    force_x = p.mass * a_t
    moment = p.yaw_inertia * omega_dot
    n_shoe = p.shoe_normal_load
    for x_shoe in (p.shoe_offset, -p.shoe_offset):
        u_x, u_y = v, omega * x_shoe
        speed = np.hypot(u_x, u_y)
        with np.errstate(invalid="ignore", divide="ignore"):
            coulomb = np.where(
                speed > 1e-12, p.shoe_friction * n_shoe * np.tanh(speed / p.shoe_slip_speed) / speed, 0.0
            )
        scale = coulomb + p.shoe_viscous_drag
        force_x = force_x + scale * u_x  # the tyres push against the shoes' drag ...
        moment = moment + x_shoe * scale * u_y  # ... and turn against their yaw moment
    peak = p.tyre_friction * p.wheel_normal_load
    out = np.empty((len(v), 2))
    for i, (force, speed) in enumerate(
        ((0.5 * force_x + moment / b, v_R), (0.5 * force_x - moment / b, v_L))
    ):
        u = np.clip(np.abs(force) / peak, 0.0, 0.999)
        sigma = np.tan(np.arcsin(u) / p.tyre_shape_factor) / p.tyre_stiffness_factor
        out[:, i] = np.sign(force) * sigma * np.maximum(np.abs(speed), p.slip_speed_floor)
    return out


def dead_reckoning_end(d: np.ndarray, slip: np.ndarray, r_R: float, r_L: float, b: float, T_N: float):
    """Final (x, y, phi) of the dead reckoning (midpoint heading) from the start pose 0: each wheel's
    ground increment r dtheta minus its creep speed times T_N."""
    dR = r_R * d[:, 0] - slip[:, 0] * T_N
    dL = r_L * d[:, 1] - slip[:, 1] * T_N
    ds, dphi = 0.5 * (dR + dL), (dR - dL) / b
    phi = np.concatenate([[0.0], np.cumsum(dphi)])
    mid = phi[:-1] + 0.5 * dphi
    return np.array([np.sum(ds * np.cos(mid)), np.sum(ds * np.sin(mid)), phi[-1]])


def identify_geometry(manoeuvres: list[Manoeuvre], robot, counts_per_revolution: int, T_N: float):
    """(r_R, r_L, b), their standard errors and chi^2/dof, by least squares of the dead-reckoned final
    poses of the straight runs and UMBmark squares (x, y, phi) and the spot turns (phi) against the
    hand-measured ones. The tyres' creep (creep_speeds) is computed with the nominal geometry, then
    again with the first fit's, and held fixed in each fit."""
    step = 2.0 * math.pi / counts_per_revolution
    r0, b0 = robot.wheel_radius, robot.track_width
    used = [m for m in manoeuvres if m.kind in ("spot_turn", "straight", "square")]
    increments = [_increments(m.log.encoder_counts, step) for m in used]
    geometry = (r0, r0, b0)
    for _ in range(2):
        slips = [creep_speeds(d, *geometry, robot, T_N) for d in increments]

        def residuals(p, slips=slips):
            r_R, r_L, b = r0 * (1 + p[0]), r0 * (1 + p[1]), b0 * (1 + p[2])
            out = []
            for m, d, slip in zip(used, increments, slips, strict=True):
                end = dead_reckoning_end(d, slip, r_R, r_L, b, T_N)
                sp, sh = m.pose_std
                if m.kind != "spot_turn":
                    out += [(end[0] - m.measured_pose[0]) / sp, (end[1] - m.measured_pose[1]) / sp]
                out.append((end[2] - m.measured_pose[2]) / sh)
            return np.array(out)

        x, se, chi2 = _fit(residuals, [0.0, 0.0, 0.0])
        geometry = (r0 * (1 + x[0]), r0 * (1 + x[1]), b0 * (1 + x[2]))
    errors = np.array([r0 * se[0], r0 * se[1], b0 * se[2]])
    return np.array(geometry), errors, chi2


def shoe_forces_per_mass(v_t, v_n, omega, robot) -> tuple[np.ndarray, np.ndarray]:
    """The nominal felt shoes' force per unit mass on the body (x, y) at body velocities (arrays), as
    systems.plant.shoe_force (tanh-regularised Coulomb plus viscous, at +- shoe_offset)."""
    p = robot
    fx, fy = np.zeros_like(v_t), np.zeros_like(v_t)
    for x_shoe in (p.shoe_offset, -p.shoe_offset):
        u_x, u_y = v_t, v_n + omega * x_shoe
        speed = np.hypot(u_x, u_y)
        with np.errstate(invalid="ignore", divide="ignore"):
            coulomb = np.where(
                speed > 1e-12,
                p.shoe_friction * p.shoe_normal_load * np.tanh(speed / p.shoe_slip_speed) / speed,
                0.0,
            )
        fx -= (coulomb + p.shoe_viscous_drag) * u_x
        fy -= (coulomb + p.shoe_viscous_drag) * u_y
    return fx / p.mass, fy / p.mass


def identify_peak_acceleration(
    m: Manoeuvre,
    T_N: float,
    robot,
    geometry,
    gyro_scale: float,
    counts_per_revolution: int,
    window=0.1,
    span=0.3,
):
    """a_peak: the vertex of a parabola fitted (least squares) within ``span`` s of its maximum to the
    tyres' force per unit mass on the friction circle, |m a - F_shoes| / m: a the de-biased mean of the
    two accelerometers (free of the rotational terms), the shoes' force (nominal shoes) at the body
    velocity from odometry (v_t), gyro (omega) and v_n integrated from dv_n/dt = a_n - v_t omega. This
    is the quantity the navigation compares with a_peak (mixing.combined_slip)."""
    bias, _ = standstill_biases(m.log, STANDSTILL_PREFIX, T_N)
    start = int(round(STANDSTILL_PREFIX / T_N))
    acc = (m.log.accelerometers - bias[1:])[start:]
    a_t, a_n = 0.5 * (acc[:, 0] + acc[:, 2]), 0.5 * (acc[:, 1] + acc[:, 3])
    omega = np.nan_to_num((m.log.gyro[start:] - bias[0]) / (1.0 + gyro_scale))
    counts = m.log.encoder_counts[start - 1 :] * (2.0 * math.pi / counts_per_revolution)
    d = np.diff(counts, axis=0)
    v_t = 0.5 * (geometry[0] * d[:, 0] + geometry[1] * d[:, 1]) / T_N
    v_t = _smooth(np.nan_to_num(v_t), max(int(round(0.02 / T_N)), 1))
    v_n = np.cumsum(np.nan_to_num(a_n) - v_t * omega) * T_N
    shoe_x, shoe_y = shoe_forces_per_mass(v_t, v_n, omega, robot)
    force = np.hypot(a_t - shoe_x, a_n - shoe_y)
    n = max(int(round(window / T_N)), 1)
    smooth = _smooth(np.nan_to_num(force), n)
    k = int(np.argmax(smooth))
    half = int(round(span / T_N))
    lo, hi = max(k - half, 0), min(k + half + 1, len(force))
    t = (np.arange(lo, hi) - k) * T_N
    y = force[lo:hi]
    good = np.isfinite(y)
    t, y = t[good], y[good]
    sigma = float(np.std(y - smooth[lo:hi][good]))  # sample noise around the moving average

    def residuals(p):
        return (p[0] - p[1] * (t - p[2]) ** 2 - y) / sigma

    x, se, chi2 = _fit(residuals, [float(smooth[k]), 1.0, 0.0])
    return float(x[0]), float(se[0])


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
    missing = {"standstill", "spot_turn", "straight", "square", "spiral"} - kinds
    if missing:
        raise ScenarioError(f"calibration needs the manoeuvres {sorted(missing)}: allowed a complete set")
    still = identify_standstill(next(m for m in manoeuvres if m.kind == "standstill"), T_N)
    scale, scale_se = identify_gyro_scale(manoeuvres, T_N, still["gyro_white_noise_std"])
    (r_R, r_L, b), (se_R, se_L, se_b), chi2 = identify_geometry(manoeuvres, robot, counts, T_N)
    peaks = np.array(
        [
            identify_peak_acceleration(m, T_N, robot, (r_R, r_L, b), scale, counts)
            for m in manoeuvres
            if m.kind == "spiral"
        ]
    )
    # The spirals' mean; its standard error from their scatter (the peak of a vibrating, sliding tyre
    # varies from run to run far more than one fit's statistics say), at least the fits' own.
    a_peak = float(np.mean(peaks[:, 0]))
    scatter = float(np.std(peaks[:, 0], ddof=1) / math.sqrt(len(peaks))) if len(peaks) > 1 else 0.0
    a_peak_se = max(scatter, float(np.sqrt(np.mean(peaks[:, 1] ** 2) / len(peaks))))
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
    }
    errors = {
        "wheel_radius_R": se_R,
        "wheel_radius_L": se_L,
        "track_width": se_b,
        "gyro_scale_error": scale_se,
        "gyro_bias": still["gyro_bias_se"],
        "tyre_peak_acceleration": a_peak_se,
    }
    navigation = dc.replace(base.navigation)
    R = list(navigation.ekf.R)
    R[0] = still["gyro_white_noise_std"] ** 2
    navigation = dc.replace(
        navigation,
        ekf=dc.replace(navigation.ekf, R=R),
        mixing=dc.replace(navigation.mixing, tyre_peak_acceleration=a_peak),
    )
    model = dc.replace(
        base,
        description="identified by slipnav calibrate (studies/calibration.py)",
        robot_overrides={
            **base.robot_overrides,
            "rolling_radius_R": r_R,
            "rolling_radius_L": r_L,
            "track_width": b,
        },
        calibration=SensorCalibration(
            gyro_scale_error=scale,
            gyro_bias=float(still["gyro_bias"]),
            accel_bias=[float(v) for v in still["accel_bias"]],
        ),
        navigation=navigation,
        standard_errors={k: float(v) for k, v in errors.items()},
    )
    details = {
        "geometry_chi2_per_dof": chi2,
        "allan_tau": still["allan_tau"],
        "allan": still["allan_deviation"],
    }
    return Calibration(values=values, standard_errors=errors, model=model.validate(), details=details)


COMPARED = (
    ("wheel_radius_R", "wheel_radius_R", "rel"),
    ("wheel_radius_L", "wheel_radius_L", "rel"),
    ("track_width", "track_width", "rel"),
    ("gyro_scale_error", "gyro_scale_error", "abs"),
    ("tyre_peak_acceleration", "traction_limit_acceleration", "rel"),
)
"""(identified key, true key of simulate_manoeuvres' truth, error kind): the scale error's error is
absolute (a relative error of the scale 1 + s), the rest relative."""


def compare(calibration: Calibration, truth: dict) -> dict:
    """key -> (identified, true, error (relative or absolute, 1), error / standard error)."""
    out = {}
    for key, true_key, kind in COMPARED:
        value, se, true = calibration.values[key], calibration.standard_errors[key], truth[true_key]
        error = value - true
        relative = error / true if kind == "rel" else error / (1.0 + true)
        out[key] = (value, true, relative, error / se if se > 0 else math.inf)
    return out


def simulated_calibration(robot_name: str, seed: int, session_dir=None) -> tuple[Calibration, dict]:
    """Drive and identify on the toleranced simulated ``robot_name`` of ``seed``: (calibration, truth).
    ``session_dir``: write the logs and measurements there as a calibration session and identify from
    reading it back (studies/calibration_session.py: the path of a real robot's logs)."""
    scenario = Scenario(robot=robot_name, mode="trajectory", trajectory=None)
    manoeuvres, truth = simulate_manoeuvres(scenario, seed)
    if session_dir is not None:
        from slipnav.studies.calibration_session import read_session, write_session

        description = f"slipnav calibrate --simulate {robot_name} --seed {seed}"
        path = write_session(manoeuvres, session_dir, robot_name, description)
        _, manoeuvres = read_session(path)
    base = RobotModel(robot=robot_name, navigation=NavigationParameters())
    base.T_N, base.T_C = SampleRates().T_N, SampleRates().T_C
    return calibrate(manoeuvres, robot_name, base), truth


def calibrate_command(
    robot_name: str, seeds: list[int], out_dir, stream=None, logs: bool = False
) -> list[dict]:
    """``slipnav calibrate --simulate ROBOT --seed N`` (or ``--seeds N``): drive, identify, write
    ``DIR/<robot>-seed<N>.calibrated.model.yaml`` per seed, print identified vs true with the errors in
    standard errors; last line ``calibration worst_radius_pct=.. worst_track_pct=.. worst_gyro_scale_pct=..
    worst_a_peak_pct=..``. ``logs``: also write each seed's session (``DIR/<robot>-seed<N>.calibration/``,
    logs and session.yaml) and identify from reading it back. Returns one row per seed."""
    import sys
    from pathlib import Path as FilePath

    from slipnav.scenarios.model import write_model

    stream = stream or sys.stdout
    out = FilePath(out_dir)
    rows = []
    for seed in seeds:
        session = out / f"{robot_name}-seed{seed}.calibration" if logs else None
        calibration, truth = simulated_calibration(robot_name, seed, session)
        path = write_model(calibration.model, out / f"{robot_name}-seed{seed}.calibrated.model.yaml")
        rows.append(compare(calibration, truth))
        print(f"{path}", file=stream)
        for key, (value, true, error, z) in rows[-1].items():
            se = calibration.standard_errors[key]
            print(
                f"  {key:24s} identified {value:.6g} +- {se:.2g}  true {true:.6g}  "
                f"error {100 * error:+.3f} % "
                f"({z:+.1f} standard errors)",
                file=stream,
            )
    worst = {
        key: max(abs(row[key][2]) for row in rows) * 100
        for key in (
            "wheel_radius_R",
            "wheel_radius_L",
            "track_width",
            "gyro_scale_error",
            "tyre_peak_acceleration",
        )
    }
    print(
        f"calibration worst_radius_pct={max(worst['wheel_radius_R'], worst['wheel_radius_L']):.4f} "
        f"worst_track_pct={worst['track_width']:.4f} worst_gyro_scale_pct={worst['gyro_scale_error']:.4f} "
        f"worst_a_peak_pct={worst['tyre_peak_acceleration']:.3f}",
        file=stream,
    )
    return rows
