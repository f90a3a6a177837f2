"""Mixing of odometric and inertial estimates, Seyr & Jakubek §IV-D: C1 S(12), C2 S(13), C3 S(14) and
the mixing laws S(15)-(17), whose result is fed back into the EKF (Fig. 3).

S(17) relaxes v_n towards zero while |a_n| < b2. Rubber tyres side-slip well below b2, in proportion to
the lateral acceleration, so here v_n relaxes towards the linear-tyre value instead (lateral_velocity_model);
cornering_stiffness = inf restores the paper's S(17) exactly.
"""

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
        cornering_stiffness: K_alpha, lateral acceleration per radian of side slip in the tyres' linear
            range (m/s^2/rad), the target of S(17)'s relaxation (lateral_velocity_model). Default: Tinyphoon's
            rubber tyres, g * wheel load fraction * mu * B * C = 107 (RobotParameters.cornering_stiffness);
            rounded down to 100, the secant up to |a_n| = b2 where the relaxation acts. inf: the paper's
            S(17) (relax to zero).
    """

    a1: float = 150.0
    b1: float = 0.04
    p: float = 0.5
    a2: float = 4.0
    b2: float = 2.0
    a3: float = 60.0
    b3: float = 0.05
    q2: float = 0.99
    cornering_stiffness: float = 100.0

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
        k = self.cornering_stiffness
        if not k > 0.0:  # also rejects NaN; inf selects the paper's S(17)
            raise ValueError(f"mixing.cornering_stiffness={k!r} is out of range: allowed (0, inf] m/s^2/rad")


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


def lateral_velocity_model(v_t: float, omega: float, cornering_stiffness: float) -> float:
    """Side-slip velocity of linear tyres in a steady turn: tan(alpha) = v_n/|v_t| = -a_n/K_alpha with the
    steady lateral acceleration a_n = v_t omega (S(2) with dv_n/dt = 0); zero for K_alpha = inf.

    v_t omega, from odometry and gyro, is used rather than the EKF's a_n: it carries none of the
    accelerometers' commotion (2.0 -> 0.5 mm/s rms v_n noise on the corner's straights)."""
    return -abs(v_t) * v_t * omega / cornering_stiffness


def mix(odo, inertial, c1: float, c2: float, c3: float, previous, p: MixingParameters) -> np.ndarray:
    """S(15)-(17): the mixed estimate [v_t, v_n, omega, ^I a_t, ^I a_n].

    v_t = C1 ^O v_t + (1 - C1) ^I v_t; omega = C3 ^O omega + (1 - C3) ^I omega;
    v_n = C2 [m_k + q2 (v_n,k-1 - m_k-1)] + (1 - C2) ^I v_n: below the a_n threshold v_n relaxes towards
    the tyre model m = lateral_velocity_model(v_t, omega) (m = 0, the paper's S(17), for K_alpha = inf).

    Args:
        previous: the previous mixed estimate x_k-1 (the EKF state), for v_n,k-1 and m_k-1.
    """
    v_t = c1 * odo[0] + (1.0 - c1) * inertial[0]
    omega = c3 * odo[1] + (1.0 - c3) * inertial[2]
    model = lateral_velocity_model(v_t, omega, p.cornering_stiffness)
    model_prev = lateral_velocity_model(previous[0], previous[2], p.cornering_stiffness)
    return np.array(
        [
            v_t,
            c2 * (model + p.q2 * (previous[1] - model_prev)) + (1.0 - c2) * inertial[1],
            omega,
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

    - previous_estimate: the EKF state x_k-1 (the previous mixed estimate), for v_n,k-1 and the tyre
      model's previous value in S(17).
    - mixed_estimate: [v_t, v_n, omega, ^I a_t, ^I a_n] (direct feedthrough).
    - body_velocity: [v_t, v_n, omega] for pose integration and the side-slip angle.
    """

    def __init__(self, params: MixingParameters):
        super().__init__()
        self._p = params
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
                self._prev.Eval(context),
                self._p,
            )
        )
