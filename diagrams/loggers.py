"""A built loop and its loggers: every logged signal gathered into one VectorLogSink on the T_N grid
(add_loggers), read back per signal (SignalLog), and the robot's logged ports (robot_ports)."""

from __future__ import annotations

import dataclasses as dc

import numpy as np
from pydrake.systems.framework import Diagram, DiagramBuilder
from pydrake.systems.primitives import LogVectorOutput, Multiplexer
from slipnav.diagrams.robot import RobotHandles


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
