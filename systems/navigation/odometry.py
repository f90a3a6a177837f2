"""Wheel odometry S(10) of Seyr & Jakubek §IV-B from quantised encoder angles."""

import math

import numpy as np
from pydrake.systems.framework import LeafSystem
from slipnav.systems.ranges import require_in


def odometry(v_R: float, v_L: float, track_width: float):
    """S(10): v_t = (v_R + v_L)/2, omega = (v_R - v_L)/b (b = track_width, full wheel distance)."""
    return 0.5 * (v_R + v_L), (v_R - v_L) / track_width


def wheel_radii(wheel_radius) -> tuple[float, float]:
    """(r_R, r_L) of a wheel radius given as one number (both wheels) or a pair (right, left), in m."""
    if isinstance(wheel_radius, (tuple, list, np.ndarray)):
        r_R, r_L = (float(r) for r in wheel_radius)
    else:
        r_R = r_L = float(wheel_radius)
    for name, r in (("wheel_radius (right)", r_R), ("wheel_radius (left)", r_L)):
        require_in(name, r, "(0, inf) m")
    return r_R, r_L


def odometry_step(state, encoders, wheel_radius, track_width: float, T_N: float):
    """One sample of encoder differencing + S(10).

    Args:
        wheel_radius: one radius for both wheels, or the pair (r_R, r_L) of a calibrated model (m).
        state: [theta_R_prev, theta_L_prev, samples_since_valid, v_t, omega, v_R, v_L]; theta_prev NaN
            means "no reading yet".
        encoders: [theta_R, theta_L] (rad); a non-finite reading is skipped (the counter keeps counting, so
            the next valid difference spans the gap).

    Returns:
        (next state, output [v_t, omega, v_R, v_L], fault 0/1)
    """
    theta_R, theta_L = encoders
    prev_R, prev_L, gap, v_t, omega, v_R, v_L = state
    if not (math.isfinite(theta_R) and math.isfinite(theta_L)):
        return [prev_R, prev_L, gap + 1.0, v_t, omega, v_R, v_L], [v_t, omega, v_R, v_L], 1.0
    if math.isfinite(prev_R):
        dt = (gap + 1.0) * T_N
        r_R, r_L = wheel_radius if isinstance(wheel_radius, tuple) else (wheel_radius, wheel_radius)
        v_R = r_R * (theta_R - prev_R) / dt
        v_L = r_L * (theta_L - prev_L) / dt
        v_t, omega = odometry(v_R, v_L, track_width)
    return [theta_R, theta_L, 0.0, v_t, omega, v_R, v_L], [v_t, omega, v_R, v_L], 0.0


ODOMETRY_STEP_LAYOUT = (("state", 7), ("odometry", 4), ("fault", 1))
"""The Odometry block's ``step`` output, in order: (name, size); diagrams/split.py slices it."""


class Odometry(LeafSystem):
    """Wheel speeds from encoder differences and S(10), every T_N.

    .. pydrake_system::

        name: Odometry
        input_ports:
        - encoders
        output_ports:
        - step

    - encoders: quantised wheel angles [theta_R, theta_L] (rad).
    - step (direct feedthrough), in ODOMETRY_STEP_LAYOUT's order: the next state; odometry
      [^O v_t, ^O omega, v_R, v_L] of the current sample; fault: 1 when the current encoder sample is not
      finite (the previous output is held). One vector, one Python call per sample; the navigation
      diagram slices it with a Demultiplexer (diagrams/split.py).

    Args:
        wheel_radius, track_width: calibrated geometry (m); wheel_radius one number for both wheels or
            the pair (r_R, r_L).
        T_N: navigation period (s).
        initial_speed: v_t output before the first difference is available (m/s).
    """

    def __init__(self, wheel_radius, track_width: float, T_N: float, initial_speed: float = 0.0):
        super().__init__()
        r_R, r_L = wheel_radii(wheel_radius)
        self._r = (r_R, r_L) if r_R != r_L else r_R
        self._b, self._T_N = track_width, T_N
        self._enc = self.DeclareVectorInputPort("encoders", 2)
        v0 = float(initial_speed)
        self._state = self.DeclareDiscreteState(np.array([np.nan, np.nan, 0.0, v0, 0.0, v0, v0]))
        prereq = {self.xd_ticket(), self._enc.ticket()}
        size = sum(n for _, n in ODOMETRY_STEP_LAYOUT)
        self._step = self.DeclareVectorOutputPort("step", size, self._calc_step, prerequisites_of_calc=prereq)
        self.DeclarePeriodicDiscreteUpdateEvent(T_N, 0.0, self._update)

    def _calc_step(self, context, output):
        state, out, fault = odometry_step(
            context.get_discrete_state(self._state).get_value().tolist(),
            self._enc.Eval(context).tolist(),
            self._r,
            self._b,
            self._T_N,
        )
        output.SetFromVector([*state, *out, fault])

    def _update(self, context, discrete_state):
        discrete_state.set_value(self._state, self._step.Eval(context)[0:7])
