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
from scipy.optimize import least_squares
from slipnav.diagrams.open_loop import build_open_loop_diagram
from slipnav.diagrams.robot import make_simulator
from slipnav.scenarios.config import Scenario, ScenarioError
from slipnav.scenarios.model import RobotModel, SensorCalibration
from slipnav.scenarios.progress import TaskProgress
from slipnav.scenarios.runner import collect_arrays
from slipnav.scenarios.sensor_log import SensorLog, sensor_log_from_arrays
from slipnav.scenarios.tolerances import plant_record
from slipnav.systems.navigation import NavigationParameters
from slipnav.systems.plant import GRAVITY
from slipnav.systems.sensor_correction import corrected_accelerometers

STANDSTILL_PREFIX = 1.0
"""s the robot is held still at the start of every manoeuvre (its biases)."""
STANDSTILL_TIME = 30.0
"""s of the standstill log (noise and Allan deviation)."""
POSITION_STD = 0.001
"""m: hand measurement of a final position (tape measure against floor marks)."""
HEADING_STD = math.radians(0.25)
"""rad: hand measurement of a final heading (protractor / a line on the floor over the robot's length)."""
A_PEAK_MODEL_UNCERTAINTY = 0.02
"""Relative standard uncertainty of a_peak from the lumped tyre model (type B, added to the spirals'
scatter): the identified a_peak's errors against the simulated tyres over 10 seeds (README.md:
Calibration), which the four spirals' scatter does not show."""
DRAG_MODEL_UNCERTAINTY = 0.002
"""Relative standard uncertainty of each drag term from the coasting model (type B): against the
simulated shoes the drag is within 0.13 % over 10 seeds, while the fit's statistics (encoder
quantisation) give 10-50 times less."""
MEASUREMENT_STREAM = 17
"""Second entropy word of the simulated hand measurements' random stream (seed, 17)."""
PEAK_WINDOW = 0.5
"""s: a_peak is the largest mean of the tyres' force over this window (identify_peak_acceleration). The
force near the friction limit stays within ~0.6 % of its peak for over a second, while the commotion's
means over 0.1 s scatter by 0.1 m/s^2 (Kurt3D at 2.5 m/s): the largest of many short means read up to
+15 % (Kurt3D draw 3), the 0.5 s means within +-1.6 %."""
SPIRAL_DIRECTIONS = (1, -1, 1, -1)
"""The tightening circles into the friction limit: 1 left, -1 right."""
SPIRAL_WHEEL_SPREAD = 0.2
"""Largest (b/2) a_peak / v^2 of the tightening circles at the friction limit (spiral_speed)."""
SPIRAL_SPEED_LIMIT = 0.6
"""The tightening circles' speed at most this fraction of the wheel-speed limit (spiral_speed)."""
SPIRAL_MIN_SPEED = 1.5
"""m/s: the tightening circles' speed at least this (spiral_speed)."""
SPIN_RATE = 0.85
"""The accelerometers' spins turn at this fraction of the gyro's 300 deg/s range (Tinyphoon: 4.45 rad/s, a
centripetal 0.5 m/s^2 at accelerometer 1's 25 mm)."""
SPIN_SEGMENTS = 16
SPIN_PAUSE = 0.8
"""s held still after each spin segment."""
COAST_RUNS = 2
"""Coasting runs (motors switched off at speed, the robot rolls out on its shoes)."""
COAST_TIME = 3.0
"""s the motors stay off in a coasting run (Tinyphoon rolls out from 1 m/s in ~1.5 s)."""
COAST_PLANT_TIME_STEP = 0.0
"""The plant step of the simulated coasting runs: 0, the continuous plant. The semi-implicit steps lag the
free wheel's stiff slip mode (tests/test_plant.py: 0.5 ms coasts ~3.5 % slower): the drag identified on
seed 3 is off by -2.5 % / +4.3 % (d0 / d1) at 0.1 ms, -0.5 % / +0.9 % at 0.02 ms, -0.07 % / +0.10 %
continuous."""


@dc.dataclass
class Manoeuvre:
    """One calibration run: its sensor log, what was measured by hand, and how it was driven.

    Args:
        kind: ``standstill``, ``spot_turn``, ``straight``, ``square``, ``spin``, ``spiral``, ``coast``.
        log: the sensor log.
        measured_pose: the hand-measured final pose (x, y, phi) relative to the start pose (phi unwrapped:
            the whole revolutions are counted, the remainder measured), or None.
        pose_std: (position, heading) standard deviations of the measurement.
        speed: the manoeuvre's cruise speed (m/s).
        turns: revolutions of a spot turn.
        motors_off: (start, end) times (s, from the log's first row) while the motors were switched off
            (a coasting run, from the lab's own command record), or None.
    """

    kind: str
    log: SensorLog
    measured_pose: tuple | None = None
    pose_std: tuple = (POSITION_STD, HEADING_STD)
    speed: float = 0.0
    turns: float = 0.0
    motors_off: tuple | None = None


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


def spin_rows(robot, T_C: float, segments: int = SPIN_SEGMENTS) -> np.ndarray:
    """Spot turns of one revolution at SPIN_RATE of the gyro's range, alternately counter-clockwise and
    clockwise, each followed by SPIN_PAUSE s held still (the accelerometers' biases between them)."""
    b = robot.track_width
    wheel = SPIN_RATE * math.radians(300.0) * b / 2.0
    rows = []
    for j in range(segments):
        rows += [spot_turn_rows((-1) ** j * 2.0 * math.pi, b, wheel, 2.0, T_C), _still(SPIN_PAUSE, T_C)]
    return np.vstack(rows)


def coast_rows(speed: float, acceleration: float, roll_out: float, T_C: float):
    """(wheel-speed rows, motor-enable rows, index of the first row with the motors off): accelerate straight
    to ``speed``, hold it 0.5 s, switch the motors off for ``roll_out`` s (commanding 0)."""
    up = _trapezoid(10.0, speed, acceleration, T_C)
    up = up[: int(np.argmax(up >= speed)) + 1]
    v = np.concatenate([up, np.full(int(round(0.5 / T_C)), speed), np.zeros(int(round(roll_out / T_C)))])
    enable = np.ones((len(v), 2))
    k_off = len(v) - int(round(roll_out / T_C))
    enable[k_off:] = 0.0
    return np.column_stack([v, v]), enable, k_off


def coast_speed(robot) -> float:
    """Speed a coasting run starts from (m/s): 1 m/s, at most a quarter of the wheel-speed limit."""
    return min(1.0, 0.25 * robot.wheel_speed_limit)


def spiral_speed(robot) -> float:
    """Cruise speed (m/s) of the tightening circles: SPIRAL_MIN_SPEED, or faster where needed so that at
    the friction limit the wheels' kinematic speed difference is at most SPIRAL_WHEEL_SPREAD of the speed
    ((b/2) a_peak / v^2: both tyres then slide alike and their forces add up to the lumped tyre's peak;
    at 1.5 m/s Kurt3D's inner wheel stands still there, the two forces' directions differ, the true net
    force peaks 4 % below mu g and a_peak read 3.5 % low), at most SPIRAL_SPEED_LIMIT of the wheel-speed
    limit (the commotion grows with speed and biases the peak of its noisy reading up). Tinyphoon 1.5 m/s
    (spread 0.08; at 0.97 m/s its a_peak read +1.4 .. +4.3 % over 10 seeds, at 1.5 m/s -3.0 .. +0.2 %);
    Kurt3D 2.46 m/s, at the cap (spread 0.26)."""
    b, a_limit = robot.track_width, robot.traction_limit_acceleration
    spread_speed = math.sqrt(0.5 * b * a_limit / SPIRAL_WHEEL_SPREAD)
    return min(max(SPIRAL_MIN_SPEED, spread_speed), SPIRAL_SPEED_LIMIT * robot.wheel_speed_limit)


def manoeuvre_plan(robot, T_C: float) -> list[tuple[str, np.ndarray, float, float]]:
    """(kind, wheel-speed rows, cruise speed, revolutions) of every manoeuvre for the nominal ``robot``;
    distances scale with its track width (Tinyphoon: 1 m square sides, 3 m straights). The coasting runs'
    motor-enable rows: coast_rows."""
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
    plan.append(("spin", spin_rows(robot, T_C), 0.0, 0.0))
    a_limit = robot.traction_limit_acceleration
    v_spiral = spiral_speed(robot)
    for direction in SPIRAL_DIRECTIONS:
        plan.append(("spiral", spiral_rows(v_spiral, a_limit, b, T_C, direction=direction), v_spiral, 0.0))
    for _ in range(COAST_RUNS):
        rows, _, _ = coast_rows(coast_speed(robot), a_lin, COAST_TIME, T_C)
        plan.append(("coast", rows, coast_speed(robot), 0.0))
    return plan


# ---------------------------------------------------------------------------------------------------
# Simulation of the manoeuvres on the toleranced robot


def simulate_manoeuvres(
    scenario: Scenario, seed: int, tolerances: bool = True
) -> tuple[list[Manoeuvre], dict]:
    """Drive manoeuvre_plan open loop on ``scenario``'s robot as its ``plant`` section makes it by ``seed``
    (``tolerances``: drawn within the tolerance preset where the scenario sets no bound); returns the
    manoeuvres (logs and simulated hand measurements) and the true values (to judge only)."""
    rates = scenario.rates()
    robot = scenario.robot_parameters()  # nominal: the commands are planned with it
    plant, sensors, _ = scenario.plant_parameters(seed, tolerances=tolerances)
    rng = np.random.default_rng([int(seed), MEASUREMENT_STREAM])
    manoeuvres = []
    plan = manoeuvre_plan(robot, rates.T_C)
    progress = TaskProgress(len(plan), f"slipnav: calibrate: driving seed {seed}'s manoeuvres", "manoeuvres")
    for i, (kind, rows, speed, turns) in enumerate(plan):
        progress.update(i)
        prefix = _still(STANDSTILL_PREFIX, rates.T_C)
        enable, motors_off, time_step = None, None, scenario.plant_time_step
        if kind == "coast":
            _, enable, k_off = coast_rows(speed, 1.0, COAST_TIME, rates.T_C)
            enable = np.vstack([np.ones((len(prefix), 2)), enable, np.ones((int(0.5 / rates.T_C), 2))])
            k_off += len(prefix)
            motors_off = (k_off * rates.T_C, (k_off + int(round(COAST_TIME / rates.T_C))) * rates.T_C)
            time_step = COAST_PLANT_TIME_STEP
        if kind != "standstill":
            rows = np.vstack([prefix, rows, _still(0.5, rates.T_C)])
        run_seed = (int(seed) * 64 + i) % 2**31
        built = build_open_loop_diagram(
            robot,
            sensors,
            rates,
            rows,
            np.zeros((len(rows), 3)),
            run_seed,
            plant_time_step=time_step,
            plant=plant,
            motor_enable=enable,
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
        manoeuvres.append(Manoeuvre(kind, log, measured, speed=speed, turns=turns, motors_off=motors_off))
    progress.update(len(plan))
    progress.close()
    truth = plant_record(plant, sensors)
    truth["traction_limit_acceleration"] = plant.traction_limit_acceleration
    truth.update(true_drag(plant))
    return manoeuvres, truth


def true_drag(plant) -> dict:
    """What the navigation's drag (systems/mixing.py) is for the robot ``plant``: the felt shoes' Coulomb
    friction per unit mass mu_s (1 - f_w) g and their viscous drag 2 c / m (mixing's Tinyphoon 0.49, 0.25)."""
    return {
        "drag_acceleration": plant.shoe_friction * (1.0 - plant.wheel_load_fraction) * GRAVITY,
        "drag_per_speed": 2.0 * plant.shoe_viscous_drag / plant.mass,
    }


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
    window=PEAK_WINDOW,
    accel=None,
):
    """a_peak: the largest mean over ``window`` s of the tyres' force per unit mass on the friction
    circle, |m a - F_shoes| / m: a the de-biased mean of the two accelerometers (free of the rotational
    terms; each component averaged over 0.02 s first, so that the commotion does not add to the modulus),
    the shoes' force (nominal shoes) at the body velocity from odometry (v_t), gyro (omega) and v_n
    integrated from dv_n/dt = a_n - v_t omega. This is the quantity the navigation compares with a_peak
    (mixing.combined_slip). ``accel``: the identified (s1, gamma1, s2, gamma2) that correct_accelerometers
    takes off the readings (None: taken as perfect). Returns (a_peak, its standard error from the
    samples' scatter in the window)."""
    bias, _ = standstill_biases(m.log, STANDSTILL_PREFIX, T_N)
    start = int(round(STANDSTILL_PREFIX / T_N))
    acc = (m.log.accelerometers - bias[1:])[start:]
    if accel is not None:
        acc = correct_accelerometers(acc, accel)
    a_t, a_n = 0.5 * (acc[:, 0] + acc[:, 2]), 0.5 * (acc[:, 1] + acc[:, 3])
    omega = np.nan_to_num((m.log.gyro[start:] - bias[0]) / (1.0 + gyro_scale))
    counts = m.log.encoder_counts[start - 1 :] * (2.0 * math.pi / counts_per_revolution)
    d = np.diff(counts, axis=0)
    v_t = 0.5 * (geometry[0] * d[:, 0] + geometry[1] * d[:, 1]) / T_N
    short = max(int(round(0.02 / T_N)), 1)
    v_t = _smooth(np.nan_to_num(v_t), short)
    v_n = np.cumsum(np.nan_to_num(a_n) - v_t * omega) * T_N
    shoe_x, shoe_y = shoe_forces_per_mass(v_t, v_n, omega, robot)
    f_x = _smooth(np.nan_to_num(a_t - shoe_x), short)
    f_y = _smooth(np.nan_to_num(a_n - shoe_y), short)
    force = np.hypot(f_x, f_y)
    n = max(int(round(window / T_N)), 1)
    mean = _smooth(force, n)
    k = int(np.argmax(mean))
    lo, hi = max(k - n // 2, 0), min(k + n // 2 + 1, len(force))
    spread = float(np.std(force[lo:hi]))
    return float(mean[k]), spread / math.sqrt(max((hi - lo) / short, 1.0))


def _box(x: np.ndarray, n: int) -> np.ndarray:
    """Means of consecutive non-overlapping blocks of n rows (the last incomplete block dropped)."""
    k = len(x) // n
    return x[: k * n].reshape(k, n, *x.shape[1:]).mean(axis=1)


def still_segments(log: SensorLog, T_N: float, margin: float = 0.1, shortest: float = 0.2) -> list:
    """(start, end) row ranges where the robot stands still: neither encoder moves by more than 2 counts
    (a wheel resting on a count's edge flickers) from ``margin`` s before to ``margin`` s after, at least
    ``shortest`` s long."""
    counts = np.asarray(log.encoder_counts, float)
    m = int(round(margin / T_N))
    still = np.zeros(len(counts), bool)
    if len(counts) > 2 * m:
        span = np.abs(counts[2 * m :] - counts[: -2 * m])
        still[m:-m] = np.all(span <= 2.0, axis=1)
    edges = np.flatnonzero(np.diff(np.concatenate([[0], still.astype(int), [0]])))
    return [(a, b) for a, b in zip(edges[::2], edges[1::2], strict=True) if b - a >= shortest / T_N]


def _bias_line(log: SensorLog, T_N: float, columns: slice) -> np.ndarray:
    """(N, c) bias of the given gyro/accelerometer columns ([gyro, a_t1, a_n1, a_t2, a_n2]) at every row:
    the means of the still segments (still_segments) at their centres, linear in between, flat outside."""
    data = np.column_stack([log.gyro, log.accelerometers])[:, columns]
    segments = still_segments(log, T_N)
    if not segments:
        n0 = int(round(STANDSTILL_PREFIX / T_N))
        segments = [(0, n0)]
    centres = np.array([0.5 * (a + b - 1) for a, b in segments])
    means = np.array([np.nanmean(data[a:b], axis=0) for a, b in segments])
    rows = np.arange(len(data))
    return np.column_stack([np.interp(rows, centres, means[:, j]) for j in range(data.shape[1])])


def body_kinematics(m: Manoeuvre, T_N: float, robot, geometry, gyro_scale: float, counts_per_revolution: int):
    """Per-row (v_t, omega, a_t, a_n, omega_dot) of the body from the encoders (each wheel's ground
    position r theta minus its creep, creep_speeds with the identified geometry), the gyro (de-biased with
    _bias_line, divided by 1 + the identified scale error): a_t = dv_t/dt, a_n = v_t omega (v_n ~ 0 on the
    tyres' own path), omega_dot = d omega/dt. Rows with a missing sample are NaN."""
    r_R, r_L, b = geometry
    step = 2.0 * math.pi / counts_per_revolution
    counts = m.log.encoder_counts.astype(float) * step
    good = np.all(np.isfinite(counts), axis=1)
    d = np.diff(counts, axis=0)
    d[~np.isfinite(d)] = 0.0
    slip = creep_speeds(d, r_R, r_L, b, robot, T_N)
    ground = np.column_stack([r_R * d[:, 0], r_L * d[:, 1]]) - slip * T_N
    v_half = 0.5 * (ground[:, 0] + ground[:, 1]) / T_N  # at t_k - T_N / 2
    v_t = 0.5 * (np.concatenate([[v_half[0]], v_half]) + np.concatenate([v_half, [v_half[-1]]]))
    n = max(int(round(0.01 / T_N)), 1)
    a_t = np.gradient(_smooth(v_t, n), T_N)
    omega = (m.log.gyro - _bias_line(m.log, T_N, slice(0, 1))[:, 0]) / (1.0 + gyro_scale)
    omega_dot = np.gradient(_smooth(np.nan_to_num(omega), n), T_N)
    out = np.column_stack([v_t, omega, a_t, v_t * omega, omega_dot])
    out[~good] = np.nan
    return out


def accelerometer_predictions(kinematics: np.ndarray, position) -> np.ndarray:
    """(N, 4) true readings [t1, n1, t2, n2] at body kinematics rows (v_t, omega, a_t, a_n, omega_dot), as
    systems.sensors.accelerometer_truth with the nominal mounting position (x, y) of accelerometer 1."""
    _, omega, a_t, a_n, omega_dot = kinematics.T
    px, py = position
    w2 = omega * omega
    dt, dn = -omega_dot * py - w2 * px, omega_dot * px - w2 * py
    return np.column_stack([a_t + dt, a_n + dn, a_t - dt, a_n - dn])


ACCEL_KINDS = ("spin",)
"""Manoeuvres that scale the accelerometers: steady spins, whose centripetal omega^2 p the gyro gives
exactly. Not the gyro's slower spot turns (0.25 m/s^2 over 6 s: the biases' drift counts 4 x as much).
Not the straights' launches: the simulated accelerometers sample the body's acceleration at the
instants of the 1 kHz speed loop's voltage steps (no anti-aliasing filter), a sawtooth of the T_C command
steps whose samples read ~5 % below its mean; nor the spirals, which slide sideways unseen by the
encoders."""
ACCEL_STEADY = 0.5
"""rad/s^2: only blocks whose yaw acceleration |omega_dot| stays below this (steady spin) and whose yaw rate
reaches half the run's largest are fitted."""
ACCEL_WINDOW = 0.05
"""s: the accelerometers and their predictions are compared as means over blocks of this length."""


def identify_accelerometers(manoeuvres, T_N: float, robot, geometry, gyro_scale: float, counts, position):
    """Each accelerometer's scale error s and misalignment gamma: its de-biased reading z' = t' + i n'
    against the prediction z = t + i n from the encoders and the gyro (body_kinematics,
    accelerometer_predictions; nominal mounting position), z' = (1 + s) exp(-i gamma) z (systems.sensors.
    sensor_frame), by least squares over the ACCEL_WINDOW block means of each steady spin segment of the
    ACCEL_KINDS runs (a segment: the blocks between two pauses). The biases' drift between the pauses
    (piecewise linear, _bias_line) errs by the same amount over a whole segment, so each segment is fitted
    on its own and the estimate is the segments' mean, its standard error their scatter / sqrt(count).

    Returns ((s1, gamma1, s2, gamma2), their standard errors, the segments' estimates (K, 4))."""
    n = max(int(round(ACCEL_WINDOW / T_N)), 1)
    skip = int(round(STANDSTILL_PREFIX / T_N))
    segments = []
    for m in manoeuvres:
        if m.kind not in ACCEL_KINDS:
            continue
        kin = body_kinematics(m, T_N, robot, geometry, gyro_scale, counts)
        predicted = accelerometer_predictions(kin, position)
        read = m.log.accelerometers - _bias_line(m.log, T_N, slice(1, 5))
        predicted, read = _box(predicted[skip:], n), _box(read[skip:], n)
        omega, omega_dot = _box(kin[skip:, 1], n), np.abs(_box(kin[skip:, 4], n))
        good = np.all(np.isfinite(predicted), axis=1) & np.all(np.isfinite(read), axis=1)
        good &= (omega_dot < ACCEL_STEADY) & (np.abs(omega) > 0.5 * np.nanmax(np.abs(omega)))
        edges = np.flatnonzero(np.diff(np.concatenate([[0], good.astype(int), [0]])))
        for a, b in zip(edges[::2], edges[1::2], strict=True):
            if b - a >= 4:
                segments.append((predicted[a:b], read[a:b]))
    if len(segments) < 2:
        raise ScenarioError("calibration needs at least two steady spin segments for the accelerometers")
    estimates = np.empty((len(segments), 4))
    for j, (p, r) in enumerate(segments):
        for i in range(2):
            z, zr = p[:, 2 * i] + 1j * p[:, 2 * i + 1], r[:, 2 * i] + 1j * r[:, 2 * i + 1]

            def residuals(q, z=z, zr=zr):
                e = zr - (1.0 + q[0]) * np.exp(-1j * q[1]) * z
                return np.concatenate([e.real, e.imag])

            x, _, _ = _fit(residuals, [0.0, 0.0])
            estimates[j, 2 * i : 2 * i + 2] = x
    values = estimates.mean(axis=0)
    errors = estimates.std(axis=0, ddof=1) / math.sqrt(len(segments))
    return values, errors, estimates


def correct_accelerometers(acc: np.ndarray, values) -> np.ndarray:
    """De-biased readings [t1, n1, t2, n2] (rows) back to the body axes, z = z' exp(i gamma) / (1 + s):
    the navigation's own correction (systems.sensor_correction.corrected_accelerometers) on each row;
    ``values``: (s1, gamma1, s2, gamma2)."""
    s1, gamma1, s2, gamma2 = values
    calibration = SensorCalibration(
        accel1_scale_error=s1, accel1_misalignment=gamma1, accel2_scale_error=s2, accel2_misalignment=gamma2
    )
    rows = [corrected_accelerometers(calibration, row) for row in np.asarray(acc, float)]
    return np.array(rows, float).reshape(np.shape(acc))


COAST_MIN_SPEED = 0.1
"""m/s: the coasting fit stops here (below, the shoes' regularised Coulomb friction and the encoders'
resolution)."""
COAST_SETTLE = 0.1
"""s after the switch-off left out of the coasting fit (the tyres' push relaxes)."""


def coast_position(t: np.ndarray, v0: float, A: float, B: float) -> np.ndarray:
    """Distance rolled in t from speed v0 under dv/dt = -(A + B v): (v0 + A/B)(1 - e^-Bt)/B - A t/B."""
    if abs(B) < 1e-9:
        return v0 * t - 0.5 * A * t * t
    return (v0 + A / B) * (-np.expm1(-B * t)) / B - A / B * t


def identify_drag(manoeuvres, T_N: float, robot, geometry, counts_per_revolution: int):
    """The drag per unit mass the tyres push against (systems/mixing.py: drag_acceleration + drag_per_speed
    |v|) from the coasting runs: with the motors off the robot rolls out on its shoes, m_eff dv/dt =
    -(m (d_0 + d_1 v) + 2 b_w v / r^2), m_eff = m + 2 J / r^2: the wheels' inertia J and bearing drag
    b_w (the nominal robot's, data sheet) are taken off. The distance rolled (the encoders' mean ground
    position with the identified radii, COAST_SETTLE after the switch-off until COAST_MIN_SPEED) is fitted
    by coast_position with one (A, B) for all runs and each run's start position and speed, weighted by the
    encoders' quantisation; d_0 = A m_eff / m, d_1 = (B m_eff - 2 b_w / r^2) / m.

    Returns ((d_0, d_1), their standard errors, chi^2/dof)."""
    r_R, r_L, _ = geometry
    step = 2.0 * math.pi / counts_per_revolution
    runs = []
    for m in manoeuvres:
        if m.kind != "coast" or m.motors_off is None:
            continue
        counts = m.log.encoder_counts.astype(float) * step
        s = 0.5 * (r_R * counts[:, 0] + r_L * counts[:, 1])
        t = np.arange(len(s)) * T_N
        v = np.gradient(_smooth(s, max(int(round(0.02 / T_N)), 1)), T_N)
        start, end = m.motors_off[0] + COAST_SETTLE, m.motors_off[1]
        window = (t >= start) & (t < end) & np.isfinite(s)
        stop = np.flatnonzero(window & (np.abs(v) < COAST_MIN_SPEED))
        if len(stop):
            window &= t < t[stop[0]]
        if window.sum() < 20:
            continue
        k0 = int(np.flatnonzero(window)[0])
        sign = math.copysign(1.0, v[k0])
        runs.append((t[window] - t[k0], sign * (s[window] - s[k0]), float(abs(v[k0]))))
    if not runs:
        raise ScenarioError("calibration needs a coasting run that rolls out above 0.1 m/s: none found")
    sigma = 0.5 * (r_R + r_L) * step / math.sqrt(12.0)

    def residuals(p):
        A, B = p[0], p[1]
        out = []
        for j, (t, s, _) in enumerate(runs):
            out.append((s - p[2 + 2 * j] - coast_position(t, p[3 + 2 * j], A, B)) / sigma)
        return np.concatenate(out)

    x0 = [0.5, 0.3]
    for _, _, v0 in runs:
        x0 += [0.0, v0]
    x, se, chi2 = _fit(residuals, x0)
    r = robot.wheel_radius
    m_eff = robot.mass + 2.0 * robot.wheel_inertia / r**2
    d0 = x[0] * m_eff / robot.mass
    d1 = (x[1] * m_eff - 2.0 * robot.bearing_drag / r**2) / robot.mass
    se = se[:2]
    if len(runs) > 1:  # the quantisation alone understates it: at least the runs' scatter
        single = [
            _fit(
                lambda p, t=t, s=s: (s - p[2] - coast_position(t, p[3], p[0], p[1])) / sigma,
                [x[0], x[1], 0.0, v0],
            )[0][:2]
            for t, s, v0 in runs
        ]
        se = np.maximum(se, np.std(single, axis=0, ddof=1) / math.sqrt(len(runs)))
    return np.array([d0, d1]), np.asarray(se) * m_eff / robot.mass, chi2


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
    # The spirals' median (robust to one spiral's odd reading); its standard error from their scatter
    # (the peak of a vibrating, sliding tyre varies from run to run more than one window's statistics
    # say: 1.4826 MAD, times 1.253 for a median), at least the windows' own.
    a_peak = float(np.median(peaks[:, 0]))
    spread = 1.4826 * float(np.median(np.abs(peaks[:, 0] - a_peak)))
    scatter = 1.253 * spread / math.sqrt(len(peaks)) if len(peaks) > 1 else 0.0
    a_peak_se = max(scatter, float(np.sqrt(np.mean(peaks[:, 1] ** 2) / len(peaks))))
    # Type B: the model errors no scatter shows, from validating against the simulated truth.
    a_peak_se = math.hypot(a_peak_se, A_PEAK_MODEL_UNCERTAINTY * a_peak)
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
    navigation = dc.replace(base.navigation)
    R = list(navigation.ekf.R)
    R[0] = still["gyro_white_noise_std"] ** 2
    navigation = dc.replace(
        navigation,
        ekf=dc.replace(navigation.ekf, R=R),
        mixing=dc.replace(
            navigation.mixing,
            tyre_peak_acceleration=a_peak,
            drag_acceleration=max(float(drag[0]), 0.0),
            drag_per_speed=max(float(drag[1]), 0.0),
        ),
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
            accel1_scale_error=float(accel[0]),
            accel2_scale_error=float(accel[2]),
            accel1_misalignment=float(accel[1]),
            accel2_misalignment=float(accel[3]),
            accel_bias=[float(v) for v in still["accel_bias"]],
        ),
        navigation=navigation,
        standard_errors={k: float(v) for k, v in errors.items()},
    )
    details = {
        "geometry_chi2_per_dof": chi2,
        "accelerometer_segments": accel_segments,
        "drag_chi2_per_dof": drag_chi2,
        "peaks": peaks,
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
        from slipnav.studies.calibration_session import read_session, write_session

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


def calibrate_command(
    robot_name: str, seeds: list[int], out_dir, stream=None, logs: bool = False, scenario=None
) -> list[dict]:
    """``slipnav calibrate --simulate ROBOT --seed N`` (or ``--seeds N``): drive, identify, write
    ``DIR/<robot>-seed<N>.calibrated.model.yaml`` per seed (``scenario``, ``--simulate SCENARIO.yaml``: its
    plant is the truth, its name replaces the robot's), print identified vs true with the errors in
    standard errors; last line ``calibration worst_radius_pct=.. worst_track_pct=.. worst_gyro_scale_pct=..
    worst_a_peak_pct=.. worst_accel_scale_pct=.. worst_misalignment_deg=.. worst_drag_pct=..`` (scale
    errors absolute, in per cent; misalignments in degrees; the drag's both terms relative). ``logs``:
    also write each seed's session (``DIR/<robot>-seed<N>.calibration/``, logs and session.yaml) and
    identify from reading it back. Returns one row per seed."""
    import sys
    from pathlib import Path as FilePath

    from slipnav.scenarios.model import write_model

    stream = stream or sys.stdout
    out = FilePath(out_dir)
    rows = []
    name = robot_name if scenario is None else scenario.name
    for seed in seeds:
        session = out / f"{name}-seed{seed}.calibration" if logs else None
        calibration, truth = simulated_calibration(robot_name, seed, session, scenario)
        path = write_model(calibration.model, out / f"{name}-seed{seed}.calibrated.model.yaml")
        rows.append(compare(calibration, truth))
        print(f"{path}", file=stream)
        kinds = {key: kind for key, _, kind in COMPARED}
        for key, (value, true, error, z) in rows[-1].items():
            se = calibration.standard_errors[key]
            shown = f"{error:+.3f} deg" if kinds[key] == "deg" else f"{100 * error:+.3f} %"
            print(
                f"  {key:24s} identified {value:.6g} +- {se:.2g}  true {true:.6g}  "
                f"error {shown} "
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
            "accel1_scale_error",
            "accel2_scale_error",
            "accel1_misalignment",
            "accel2_misalignment",
            "drag_acceleration",
            "drag_per_speed",
        )
    }
    worst["accel1_misalignment"] /= 100.0  # degrees, not per cent
    worst["accel2_misalignment"] /= 100.0
    print(
        f"calibration worst_radius_pct={max(worst['wheel_radius_R'], worst['wheel_radius_L']):.4f} "
        f"worst_track_pct={worst['track_width']:.4f} worst_gyro_scale_pct={worst['gyro_scale_error']:.4f} "
        f"worst_a_peak_pct={worst['tyre_peak_acceleration']:.3f} "
        f"worst_accel_scale_pct={max(worst['accel1_scale_error'], worst['accel2_scale_error']):.3f} "
        f"worst_misalignment_deg={max(worst['accel1_misalignment'], worst['accel2_misalignment']):.3f} "
        f"worst_drag_pct={max(worst['drag_acceleration'], worst['drag_per_speed']):.2f}",
        file=stream,
    )
    return rows
