"""The calibration's manoeuvres (studies/calibration.py): their wheel-speed profiles (rows at T_C:
[v_R, v_L] m/s), their plan, and their simulation open loop on the toleranced robot, which logs what a
real robot would (sensor logs, hand measurements of the final poses)."""

from __future__ import annotations

import dataclasses as dc
import math

import numpy as np
from slipnav.diagrams.open_loop import build_open_loop_diagram
from slipnav.diagrams.records import Belief, Truth
from slipnav.diagrams.robot import make_simulator
from slipnav.scenarios.artifact_arrays import collect_arrays
from slipnav.scenarios.config import Scenario
from slipnav.scenarios.progress import TaskProgress
from slipnav.scenarios.sensor_log import SensorLog, sensor_log_from_arrays
from slipnav.scenarios.tolerances import plant_record
from slipnav.systems.robot.parameters import GRAVITY

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
free wheel's stiff slip mode (tests/test_plant.py: 0.5 ms coasts ~3.5 % slower), and the drag identified
from their coasts takes the lag up, the less the smaller the step; the continuous plant has none."""


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
    force peaks 4 % below mu g and a_peak reads low), at most SPIRAL_SPEED_LIMIT of the wheel-speed
    limit (the commotion grows with speed and biases the peak of its noisy reading up). Tinyphoon 1.5 m/s
    (spread 0.08); Kurt3D 2.46 m/s, at the cap (spread 0.26)."""
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
        simulated = Truth(sensors=sensors, seed=run_seed, plant=plant, plant_time_step=time_step)
        believed = Belief(robot=robot, rates=rates)  # no navigation: the lab logs the raw sensors
        poses = np.zeros((len(rows), 3))
        built = build_open_loop_diagram(simulated, believed, rows, poses, motor_enable=enable)
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
    """What the navigation's drag (MixingParameters) is for the robot ``plant``: the felt shoes' Coulomb
    friction per unit mass mu_s (1 - f_w) g and their viscous drag 2 c / m (mixing's Tinyphoon 0.49, 0.25)."""
    return {
        "drag_acceleration": plant.shoe_friction * (1.0 - plant.wheel_load_fraction) * GRAVITY,
        "drag_per_speed": 2.0 * plant.shoe_viscous_drag / plant.mass,
    }
