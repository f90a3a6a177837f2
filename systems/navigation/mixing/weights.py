"""The mixing parameters of Seyr & Jakubek §IV-D: C1 S(12) from the slip detector's speed difference
(every T_C), C2 S(13) from the lateral acceleration and C3 S(14) from the yaw-rate disagreement (every
T_N), the logsig switches and filters behind them, and their Drake blocks MixerC1 and MixerC2C3.
"""

import math

from pydrake.systems.framework import LeafSystem
from slipnav.systems.navigation.mixing.parameters import MixingParameters
from slipnav.systems.rates import pt1_step


def logsig(a: float, x: float, b: float) -> float:
    """1 / (1 + exp(a (x - b))), the switch of S(12)-(14) (1: odometric, 0: inertial); overflow-safe."""
    z = a * (x - b)
    if z > 0:
        e = math.exp(-z)
        return e / (1.0 + e)
    return 1.0 / (1.0 + math.exp(z))


def mixing_c1(c1_prev: float, delta_v: float, p: MixingParameters) -> float:
    """S(12): C1_K = p C1_K-1 + (1 - p) logsig(a1 (|dv_K| - b1))."""
    return p.p * c1_prev + (1.0 - p.p) * logsig(p.a1, abs(delta_v), p.b1)


def accumulate_delta_v(accumulated: float, delta_v: float, p: MixingParameters) -> tuple[float, float]:
    """Leaky sum of S(11)'s batch speed differences, A_K = dv_memory A_K-1 + dv_K, and the value that
    S(12)'s logsig sees instead of |dv_K|: max(|dv_K|, |A_K|) (|dv_K| alone for dv_memory = 0, the paper).

    Returns:
        (A_K, max(|dv_K|, |A_K|))
    """
    accumulated = p.dv_memory * accumulated + delta_v
    return accumulated, max(abs(delta_v), abs(accumulated))


def mixer_c1_step(c1_prev: float, accumulated: float, delta_v: float, p: MixingParameters):
    """One T_C update of the C1 mixer: (C1_K, A_K) from S(11)'s dv_K (accumulate_delta_v, mixing_c1).
    A NaN dv_K (every sample of the batch failed a sensor check, slip_detector_delta_v) is no evidence:
    C1 and A hold. Reading it as dv = 0 would hand v_t back to the odometry whenever S(11) is blind (an
    encoder excluded in a braking slide: open square, 4.5 x the fault-free error).

    Returns:
        (C1_K, A_K)
    """
    if math.isnan(delta_v):
        return c1_prev, accumulated
    accumulated, evidence = accumulate_delta_v(accumulated, delta_v, p)
    return mixing_c1(c1_prev, evidence, p), accumulated


def mixing_c2(inertial_a_n: float, p: MixingParameters) -> float:
    """S(13): C2 = logsig(a2 (|^I a_n| - b2))."""
    return logsig(p.a2, abs(inertial_a_n), p.b2)


def c3_residual(
    previous: float, odometric_omega: float, inertial_omega: float, p: MixingParameters, T_N: float
):
    """^O omega - ^I omega, PT1-filtered with c3_residual_time_constant (0: this sample's, as in S(14))."""
    return pt1_step(previous, odometric_omega - inertial_omega, p.c3_residual_time_constant, T_N)


def c3_turn_rate(previous: float, inertial_omega: float, p: MixingParameters, T_N: float) -> float:
    """^I omega, PT1-filtered with c3_residual_time_constant: the turn rate mixing_c3 tests."""
    return pt1_step(previous, inertial_omega, p.c3_residual_time_constant, T_N)


def mixing_c3(residual: float, p: MixingParameters, turn_rate: float = 0.0, odometry_share: float = 1.0):
    """S(14): C3 = logsig(a3 (|^O omega - ^I omega| - b3)), on the (filtered) residual of c3_residual;
    in a turn (|turn_rate| above gyro_turn_rate, c3_turn_rate) times logsig(a3 (|turn_rate| -
    gyro_turn_rate)), which hands the turn to the gyro; times ``odometry_share`` in [0, 1], the share
    the online calibration's covariance gives the odometric yaw rate where the two agree
    (systems/navigation/calibrated_signals.py, odometric_yaw_share; 1: S(14) alone)."""
    c3 = logsig(p.a3, abs(residual), p.b3) * odometry_share
    if math.isinf(p.gyro_turn_rate):
        return c3
    return c3 * logsig(p.a3, abs(turn_rate), p.gyro_turn_rate)


class MixerC1(LeafSystem):
    """Mixing parameter C1 S(12): double-sided logsig of the slip detector's dv (or of its leaky sum over
    the recent batches, accumulate_delta_v, when larger), PT1-relaxed, every T_C.

    .. pydrake_system::

        name: MixerC1
        input_ports:
        - delta_v
        output_ports:
        - C1
        - delta_v_held
        - delta_v_accumulated

    - delta_v: dv_K from the TangentialSlipDetector, sampled at t = K*T_C; NaN (a batch with no usable
      sample) holds C1 and A_K (mixer_c1_step).
    - C1: C1_K (state); computed at t_K and used by the velocity mixer from the next sample on.
    - delta_v_held: dv_K as sampled (state), for logging.
    - delta_v_accumulated: A_K = dv_memory A_K-1 + dv_K (state).

    Args:
        params: MixingParameters. T_C: control period (s). c1_initial: C1_-1 (1 = trust odometry).
    """

    def __init__(self, params: MixingParameters, T_C: float, c1_initial: float = 1.0):
        super().__init__()
        self._p = params
        self._dv = self.DeclareVectorInputPort("delta_v", 1)
        self._c1 = self.DeclareDiscreteState([c1_initial])
        self._dv_held = self.DeclareDiscreteState(1)
        self._dv_sum = self.DeclareDiscreteState(1)
        self.DeclareStateOutputPort("C1", self._c1)
        self.DeclareStateOutputPort("delta_v_held", self._dv_held)
        self.DeclareStateOutputPort("delta_v_accumulated", self._dv_sum)
        self.DeclarePeriodicDiscreteUpdateEvent(T_C, 0.0, self._update)

    def _update(self, context, discrete_state):
        dv = self._dv.Eval(context)[0]
        c1 = context.get_discrete_state(self._c1).get_value()[0]
        dv_sum = context.get_discrete_state(self._dv_sum).get_value()[0]
        c1, dv_sum = mixer_c1_step(c1, dv_sum, dv, self._p)
        discrete_state.set_value(self._c1, [c1])
        discrete_state.set_value(self._dv_held, [dv])
        discrete_state.set_value(self._dv_sum, [dv_sum])


C2C3_STEP_LAYOUT = (("C2_C3", 2), ("C3_filters", 2))
"""MixerC2C3's ``step`` output, in order: (name, size); diagrams/split.py slices it."""


class MixerC2C3(LeafSystem):
    """Mixing parameters C2 S(13) (lateral acceleration) and C3 S(14) (yaw-rate disagreement), at T_N.

    .. pydrake_system::

        name: MixerC2C3
        input_ports:
        - inertial_estimate
        - odometry
        - odometry_share
        output_ports:
        - step

    - step (direct feedthrough), in C2C3_STEP_LAYOUT's order: C2_C3, [C2, C3] of this sample's EKF
      estimate and odometry (C3 of the filters below); C3_filters, [^O omega - ^I omega, ^I omega], each
      PT1-filtered up to this sample (c3_residual, c3_turn_rate). One vector, one Python call per sample;
      the navigation diagram slices it with a Demultiplexer (diagrams/split.py).
    - odometry_share (optional input): the odometric yaw rate's share in the mix (mixing_c3's
      odometry_share; unconnected: 1, S(14) alone).

    Update every T_N: the filters (state).

    Args:
        params: MixingParameters. T_N: navigation period (s).
    """

    def __init__(self, params: MixingParameters, T_N: float):
        super().__init__()
        self._p, self._T_N = params, T_N
        self._inertial = self.DeclareVectorInputPort("inertial_estimate", 5)
        self._odo = self.DeclareVectorInputPort("odometry", 4)
        self._share = self.DeclareVectorInputPort("odometry_share", 1)
        self._filters = self.DeclareDiscreteState(2)
        prereq = {self.xd_ticket(), self._inertial.ticket(), self._odo.ticket(), self._share.ticket()}
        self._step = self.DeclareVectorOutputPort("step", 4, self._calc, prerequisites_of_calc=prereq)
        self.DeclarePeriodicDiscreteUpdateEvent(T_N, 0.0, self._update)

    def _calc(self, context, output):
        previous_residual, previous_turn = context.get_discrete_state(self._filters).get_value().tolist()
        inertial = self._inertial.Eval(context).tolist()
        omega_o = float(self._odo.Eval(context)[1])
        residual = c3_residual(previous_residual, omega_o, inertial[2], self._p, self._T_N)
        turn = c3_turn_rate(previous_turn, inertial[2], self._p, self._T_N)
        share = float(self._share.Eval(context)[0]) if self._share.HasValue(context) else 1.0
        c3 = mixing_c3(residual, self._p, turn, share)
        output.SetFromVector([mixing_c2(inertial[4], self._p), c3, residual, turn])

    def _update(self, context, discrete_state):
        discrete_state.set_value(self._filters, self._step.Eval(context)[2:4])
