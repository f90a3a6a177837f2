"""The two engines that replay a sensor log's rows through the navigation (scenarios/replay.py):

- ``plain`` (PlainReplay): the navigation and the perturbation monitor as plain sequential Python over
  the diagram's pure functions (scenarios/plain_navigation.py: NavigationLoop, PlainMonitor), row by row;
- ``diagram`` (DiagramReplay): the navigation diagram and the monitor fed by a log source system in a
  Drake Simulator (diagrams/replay.py build_log_replay_diagram).

Both give the same artifact keys bit for bit (tests/test_replay_engines.py); the plain engine takes about
a third of the diagram's time. An engine steps the rows up to a time (``advance_to``, so that the
caller shows progress and takes Ctrl-C between steps) and then gives the navigation's and the monitor's
artifact keys (``arrays``: artifact_arrays.collect_navigation, collect_perturbations).
"""

from __future__ import annotations

import math

import numpy as np
from pydrake.systems.analysis import Simulator
from slipnav.diagrams.replay import build_log_replay_diagram
from slipnav.scenarios.artifact_arrays import (
    NAVIGATION_SIGNALS,
    YAW_CALIBRATION_KEYS,
    collect_navigation,
    collect_perturbations,
)
from slipnav.scenarios.plain_navigation import PlainNavigation
from slipnav.systems.health.perturbation import FORCE_CHANNELS, PERTURBATION_CHANNELS, PerturbationParameters
from slipnav.systems.navigation.loop import LOOP_KEYS
from slipnav.systems.navigation.parameters import NavigationBelief
from slipnav.systems.navigation.yaw_calibration import calibration_parameters

REPLAY_ENGINES = ("plain", "diagram")
"""The replay engines, the default first."""


def start_replay(engine: str, belief: NavigationBelief, accelerometers, gyro, encoders, currents, commands):
    """The ``engine``'s replay (PlainReplay or DiagramReplay) of the log's rows, at its first row;
    ValueError for an unknown engine.

    Args:
        belief: what the navigation is given (NavigationBelief of the model).
        accelerometers: (N, 4); gyro: (N,); encoders: (N, 2) wheel angles (rad); currents: (N, 2) the
            motor drivers' readings (A) or None; commands: (N, 2) the wheel speed commands (m/s) or None
            (no perturbation monitor, no push).
    """
    if engine == "plain":
        return PlainReplay(belief, accelerometers, gyro, encoders, currents, commands)
    if engine == "diagram":
        return DiagramReplay(belief, accelerometers, gyro, encoders, currents, commands)
    raise ValueError(f"engine={engine!r} is unknown: allowed {', '.join(REPLAY_ENGINES)}")


class DiagramReplay:
    """The navigation diagram on the log's rows in a Drake Simulator (build_log_replay_diagram, with the
    perturbation monitor when the log has the commands)."""

    def __init__(self, belief: NavigationBelief, accelerometers, gyro, encoders, currents, commands):
        self.rows = len(gyro)
        diagram, self.loggers = build_log_replay_diagram(
            belief, accelerometers, gyro, encoders, currents, commands
        )
        self.monitored = "perturbation" in self.loggers
        self.simulator = Simulator(diagram)
        self.simulator.Initialize()

    def advance_to(self, t: float) -> None:
        """Step the rows up to time ``t`` (s, row k at k T_N)."""
        self.simulator.AdvanceTo(t)

    def arrays(self) -> dict:
        """The navigation's and the monitor's artifact keys, once every row is stepped."""
        context = self.simulator.get_context()
        logs = {key: logger.FindLog(context) for key, logger in self.loggers.items()}

        def data(key):
            d = logs[key].data()
            if d.shape[1] != self.rows:
                raise RuntimeError(f"logger {key} has {d.shape[1]} samples, the log has {self.rows} rows")
            return d.copy()  # Drake's log lives only as long as the context

        a = {}
        collect_navigation(a, data)
        collect_perturbations(a, logs, data)  # with the log's commands
        return a


_YAW = len(LOOP_KEYS)
_ENCODER_FAULT = _YAW + len(YAW_CALIBRATION_KEYS)
_FLAGS = _ENCODER_FAULT + 1
_FORCES = _FLAGS + len(PERTURBATION_CHANNELS)
_COLUMNS = _FORCES + len(FORCE_CHANNELS)
"""PlainReplay's columns: the NavigationLoop row (LOOP_KEYS), the yaw calibration's parameters, the
encoder exclusion, the monitor's flags and force residuals."""
_LOOP_COLUMN = {key: i for i, key in enumerate(LOOP_KEYS)}
_SIGNAL_KEYS = dict(NAVIGATION_SIGNALS)


class PlainReplay:
    """The navigation and the perturbation monitor (PlainNavigation; the monitor with its default
    PerturbationParameters, as build_log_replay_diagram's, when the log has the commands) stepped row by
    row. Each row records what the diagram's loggers record at t_k: the NavigationLoop row, the yaw
    calibration's parameters before the sample's update, the encoder exclusion, the monitor's flags and
    force residuals before its update."""

    def __init__(self, belief: NavigationBelief, accelerometers, gyro, encoders, currents, commands):
        n = len(gyro)
        self.T_N, self.monitored = belief.rates.T_N, commands is not None
        self.navigation = PlainNavigation(belief, PerturbationParameters() if self.monitored else None)
        self.inputs = (
            np.asarray(accelerometers, float).tolist(),
            np.asarray(gyro, float).reshape(-1).tolist(),
            np.asarray(encoders, float).tolist(),
            (np.full((n, 2), np.nan) if currents is None else np.asarray(currents, float)).tolist(),
            None if commands is None else np.asarray(commands, float).tolist(),
        )
        self.out = np.full((n, _COLUMNS), np.nan)
        self.k = 0

    def advance_to(self, t: float) -> None:
        """Step the rows up to time ``t`` (s, row k at k T_N)."""
        self._step(min(len(self.out), int(math.floor(t / self.T_N + 1e-6)) + 1))

    def _step(self, stop: int) -> None:
        """Step the rows from the next one to row ``stop`` (excluded)."""
        navigation, nav, out = self.navigation, self.navigation.nav, self.out
        acc, gyro, enc, cur, cmd = self.inputs
        for k in range(self.k, stop):
            calibration = calibration_parameters(nav.calibration)  # the outputs at t_k: before the update
            row = navigation.step(acc[k], gyro[k], enc[k], cur[k])
            if cmd is None:
                out[k, :_FLAGS] = (*row, *calibration, nav.encoder_fault)
                continue
            out[k] = (*row, *calibration, nav.encoder_fault, *navigation.flags(), *navigation.forces())
            navigation.watch(cmd[k], row, cur[k])
        self.k = max(self.k, stop)

    def arrays(self) -> dict:
        """The navigation's and the monitor's artifact keys (the rows not yet stepped first), by the
        diagram's collect_navigation and collect_perturbations from the recorded rows."""
        self._step(len(self.out))
        a = {}
        collect_navigation(a, self.data)
        collect_perturbations(a, {"perturbation", "force_residual"} if self.monitored else (), self.data)
        return a

    def data(self, name: str) -> np.ndarray:
        """The recorded samples of the diagram's logger ``name`` (its rows x samples; only the rows that
        collect_navigation reads hold values, the others NaN)."""
        out = self.out
        if name == "nav_yaw_calibration":
            return out[:, _YAW:_ENCODER_FAULT].T.copy()
        if name == "nav_encoder_fault":
            return out[:, _ENCODER_FAULT:_FLAGS].T.copy()
        if name == "perturbation":
            return out[:, _FLAGS:_FORCES].T.copy()
        if name == "force_residual":
            return out[:, _FORCES:_COLUMNS].T.copy()
        columns = [_LOOP_COLUMN[key] if key is not None else None for key in _SIGNAL_KEYS[name]]
        return np.array([out[:, i] if i is not None else np.full(len(out), np.nan) for i in columns])
