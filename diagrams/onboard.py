"""What both loops build around their commands: the robot with its sensors and the navigation reading
them (add_robot_and_navigation), and the perturbation monitor on the commands (add_command_monitor)."""

from __future__ import annotations

from pydrake.systems.framework import DiagramBuilder
from slipnav.diagrams.navigation import add_navigation
from slipnav.diagrams.robot import RobotHandles, add_robot_with_sensors
from slipnav.systems.health.perturbation import PerturbationParameters
from slipnav.systems.health.perturbation_monitor import add_perturbation_monitor
from slipnav.systems.navigation.parameters import NavigationParameters
from slipnav.systems.navigation.sensor_correction import SensorCalibration
from slipnav.systems.rates import SampleRates
from slipnav.systems.robot.parameters import RobotParameters
from slipnav.systems.robot.sensors import SensorParameters, default_sensor_parameters


def add_robot_and_navigation(
    builder: DiagramBuilder,
    robot: RobotParameters,
    sensor_params: SensorParameters,
    rates: SampleRates,
    seed: int,
    initial_pose,
    initial_speed: float,
    plant_time_step: float,
    plant: RobotParameters | None,
    faults,
    navigation: NavigationParameters | None,
    nominal_sensors: SensorParameters | None,
    calibration: SensorCalibration | None,
):
    """The simulated robot (``plant``, default ``robot``) with its sensors and their ``faults``, and the
    navigation reading them (``navigation=None``: none), which knows the nominal ``robot``, the sensors'
    data sheet ``nominal_sensors`` and the model's ``calibration`` (add_navigation).

    Returns (RobotHandles, the navigation subsystem or None, its output ports keyed for logging).
    """
    handles = add_robot_with_sensors(
        builder,
        plant or robot,
        sensor_params,
        rates.T_N,
        seed,
        initial_pose,
        initial_speed,
        plant_time_step,
        faults,
    )
    if navigation is None:
        return handles, None, {}
    nav, nav_ports = add_navigation(
        builder,
        handles.readings,
        navigation,
        rates,
        robot,
        initial_speed,
        initial_pose,
        nominal_sensors,
        calibration,
        handles.sensors.GetOutputPort("motor_currents"),
    )
    return handles, nav, nav_ports


def add_command_monitor(
    builder: DiagramBuilder,
    parameters: PerturbationParameters | None,
    command_port,
    nav,
    robot: RobotParameters,
    rates: SampleRates,
    handles: RobotHandles,
    nominal_sensors: SensorParameters | None = None,
):
    """The PerturbationMonitor (``parameters``, default PerturbationParameters()) on the wheel-speed
    commands ``command_port``, the navigation's checked encoders and estimate and the motor drivers'
    currents; ``nominal_sensors`` (default the robot's data sheet) say whether it carries accelerometers;
    returns it."""
    sensors = nominal_sensors or default_sensor_parameters(robot.name)
    return add_perturbation_monitor(
        builder,
        parameters or PerturbationParameters(),
        command_port,
        nav.GetOutputPort("checked_encoders"),
        nav,
        robot,
        rates.T_N,
        handles.sensors.GetOutputPort("motor_currents"),
        sensors.accelerometer_sets > 0,
    )
