"""The navigation diagram of Seyr & Jakubek's Fig. 3 (plus the odometry-only and Gyrodometry baselines).

Inputs: the sensor signals. Outputs: the navigation estimate and internals. Block timing: see
systems/navigation.py (the sequential reference loop documents the same ordering).
"""

import math

import numpy as np
from pydrake.systems.framework import Diagram, DiagramBuilder, LeafSystem
from pydrake.systems.primitives import LogVectorOutput
from slipnav.diagrams.split import split_port
from slipnav.systems.baselines import Baselines
from slipnav.systems.ekf import InertialEkf, KalmanGain, ekf_prior_covariance
from slipnav.systems.health import HEALTH_STEP_LAYOUT, SensorHealthMonitor
from slipnav.systems.mixing import (
    C2C3_STEP_LAYOUT,
    MIXER_LAYOUT,
    TYRE_MODEL_STATE_LAYOUT,
    MixerC1,
    MixerC2C3,
    VelocityMixer,
)
from slipnav.systems.navigation import (
    NavigationInitialState,
    NavigationParameters,
    check_slide_onset,
    health_geometry,
)
from slipnav.systems.odometry import ODOMETRY_STEP_LAYOUT, Odometry
from slipnav.systems.plant import RobotParameters
from slipnav.systems.pose import PoseIntegrator
from slipnav.systems.rates import SampleRates
from slipnav.systems.sensor_correction import SensorCalibration, SensorCorrection
from slipnav.systems.sensors import SensorParameters, default_sensor_parameters
from slipnav.systems.sideslip import SideSlipEstimator
from slipnav.systems.slip_detector import TangentialSlipDetector
from slipnav.systems.standstill import STANDSTILL_STEP_LAYOUT, StandstillDetector, standstill_constants
from slipnav.systems.yaw_calibration import CALIBRATED_LAYOUT, PARAMETERS_LAYOUT, YawRateCalibration

NAVIGATION_OUTPUTS = (
    "pose",
    "mixed_estimate",
    "side_slip_angle",
    "track_speed",
    "C1",
    "slide_onset",
    "C2_C3",
    "tyre_model_check",
    "delta_v",
    "odometry",
    "odometry_pose",
    "gyrodometry_pose",
    "inertial_fault",
    "encoder_fault",
    "covariance",
    "gyro_bias",
    "yaw_calibration",
    "health",
    "standstill",
    "accelerometer_bias",
)


def build_navigation_diagram(
    params: NavigationParameters,
    rates: SampleRates,
    wheel_radius,
    track_width: float,
    initial: NavigationInitialState | None = None,
    sensors: SensorParameters | None = None,
    no_load_speed: float | None = None,
    calibration: SensorCalibration | None = None,
    robot: RobotParameters | None = None,
) -> Diagram:
    """The navigation algorithm as a Diagram.

    ``wheel_radius``: one radius for both wheels or the pair (r_R, r_L) of a calibrated model (m).
    ``sensors``, ``no_load_speed``: the sensors' data sheet (default Tinyphoon's) and the nominal motors'
    no-load speed (m/s) for the sensor checks (systems.navigation.health_geometry).
    ``calibration``: the model's SensorCalibration; unless it is the identity a SensorCorrection block
    removes it from the checked inertial samples before every block that reads them.
    ``robot``: the nominal robot, whose mass, motors and drags give the sensor checks the force reference
    of the tangential accelerometers from the optional ``motor_currents`` input (None: none).
    ``external_force`` (optional; unconnected: none): the perturbation monitor's sideways push, which
    leaves v_n to the lateral kinematics (VelocityMixer); add_perturbation_monitor connects it.
    The baselines (odometry-only and Gyrodometry, systems/baselines.py) read the raw encoders and gyro,
    not the checked ones.

    .. pydrake_system::

        name: navigation
        input_ports:
        - accelerometers
        - gyro
        - encoders
        - motor_currents
        - external_force
        output_ports:
        - pose
        - mixed_estimate
        - side_slip_angle
        - track_speed
        - C1
        - slide_onset
        - C2_C3
        - tyre_model_check
        - delta_v
        - odometry
        - odometry_pose
        - gyrodometry_pose
        - inertial_fault
        - encoder_fault
        - covariance
        - gyro_bias
        - yaw_calibration
        - health
        - checked_encoders
        - standstill
        - accelerometer_bias
    """
    params.validate()
    initial = initial or NavigationInitialState()
    T_N, T_C = rates.T_N, rates.T_C
    b = DiagramBuilder()

    def add(system, name):
        system.set_name(name)
        return b.AddSystem(system)

    geometry = health_geometry(params, wheel_radius, track_width, T_N, sensors, no_load_speed, robot)
    check_slide_onset(params.mixing, geometry)
    monitor = add(SensorHealthMonitor(params.health, geometry, initial.speed), "Sensor checks")
    b.ExportInput(monitor.GetInputPort("motor_currents"), "motor_currents")
    check = split_port(b, monitor.GetOutputPort("step"), HEALTH_STEP_LAYOUT, "Sensor checks' signals")
    odometry_block = add(Odometry(wheel_radius, track_width, T_N, initial.speed), "Odometry")
    odometry = split_port(b, odometry_block.GetOutputPort("step"), ODOMETRY_STEP_LAYOUT, "Odometry's signals")
    ekf = add(InertialEkf(params.ekf, T_N, initial.ekf_state()), "EKF")
    Q, _, P0 = params.ekf.matrices()
    gain = add(
        KalmanGain(params.ekf, T_C, ekf_prior_covariance(P0, initial.ekf_state(), Q, T_N)), "Kalman gain"
    )
    detector = add(
        TangentialSlipDetector(T_N, T_C, initial.speed, params.mixing.delta_v_running_integral),
        "Tangential slip detector",
    )
    c1 = add(MixerC1(params.mixing, T_C), "Mixer C1")
    c23_block = add(MixerC2C3(params.mixing, T_N), "Mixer C2 C3")
    c23 = split_port(b, c23_block.GetOutputPort("step"), C2C3_STEP_LAYOUT, "Mixer C2 C3's signals")
    yaw_calibration = add(
        YawRateCalibration(params.yaw_calibration, track_width, T_N, T_C), "Gyro and odometry calibration"
    )
    mixer_block = add(
        VelocityMixer(
            params.mixing,
            T_N,
            initial.ekf_state()[1],
            geometry.accelerometer_position,
        ),
        "Velocity mixer",
    )
    mixer = split_port(b, mixer_block.GetOutputPort("mixing"), MIXER_LAYOUT, "Velocity mixer's signals")
    sideslip = add(SideSlipEstimator(params.sideslip, T_C), "Side-slip angle")
    pose = add(PoseIntegrator(T_N, initial.pose), "Pose integration")
    baselines = add(
        Baselines(
            params.gyrodometry, wheel_radius, track_width, T_N, initial.pose, initial.speed, calibration
        ),
        "Baselines",
    )

    b.ExportInput(monitor.GetInputPort("accelerometers"), "accelerometers")
    b.ExportInput(monitor.GetInputPort("gyro"), "gyro")
    b.ExportInput(monitor.GetInputPort("encoders"), "encoders")
    b.ConnectInput("encoders", baselines.GetInputPort("encoders"))  # the raw sensors
    b.ConnectInput("gyro", baselines.GetInputPort("gyro"))
    b.Connect(check["encoders"], odometry_block.GetInputPort("encoders"))

    acc, gyro, raw_odo = (
        check["accelerometers"],
        check["gyro"],
        odometry["odometry"],
    )
    if calibration is not None and not calibration.is_identity():
        correction = add(SensorCorrection(calibration), "Sensor calibration")
        b.Connect(acc, correction.GetInputPort("accelerometers"))
        b.Connect(gyro, correction.GetInputPort("gyro"))
        acc, gyro = correction.GetOutputPort("accelerometers"), correction.GetOutputPort("gyro")
    calibrated = split_port(
        b, yaw_calibration.GetOutputPort("calibrated"), CALIBRATED_LAYOUT, "Calibrated gyro and odometry"
    )
    learned = split_port(
        b, yaw_calibration.GetOutputPort("parameters"), PARAMETERS_LAYOUT, "Learned gyro bias and D"
    )
    standstill = add(StandstillDetector(standstill_constants(params.standstill, geometry, T_N)), "Standstill")
    b.Connect(acc, standstill.GetInputPort("accelerometers"))
    b.Connect(calibrated["gyro"], standstill.GetInputPort("gyro"))
    b.Connect(check["encoders"], standstill.GetInputPort("encoders"))
    zupt = split_port(b, standstill.GetOutputPort("step"), STANDSTILL_STEP_LAYOUT, "Standstill's signals")
    acc = zupt["accelerometers"]  # less the biases: what every later block reads
    odo = calibrated["odometry"]  # what the fusion reads; the calibration reads raw_odo
    b.Connect(acc, ekf.GetInputPort("accelerometers"))
    b.Connect(gyro, yaw_calibration.GetInputPort("gyro"))
    b.Connect(raw_odo, yaw_calibration.GetInputPort("odometry"))
    b.Connect(c1.GetOutputPort("C1"), yaw_calibration.GetInputPort("C1"))
    b.Connect(check["inertial_fault"], yaw_calibration.GetInputPort("inertial_fault"))
    b.Connect(check["encoder_fault"], yaw_calibration.GetInputPort("encoder_fault"))
    b.Connect(check["gyro_bias_step"], yaw_calibration.GetInputPort("gyro_bias_step"))
    if params.standstill.enabled:  # a rest the detector confirms (else the wheels' alone)
        b.Connect(zupt["standstill"], yaw_calibration.GetInputPort("standstill"))
    b.Connect(calibrated["gyro"], ekf.GetInputPort("gyro"))
    b.Connect(gain.GetOutputPort("kalman_gain"), ekf.GetInputPort("kalman_gain"))
    b.Connect(ekf.GetOutputPort("prior_covariance"), gain.GetInputPort("prior_covariance"))
    b.Connect(odo, detector.GetInputPort("odometry"))
    b.Connect(acc, detector.GetInputPort("accelerometers"))
    b.Connect(check["sensor_fault"], detector.GetInputPort("sensor_fault"))
    b.Connect(detector.GetOutputPort("delta_v"), c1.GetInputPort("delta_v"))
    b.Connect(ekf.GetOutputPort("inertial_estimate"), c23_block.GetInputPort("inertial_estimate"))
    b.Connect(odo, c23_block.GetInputPort("odometry"))
    b.Connect(odo, mixer_block.GetInputPort("odometry"))
    b.Connect(ekf.GetOutputPort("inertial_estimate"), mixer_block.GetInputPort("inertial_estimate"))
    b.Connect(c1.GetOutputPort("C1"), mixer_block.GetInputPort("C1"))
    b.Connect(c23["C2_C3"], mixer_block.GetInputPort("C2_C3"))
    b.Connect(ekf.GetOutputPort("estimate"), mixer_block.GetInputPort("previous_estimate"))
    velocity_layout = (("body_velocity", 2), ("rest", 3))
    estimate = split_port(b, ekf.GetOutputPort("estimate"), velocity_layout, "EKF's v_t, v_n")
    b.Connect(estimate["body_velocity"], monitor.GetInputPort("body_velocity"))  # the gyro's replacement
    tyre_state = mixer_block.GetOutputPort("tyre_model_state")
    tyre = split_port(b, tyre_state, TYRE_MODEL_STATE_LAYOUT, "Identified tyre peak")
    b.Connect(tyre["tyre_peak"], monitor.GetInputPort("tyre_peak"))
    b.Connect(learned["estimate"], monitor.GetInputPort("yaw_calibration"))  # the replacements read them
    b.Connect(check["inertial_fault"], mixer_block.GetInputPort("inertial_fault"))
    b.Connect(check["encoder_fault"], mixer_block.GetInputPort("encoder_fault"))
    b.Connect(acc, mixer_block.GetInputPort("accelerometers"))
    b.ExportInput(mixer_block.GetInputPort("external_force"), "external_force")
    b.Connect(zupt["standstill"], mixer_block.GetInputPort("standstill"))
    b.Connect(mixer["mixed_estimate"], ekf.GetInputPort("mixed_estimate"))  # Fig. 3 feedback
    b.Connect(mixer["mixing_gain"], ekf.GetInputPort("mixing_gain"))  # the mixing in P
    b.Connect(mixer["body_velocity"], sideslip.GetInputPort("body_velocity"))
    b.Connect(mixer["body_velocity"], pose.GetInputPort("body_velocity"))

    b.ExportOutput(pose.GetOutputPort("pose"), "pose")
    b.ExportOutput(mixer["mixed_estimate"], "mixed_estimate")
    b.ExportOutput(sideslip.GetOutputPort("side_slip_angle"), "side_slip_angle")
    b.ExportOutput(sideslip.GetOutputPort("track_speed"), "track_speed")
    b.ExportOutput(c1.GetOutputPort("C1"), "C1")
    b.ExportOutput(mixer["slide_onset"], "slide_onset")
    b.ExportOutput(c23["C2_C3"], "C2_C3")
    b.ExportOutput(mixer["tyre_model_check"], "tyre_model_check")
    b.ExportOutput(c1.GetOutputPort("delta_v_held"), "delta_v")
    b.ExportOutput(raw_odo, "odometry")
    b.ExportOutput(baselines.GetOutputPort("odometry_pose"), "odometry_pose")
    b.ExportOutput(baselines.GetOutputPort("gyrodometry_pose"), "gyrodometry_pose")
    b.ExportOutput(check["inertial_fault"], "inertial_fault")
    b.ExportOutput(check["encoder_fault"], "encoder_fault")
    b.ExportOutput(ekf.GetOutputPort("covariance"), "covariance")
    b.ExportOutput(yaw_calibration.GetOutputPort("bias"), "gyro_bias")
    b.ExportOutput(yaw_calibration.GetOutputPort("parameters"), "yaw_calibration")
    b.ExportOutput(check["health"], "health")
    b.ExportOutput(check["encoders"], "checked_encoders")
    b.ExportOutput(zupt["standstill"], "standstill")
    b.ExportOutput(zupt["accelerometer_bias"], "accelerometer_bias")
    diagram = b.Build()
    diagram.set_name("navigation")
    return diagram


class SensorReplay(LeafSystem):
    """Plays back logged sensor rows: at t in [t_k, t_k+1) the outputs hold row k.

    .. pydrake_system::

        name: SensorReplay
        output_ports:
        - accelerometers
        - gyro
        - encoders
        - motor_currents
        - wheel_speed_command

    A row k of a run artifact is what the navigation blocks read at t_k, so replaying the ``meas_*`` keys
    through build_navigation_diagram reproduces the run's navigation exactly.
    ``wheel_speed_command`` is declared only with ``commands`` (for the perturbation monitor).

    Args:
        T_N: period of the rows (s). accelerometers (N, 4), gyro (N,), encoders (N, 2); currents (N, 2)
        the motor drivers' readings (A; None: NaN, no force reference); commands (N, 2) the wheel speed
        commands [v_R, v_L] (m/s; None: no such port).
    """

    def __init__(self, T_N: float, accelerometers, gyro, encoders, currents=None, commands=None):
        super().__init__()
        self._T_N = T_N
        gyro = np.asarray(gyro, float).reshape(-1, 1)
        if currents is None:
            currents = np.full((len(gyro), 2), np.nan)
        columns = [np.asarray(accelerometers, float), gyro, np.asarray(encoders, float)]
        columns.append(np.asarray(currents, float))
        ports = [
            ("accelerometers", slice(0, 4)),
            ("gyro", slice(4, 5)),
            ("encoders", slice(5, 7)),
            ("motor_currents", slice(7, 9)),
        ]
        if commands is not None:
            columns.append(np.asarray(commands, float))
            ports.append(("wheel_speed_command", slice(9, 11)))
        self._rows = np.column_stack(columns)
        time_only = {self.time_ticket()}
        for name, cols in ports:
            self.DeclareVectorOutputPort(
                name,
                cols.stop - cols.start,
                lambda c, o, cols=cols: o.SetFromVector(self._row(c)[cols]),
                prerequisites_of_calc=time_only,
            )

    def _row(self, context):
        k = int(math.floor(context.get_time() / self._T_N + 1e-6))
        return self._rows[min(k, len(self._rows) - 1)]


def build_navigation_replay(
    params, rates, wheel_radius, track_width, accelerometers, gyro, encoders, initial=None
):
    """SensorReplay -> navigation diagram, with the navigation outputs logged every T_N.

    Returns (diagram, loggers keyed by navigation output name).
    """
    b = DiagramBuilder()
    replay = b.AddSystem(SensorReplay(rates.T_N, accelerometers, gyro, encoders))
    replay.set_name("Sensor replay")
    nav = b.AddSystem(build_navigation_diagram(params, rates, wheel_radius, track_width, initial))
    for name in ("accelerometers", "gyro", "encoders"):
        b.Connect(replay.GetOutputPort(name), nav.GetInputPort(name))
    loggers = {}
    for name in NAVIGATION_OUTPUTS:
        loggers[name] = LogVectorOutput(nav.GetOutputPort(name), b, rates.T_N)
        loggers[name].set_name(f"log {name}")
    diagram = b.Build()
    diagram.set_name("navigation_replay")
    return diagram, loggers


def add_navigation(
    builder,
    sensors,
    navigation,
    rates,
    robot,
    initial_speed=0.0,
    initial_pose=(0.0, 0.0, 0.0),
    nominal_sensors: SensorParameters | None = None,
    calibration: SensorCalibration | None = None,
    currents_port=None,
):
    """Add the navigation diagram fed by ``sensors`` (ProprioceptiveSensors or a SensorFaultInjector) and
    the motor drivers' ``currents_port`` (None: unconnected) to ``builder``; ``robot``,
    ``nominal_sensors`` (default the robot's data sheet) and ``calibration`` (the model's
    SensorCalibration, default none) are what it knows.

    Returns (navigation subsystem, its output ports keyed ``nav_<name>`` for logging).
    """
    nav = builder.AddSystem(
        build_navigation_diagram(
            navigation,
            rates,
            (robot.radius_R, robot.radius_L),
            robot.track_width,
            NavigationInitialState(speed=initial_speed, pose=tuple(initial_pose)),
            nominal_sensors or default_sensor_parameters(robot.name),
            robot.no_load_speed,
            calibration,
            robot,
        )
    )
    for name in ("accelerometers", "gyro", "encoders"):
        builder.Connect(sensors.GetOutputPort(name), nav.GetInputPort(name))
    if currents_port is not None:
        builder.Connect(currents_port, nav.GetInputPort("motor_currents"))
    ports = {f"nav_{name}": nav.GetOutputPort(name) for name in NAVIGATION_OUTPUTS if name != "covariance"}
    return nav, ports
