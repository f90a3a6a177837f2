"""The whole closed loop as a plain sequential Python loop over the same pure functions as the diagram.

``run_plain_loop`` takes exactly what ``diagrams.closed_loop.build_closed_loop_diagram`` takes and steps,
every T_N, the discrete plant (plant_advance), the sensors (sensor_update), the navigation
(systems.navigation.NavigationLoop) and, every T_C, the control blocks (follower_step, the speed law,
step_size, interpolate), in the order Drake's pre-update semantics imply: every block that updates at
t_k reads the values all blocks held at t_k. With the seed's sensor noise (systems.sensors.sensor_noise,
which the diagram's sensors read too) it reproduces the diagram sample for sample
(tests/test_plain_loop.py); it is also the baseline of ``slipnav bench``.
"""

import math
import time

import numpy as np
from slipnav.diagrams.closed_loop import ControlSettings, control_offset
from slipnav.systems.faults import (
    apply_sensor_faults,
    check_fault_events,
    has_plant_events,
    has_sensor_faults,
    plant_disturbance,
)
from slipnav.systems.health.perturbation import (
    FORCE_CHANNELS,
    PERTURBATION_CHANNELS,
    PerturbationParameters,
    force_model,
    perturbation_initial_state,
    perturbation_step,
    sideways_push,
)
from slipnav.systems.navigation import LOOP_KEYS, NavigationInitialState, NavigationLoop, NavigationParameters
from slipnav.systems.path_follower import (
    bounded_speed,
    check_path_curvature,
    follower_step,
    saturate_wheel_speeds,
    speed_law,
)
from slipnav.systems.plant import (
    NO_DISTURBANCE,
    RobotParameters,
    motor_current,
    motor_currents,
    plant_advance,
    plant_derivatives,
    substeps_per,
)
from slipnav.systems.rates import SampleRates
from slipnav.systems.sensor_correction import SensorCalibration
from slipnav.systems.sensors import (
    NOISE_CHANNELS,
    SensorParameters,
    current_noise,
    current_sense,
    default_sensor_parameters,
    initial_biases,
    sensor_noise,
    sensor_update,
)
from slipnav.systems.slip_control import interpolate, step_size

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
MIXED_ESTIMATE_COLUMNS = [
    LOOP_KEYS.index(k) for k in ("est_v_t", "est_v_n", "est_omega", "est_a_t", "est_a_n")
]


def run_plain_loop(
    robot: RobotParameters,
    sensor_params: SensorParameters,
    rates: SampleRates,
    navigation: NavigationParameters,
    control: ControlSettings,
    seed: int,
    num_steps: int,
    initial_pose=(0.0, 0.0, 0.0),
    initial_speed: float = 0.0,
    plant_time_step: float = 5e-4,
    noise=None,
    timings: dict | None = None,
    plant: RobotParameters | None = None,
    faults=(),
    nominal_sensors: SensorParameters | None = None,
    calibration: SensorCalibration | None = None,
    perturbation_monitor: PerturbationParameters | None = None,
) -> dict:
    """Simulate ``num_steps`` samples t_0 ... t_{num_steps-1} of the closed loop.

    Args:
        as build_closed_loop_diagram, plus:
        num_steps: number of T_N samples.
        plant_time_step: the discrete plant's step (> 0; the continuous plant has no plain-loop twin).
        noise: (num_steps, NOISE_CHANNELS) standard-normal draws that the sensors read at t_k; None: the
            seed's, ``sensor_noise(seed, num_steps)``, which the diagram's sensors read too.
        timings: if given, receives the wall time (s) spent in ``plant``, ``sensors``, ``navigation``
            and ``control``.
        plant: the simulated robot as it really is (default ``robot``); navigation and control read
            ``robot``, the nominal model.
        faults: sensor FaultEvents between the sensors and the navigation (apply_sensor_faults).
        nominal_sensors: the sensors' data sheet the navigation knows (default the robot's).
        calibration: the model's SensorCalibration, which the navigation removes (SensorCorrection).
        perturbation_monitor: PerturbationParameters (PerturbationMonitor; default the defaults).

    Returns:
        dict of (num_steps,) arrays keyed by PLAIN_LOOP_KEYS.
    """
    if not plant_time_step > 0.0:
        raise ValueError(f"plant_time_step={plant_time_step!r} is out of range: allowed (0, 0.01] s")
    T_N, T_C, p = rates.T_N, rates.T_C, robot
    world = plant or robot
    n = int(round(T_C / T_N))
    k_start = int(round(control.start_time / T_N))  # the controller's first instant (the standstill before)
    plant_steps = substeps_per(T_N, plant_time_step, "T_N")
    if noise is None:
        noise = sensor_noise(seed, num_steps)
    noise = np.asarray(noise, float)
    if noise.shape != (num_steps, NOISE_CHANNELS):
        raise ValueError(f"noise must have shape ({num_steps}, {NOISE_CHANNELS}), got {noise.shape}")
    noise = noise.tolist()  # floats, as the diagram's sensors read them

    # Plant (DifferentialDrivePlant, discrete).
    w0 = [initial_speed / world.radius_R, initial_speed / world.radius_L]
    x = [*initial_pose, initial_speed, 0.0, 0.0, 0.0, 0.0, *w0]
    loop = [0.0] * 4
    currents = (motor_current(0.0, w0[0], world), motor_current(0.0, w0[1], world))
    acc = list(plant_derivatives(x, currents, world)[1])
    # Sensors (ProprioceptiveSensors): outputs hold the previous sample.
    bias0 = initial_biases(sensor_params, np.random.default_rng(seed))
    internal = np.concatenate([bias0, np.zeros(4)])
    step = sensor_params.encoder_step
    meas_acc, meas_gyro = bias0[0:4].copy(), float(bias0[4])
    meas_enc = np.floor(-np.array(w0) * T_N / step) * step
    meas_current, current_draws = [math.nan, math.nan], current_noise(seed)
    nav = NavigationLoop(
        navigation,
        (p.radius_R, p.radius_L),
        p.track_width,
        T_N,
        T_C,
        NavigationInitialState(speed=initial_speed, pose=tuple(initial_pose)),
        nominal_sensors or default_sensor_parameters(p.name),
        p.no_load_speed,
        calibration,
        p,
    )
    # Control (build_control_diagram): at t_K, or right after the navigation's sample k (control_offset).
    ctrl = PlainControl(control, p, T_C)
    after = control_offset(control, rates, p) > 0.0

    def instant(j):
        """K if sample j is a control instant t_K, else None."""
        return (j - k_start) // n if j >= k_start and (j - k_start) % n == 0 else None

    out = np.empty((num_steps, len(PLAIN_LOOP_KEYS)))
    clock = time.perf_counter
    spent = dict.fromkeys(("plant", "sensors", "navigation", "control"), 0.0)
    faults = check_fault_events(faults)
    perturbed, faulty = has_plant_events(faults), has_sensor_faults(faults)
    # PerturbationMonitor
    monitor_params = (perturbation_monitor or PerturbationParameters()).validate()
    monitor, radii, force = perturbation_initial_state(), (p.radius_R, p.radius_L), force_model(p)
    held = previous = None
    for k in range(num_steps):
        t0 = clock()
        if faulty:  # SensorFaultInjector: what the navigation reads at t_k
            raw = [*meas_acc, meas_gyro, *meas_enc]
            held = (
                raw if held is None else [r if math.isnan(h) else h for r, h in zip(raw, held, strict=True)]
            )
            previous = raw if previous is None else previous
            held = apply_sensor_faults(k * T_N, raw, held, previous, faults, T_N, sensor_params.encoder_step)
            previous = raw
            meas_acc, meas_gyro, meas_enc = held[0:4], held[4], held[5:7]
        nav_row = nav.step(meas_acc, meas_gyro, meas_enc, meas_current, sideways_push(monitor))
        t1 = clock()
        spent["navigation"] += t1 - t0
        if after and instant(k - 1) is not None:  # t_K + offset: the navigation's outputs after sample k
            ctrl.step(instant(k - 1), nav_row, x)
        follower = ctrl.follower
        command = saturate_wheel_speeds(follower[1], follower[2], p.wheel_speed_limit)
        out[k] = (
            *x,
            *meas_acc,
            meas_gyro,
            *meas_enc,
            *command,
            follower[3],
            follower[0],
            ctrl.delta,
            ctrl.progress,
            *nav_row,
            *monitor[-4:],
            *monitor[-6:-4],
            *meas_current,
        )
        mixed = [nav_row[i] for i in MIXED_ESTIMATE_COLUMNS]
        monitor = perturbation_step(
            monitor,
            command,
            nav.checked_encoders,
            mixed,
            monitor_params,
            radii,
            p.track_width,
            T_N,
            meas_current,
            force,
            nav.slide_onset,
        )

        if not after and instant(k) is not None:  # control instant: pre-update values of t_K
            ctrl.step(instant(k), nav_row, x)
        t2 = clock()
        spent["control"] += t2 - t1
        internal, meas_acc, gyro, meas_enc = sensor_update(internal, x, acc, noise[k], sensor_params, T_N)
        meas_gyro = float(gyro[0])
        meas_current = current_sense(currents, current_draws.row(k), sensor_params)
        t3 = clock()
        spent["sensors"] += t3 - t2
        disturbance = plant_disturbance(k * T_N, faults, T_N) if perturbed else NO_DISTURBANCE
        x, loop, acc = plant_advance(
            x, loop, command, k * plant_steps, plant_steps, plant_time_step, world, disturbance
        )
        currents = motor_currents(loop, x, world)
        spent["plant"] += clock() - t3
    if timings is not None:
        timings.update(spent)
    return {key: out[:, i].copy() for i, key in enumerate(PLAIN_LOOP_KEYS)}


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
    """run_plain_loop for a Scenario, built as run_scenario builds its closed loop (same overrides)."""
    from slipnav.scenarios.config import with_paper_mode
    from slipnav.scenarios.runner import closed_loop_settings

    scenario = with_paper_mode(scenario)
    slip_control = scenario.slip_control_enabled if slip_control is None else slip_control
    plant, sensor_params, _ = scenario.plant_parameters(seed)
    speed_law = scenario.speed_law if speed_law is None else speed_law
    control, initial_speed, _ = closed_loop_settings(scenario, slip_control, speed_law)
    belief = scenario.belief()
    return run_plain_loop(
        belief.robot,
        sensor_params,
        scenario.rates(),
        belief.navigation,
        control,
        seed,
        num_steps,
        tuple(scenario.initial_pose),
        initial_speed,
        scenario.plant_time_step,
        noise=noise,
        timings=timings,
        plant=plant,
        faults=scenario.faults,
        nominal_sensors=belief.sensors,
        calibration=belief.calibration,
        perturbation_monitor=scenario.perturbation_monitor,
    )
