"""Open-loop diagram: trajectory feed-forward -> plant -> sensors, with loggers on the T_N grid."""

from __future__ import annotations

import dataclasses as dc

import numpy as np
from pydrake.systems.framework import Diagram, DiagramBuilder
from pydrake.systems.primitives import LogVectorOutput, Multiplexer, TrajectorySource
from pydrake.trajectories import PiecewisePolynomial
from slipnav.diagrams.navigation import add_navigation
from slipnav.diagrams.robot import RobotHandles, add_robot_with_sensors
from slipnav.systems.checks import (
    check_robot_physics,
    check_start_time,
    require_finite,
    require_instance,
    require_pose,
    require_seed,
    require_table,
)
from slipnav.systems.feedforward import TrajectoryFeedforward
from slipnav.systems.health.perturbation import PerturbationParameters
from slipnav.systems.health.perturbation_monitor import add_perturbation_monitor
from slipnav.systems.navigation import NavigationParameters
from slipnav.systems.plant import DEFAULT_TIME_STEP, RobotParameters
from slipnav.systems.rates import SampleRates
from slipnav.systems.sensor_correction import SensorCalibration
from slipnav.systems.sensors import SensorParameters


@dc.dataclass
class LoggedDiagram:
    """A built diagram and the loggers of its signals, keyed by signal name."""

    diagram: Diagram
    robot: RobotHandles
    loggers: dict[str, SignalLog]


class SignalLog:
    """One signal's rows in the shared log of add_loggers; ``FindLog(context)`` as on a VectorLogSink."""

    def __init__(self, sink, rows: slice):
        self.sink, self.rows = sink, rows

    def FindLog(self, context):  # noqa: N802 (the VectorLogSink API)
        return _SignalRows(self.sink.FindLog(context), self.rows)


class _SignalRows:
    def __init__(self, log, rows):
        self._log, self._rows = log, rows

    def data(self):
        return self._log.data()[self._rows]

    def sample_times(self):
        return self._log.sample_times()

    def num_samples(self):
        return self._log.num_samples()


def add_loggers(builder: DiagramBuilder, ports: dict, period: float) -> dict[str, SignalLog]:
    """Log every port every ``period`` seconds: a Multiplexer gathers them into one VectorLogSink (one
    publish event per sample instead of one per signal). Returns a SignalLog per port name."""
    sizes = [port.size() for port in ports.values()]
    mux = builder.AddSystem(Multiplexer(sizes))
    mux.set_name("logged signals")
    for i, port in enumerate(ports.values()):
        builder.Connect(port, mux.get_input_port(i))
    sink = LogVectorOutput(mux.get_output_port(0), builder, period)
    sink.set_name("log")
    offsets = np.cumsum([0, *sizes])
    return {name: SignalLog(sink, slice(offsets[i], offsets[i + 1])) for i, name in enumerate(ports)}


def robot_ports(robot: RobotHandles) -> dict:
    plant, sensors = robot.plant, robot.readings or robot.sensors
    return {
        "state": plant.GetOutputPort("state"),  # wheel speeds, angles and tyre slip follow from it
        "accelerometers": sensors.GetOutputPort("accelerometers"),
        "gyro": sensors.GetOutputPort("gyro"),
        "encoders": sensors.GetOutputPort("encoders"),
        "gyro_bias": robot.sensors.GetOutputPort("gyro_bias"),
        "motor_currents": robot.sensors.GetOutputPort("motor_currents"),
    }


def check_robot_inputs(robot, sensor_params, rates, seed, initial_pose, initial_speed, plant_time_step):
    """The builders' common inputs (Python API): ValueError naming the parameter."""
    require_instance("robot", robot, RobotParameters)
    check_robot_physics(robot, "robot.")
    require_instance("sensor_params", sensor_params, SensorParameters)
    require_instance("rates", rates, SampleRates)
    require_seed(seed)
    require_pose("initial_pose", initial_pose)
    require_finite("initial_speed", initial_speed, 0.0, robot.wheel_speed_limit)
    require_finite("plant_time_step", plant_time_step, 0.0, 0.01)


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
    knows (default the robot's, systems.sensors.default_sensor_parameters); ``calibration``: the sensors'
    systematic errors a calibrated model states (SensorCalibration); ``perturbation_monitor``:
    PerturbationParameters of the PerturbationMonitor on the commands, encoders and navigation.
    ``motor_enable``: None (the motors always driven, the plant's motor_enable input left unconnected) or
    one row [enable_R, enable_L] of 0/1 per wheel_speeds row, held from that row's time on (a
    TrajectorySource): 0 switches the motor off (systems.plant.MOTORS_ON; a coasting run)."""
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
    builder = DiagramBuilder()
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
    nav_ports, nav = {}, None
    if navigation is not None:
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
    feedforward = builder.AddSystem(
        TrajectoryFeedforward(rates.T_C, wheel_speeds, reference_poses, start_time)
    )
    feedforward.set_name("Trajectory feed-forward")
    builder.Connect(
        feedforward.GetOutputPort("wheel_speed_command"),
        handles.plant.GetInputPort("wheel_speed_command"),
    )
    if motor_enable is not None:
        times = start_time + rates.T_C * np.arange(len(motor_enable) + 1)
        values = np.vstack([motor_enable, motor_enable[-1:]]).T
        enable = builder.AddSystem(TrajectorySource(PiecewisePolynomial.ZeroOrderHold(times, values)))
        enable.set_name("Motor enable")
        builder.Connect(enable.get_output_port(0), handles.plant.GetInputPort("motor_enable"))
    ports = robot_ports(handles)
    ports["command"] = feedforward.GetOutputPort("wheel_speed_command")
    if nav is not None:
        monitor = add_perturbation_monitor(
            builder,
            perturbation_monitor or PerturbationParameters(),
            feedforward.GetOutputPort("wheel_speed_command"),
            nav.GetOutputPort("checked_encoders"),
            nav,
            robot,
            rates.T_N,
            handles.sensors.GetOutputPort("motor_currents"),
        )
        ports["perturbation"] = monitor.GetOutputPort("perturbation")
        ports["force_residual"] = monitor.GetOutputPort("force_residual")
    ports["reference_pose"] = feedforward.GetOutputPort("reference_pose")
    ports.update(nav_ports)
    loggers = add_loggers(builder, ports, rates.T_N)
    diagram = builder.Build()
    diagram.set_name("open_loop")
    return LoggedDiagram(diagram=diagram, robot=handles, loggers=loggers)
