"""The whole closed loop as a plain sequential Python loop over the same pure functions as the diagram.

``run_plain_loop`` takes the Truth, Belief and ControlSettings that
``diagrams.closed_loop.build_closed_loop_diagram`` takes and steps, every T_N, the discrete plant
(plant_advance), the sensors (sensor_update), the navigation and the perturbation monitor on it
(scenarios/plain_navigation.py: NavigationLoop, PlainMonitor) and, every T_C, the control blocks
(follower_step, the speed law, step_size, interpolate), in the order Drake's pre-update semantics imply:
every block that updates at t_k reads the values all blocks held at t_k. With the seed's sensor noise
(systems.robot.sensors.sensor_noise, which the diagram's sensors read too) it reproduces the diagram
sample for sample (tests/test_plain_loop.py); it is also the baseline of ``slipnav bench``.
"""

import math
import time

import numpy as np
from slipnav.diagrams.closed_loop import ControlSettings, control_offset
from slipnav.diagrams.records import Belief, Truth
from slipnav.scenarios.plain_navigation import PlainNavigation
from slipnav.scenarios.run_plan import RunOptions, plan_run
from slipnav.systems.control.path_follower import (
    bounded_speed,
    check_path_curvature,
    follower_step,
    saturate_wheel_speeds,
    speed_law,
)
from slipnav.systems.control.slip_control import interpolate, step_size
from slipnav.systems.health.perturbation import FORCE_CHANNELS, PERTURBATION_CHANNELS
from slipnav.systems.navigation.loop import LOOP_KEYS
from slipnav.systems.rates import SampleRates
from slipnav.systems.robot.contact import NO_DISTURBANCE
from slipnav.systems.robot.dynamics import plant_advance, plant_derivatives, substeps_per
from slipnav.systems.robot.faults import (
    apply_sensor_faults,
    check_fault_events,
    has_plant_events,
    has_sensor_faults,
    plant_disturbance,
)
from slipnav.systems.robot.motors import motor_current, motor_currents
from slipnav.systems.robot.parameters import RobotParameters
from slipnav.systems.robot.sensors import (
    NOISE_CHANNELS,
    SensorParameters,
    current_noise,
    current_sense,
    initial_accelerometers,
    initial_biases,
    sensor_noise,
    sensor_update,
)

PLAIN_LOOP_KEYS = (
    (
        "true_x true_y true_phi true_v_t true_v_n true_omega true_theta_R true_theta_L true_w_R true_w_L "
        "meas_a_t1 meas_a_n1 meas_a_t2 meas_a_n2 meas_gyro meas_enc_R meas_enc_L cmd_R cmd_L V1 "
        "virtual_target step_size progress"
    ).split()
    + [f"nav_{key}" for key in LOOP_KEYS]
    + [f"perturbation_{c}" for c in PERTURBATION_CHANNELS]
    + [f"perturbation_{c}" for c in FORCE_CHANNELS]
    + ["meas_current_R", "meas_current_L"]
)
"""Columns of run_plain_loop's result, each the value at t_k (as a Drake logger at t_k records it)."""


def run_plain_loop(
    truth: Truth,
    belief: Belief,
    control: ControlSettings,
    num_steps: int,
    noise=None,
    timings: dict | None = None,
) -> dict:
    """Simulate ``num_steps`` samples t_0 ... t_{num_steps-1} of the closed loop.

    Args:
        truth, belief, control: as build_closed_loop_diagram (``truth.plant_time_step`` > 0: the
            continuous plant has no plain-loop twin).
        num_steps: number of T_N samples.
        noise: (num_steps, NOISE_CHANNELS) standard-normal draws that the sensors read at t_k; None: the
            seed's, ``sensor_noise(truth.seed, num_steps)``, which the diagram's sensors read too.
        timings: if given, receives the wall time (s) spent in ``plant``, ``sensors``, ``navigation``
            and ``control``.

    Returns:
        dict of (num_steps,) arrays keyed by PLAIN_LOOP_KEYS.
    """
    rates, robot, time_step = belief.rates, belief.robot, truth.plant_time_step
    if not time_step > 0.0:
        raise ValueError(f"truth.plant_time_step={time_step!r} is out of range: allowed (0, 0.01] s")
    plant_steps = substeps_per(rates.T_N, time_step, "T_N")
    noise = checked_noise(noise, truth.seed, num_steps)
    world = PlainPlant(
        truth.robot(belief), truth.initial_pose, truth.initial_speed, rates.T_N, plant_steps, time_step
    )
    sensors = PlainSensors(truth.sensors, truth.seed, world.initial_wheel_speeds, rates.T_N)
    # the navigation and the perturbation monitor on it (NavigationLoop, PlainMonitor)
    navigation = PlainNavigation(belief.navigation_belief(truth.initial_state), belief.monitor)
    # Control (build_control_diagram): at t_K, or right after the navigation's sample k (control_offset).
    ctrl = PlainControl(control, robot, rates.T_C)
    faults = check_fault_events(truth.faults)
    spent = dict.fromkeys(("plant", "sensors", "navigation", "control"), 0.0)
    out = _step_plain_loop(world, sensors, navigation, ctrl, faults, rates, noise, spent)
    if timings is not None:
        timings.update(spent)
    return {key: out[:, i].copy() for i, key in enumerate(PLAIN_LOOP_KEYS)}


def checked_noise(noise, seed: int, num_steps: int) -> list:
    """The sensors' standard-normal draws as lists of floats (as the diagram's sensors read them): the
    seed's, ``sensor_noise(seed, num_steps)``, for None; ValueError for a wrong shape."""
    if noise is None:
        noise = sensor_noise(seed, num_steps)
    noise = np.asarray(noise, float)
    if noise.shape != (num_steps, NOISE_CHANNELS):
        raise ValueError(f"noise must have shape ({num_steps}, {NOISE_CHANNELS}), got {noise.shape}")
    return noise.tolist()


def _step_plain_loop(
    world, sensors, navigation: PlainNavigation, ctrl, faults, rates: SampleRates, noise, spent
) -> np.ndarray:
    """Step the loop over the samples of ``noise``, in the order of Drake's pre-update semantics; returns
    the rows of PLAIN_LOOP_KEYS and adds each part's wall time to ``spent``."""
    T_N, p = rates.T_N, ctrl.robot
    n = int(round(rates.T_C / T_N))
    k_start = int(
        round(ctrl.control.start_time / T_N)
    )  # the controller's first instant (the standstill before)
    after = control_offset(ctrl.control, rates, p) > 0.0
    perturbed, faulty = has_plant_events(faults), has_sensor_faults(faults)
    out = np.empty((len(noise), len(PLAIN_LOOP_KEYS)))
    clock = time.perf_counter
    for k in range(len(noise)):
        t0 = clock()
        if faulty:  # SensorFaultInjector: what the navigation reads at t_k
            sensors.apply_faults(k, faults)
        nav_row = navigation.step(sensors.acc, sensors.gyro, sensors.encoders, sensors.current)
        t1 = clock()
        spent["navigation"] += t1 - t0
        if after and control_instant(k - 1, k_start, n) is not None:  # t_K + offset: the navigation after k
            ctrl.step(control_instant(k - 1, k_start, n), nav_row, world.x)
        follower = ctrl.follower
        command = saturate_wheel_speeds(follower[1], follower[2], p.wheel_speed_limit)
        out[k] = (
            *world.x,
            *sensors.acc,
            sensors.gyro,
            *sensors.encoders,
            *command,
            follower[3],
            follower[0],
            ctrl.delta,
            ctrl.progress,
            *nav_row,
            *navigation.flags(),
            *navigation.forces(),
            *sensors.current,
        )
        navigation.watch(command, nav_row, sensors.current)
        if not after and control_instant(k, k_start, n) is not None:  # control instant: pre-update values
            ctrl.step(control_instant(k, k_start, n), nav_row, world.x)
        t2 = clock()
        spent["control"] += t2 - t1
        sensors.update(k, world, noise[k])
        t3 = clock()
        spent["sensors"] += t3 - t2
        disturbance = plant_disturbance(k * T_N, faults, T_N) if perturbed else NO_DISTURBANCE
        world.advance(k, command, disturbance)
        spent["plant"] += clock() - t3
    return out


def control_instant(j: int, k_start: int, n: int):
    """K if sample j is a control instant t_K (every ``n``-th sample from ``k_start``), else None."""
    return (j - k_start) // n if j >= k_start and (j - k_start) % n == 0 else None


class PlainPlant:
    """DifferentialDrivePlant (discrete) as plain state: ``x`` (PlantState), the speed loops' state, the
    motor currents and the body accelerations the sensors read; ``advance`` steps one T_N."""

    def __init__(
        self, world: RobotParameters, initial_pose, initial_speed, T_N, steps: int, time_step: float
    ):
        self.world, self.steps, self.time_step = world, steps, time_step
        w0 = [initial_speed / world.radius_R, initial_speed / world.radius_L]
        self.initial_wheel_speeds = w0
        self.x = [*initial_pose, initial_speed, 0.0, 0.0, 0.0, 0.0, *w0]
        self.loop = [0.0] * 4
        self.currents = (motor_current(0.0, w0[0], world), motor_current(0.0, w0[1], world))
        self.acc = list(plant_derivatives(self.x, self.currents, world)[1])

    def advance(self, k: int, command, disturbance) -> None:
        """From t_k to t_k+1 under the wheel-speed ``command`` and a fault's ``disturbance``."""
        self.x, self.loop, self.acc = plant_advance(
            self.x, self.loop, command, k * self.steps, self.steps, self.time_step, self.world, disturbance
        )
        self.currents = motor_currents(self.loop, self.x, self.world)


class PlainSensors:
    """ProprioceptiveSensors (and the SensorFaultInjector after them) as plain state: the samples the
    navigation reads at t_k (``acc``, ``gyro``, ``encoders``, the motor drivers' ``current``), which hold
    the previous sample's values."""

    def __init__(self, params: SensorParameters, seed: int, wheel_speeds, T_N: float):
        self.params, self.T_N = params, T_N
        bias0 = initial_biases(params, np.random.default_rng(seed))
        self.internal = np.concatenate([bias0, np.zeros(4)])
        step = params.encoder_step
        self.acc, self.gyro = initial_accelerometers(bias0, params), float(bias0[4])
        self.encoders = np.floor(-np.array(wheel_speeds) * T_N / step) * step
        self.current, self.current_draws = [math.nan, math.nan], current_noise(seed)
        self.held = self.previous = None

    def apply_faults(self, k: int, faults) -> None:
        """The SensorFaultInjector at t_k: the samples as the navigation reads them (apply_sensor_faults)."""
        raw = [*self.acc, self.gyro, *self.encoders]
        held = self.held
        held = raw if held is None else [r if math.isnan(h) else h for r, h in zip(raw, held, strict=True)]
        self.previous = raw if self.previous is None else self.previous
        T_N = self.T_N
        held = apply_sensor_faults(k * T_N, raw, held, self.previous, faults, T_N, self.params.encoder_step)
        self.previous, self.held = raw, held
        self.acc, self.gyro, self.encoders = held[0:4], held[4], held[5:7]

    def update(self, k: int, world: PlainPlant, noise_row) -> None:
        """Sample k of the plant ``world`` with the draws ``noise_row``: the samples read at t_k+1."""
        self.internal, self.acc, gyro, self.encoders = sensor_update(
            self.internal, world.x, world.acc, noise_row, self.params, self.T_N
        )
        self.gyro = float(gyro[0])
        self.current = current_sense(world.currents, self.current_draws.row(k), self.params)


class PlainControl:
    """build_control_diagram's blocks at a control instant, and their state between instants: the
    follower (FollowerState), the step size delta and progress Pi (trajectory mode)."""

    def __init__(self, control: ControlSettings, robot: RobotParameters, T_C: float):
        self.control, self.robot, self.T_C = control, robot, T_C
        self.half = 0.5 * robot.track_width
        check_path_curvature(control.path.max_abs_curvature, robot.track_width)
        self.follower = [0.0, 0.0, 0.0, math.inf, 0.0, 0.0, 0.0]  # FollowerState
        self.delta, self.progress = 1.0, 0.0
        self.localised = localisation_reader(control.localisation)
        if control.mode == "trajectory":
            tr = control.trajectory
            self.table = np.column_stack([tr.x, tr.y, tr.phi, tr.v, tr.s])
            self.table_end = float(len(self.table) - 1)

    def step(self, K: int, nav_row, x) -> None:
        """Control instant K from the navigation's row and the plant's state the blocks read."""
        control, p, s = self.control, self.robot, self.follower[0]
        path, V_m = control.path, p.wheel_speed_limit
        pose_k, v_t_k = self.localised(nav_row, x)
        if control.mode == "trajectory":
            u = self._trajectory_speed(K, nav_row, s)
        elif s >= path.length:
            u = 0.0
        elif control.speed_law == "constant":
            u = 0.5 * V_m
        elif control.follower.delayed_speed_law:
            u = bounded_speed(self.follower[3], path.curvature(s), V_m, self.half, control.follower.epsilon)
        else:
            u = speed_law(pose_k, s, path, control.follower, V_m, self.half)[0]
        self.follower = follower_step(s, pose_k, u, path, control.follower, self.half, self.T_C, v_t_k)

    def _trajectory_speed(self, K: int, nav_row, s: float) -> float:
        """S(22)-(25) and the interpolator's speed command; advances delta and Pi."""
        control = self.control
        pace = self.delta  # delta_K-1 (delayed_step_size), else delta_K below
        if control.slip_control:
            c1, alpha = nav_row[LOOP_KEYS.index("C1")], nav_row[LOOP_KEYS.index("est_alpha")]
            self.delta = step_size(self.delta, c1, alpha, K - self.progress, control.step_size)
        else:
            self.delta = 1.0
        if not control.step_size.delayed_step_size:
            pace = self.delta
        u = 0.0
        if self.progress < self.table_end:
            ref = interpolate(self.table, self.progress)
            u = max(pace * ref[3] + control.step_size.k_s * (ref[4] - s), 0.0)
        self.progress += self.delta
        return u


def localisation_reader(source: str):
    """(nav_row, plant state) -> (pose, v_t) the follower reads (ControlSettings.localisation)."""
    if source == "truth":
        return lambda row, x: (x[0:3], x[3])
    prefix = {"fused": "est", "odometry": "odo", "gyrodometry": "gyro"}[source]
    first = LOOP_KEYS.index(f"{prefix}_x")
    speed = LOOP_KEYS.index("est_v_t" if source == "fused" else "odo_v_t")
    return lambda row, x: (row[first : first + 3], row[speed])


def run_scenario_plain_loop(
    scenario, seed: int, num_steps: int, slip_control=None, speed_law=None, noise=None, timings=None
) -> dict:
    """run_plain_loop for a Scenario, built as run_scenario builds its closed loop (plan_run with the same
    overrides, RunPlan.closed_loop)."""
    options = RunOptions(seed=seed, slip_control=slip_control, speed_law=speed_law, open_loop=False)
    plan = plan_run(scenario, options)
    truth, control, _ = plan.closed_loop()
    return run_plain_loop(truth, plan.belief, control, num_steps, noise=noise, timings=timings)
