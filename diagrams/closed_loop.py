"""The closed loop: plant and sensors -> navigation -> control (path follower, speed law or slip
control) -> wheel-speed saturator -> plant. The controller acts on the navigation estimate only."""

import dataclasses as dc

import numpy as np
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import MatrixGain
from slipnav.diagrams.loggers import LoggedDiagram, add_loggers, robot_ports
from slipnav.diagrams.onboard import add_command_monitor, add_robot_and_navigation
from slipnav.diagrams.records import Belief, Truth
from slipnav.diagrams.robot import check_records
from slipnav.systems.checks import check_follower_gains, check_start_time, require_instance
from slipnav.systems.control.path_follower import (
    LyapunovPathFollower,
    PathFollowerParameters,
    WheelSpeedSaturator,
)
from slipnav.systems.control.slip_control import (
    StepSizeController,
    StepSizeParameters,
    TrajectoryInterpolator,
)
from slipnav.systems.navigation.parameters import NavigationParameters
from slipnav.systems.rates import SampleRates
from slipnav.systems.robot.parameters import RobotParameters


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
        start_time: the controller's first update (s, a multiple of T_C): until then the commands are
            zero, the robot stands and the navigation learns the gyro's bias (the scenario's
            ``standstill_time``).
        localisation: the pose and speed the follower reads (Indiveri et al. Fig. 6): ``fused`` (the
            navigation's estimate, default), ``odometry`` (odometry-only dead reckoning), ``gyrodometry``
            (Indiveri's Algorithm 1; speed from the odometry) or ``truth`` (the plant's state: an
            oracle for comparison). Slip control reads the navigation's C1 and side slip throughout.
    """

    mode: str
    path: object
    trajectory: object = None
    follower: PathFollowerParameters = dc.field(default_factory=PathFollowerParameters)
    step_size: StepSizeParameters = dc.field(default_factory=StepSizeParameters)
    slip_control: bool = True
    speed_law: str = "bounded"
    start_time: float = 0.0
    localisation: str = "fused"


LOCALISATION_SOURCES = ("fused", "odometry", "gyrodometry", "truth")
CONTROL_OUTPUTS = ("wheel_speed_command", "V1", "virtual_target", "frenet_errors", "reference_pose")
TRAJECTORY_OUTPUTS = ("step_size", "progress")


def control_offset(control: ControlSettings, rates: SampleRates, robot: RobotParameters) -> float:
    """The control blocks' delay after each t_K (s): half the shorter of T_N and the robot's speed-loop
    period in trajectory mode with ``step_size.after_navigation``, else 0.

    The navigation's blocks update at t_K; blocks updating at the same instant read their outputs as
    they stood before (Drake's discrete updates). Updating half a sample later, the control reads what
    the navigation computed at t_K (C1_K, alpha_K, the pose) and nothing else has moved: the sensors and
    the discrete plant update at T_N multiples only, the continuous plant's speed loop at its period's,
    so the command reaches the robot at the same sample as without the offset (t_K + T_N)."""
    if control.mode != "trajectory" or not control.step_size.after_navigation:
        return 0.0
    return 0.5 * min(rates.T_N, robot.speed_loop_period)


def build_control_diagram(control: ControlSettings, rates: SampleRates, robot: RobotParameters):
    """The control blocks as one Diagram, acting on the navigation estimate.

    .. pydrake_system::

        name: control
        input_ports:
        - estimated_pose
        - estimated_speed
        - C1
        - side_slip_angle
        output_ports:
        - wheel_speed_command
        - V1
        - virtual_target
        - frenet_errors
        - reference_pose
        - step_size
        - progress

    ``wheel_speed_command`` is the saturated command for the plant. ``step_size`` and ``progress`` exist
    in trajectory mode only; C1 and side_slip_angle are inputs there only.
    """
    if control.mode not in ("trajectory", "max_speed"):
        raise ValueError(f"mode={control.mode!r} is unknown: allowed 'trajectory', 'max_speed'")
    b = DiagramBuilder()
    check_start_time(control.start_time, rates.T_C, "control.start_time")
    offset = control_offset(control, rates, robot)
    follower = b.AddSystem(
        LyapunovPathFollower(
            control.follower,
            control.path,
            robot.track_width,
            rates.T_C,
            start_time=control.start_time,
            offset=offset,
        )
    )
    follower.set_name("Lyapunov path follower")
    saturator = b.AddSystem(
        WheelSpeedSaturator(
            control.path,
            robot.wheel_speed_limit,
            robot.track_width,
            control.follower,
            control.speed_law,
        )
    )
    saturator.set_name("Wheel-speed saturator")
    b.ExportInput(follower.GetInputPort("estimated_pose"), "estimated_pose")
    b.ConnectInput("estimated_pose", saturator.GetInputPort("estimated_pose"))  # I(24)'s V1 of this instant
    b.ExportInput(follower.GetInputPort("estimated_speed"), "estimated_speed")
    b.Connect(follower.GetOutputPort("lyapunov_value"), saturator.GetInputPort("lyapunov_value"))
    b.Connect(follower.GetOutputPort("virtual_target"), saturator.GetInputPort("virtual_target"))
    b.Connect(follower.GetOutputPort("wheel_speed_command"), saturator.GetInputPort("wheel_speed_command"))
    b.ExportOutput(saturator.GetOutputPort("saturated_command"), "wheel_speed_command")
    b.ExportOutput(follower.GetOutputPort("lyapunov_value"), "V1")
    b.ExportOutput(follower.GetOutputPort("virtual_target"), "virtual_target")
    b.ExportOutput(follower.GetOutputPort("frenet_errors"), "frenet_errors")
    if control.mode == "trajectory":
        step = b.AddSystem(
            StepSizeController(
                control.step_size, rates.T_C, control.slip_control, control.start_time, offset
            )
        )
        step.set_name("Step-size controller")
        interpolator = b.AddSystem(TrajectoryInterpolator(control.trajectory, control.step_size))
        interpolator.set_name("Trajectory interpolator")
        b.ExportInput(step.GetInputPort("C1"), "C1")
        b.ExportInput(step.GetInputPort("side_slip_angle"), "side_slip_angle")
        b.Connect(step.GetOutputPort("pace"), interpolator.GetInputPort("step_size"))
        b.Connect(step.GetOutputPort("progress"), interpolator.GetInputPort("progress"))
        b.Connect(follower.GetOutputPort("virtual_target"), interpolator.GetInputPort("virtual_target"))
        b.Connect(interpolator.GetOutputPort("speed"), follower.GetInputPort("speed"))
        b.ExportOutput(interpolator.GetOutputPort("reference_pose"), "reference_pose")
        b.ExportOutput(step.GetOutputPort("step_size"), "step_size")
        b.ExportOutput(step.GetOutputPort("progress"), "progress")
    else:
        b.Connect(saturator.GetOutputPort("speed"), follower.GetInputPort("speed"))
        b.ExportOutput(follower.GetOutputPort("path_point"), "reference_pose")
    diagram = b.Build()
    diagram.set_name("control")
    return diagram


def localisation_ports(builder, source: str, nav, plant):
    """(pose port [x, y, phi], speed port [v_t]) of the localisation ``source``
    (ControlSettings.localisation); the speed picked out of a wider port by a MatrixGain."""
    if source == "fused":
        speed = builder.AddSystem(MatrixGain(np.eye(1, 5)))
        speed.set_name("Estimated speed")
        builder.Connect(nav.GetOutputPort("mixed_estimate"), speed.get_input_port())
        return nav.GetOutputPort("pose"), speed.get_output_port()
    if source == "truth":
        pose = builder.AddSystem(MatrixGain(np.eye(3, 10)))
        pose.set_name("True pose")
        builder.Connect(plant.GetOutputPort("state"), pose.get_input_port())
        speed = builder.AddSystem(MatrixGain(np.eye(1, 10, 3)))
        speed.set_name("True speed")
        builder.Connect(plant.GetOutputPort("state"), speed.get_input_port())
        return pose.get_output_port(), speed.get_output_port()
    speed = builder.AddSystem(MatrixGain(np.eye(1, 4)))
    speed.set_name("Odometric speed")
    builder.Connect(nav.GetOutputPort("odometry"), speed.get_input_port())
    pose = "odometry_pose" if source == "odometry" else "gyrodometry_pose"
    return nav.GetOutputPort(pose), speed.get_output_port()


def build_closed_loop_diagram(
    truth: Truth, belief: Belief, control: ControlSettings, log: bool = True
) -> LoggedDiagram:
    """Robot and sensors -> navigation -> control -> robot, with every artifact signal logged every T_N
    (``log=False`` leaves the loggers out, e.g. for a block-diagram picture). Raises ValueError naming
    the field for an input that cannot be simulated.

    ``truth`` is the simulated robot, its sensors and their faults (Truth; ``plant_time_step``: see
    DifferentialDrivePlant, 0: continuous); the navigation, the PerturbationMonitor on the wheel commands
    and the ``control`` read the ``belief`` only (Belief: the nominal robot, the sensors' data sheet, the
    calibration, the tunings and the rates)."""
    check_closed_loop_inputs(truth, belief, control)
    rates, robot = belief.rates, belief.robot
    builder = DiagramBuilder()
    handles, nav, nav_ports = add_robot_and_navigation(builder, truth, belief)
    ctrl = builder.AddSystem(build_control_diagram(control, rates, robot))
    pose, speed = localisation_ports(builder, control.localisation, nav, handles.plant)
    builder.Connect(pose, ctrl.GetInputPort("estimated_pose"))
    builder.Connect(speed, ctrl.GetInputPort("estimated_speed"))
    if control.mode == "trajectory":
        builder.Connect(nav.GetOutputPort("C1"), ctrl.GetInputPort("C1"))
        builder.Connect(nav.GetOutputPort("side_slip_angle"), ctrl.GetInputPort("side_slip_angle"))
    command = ctrl.GetOutputPort("wheel_speed_command")
    builder.Connect(command, handles.plant.GetInputPort("wheel_speed_command"))
    monitor = add_command_monitor(builder, belief, command, nav, handles)
    loggers = {}
    if log:
        ports = robot_ports(handles)
        ports.update(nav_ports)
        ports["command"] = command
        ports["perturbation"] = monitor.GetOutputPort("perturbation")
        ports["force_residual"] = monitor.GetOutputPort("force_residual")
        names = CONTROL_OUTPUTS[1:] + (TRAJECTORY_OUTPUTS if control.mode == "trajectory" else ())
        ports.update({name: ctrl.GetOutputPort(name) for name in names})
        loggers = add_loggers(builder, ports, rates.T_N)
    diagram = builder.Build()
    diagram.set_name("closed_loop")
    return LoggedDiagram(diagram=diagram, robot=handles, loggers=loggers)


def check_closed_loop_inputs(truth: Truth, belief: Belief, control: ControlSettings) -> None:
    """build_closed_loop_diagram's inputs (Python API): ValueError naming the field."""
    check_records(truth, belief)
    require_instance("belief.navigation", belief.navigation, NavigationParameters)
    belief.navigation.validate()
    rates = belief.rates
    require_instance("control", control, ControlSettings)
    for name, kind in (("follower", PathFollowerParameters), ("step_size", StepSizeParameters)):
        require_instance(f"control.{name}", getattr(control, name), kind)
        getattr(control, name).__post_init__()
    check_follower_gains(control.follower, rates.T_C, "control.follower.")
    if not hasattr(control.path, "max_abs_curvature"):
        raise ValueError(f"control.path must be a scenarios.trajectories.Path, got {control.path!r}")
    if control.mode == "trajectory" and not hasattr(control.trajectory, "num_samples"):
        raise ValueError(
            f"control.trajectory must be a Trajectory in trajectory mode, got {control.trajectory!r}"
        )
    if control.localisation not in LOCALISATION_SOURCES:
        raise ValueError(
            f"control.localisation={control.localisation!r} is unknown: allowed {list(LOCALISATION_SOURCES)}"
        )
    if control.start_time > 0.0 and truth.initial_speed != 0.0:
        raise ValueError(
            f"control.start_time={control.start_time!r} needs a robot at rest: truth.initial_speed="
            f"{truth.initial_speed!r}, allowed 0 (or start_time 0)"
        )
