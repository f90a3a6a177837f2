"""The closed loop: plant and sensors -> navigation -> control (path follower, speed law or slip
control) -> wheel-speed saturator -> plant. The controller acts on the navigation estimate only."""

import dataclasses as dc

from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import Demultiplexer

from diagrams.navigation import add_navigation
from diagrams.open_loop import LoggedDiagram, add_loggers, robot_ports
from diagrams.robot import add_robot_with_sensors
from systems.navigation import NavigationParameters
from systems.path_follower import LyapunovPathFollower, PathFollowerParameters, WheelSpeedSaturator
from systems.plant import RobotParameters
from systems.rates import SampleRates
from systems.sensors import SensorParameters
from systems.slip_control import StepSizeController, StepSizeParameters, TrajectoryInterpolator


@dc.dataclass
class ControlSettings:
    """What the control side of the closed loop does.

    Args:
        mode: ``trajectory`` (Seyr: follow a timed trajectory, slip control) or ``max_speed`` (Indiveri).
        path: geometric path the follower follows (in trajectory mode: the trajectory's geometry).
        trajectory: the timed trajectory (trajectory mode).
        follower: PathFollowerParameters. step_size: StepSizeParameters.
        slip_control: False keeps delta = 1 (``--no-slip-control``).
        speed_law: ``bounded`` (I(24)) or ``constant`` (u = V_m/2), max_speed mode.
    """

    mode: str
    path: object
    trajectory: object = None
    follower: PathFollowerParameters = dc.field(default_factory=PathFollowerParameters)
    step_size: StepSizeParameters = dc.field(default_factory=StepSizeParameters)
    slip_control: bool = True
    speed_law: str = "bounded"


def build_closed_loop_diagram(
    robot: RobotParameters,
    sensor_params: SensorParameters,
    rates: SampleRates,
    navigation: NavigationParameters,
    control: ControlSettings,
    seed: int,
    initial_pose=(0.0, 0.0, 0.0),
    initial_speed: float = 0.0,
) -> LoggedDiagram:
    """The full closed loop, with every signal of the run artifact logged every T_N."""
    builder = DiagramBuilder()
    handles = add_robot_with_sensors(
        builder, robot, sensor_params, rates.T_N, seed, initial_pose, initial_speed
    )
    nav, nav_ports = add_navigation(
        builder, handles.sensors, navigation, rates, robot, initial_speed, initial_pose
    )

    follower = builder.AddSystem(
        LyapunovPathFollower(control.follower, control.path, robot.track_width, rates.T_C)
    )
    follower.set_name("Lyapunov path follower")
    saturator = builder.AddSystem(
        WheelSpeedSaturator(
            control.path,
            robot.wheel_speed_limit,
            robot.track_width,
            control.follower.epsilon,
            control.speed_law,
        )
    )
    saturator.set_name("Wheel-speed saturator")
    builder.Connect(nav.GetOutputPort("pose"), follower.GetInputPort("estimated_pose"))
    speed = builder.AddSystem(Demultiplexer([1, 4]))
    speed.set_name("Estimated speed")
    builder.Connect(nav.GetOutputPort("mixed_estimate"), speed.get_input_port(0))
    builder.Connect(speed.get_output_port(0), follower.GetInputPort("estimated_speed"))
    builder.Connect(follower.GetOutputPort("lyapunov_value"), saturator.GetInputPort("lyapunov_value"))
    builder.Connect(follower.GetOutputPort("virtual_target"), saturator.GetInputPort("virtual_target"))
    builder.Connect(
        follower.GetOutputPort("wheel_speed_command"), saturator.GetInputPort("wheel_speed_command")
    )
    builder.Connect(
        saturator.GetOutputPort("saturated_command"), handles.plant.GetInputPort("wheel_speed_command")
    )

    ports = robot_ports(handles)
    ports.update(nav_ports)
    ports["command"] = saturator.GetOutputPort("saturated_command")
    ports["V1"] = follower.GetOutputPort("lyapunov_value")
    ports["virtual_target"] = follower.GetOutputPort("virtual_target")
    ports["frenet_errors"] = follower.GetOutputPort("frenet_errors")
    if control.mode == "trajectory":
        step = builder.AddSystem(StepSizeController(control.step_size, rates.T_C, control.slip_control))
        step.set_name("Step-size controller")
        interpolator = builder.AddSystem(TrajectoryInterpolator(control.trajectory, control.step_size))
        interpolator.set_name("Trajectory interpolator")
        builder.Connect(nav.GetOutputPort("C1"), step.GetInputPort("C1"))
        builder.Connect(nav.GetOutputPort("side_slip_angle"), step.GetInputPort("side_slip_angle"))
        builder.Connect(step.GetOutputPort("step_size"), interpolator.GetInputPort("step_size"))
        builder.Connect(step.GetOutputPort("progress"), interpolator.GetInputPort("progress"))
        builder.Connect(follower.GetOutputPort("virtual_target"), interpolator.GetInputPort("virtual_target"))
        builder.Connect(interpolator.GetOutputPort("speed"), follower.GetInputPort("speed"))
        ports["step_size"] = step.GetOutputPort("step_size")
        ports["progress"] = step.GetOutputPort("progress")
        ports["reference_pose"] = interpolator.GetOutputPort("reference_pose")
    elif control.mode == "max_speed":
        builder.Connect(saturator.GetOutputPort("speed"), follower.GetInputPort("speed"))
        ports["reference_pose"] = follower.GetOutputPort("path_point")
    else:
        raise ValueError(f"mode={control.mode!r} is unknown: allowed 'trajectory', 'max_speed'")
    loggers = add_loggers(builder, ports, rates.T_N)
    diagram = builder.Build()
    diagram.set_name("closed_loop")
    return LoggedDiagram(diagram=diagram, robot=handles, loggers=loggers)
