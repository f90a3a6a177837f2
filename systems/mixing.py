"""Mixing of odometric and inertial estimates, Seyr & Jakubek §IV-D: C1 S(12), C2 S(13), C3 S(14) and
the mixing laws S(15)-(17), whose result is fed back into the EKF (Fig. 3)."""

import dataclasses as dc
import math

import numpy as np
from pydrake.systems.framework import LeafSystem


@dc.dataclass
class MixingParameters:
    """Tuning of the mixing parameters (rationale in the paper's spirit, §IV-D).

    Args:
        a1: C1 steepness (s/m): as steep as possible, flat enough to avoid limit cycles; 150 gives a
            10 %-90 % transition over 0.03 m/s of dv.
        b1: C1 threshold (m/s): as small as possible but above the dv produced by accelerometer bias and
            encoder quantisation (~5 mm/s per batch).
        p: PT1 pole of C1: as fast as possible without limit cycles; 0.5 halves the gap every T_C.
        a2: C2 steepness (s^2/m): 4 gives a 10 %-90 % transition over 1.1 m/s^2.
        b2: C2 threshold on |a_n| (m/s^2): above the EKF's a_n noise (commotion) at speed.
        a3: C3 steepness (s/rad): 60 gives a 10 %-90 % transition over 0.07 rad/s.
        b3: C3 threshold on |^O omega - ^I omega| (rad/s): 0.05, a few gyro noise sigmas after the EKF.
            The single-sample odometric yaw rate is quantised in steps of 0.11 rad/s (7.7 mm/s / 68 mm),
            so C3 hands part of the yaw rate to the gyro whenever the quantisation error is large; that
            costs less heading than trusting odometry through the 1-2 % scrub of spot turns against the
            felt shoes (square: fused heading error 5.8 deg with b3 = 0.5, 0.9 deg with 0.05).
        q2: geometric relaxation of v_n towards zero per T_N, S(17): as small as possible but large enough
            for consistent velocity (0.99 -> 0.2 s time constant).
    """

    a1: float = 150.0
    b1: float = 0.04
    p: float = 0.5
    a2: float = 4.0
    b2: float = 2.0
    a3: float = 60.0
    b3: float = 0.05
    q2: float = 0.99

    def __post_init__(self):
        for name in ("a1", "b1", "a2", "b2", "a3", "b3"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0.0):
                raise ValueError(f"mixing.{name}={v!r} is out of range: allowed (0, inf)")
        for name in ("p", "q2"):
            v = getattr(self, name)
            if not (math.isfinite(v) and 0.0 <= v < 1.0) or (name == "q2" and v == 0.0):
                bracket = "(0, 1)" if name == "q2" else "[0, 1)"
                raise ValueError(f"mixing.{name}={v!r} is out of range: allowed {bracket}")


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


def mixing_c2(inertial_a_n: float, p: MixingParameters) -> float:
    """S(13): C2 = logsig(a2 (|^I a_n| - b2))."""
    return logsig(p.a2, abs(inertial_a_n), p.b2)


def mixing_c3(odometric_omega: float, inertial_omega: float, p: MixingParameters) -> float:
    """S(14): C3 = logsig(a3 (|^O omega - ^I omega| - b3))."""
    return logsig(p.a3, abs(odometric_omega - inertial_omega), p.b3)


def mix(odo, inertial, c1: float, c2: float, c3: float, v_n_prev: float, q2: float) -> np.ndarray:
    """S(15)-(17): the mixed estimate [v_t, v_n, omega, ^I a_t, ^I a_n].

    v_t = C1 ^O v_t + (1 - C1) ^I v_t; omega = C3 ^O omega + (1 - C3) ^I omega;
    v_n = C2 v_n,k-1 q2 + (1 - C2) ^I v_n (relaxed to zero while |a_n| is below the threshold).
    """
    return np.array(
        [
            c1 * odo[0] + (1.0 - c1) * inertial[0],
            c2 * v_n_prev * q2 + (1.0 - c2) * inertial[1],
            c3 * odo[1] + (1.0 - c3) * inertial[2],
            inertial[3],
            inertial[4],
        ]
    )


class MixerC1(LeafSystem):
    """Mixing parameter C1 S(12): double-sided logsig of the slip detector's dv, PT1-relaxed, every T_C.

    .. pydrake_system::

        name: MixerC1
        input_ports:
        - delta_v
        output_ports:
        - C1
        - delta_v_held

    - delta_v: dv_K from the TangentialSlipDetector, sampled at t = K*T_C.
    - C1: C1_K (state); computed at t_K and used by the velocity mixer from the next sample on.
    - delta_v_held: dv_K as sampled (state), for logging.

    Args:
        params: MixingParameters. T_C: control period (s). c1_initial: C1_-1 (1 = trust odometry).
    """

    def __init__(self, params: MixingParameters, T_C: float, c1_initial: float = 1.0):
        super().__init__()
        self._p = params
        self._dv = self.DeclareVectorInputPort("delta_v", 1)
        self._c1 = self.DeclareDiscreteState([c1_initial])
        self._dv_held = self.DeclareDiscreteState(1)
        self.DeclareStateOutputPort("C1", self._c1)
        self.DeclareStateOutputPort("delta_v_held", self._dv_held)
        self.DeclarePeriodicDiscreteUpdateEvent(T_C, 0.0, self._update)

    def _update(self, context, discrete_state):
        dv = self._dv.Eval(context)[0]
        c1 = context.get_discrete_state(self._c1).get_value()[0]
        discrete_state.set_value(self._c1, [mixing_c1(c1, dv, self._p)])
        discrete_state.set_value(self._dv_held, [dv])


class MixerC2C3(LeafSystem):
    """Mixing parameters C2 S(13) (lateral acceleration) and C3 S(14) (yaw-rate disagreement), at T_N.

    .. pydrake_system::

        name: MixerC2C3
        input_ports:
        - inertial_estimate
        - odometry
        output_ports:
        - C2_C3

    Memoryless (direct feedthrough): evaluated on each T_N sample's EKF estimate and odometry.
    """

    def __init__(self, params: MixingParameters):
        super().__init__()
        self._p = params
        self._inertial = self.DeclareVectorInputPort("inertial_estimate", 5)
        self._odo = self.DeclareVectorInputPort("odometry", 4)
        self.DeclareVectorOutputPort("C2_C3", 2, self._calc)

    def _calc(self, context, output):
        inertial = self._inertial.Eval(context)
        odo = self._odo.Eval(context)
        output.SetFromVector([mixing_c2(inertial[4], self._p), mixing_c3(odo[1], inertial[2], self._p)])


class VelocityMixer(LeafSystem):
    """Velocity mixer S(15)-(17); its output is the navigation estimate and the EKF's next state.

    .. pydrake_system::

        name: VelocityMixer
        input_ports:
        - odometry
        - inertial_estimate
        - C1
        - C2_C3
        - previous_estimate
        output_ports:
        - mixed_estimate
        - body_velocity

    - previous_estimate: the EKF state x_k-1 (the previous mixed estimate), for v_n,k-1 in S(17).
    - mixed_estimate: [v_t, v_n, omega, ^I a_t, ^I a_n] (direct feedthrough).
    - body_velocity: [v_t, v_n, omega] for pose integration and the side-slip angle.
    """

    def __init__(self, params: MixingParameters):
        super().__init__()
        self._q2 = params.q2
        self._odo = self.DeclareVectorInputPort("odometry", 4)
        self._inertial = self.DeclareVectorInputPort("inertial_estimate", 5)
        self._c1 = self.DeclareVectorInputPort("C1", 1)
        self._c23 = self.DeclareVectorInputPort("C2_C3", 2)
        self._prev = self.DeclareVectorInputPort("previous_estimate", 5)
        self._mixed = self.DeclareVectorOutputPort("mixed_estimate", 5, self._calc)
        self.DeclareVectorOutputPort(
            "body_velocity", 3, lambda c, o: o.SetFromVector(self._mixed.Eval(c)[0:3])
        )

    def _calc(self, context, output):
        c2, c3 = self._c23.Eval(context)
        output.SetFromVector(
            mix(
                self._odo.Eval(context),
                self._inertial.Eval(context),
                self._c1.Eval(context)[0],
                c2,
                c3,
                self._prev.Eval(context)[1],
                self._q2,
            )
        )
