"""Open-loop diagram: trajectory feed-forward -> plant -> sensors, with loggers on the T_N grid."""

from __future__ import annotations

import numpy as np
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import TrajectorySource
from pydrake.trajectories import PiecewisePolynomial
from slipnav.diagrams.loggers import LoggedDiagram, add_loggers, robot_ports
from slipnav.diagrams.onboard import add_command_monitor, add_robot_and_navigation
from slipnav.diagrams.records import Belief, Truth
from slipnav.diagrams.robot import RobotHandles, check_records
from slipnav.systems.checks import (
    check_start_time,
    require_instance,
    require_table,
)
from slipnav.systems.control.feedforward import TrajectoryFeedforward
from slipnav.systems.navigation.parameters import NavigationParameters


def build_open_loop_diagram(
    truth: Truth,
    belief: Belief,
    wheel_speeds: np.ndarray,
    reference_poses: np.ndarray,
    start_time: float = 0.0,
    motor_enable: np.ndarray | None = None,
) -> LoggedDiagram:
    """Feed-forward of a trajectory's wheel speeds driving the plant with its sensors (no feedback);
    the navigation diagram estimates the motion from the sensors (``belief.navigation=None`` leaves it
    out, and the PerturbationMonitor with it). ``truth``: the simulated robot, its sensors and their
    faults (Truth); ``belief``: what the navigation and the monitor know (Belief). ``wheel_speeds``,
    ``reference_poses``: one row [v_R, v_L] (m/s) and [x, y, phi] per T_C.
    ``start_time``: the table's row 0 plays until then (the standstill, s; a robot at rest only).
    ``motor_enable``: None (the motors always driven, the plant's motor_enable input left unconnected) or
    one row [enable_R, enable_L] of 0/1 per wheel_speeds row, held from that row's time on (a
    TrajectorySource): 0 switches the motor off (systems.robot.motors.MOTORS_ON; a coasting run).
    Raises ValueError naming the field for an input that cannot be simulated."""
    wheel_speeds, reference_poses, motor_enable = check_open_loop_inputs(
        truth, belief, wheel_speeds, reference_poses, start_time, motor_enable
    )
    rates = belief.rates
    builder = DiagramBuilder()
    handles, nav, nav_ports = add_robot_and_navigation(builder, truth, belief)
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
        monitor = add_command_monitor(builder, belief, command, nav, handles)
        ports["perturbation"] = monitor.GetOutputPort("perturbation")
        ports["force_residual"] = monitor.GetOutputPort("force_residual")
    ports["reference_pose"] = feedforward.GetOutputPort("reference_pose")
    ports.update(nav_ports)
    loggers = add_loggers(builder, ports, rates.T_N)
    diagram = builder.Build()
    diagram.set_name("open_loop")
    return LoggedDiagram(diagram=diagram, robot=handles, loggers=loggers)


def check_open_loop_inputs(
    truth: Truth, belief: Belief, wheel_speeds, reference_poses, start_time: float, motor_enable
):
    """build_open_loop_diagram's inputs (Python API): ValueError naming the field. Returns the
    checked tables (wheel_speeds, reference_poses, motor_enable) as float arrays."""
    check_records(truth, belief)
    robot, rates = belief.robot, belief.rates
    if belief.navigation is not None:
        require_instance("belief.navigation", belief.navigation, NavigationParameters)
        belief.navigation.validate()
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
    if start_time > 0.0 and truth.initial_speed != 0.0:
        raise ValueError(
            f"start_time={start_time!r} needs a robot at rest: truth.initial_speed={truth.initial_speed!r}, "
            "allowed 0"
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
