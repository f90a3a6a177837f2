"""The navigation diagram alone, fed by logged sensor rows (SensorReplay) instead of the plant and its
sensors: a sensor log's replay, and the replay of a run's ``meas_*`` keys."""

from __future__ import annotations

import math

import numpy as np
from pydrake.systems.framework import DiagramBuilder, LeafSystem
from pydrake.systems.primitives import LogVectorOutput
from slipnav.diagrams.loggers import add_loggers
from slipnav.diagrams.navigation import NAVIGATION_OUTPUTS, build_navigation_diagram
from slipnav.systems.health.perturbation import PerturbationParameters
from slipnav.systems.health.perturbation_monitor import add_perturbation_monitor
from slipnav.systems.navigation.parameters import NavigationBelief
from slipnav.systems.robot.sensors import default_sensor_parameters


def build_log_replay_diagram(
    belief: NavigationBelief,
    accelerometers,
    gyro,
    encoders,
    currents=None,
    commands=None,
    perturbation_monitor=None,
):
    """SensorReplay (the log's rows, row k at t_k = k T_N) -> navigation diagram, every navigation output
    but the covariance logged every T_N through diagrams.loggers.add_loggers, keyed ``nav_<output>``
    as in a run (so artifact_arrays.collect_navigation reads them).

    Args:
        belief: what the navigation is given (NavigationBelief: the model), as build_navigation_diagram.
        accelerometers: (N, 4) a_t1, a_n1, a_t2, a_n2; gyro: (N,); encoders: (N, 2) wheel angles (rad);
        currents: (N, 2) the motor drivers' readings (A) or None.
        commands: (N, 2) the logged wheel speed commands (m/s) or None. With them (and ``belief.robot``) a
            PerturbationMonitor (``perturbation_monitor``: its PerturbationParameters, default the
            defaults) runs as in the run: its flags are logged (``perturbation``, ``force_residual``) and
            its sideways push reaches the navigation, so that a run with a push replays bit for bit too.

    Returns:
        (diagram, loggers keyed ``nav_<output>``).
    """
    rates, robot = belief.rates, belief.robot
    b = DiagramBuilder()
    source = b.AddSystem(SensorReplay(rates.T_N, accelerometers, gyro, encoders, currents, commands))
    source.set_name("Sensor log")
    nav = b.AddSystem(build_navigation_diagram(belief))
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
            (belief.sensors or default_sensor_parameters(robot.name)).accelerometer_sets > 0,
        )
        ports["perturbation"] = monitor.GetOutputPort("perturbation")
        ports["force_residual"] = monitor.GetOutputPort("force_residual")
    loggers = add_loggers(b, ports, rates.T_N)
    diagram = b.Build()
    diagram.set_name("navigation_replay")
    return diagram, loggers


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


def build_navigation_replay(belief: NavigationBelief, accelerometers, gyro, encoders):
    """SensorReplay -> navigation diagram of ``belief`` (NavigationBelief), with the navigation outputs
    logged every T_N.

    Returns (diagram, loggers keyed by navigation output name).
    """
    rates = belief.rates
    b = DiagramBuilder()
    replay = b.AddSystem(SensorReplay(rates.T_N, accelerometers, gyro, encoders))
    replay.set_name("Sensor replay")
    nav = b.AddSystem(build_navigation_diagram(belief))
    for name in ("accelerometers", "gyro", "encoders"):
        b.Connect(replay.GetOutputPort(name), nav.GetInputPort(name))
    loggers = {}
    for name in NAVIGATION_OUTPUTS:
        loggers[name] = LogVectorOutput(nav.GetOutputPort(name), b, rates.T_N)
        loggers[name].set_name(f"log {name}")
    diagram = b.Build()
    diagram.set_name("navigation_replay")
    return diagram, loggers
