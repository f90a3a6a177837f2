"""The navigation diagram alone, fed by a sensor log instead of the plant and its sensors."""

from __future__ import annotations

from pydrake.systems.framework import DiagramBuilder
from slipnav.diagrams.navigation import NAVIGATION_OUTPUTS, SensorReplay, build_navigation_diagram
from slipnav.diagrams.open_loop import add_loggers
from slipnav.systems.health.perturbation import PerturbationParameters
from slipnav.systems.health.perturbation_monitor import add_perturbation_monitor
from slipnav.systems.navigation import NavigationInitialState, NavigationParameters
from slipnav.systems.rates import SampleRates
from slipnav.systems.sensor_correction import SensorCalibration
from slipnav.systems.sensors import SensorParameters


def build_log_replay_diagram(
    params: NavigationParameters,
    rates: SampleRates,
    wheel_radius,
    track_width: float,
    accelerometers,
    gyro,
    encoders,
    initial: NavigationInitialState | None = None,
    sensors: SensorParameters | None = None,
    no_load_speed: float | None = None,
    calibration: SensorCalibration | None = None,
    currents=None,
    robot=None,
    commands=None,
    perturbation_monitor=None,
):
    """SensorReplay (the log's rows, row k at t_k = k T_N) -> navigation diagram, every navigation output
    but the covariance logged every T_N through diagrams.open_loop.add_loggers, keyed ``nav_<output>``
    as in a run (so runner.collect_navigation reads them).

    Args:
        params, rates, wheel_radius, track_width, initial, sensors, no_load_speed, calibration: as
            build_navigation_diagram (the model).
        accelerometers: (N, 4) a_t1, a_n1, a_t2, a_n2; gyro: (N,); encoders: (N, 2) wheel angles (rad);
        currents: (N, 2) the motor drivers' readings (A) or None; robot: the nominal RobotParameters, for
        the sensor checks' force reference (build_navigation_diagram).
        commands: (N, 2) the logged wheel speed commands (m/s) or None. With them (and ``robot``) a
            PerturbationMonitor (``perturbation_monitor``: its PerturbationParameters, default the
            defaults) runs as in the run: its flags are logged (``perturbation``, ``force_residual``) and
            its sideways push reaches the navigation, so that a run with a push replays bit for bit too.

    Returns:
        (diagram, loggers keyed ``nav_<output>``).
    """
    b = DiagramBuilder()
    source = b.AddSystem(SensorReplay(rates.T_N, accelerometers, gyro, encoders, currents, commands))
    source.set_name("Sensor log")
    nav = b.AddSystem(
        build_navigation_diagram(
            params, rates, wheel_radius, track_width, initial, sensors, no_load_speed, calibration, robot
        )
    )
    for name in ("accelerometers", "gyro", "encoders", "motor_currents"):
        b.Connect(source.GetOutputPort(name), nav.GetInputPort(name))
    ports = {f"nav_{name}": nav.GetOutputPort(name) for name in NAVIGATION_OUTPUTS if name != "covariance"}
    if commands is not None and robot is not None:
        monitor = add_perturbation_monitor(
            b,
            perturbation_monitor or PerturbationParameters(),
            source.GetOutputPort("wheel_speed_command"),
            nav.GetOutputPort("checked_encoders"),
            nav,
            robot,
            rates.T_N,
            source.GetOutputPort("motor_currents"),
        )
        ports["perturbation"] = monitor.GetOutputPort("perturbation")
        ports["force_residual"] = monitor.GetOutputPort("force_residual")
    loggers = add_loggers(b, ports, rates.T_N)
    diagram = b.Build()
    diagram.set_name("navigation_replay")
    return diagram, loggers
