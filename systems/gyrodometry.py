"""Gyrodometry (Indiveri, Nüchter & Lingemann §IV-B, Algorithm 1; after Solda et al. and Borenstein):
heading from the gyro while the odometry reports a rotation or the gyro disagrees, otherwise from the
odometry while the gyro drift e is learned; position by dead reckoning of the odometric speed."""

import dataclasses as dc
import math

import numpy as np
from pydrake.systems.framework import LeafSystem


@dc.dataclass
class GyrodometryParameters:
    """Thresholds of Algorithm 1, expressed as rates (multiplied by T_N to compare per-sample increments).

    Args:
        c1: |odometric yaw rate| above which the gyro is used (rad/s): 0.05 rad/s, above the odometric
            noise of a robot driving straight.
        c2: |gyro rate - drift| above which the gyro is used (rad/s): 0.1 rad/s, ~7 gyro noise sigmas /
            sqrt(N) is not needed at 2 ms, so a conservative multiple of the bias.
        drift_rate: lambda of the drift learning e <- lambda e + (1 - lambda)(d_gyro - d_odo); 0.999 per
            T_N averages over ~2 s.
    """

    c1: float = 0.05
    c2: float = 0.1
    drift_rate: float = 0.999

    def __post_init__(self):
        for name in ("c1", "c2"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0.0):
                raise ValueError(f"gyrodometry.{name}={v!r} is out of range: allowed (0, inf)")
        if not (0.0 <= self.drift_rate < 1.0):
            raise ValueError(f"gyrodometry.drift_rate={self.drift_rate!r} is out of range: allowed [0, 1)")


def gyrodometry_step(
    state,
    odometric_v_t: float,
    odometric_omega: float,
    gyro_omega: float,
    p: GyrodometryParameters,
    T_N: float,
):
    """One step of Algorithm 1 plus S(21) with v_n = 0. state = [x, y, theta, e] (e per sample, rad)."""
    x, y, theta, e = state
    c, s = math.cos(theta), math.sin(theta)
    x += odometric_v_t * c * T_N
    y += odometric_v_t * s * T_N
    d_odo = odometric_omega * T_N
    d_gyro = gyro_omega * T_N
    if abs(d_odo) > p.c1 * T_N or abs(d_gyro - e) > p.c2 * T_N:
        theta += d_gyro - e
    else:
        e = p.drift_rate * e + (1.0 - p.drift_rate) * (d_gyro - d_odo)
        theta += d_odo
    return [x, y, theta, e]


class Gyrodometry(LeafSystem):
    """Gyrodometry baseline (Indiveri Algorithm 1) every T_N.

    .. pydrake_system::

        name: Gyrodometry
        input_ports:
        - odometry
        - gyro
        output_ports:
        - pose
        - drift

    - odometry: [^O v_t, ^O omega, v_R, v_L]; gyro: checked [omega].
    - pose: [x, y, theta] (state); drift: learned gyro drift e (rad per sample).
    """

    def __init__(self, params: GyrodometryParameters, T_N: float, initial_pose=(0.0, 0.0, 0.0)):
        super().__init__()
        self._p, self._T_N = params, T_N
        self._odo = self.DeclareVectorInputPort("odometry", 4)
        self._gyro = self.DeclareVectorInputPort("gyro", 1)
        self._pose = self.DeclareDiscreteState(np.asarray(initial_pose, float))
        self._drift = self.DeclareDiscreteState(1)
        self.DeclareStateOutputPort("pose", self._pose)
        self.DeclareStateOutputPort("drift", self._drift)
        self.DeclarePeriodicDiscreteUpdateEvent(T_N, 0.0, self._update)

    def _update(self, context, discrete_state):
        odo = self._odo.Eval(context)
        state = [
            *context.get_discrete_state(self._pose).get_value(),
            context.get_discrete_state(self._drift).get_value()[0],
        ]
        new = gyrodometry_step(state, odo[0], odo[1], self._gyro.Eval(context)[0], self._p, self._T_N)
        discrete_state.set_value(self._pose, new[0:3])
        discrete_state.set_value(self._drift, new[3:4])
