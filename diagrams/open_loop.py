"""Open-loop diagram: trajectory feed-forward -> plant -> sensors, with loggers on the T_N grid."""

from __future__ import annotations

import numpy as np
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import TrajectorySource
from pydrake.trajectories import PiecewisePolynomial
from slipnav.diagrams.loggers import LoggedDiagram, add_loggers, robot_ports
from slipnav.diagrams.onboard import add_command_monitor, add_robot_and_navigation
from slipnav.diagrams.robot import RobotHandles, check_robot_inputs
from slipnav.systems.checks import (
    check_start_time,
    require_instance,
    require_table,
)
from slipnav.systems.control.feedforward import TrajectoryFeedforward
from slipnav.systems.health.perturbation import PerturbationParameters
from slipnav.systems.navigation.parameters import NavigationParameters
from slipnav.systems.navigation.sensor_correction import SensorCalibration
from slipnav.systems.rates import SampleRates
from slipnav.systems.robot.parameters import RobotParameters
from slipnav.systems.robot.plant import DEFAULT_TIME_STEP
from slipnav.systems.robot.sensors import SensorParameters


def build_open_loop_diagram(
    robot: RobotParameters,
    sensor_params: SensorParameters,
    rates: SampleRates,
    wheel_speeds: np.ndarray,
    reference_poses: np.ndarray,
    seed: int,
    initial_pose=(0.0, 0.0, 0.0),
    initial_speed: float = 0.0,
    navigation: NavigationParameters | None = None,
    plant_time_step: float = DEFAULT_TIME_STEP,
    plant: RobotParameters | None = None,
    start_time: float = 0.0,
    faults=(),
    nominal_sensors: SensorParameters | None = None,
    calibration: SensorCalibration | None = None,
    perturbation_monitor: PerturbationParameters | None = None,
    motor_enable: np.ndarray | None = None,
) -> LoggedDiagram:
    """Feed-forward of a trajectory's wheel speeds driving the plant with its sensors (no feedback);
    the navigation diagram estimates the motion from the sensors (``navigation=None`` leaves it out).
    ``robot`` is the nominal model the navigation reads, ``plant`` the real robot (default ``robot``).
    ``start_time``: the table's row 0 plays until then (the standstill; a robot at rest only). Raises
    ValueError naming the parameter for an input that cannot be simulated. ``faults``: sensor FaultEvents
    between the sensors and the navigation; ``nominal_sensors``: the sensors' data sheet the navigation
    knows (default the robot's, systems.robot.sensors.default_sensor_parameters); ``calibration``: the
    sensors' systematic errors a calibrated model states (SensorCalibration); ``perturbation_monitor``:
    PerturbationParameters of the PerturbationMonitor on the commands, encoders and navigation.
    ``motor_enable``: None (the motors always driven, the plant's motor_enable input left unconnected) or
    one row [enable_R, enable_L] of 0/1 per wheel_speeds row, held from that row's time on (a
    TrajectorySource): 0 switches the motor off (systems.robot.motors.MOTORS_ON; a coasting run)."""
    wheel_speeds, reference_poses, motor_enable = check_open_loop_inputs(
        robot,
        sensor_params,
        rates,
        wheel_speeds,
        reference_poses,
        seed,
        initial_pose,
        initial_speed,
        navigation,
        plant_time_step,
        start_time,
        motor_enable,
    )
    builder = DiagramBuilder()
    handles, nav, nav_ports = add_robot_and_navigation(
        builder,
        robot,
        sensor_params,
        rates,
        seed,
        initial_pose,
        initial_speed,
        plant_time_step,
        plant,
        faults,
        navigation,
        nominal_sensors,
        calibration,
    )
    feedforward = builder.AddSystem(
        TrajectoryFeedforward(rates.T_C, wheel_speeds, reference_poses, start_time)
    )
    feedforward.set_name("Trajectory feed-forward")
    builder.Connect(
        feedforward.GetOutputPort("wheel_speed_command"),
        handles.plant.GetInputPort("wheel_speed_command"),
    )
    if motor_enable is not None:
        add_motor_enable(builder, handles, motor_enable, start_time, rates.T_C)
    ports = robot_ports(handles)
    ports["command"] = feedforward.GetOutputPort("wheel_speed_command")
    if nav is not None:
        command = feedforward.GetOutputPort("wheel_speed_command")
        monitor = add_command_monitor(
            builder, perturbation_monitor, command, nav, robot, rates, handles, nominal_sensors
        )
        ports["perturbation"] = monitor.GetOutputPort("perturbation")
        ports["force_residual"] = monitor.GetOutputPort("force_residual")
    ports["reference_pose"] = feedforward.GetOutputPort("reference_pose")
    ports.update(nav_ports)
    loggers = add_loggers(builder, ports, rates.T_N)
    diagram = builder.Build()
    diagram.set_name("open_loop")
    return LoggedDiagram(diagram=diagram, robot=handles, loggers=loggers)


def check_open_loop_inputs(
    robot: RobotParameters,
    sensor_params: SensorParameters,
    rates: SampleRates,
    wheel_speeds,
    reference_poses,
    seed: int,
    initial_pose,
    initial_speed: float,
    navigation: NavigationParameters | None,
    plant_time_step: float,
    start_time: float,
    motor_enable,
):
    """build_open_loop_diagram's inputs (Python API): ValueError naming the parameter. Returns the
    checked tables (wheel_speeds, reference_poses, motor_enable) as float arrays."""
    check_robot_inputs(robot, sensor_params, rates, seed, initial_pose, initial_speed, plant_time_step)
    if navigation is not None:
        require_instance("navigation", navigation, NavigationParameters)
        navigation.validate()
    wheel_speeds = require_table("wheel_speeds", wheel_speeds, 2, robot.no_load_speed)
    reference_poses = require_table("reference_poses", reference_poses, 3)
    if len(reference_poses) != len(wheel_speeds):
        raise ValueError(
            f"reference_poses has {len(reference_poses)} rows: allowed one per wheel_speeds row "
            f"({len(wheel_speeds)})"
        )
    check_start_time(start_time, rates.T_C)
    if motor_enable is not None:
        motor_enable = require_table("motor_enable", motor_enable, 2)
        if len(motor_enable) != len(wheel_speeds):
            raise ValueError(
                f"motor_enable has {len(motor_enable)} rows: allowed one per wheel_speeds row "
                f"({len(wheel_speeds)})"
            )
        if not np.all(np.isin(motor_enable, (0.0, 1.0))):
            raise ValueError("motor_enable holds values other than 0 and 1: allowed 0 (off) or 1 (driven)")
    if start_time > 0.0 and initial_speed != 0.0:
        raise ValueError(
            f"start_time={start_time!r} needs a robot at rest: initial_speed={initial_speed!r}, allowed 0"
        )
    return wheel_speeds, reference_poses, motor_enable


def add_motor_enable(
    builder: DiagramBuilder, handles: RobotHandles, motor_enable, start_time: float, T_C: float
):
    """The plant's motor_enable input from one row [enable_R, enable_L] per T_C from ``start_time`` on
    (a zero-order hold TrajectorySource; the last row held)."""
    times = start_time + T_C * np.arange(len(motor_enable) + 1)
    values = np.vstack([motor_enable, motor_enable[-1:]]).T
    enable = builder.AddSystem(TrajectorySource(PiecewisePolynomial.ZeroOrderHold(times, values)))
    enable.set_name("Motor enable")
    builder.Connect(enable.get_output_port(0), handles.plant.GetInputPort("motor_enable"))
