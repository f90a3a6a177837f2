"""Track speed S(18), side-slip angle S(19) and its validity function S(20), Seyr & Jakubek §IV-E."""

import dataclasses as dc
import math

from pydrake.systems.framework import LeafSystem
from slipnav.systems.ranges import out_of_range, require_in


@dc.dataclass
class SideSlipParameters:
    """Thresholds of the validity function S(20) on |v * omega| (the lateral acceleration, m/s^2).

    Args:
        c_alpha: below it alpha is forced to zero (m/s^2, >= 0): the side slip is physically tiny there
            (< 0.3 deg for Tinyphoon's tyres) and v_n is dominated by noise.
        d_alpha: above it alpha is fully valid (m/s^2, > c_alpha).
    """

    c_alpha: float = 0.5
    d_alpha: float = 1.5

    def __post_init__(self):
        require_in("sideslip.c_alpha", self.c_alpha, "[0, inf)")
        if not (math.isfinite(self.d_alpha) and self.d_alpha > self.c_alpha):
            raise out_of_range("sideslip.d_alpha", self.d_alpha, f"(c_alpha={self.c_alpha}, inf)")


def track_speed(v_t: float, v_n: float) -> float:
    """S(18): v = sqrt(v_t^2 + v_n^2) sign(v_t) (|alpha| <= pi/2 assumed)."""
    return math.copysign(math.hypot(v_t, v_n), v_t) if v_t != 0.0 else 0.0


def validity(v: float, omega: float, p: SideSlipParameters) -> float:
    """S(20): 0 below c_alpha, linear between, 1 above d_alpha, on |v omega|."""
    g = abs(v * omega)
    if g <= p.c_alpha:
        return 0.0
    if g >= p.d_alpha:
        return 1.0
    return (g - p.c_alpha) / (p.d_alpha - p.c_alpha)


def side_slip_angle(v_t: float, v_n: float, omega: float, p: SideSlipParameters):
    """S(18)-(20): (track speed v, alpha = atan(v_n/v_t) f(v, omega), f). v_t = 0 gives alpha = 0."""
    v = track_speed(v_t, v_n)
    f = validity(v, omega, p)
    if f == 0.0 or v_t == 0.0:
        return v, 0.0, f
    return v, math.atan(v_n / v_t) * f, f


class SideSlipEstimator(LeafSystem):
    """S(18)-(20) on the mixed estimate, every T_C.

    .. pydrake_system::

        name: SideSlipEstimator
        input_ports:
        - body_velocity
        output_ports:
        - track_speed
        - side_slip_angle
        - validity

    - body_velocity: mixed [v_t, v_n, omega] of the current sample (sampled at t = K*T_C).
    - track_speed, side_slip_angle, validity: v_K, alpha_K, f_K (state; from t_K on).
    """

    def __init__(self, params: SideSlipParameters, T_C: float):
        super().__init__()
        self._p = params
        self._vel = self.DeclareVectorInputPort("body_velocity", 3)
        self._v = self.DeclareDiscreteState(1)
        self._alpha = self.DeclareDiscreteState(1)
        self._f = self.DeclareDiscreteState(1)
        self.DeclareStateOutputPort("track_speed", self._v)
        self.DeclareStateOutputPort("side_slip_angle", self._alpha)
        self.DeclareStateOutputPort("validity", self._f)
        self.DeclarePeriodicDiscreteUpdateEvent(T_C, 0.0, self._update)

    def _update(self, context, discrete_state):
        v_t, v_n, omega = self._vel.Eval(context)
        v, alpha, f = side_slip_angle(v_t, v_n, omega, self._p)
        discrete_state.set_value(self._v, [v])
        discrete_state.set_value(self._alpha, [alpha])
        discrete_state.set_value(self._f, [f])
