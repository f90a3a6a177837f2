"""Gyro bias estimate from the odometry while it is trusted (an extension of Seyr & Jakubek's Fig. 3, in
the spirit of the drift learning of Gyrodometry, Indiveri et al. Algorithm 1).

The paper's EKF has no gyro bias state: while C3 S(14) hands the yaw rate to the gyro (spot turns, where
the odometry scrubs), the heading integrates the gyro's bias. Here the bias is the exponentially weighted
mean of gyro - ^O omega over the samples where the odometry rolls: no tangential slip (C1 high), driving
straight (|gyro - b| low, judged on a PT1 of past samples so that the gate does not select on the
sample's own noise), no sensor fault. The sum telescopes the encoders' quantisation: over any stretch of
straight driving its error is one count, not one count per sample. The EKF gets gyro - b.
"""

import dataclasses as dc
import math

import numpy as np
from pydrake.systems.framework import LeafSystem
from slipnav.systems.rates import pt1_step


@dc.dataclass
class GyroBiasParameters:
    """Tuning of the gyro bias estimate.

    Args:
        enabled: estimate the bias (False: the EKF gets the raw gyro, as in the paper).
        averaging_time: forgetting time of the weighted mean (s): 5 s, where the bias random walk
            (0.5 mrad/s per sqrt(s)) moves about as much as the gyro noise averaged over the trusted
            part of that time; inf: a growing mean.
        prior_time: weight of the prior b = 0, as trusted time (s): T_N (sigma_gyro / sigma_bias)^2 =
            0.002 (0.014 / 0.0035)^2 = 0.032 s, the Bayesian mean of a constant with that prior.
        straight_yaw_rate: |gyro - b| (PT1-filtered) below which the robot drives straight (rad/s):
            0.05, ~15 sigma of the filtered gyro noise; the odometry's 1-2 % scrub is then < 1 mrad/s.
        gate_time_constant: PT1 of the straightness gate (s): 0.02 (one T_C), long enough to average
            the gyro noise, short enough to close before a spot turn's first 10 ms.
        trusted_c1: C1 S(12) at or above which the odometry has no tangential slip: 0.9.
    """

    enabled: bool = True
    averaging_time: float = 5.0
    prior_time: float = 0.032
    straight_yaw_rate: float = 0.05
    gate_time_constant: float = 0.02
    trusted_c1: float = 0.9

    def __post_init__(self):
        if not isinstance(self.enabled, bool):
            raise ValueError(f"gyro_bias.enabled={self.enabled!r} is out of range: allowed true, false")
        if not self.averaging_time > 0.0:  # also rejects NaN; inf: a growing mean
            raise ValueError(
                f"gyro_bias.averaging_time={self.averaging_time!r} is out of range: allowed (0, inf] s"
            )
        for name in ("prior_time", "straight_yaw_rate", "gate_time_constant"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0.0):
                raise ValueError(f"gyro_bias.{name}={v!r} is out of range: allowed (0, inf)")
        if not (0.0 <= self.trusted_c1 <= 1.0):
            raise ValueError(f"gyro_bias.trusted_c1={self.trusted_c1!r} is out of range: allowed [0, 1]")


def gyro_bias_initial_state() -> list:
    """[weighted sum of gyro - ^O omega (rad), weighted trusted time (s), bias b (rad/s), gate PT1
    (rad/s)]."""
    return [0.0, 0.0, 0.0, 0.0]


def gyro_bias_step(state, gyro: float, odometric_omega: float, c1: float, fault: bool, p, T_N: float):
    """One T_N sample of the bias estimate; returns the next state (the bias used at this sample is
    state[2], learned from the earlier samples)."""
    total, weight, bias, gate = state
    if p.enabled and not fault and c1 >= p.trusted_c1 and abs(gate) <= p.straight_yaw_rate:
        forget = math.exp(-T_N / p.averaging_time)
        total = forget * total + (gyro - odometric_omega) * T_N
        weight = forget * weight + T_N
        new_bias = total / (weight + p.prior_time)
    else:
        new_bias = bias
    gate = pt1_step(gate, gyro - bias, p.gate_time_constant, T_N)
    return [total, weight, new_bias, gate]


class GyroBiasEstimator(LeafSystem):
    """Gyro bias learned from the odometry while it rolls straight without slip; outputs the corrected gyro.

    .. pydrake_system::

        name: GyroBiasEstimator
        input_ports:
        - gyro
        - odometry
        - C1
        - inertial_fault
        - encoder_fault
        output_ports:
        - gyro
        - bias

    - gyro: the checked gyro sample [omega] (rad/s); odometry: [^O v_t, ^O omega, v_R, v_L]; C1: the C1
      in force; inertial_fault, encoder_fault: 1 when this sample's reading was replaced (no learning).
    - gyro (out): [omega - b] for the EKF (direct feedthrough of the input, b from the state).
    - bias: [b] (rad/s, state).

    Update every T_N: gyro_bias_step.

    Args:
        params: GyroBiasParameters. T_N: navigation period (s).
    """

    def __init__(self, params: GyroBiasParameters, T_N: float):
        super().__init__()
        self._p, self._T_N = params, T_N
        self._gyro = self.DeclareVectorInputPort("gyro", 1)
        self._odo = self.DeclareVectorInputPort("odometry", 4)
        self._c1 = self.DeclareVectorInputPort("C1", 1)
        self._faults = [self.DeclareVectorInputPort(name, 1) for name in ("inertial_fault", "encoder_fault")]
        self._state = self.DeclareDiscreteState(np.array(gyro_bias_initial_state()))
        self.DeclareVectorOutputPort(
            "gyro",
            1,
            self._calc_gyro,
            prerequisites_of_calc={self.xd_ticket(), self._gyro.ticket()},
        )
        self.DeclareVectorOutputPort(
            "bias",
            1,
            lambda c, o: o.SetFromVector(c.get_discrete_state(self._state).get_value()[2:3]),
            prerequisites_of_calc={self.xd_ticket()},
        )
        self.DeclarePeriodicDiscreteUpdateEvent(T_N, 0.0, self._update)

    def _calc_gyro(self, context, output):
        bias = context.get_discrete_state(self._state).get_value()[2]
        output.SetFromVector([self._gyro.Eval(context)[0] - bias])

    def _update(self, context, discrete_state):
        fault = any(port.Eval(context)[0] > 0.5 for port in self._faults)
        state = gyro_bias_step(
            context.get_discrete_state(self._state).get_value(),
            self._gyro.Eval(context)[0],
            self._odo.Eval(context)[1],
            self._c1.Eval(context)[0],
            fault,
            self._p,
            self._T_N,
        )
        discrete_state.set_value(self._state, state)
