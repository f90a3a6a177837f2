"""What both loops build around their commands: the robot with its sensors and the navigation reading
them (add_robot_and_navigation), and the perturbation monitor on the commands (add_command_monitor)."""

from __future__ import annotations

from pydrake.systems.framework import DiagramBuilder
from slipnav.diagrams.navigation import add_navigation
from slipnav.diagrams.records import Belief, Truth
from slipnav.diagrams.robot import RobotHandles, add_robot_with_sensors
from slipnav.systems.health.perturbation_monitor import add_perturbation_monitor


def add_robot_and_navigation(builder: DiagramBuilder, truth: Truth, belief: Belief):
    """The simulated robot (``truth.robot(belief)``) with its sensors and their faults, and the navigation
    reading them (``belief.navigation`` None: none), which knows the nominal robot, the sensors' data
    sheet and the model's calibration of the ``belief`` and starts from the truth's initial speed and
    pose (Belief.navigation_belief, add_navigation).

    Returns (RobotHandles, the navigation subsystem or None, its output ports keyed for logging).
    """
    handles = add_robot_with_sensors(
        builder,
        truth.robot(belief),
        truth.sensors,
        belief.rates.T_N,
        truth.seed,
        truth.initial_pose,
        truth.initial_speed,
        truth.plant_time_step,
        truth.faults,
    )
    if belief.navigation is None:
        return handles, None, {}
    nav, nav_ports = add_navigation(
        builder,
        handles.readings,
        belief.navigation_belief(truth.initial_state),
        handles.sensors.GetOutputPort("motor_currents"),
    )
    return handles, nav, nav_ports


def add_command_monitor(builder: DiagramBuilder, belief: Belief, command_port, nav, handles: RobotHandles):
    """The PerturbationMonitor (``belief.monitor``) on the wheel-speed commands ``command_port``, the
    navigation's checked encoders and estimate and the motor drivers' currents; the belief's data sheet
    says whether it carries accelerometers; returns it."""
    return add_perturbation_monitor(
        builder,
        belief.monitor,
        command_port,
        nav.GetOutputPort("checked_encoders"),
        nav,
        belief.robot,
        belief.rates.T_N,
        handles.sensors.GetOutputPort("motor_currents"),
        belief.data_sheet.accelerometer_sets > 0,
    )
