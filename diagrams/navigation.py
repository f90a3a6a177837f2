"""The navigation diagram of Seyr & Jakubek's Fig. 3 (plus the odometry-only and Gyrodometry baselines).

Inputs: the sensor signals. Outputs: the navigation estimate and internals. Block timing: see
systems/navigation/loop.py (the sequential reference loop documents the same ordering).
"""

import dataclasses as dc

from pydrake.systems.framework import Diagram, DiagramBuilder
from slipnav.diagrams.split import split_port
from slipnav.systems.health import HEALTH_STEP_LAYOUT, SensorHealthMonitor
from slipnav.systems.navigation.baselines import Baselines
from slipnav.systems.navigation.calibration_batches import believed_tyre_slip
from slipnav.systems.navigation.ekf import InertialEkf, KalmanGain, ekf_prior_covariance
from slipnav.systems.navigation.mixing.mixer import MIXER_LAYOUT, TYRE_MODEL_STATE_LAYOUT, VelocityMixer
from slipnav.systems.navigation.mixing.weights import C2C3_STEP_LAYOUT, MixerC1, MixerC2C3
from slipnav.systems.navigation.odometry import ODOMETRY_STEP_LAYOUT, Odometry
from slipnav.systems.navigation.parameters import NavigationBelief
from slipnav.systems.navigation.pose import PoseIntegrator
from slipnav.systems.navigation.sensor_correction import SensorCorrection
from slipnav.systems.navigation.sideslip import SideSlipEstimator
from slipnav.systems.navigation.slip_detector import TangentialSlipDetector
from slipnav.systems.navigation.standstill import (
    STANDSTILL_STEP_LAYOUT,
    StandstillDetector,
    standstill_constants,
)
from slipnav.systems.navigation.yaw_calibration import (
    CALIBRATED_LAYOUT,
    PARAMETERS_LAYOUT,
    YawRateCalibration,
)

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


def build_navigation_diagram(belief: NavigationBelief) -> Diagram:
    """The navigation algorithm as a Diagram, of what the navigation is given (``belief``:
    systems.navigation.parameters.NavigationBelief).

    Unless ``belief.calibration`` (the model's SensorCalibration) is None or the identity, a
    SensorCorrection block removes it from the checked inertial samples before every block that reads
    them. ``belief.robot`` (None: none) gives the sensor checks the force reference of the tangential
    accelerometers from the optional ``motor_currents`` input.
    ``external_force`` (optional; unconnected: none): the perturbation monitor's sideways push, which
    leaves v_n to the lateral kinematics (VelocityMixer); add_perturbation_monitor connects it.
    The baselines (odometry-only and Gyrodometry, systems/navigation/baselines.py) read the raw encoders and
    gyro, not the checked ones.

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
    params = belief.params.validate()
    b = DiagramBuilder()
    geometry = belief.geometry()
    blocks = _add_navigation_blocks(b, belief, geometry)
    signals = _connect_sensor_signals(b, blocks, params, geometry, belief.rates.T_N, belief.calibration)
    _connect_fusion(b, blocks, signals, params)
    _export_navigation_outputs(b, blocks, signals)
    diagram = b.Build()
    diagram.set_name("navigation")
    return diagram


@dc.dataclass
class NavigationBlocks:
    """The navigation diagram's blocks and the split signals (split_port) of their vector outputs."""

    monitor: object
    check: object
    odometry_block: object
    odometry: object
    ekf: object
    gain: object
    detector: object
    c1: object
    c23_block: object
    c23: object
    yaw_calibration: object
    mixer_block: object
    mixer: object
    sideslip: object
    pose: object
    baselines: object


@dc.dataclass
class NavigationSignals:
    """The sensor signals as the fusion reads them: ``acc`` (checked, calibrated, less the standstill's
    biases), ``gyro`` (checked, calibrated), ``raw_odo`` (the odometry the calibration reads), ``odo``
    (the calibrated odometry the fusion reads) and the split outputs ``calibrated``, ``learned`` (the yaw
    calibration's) and ``zupt`` (the standstill detector's)."""

    acc: object
    gyro: object
    raw_odo: object
    odo: object
    calibrated: object
    learned: object
    zupt: object


def _add(b: DiagramBuilder, system, name: str):
    system.set_name(name)
    return b.AddSystem(system)


def _add_navigation_blocks(b, belief: NavigationBelief, geometry):
    """Add the navigation's blocks (in the diagram's order) and split their vector outputs; exports the
    ``motor_currents`` input."""
    params, initial, T_N, T_C = belief.params, belief.initial, belief.rates.T_N, belief.rates.T_C
    wheel_radius, track_width = belief.wheel_radius, belief.track_width
    monitor = _add(b, SensorHealthMonitor(params.health, geometry, initial.speed), "Sensor checks")
    b.ExportInput(monitor.GetInputPort("motor_currents"), "motor_currents")
    check = split_port(b, monitor.GetOutputPort("step"), HEALTH_STEP_LAYOUT, "Sensor checks' signals")
    odometry_block = _add(b, Odometry(wheel_radius, track_width, T_N, initial.speed), "Odometry")
    odometry = split_port(b, odometry_block.GetOutputPort("step"), ODOMETRY_STEP_LAYOUT, "Odometry's signals")
    ekf = _add(b, InertialEkf(params.ekf, T_N, initial.ekf_state()), "EKF")
    Q, _, P0 = params.ekf.matrices()
    gain = _add(
        b, KalmanGain(params.ekf, T_C, ekf_prior_covariance(P0, initial.ekf_state(), Q, T_N)), "Kalman gain"
    )
    detector = _add(
        b,
        TangentialSlipDetector(T_N, T_C, initial.speed, params.mixing.delta_v_running_integral),
        "Tangential slip detector",
    )
    c1 = _add(b, MixerC1(params.mixing, T_C), "Mixer C1")
    c23_block = _add(b, MixerC2C3(params.mixing, T_N), "Mixer C2 C3")
    c23 = split_port(b, c23_block.GetOutputPort("step"), C2C3_STEP_LAYOUT, "Mixer C2 C3's signals")
    calibration = believed_tyre_slip(params.yaw_calibration, belief.robot, params.mixing, track_width)
    yaw_calibration = _add(
        b,
        YawRateCalibration(calibration, track_width, T_N, T_C, belief.sensors),
        "Gyro and odometry calibration",
    )
    mixer_block = _add(
        b,
        VelocityMixer(
            params.mixing,
            T_N,
            initial.ekf_state()[1],
            geometry.accelerometer_position,
        ),
        "Velocity mixer",
    )
    mixer = split_port(b, mixer_block.GetOutputPort("mixing"), MIXER_LAYOUT, "Velocity mixer's signals")
    sideslip = _add(b, SideSlipEstimator(params.sideslip, T_C), "Side-slip angle")
    pose = _add(b, PoseIntegrator(T_N, initial.pose), "Pose integration")
    baselines = _add(
        b,
        Baselines(
            params.gyrodometry,
            wheel_radius,
            track_width,
            T_N,
            initial.pose,
            initial.speed,
            belief.calibration,
        ),
        "Baselines",
    )
    return NavigationBlocks(
        monitor=monitor,
        check=check,
        odometry_block=odometry_block,
        odometry=odometry,
        ekf=ekf,
        gain=gain,
        detector=detector,
        c1=c1,
        c23_block=c23_block,
        c23=c23,
        yaw_calibration=yaw_calibration,
        mixer_block=mixer_block,
        mixer=mixer,
        sideslip=sideslip,
        pose=pose,
        baselines=baselines,
    )


def _connect_sensor_signals(b, blocks: NavigationBlocks, params, geometry, T_N: float, calibration):
    """Export the sensor inputs and connect them through the sensor checks, the model's calibration
    (a SensorCorrection unless it is the identity), the yaw calibration and the standstill detector;
    returns the signals the fusion reads."""
    b.ExportInput(blocks.monitor.GetInputPort("accelerometers"), "accelerometers")
    b.ExportInput(blocks.monitor.GetInputPort("gyro"), "gyro")
    b.ExportInput(blocks.monitor.GetInputPort("encoders"), "encoders")
    b.ConnectInput("encoders", blocks.baselines.GetInputPort("encoders"))  # the raw sensors
    b.ConnectInput("gyro", blocks.baselines.GetInputPort("gyro"))
    b.Connect(blocks.check["encoders"], blocks.odometry_block.GetInputPort("encoders"))

    acc, gyro, raw_odo = (
        blocks.check["accelerometers"],
        blocks.check["gyro"],
        blocks.odometry["odometry"],
    )
    if calibration is not None and not calibration.is_identity():
        correction = _add(b, SensorCorrection(calibration), "Sensor calibration")
        b.Connect(acc, correction.GetInputPort("accelerometers"))
        b.Connect(gyro, correction.GetInputPort("gyro"))
        acc, gyro = correction.GetOutputPort("accelerometers"), correction.GetOutputPort("gyro")
    calibrated = split_port(
        b,
        blocks.yaw_calibration.GetOutputPort("calibrated"),
        CALIBRATED_LAYOUT,
        "Calibrated gyro and odometry",
    )
    learned = split_port(
        b, blocks.yaw_calibration.GetOutputPort("parameters"), PARAMETERS_LAYOUT, "Learned gyro bias and D"
    )
    standstill = _add(
        b, StandstillDetector(standstill_constants(params.standstill, geometry, T_N)), "Standstill"
    )
    b.Connect(acc, standstill.GetInputPort("accelerometers"))
    b.Connect(calibrated["gyro"], standstill.GetInputPort("gyro"))
    b.Connect(blocks.check["encoders"], standstill.GetInputPort("encoders"))
    zupt = split_port(b, standstill.GetOutputPort("step"), STANDSTILL_STEP_LAYOUT, "Standstill's signals")
    acc = zupt["accelerometers"]  # less the biases: what every later block reads
    odo = calibrated["odometry"]  # what the fusion reads; the calibration reads raw_odo
    return NavigationSignals(
        acc=acc, gyro=gyro, raw_odo=raw_odo, odo=odo, calibrated=calibrated, learned=learned, zupt=zupt
    )


def _connect_fusion(b, blocks: NavigationBlocks, signals: NavigationSignals, params) -> None:
    """Connect the fusion of Fig. 3: the yaw calibration, the EKF and its gain, the slip detector, the
    mixers, the side-slip angle, the pose and the sensor checks' feedback (replacements, tyre peak)."""
    b.Connect(signals.acc, blocks.ekf.GetInputPort("accelerometers"))
    b.Connect(signals.gyro, blocks.yaw_calibration.GetInputPort("gyro"))
    b.Connect(signals.raw_odo, blocks.yaw_calibration.GetInputPort("odometry"))
    b.Connect(blocks.c1.GetOutputPort("C1"), blocks.yaw_calibration.GetInputPort("C1"))
    b.Connect(blocks.check["inertial_fault"], blocks.yaw_calibration.GetInputPort("inertial_fault"))
    b.Connect(blocks.check["encoder_fault"], blocks.yaw_calibration.GetInputPort("encoder_fault"))
    b.Connect(blocks.check["gyro_bias_step"], blocks.yaw_calibration.GetInputPort("gyro_bias_step"))
    b.Connect(blocks.check["yaw_pair_witness"], blocks.yaw_calibration.GetInputPort("yaw_pair_witness"))
    b.Connect(blocks.check["yaw_verdict"], blocks.yaw_calibration.GetInputPort("yaw_verdict"))
    if params.standstill.enabled:  # a rest the detector confirms (else the wheels' alone)
        b.Connect(signals.zupt["standstill"], blocks.yaw_calibration.GetInputPort("standstill"))
    b.Connect(signals.calibrated["gyro"], blocks.ekf.GetInputPort("gyro"))
    b.Connect(blocks.gain.GetOutputPort("kalman_gain"), blocks.ekf.GetInputPort("kalman_gain"))
    b.Connect(blocks.ekf.GetOutputPort("prior_covariance"), blocks.gain.GetInputPort("prior_covariance"))
    b.Connect(signals.odo, blocks.detector.GetInputPort("odometry"))
    b.Connect(signals.acc, blocks.detector.GetInputPort("accelerometers"))
    b.Connect(blocks.check["sensor_fault"], blocks.detector.GetInputPort("sensor_fault"))
    b.Connect(blocks.detector.GetOutputPort("delta_v"), blocks.c1.GetInputPort("delta_v"))
    b.Connect(
        blocks.ekf.GetOutputPort("inertial_estimate"), blocks.c23_block.GetInputPort("inertial_estimate")
    )
    b.Connect(signals.odo, blocks.c23_block.GetInputPort("odometry"))
    b.Connect(signals.calibrated["odometry_share"], blocks.c23_block.GetInputPort("odometry_share"))
    b.Connect(signals.odo, blocks.mixer_block.GetInputPort("odometry"))
    b.Connect(
        blocks.ekf.GetOutputPort("inertial_estimate"), blocks.mixer_block.GetInputPort("inertial_estimate")
    )
    b.Connect(blocks.c1.GetOutputPort("C1"), blocks.mixer_block.GetInputPort("C1"))
    b.Connect(blocks.c23["C2_C3"], blocks.mixer_block.GetInputPort("C2_C3"))
    b.Connect(blocks.ekf.GetOutputPort("estimate"), blocks.mixer_block.GetInputPort("previous_estimate"))
    velocity_layout = (("body_velocity", 2), ("rest", 3))
    estimate = split_port(b, blocks.ekf.GetOutputPort("estimate"), velocity_layout, "EKF's v_t, v_n")
    b.Connect(
        estimate["body_velocity"], blocks.monitor.GetInputPort("body_velocity")
    )  # the gyro's replacement
    tyre_state = blocks.mixer_block.GetOutputPort("tyre_model_state")
    tyre = split_port(b, tyre_state, TYRE_MODEL_STATE_LAYOUT, "Identified tyre peak")
    b.Connect(tyre["tyre_peak"], blocks.monitor.GetInputPort("tyre_peak"))
    b.Connect(
        signals.learned["estimate"], blocks.monitor.GetInputPort("yaw_calibration")
    )  # the replacements read them
    b.Connect(blocks.check["inertial_fault"], blocks.mixer_block.GetInputPort("inertial_fault"))
    b.Connect(blocks.check["encoder_fault"], blocks.mixer_block.GetInputPort("encoder_fault"))
    b.Connect(signals.acc, blocks.mixer_block.GetInputPort("accelerometers"))
    b.ExportInput(blocks.mixer_block.GetInputPort("external_force"), "external_force")
    b.Connect(signals.zupt["standstill"], blocks.mixer_block.GetInputPort("standstill"))
    b.Connect(blocks.mixer["mixed_estimate"], blocks.ekf.GetInputPort("mixed_estimate"))  # Fig. 3 feedback
    b.Connect(blocks.mixer["mixing_gain"], blocks.ekf.GetInputPort("mixing_gain"))  # the mixing in P
    b.Connect(blocks.mixer["body_velocity"], blocks.sideslip.GetInputPort("body_velocity"))
    b.Connect(blocks.mixer["body_velocity"], blocks.pose.GetInputPort("body_velocity"))


def _export_navigation_outputs(b, blocks: NavigationBlocks, signals: NavigationSignals) -> None:
    """Export the navigation's outputs (NAVIGATION_OUTPUTS, ``checked_encoders``)."""
    b.ExportOutput(blocks.pose.GetOutputPort("pose"), "pose")
    b.ExportOutput(blocks.mixer["mixed_estimate"], "mixed_estimate")
    b.ExportOutput(blocks.sideslip.GetOutputPort("side_slip_angle"), "side_slip_angle")
    b.ExportOutput(blocks.sideslip.GetOutputPort("track_speed"), "track_speed")
    b.ExportOutput(blocks.c1.GetOutputPort("C1"), "C1")
    b.ExportOutput(blocks.mixer["slide_onset"], "slide_onset")
    b.ExportOutput(blocks.c23["C2_C3"], "C2_C3")
    b.ExportOutput(blocks.mixer["tyre_model_check"], "tyre_model_check")
    b.ExportOutput(blocks.c1.GetOutputPort("delta_v_held"), "delta_v")
    b.ExportOutput(signals.raw_odo, "odometry")
    b.ExportOutput(blocks.baselines.GetOutputPort("odometry_pose"), "odometry_pose")
    b.ExportOutput(blocks.baselines.GetOutputPort("gyrodometry_pose"), "gyrodometry_pose")
    b.ExportOutput(blocks.check["inertial_fault"], "inertial_fault")
    b.ExportOutput(blocks.check["encoder_fault"], "encoder_fault")
    b.ExportOutput(blocks.ekf.GetOutputPort("covariance"), "covariance")
    b.ExportOutput(blocks.yaw_calibration.GetOutputPort("bias"), "gyro_bias")
    b.ExportOutput(blocks.yaw_calibration.GetOutputPort("parameters"), "yaw_calibration")
    b.ExportOutput(blocks.check["health"], "health")
    b.ExportOutput(blocks.check["encoders"], "checked_encoders")
    b.ExportOutput(signals.zupt["standstill"], "standstill")
    b.ExportOutput(signals.zupt["accelerometer_bias"], "accelerometer_bias")


def add_navigation(builder, sensors, belief: NavigationBelief, currents_port=None):
    """Add the navigation diagram of ``belief`` (NavigationBelief: what it knows) fed by ``sensors``
    (ProprioceptiveSensors or a SensorFaultInjector) and the motor drivers' ``currents_port`` (None:
    unconnected) to ``builder``.

    Returns (navigation subsystem, its output ports keyed ``nav_<name>`` for logging).
    """
    nav = builder.AddSystem(build_navigation_diagram(belief))
    for name in ("accelerometers", "gyro", "encoders"):
        builder.Connect(sensors.GetOutputPort(name), nav.GetInputPort(name))
    if currents_port is not None:
        builder.Connect(currents_port, nav.GetInputPort("motor_currents"))
    ports = {f"nav_{name}": nav.GetOutputPort(name) for name in NAVIGATION_OUTPUTS if name != "covariance"}
    return nav, ports
