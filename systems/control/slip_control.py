"""Slip control of Seyr & Jakubek §V: step size S(22)-(23), progress S(24) and trajectory interpolation
S(25) along a pre-planned trajectory, at T_C; plus the speed command that makes the path follower track
the interpolated reference.

How the follower uses the reference (our design, §V leaves the tracking controller open): the follower
follows the trajectory's geometric path (Indiveri's law), with speed

    u_K = delta_K v_ref(Pi_K) + k_s (s_ref(Pi_K) - s_K),

the reference speed expanded by the step size (S(25): "the progression of velocities ... is expanded or
compressed according to delta") plus a correction of the arc-length lag of the virtual target s behind
the interpolated reference point. delta < 1 slows the robot along the same path; delta > 1 catches up.

S(25) is evaluated at i = 0 only: the reference pose at Pi_K. Seyr feeds the points i = 0 .. H - 1 (a
prediction horizon) to the predictive tracker of their reference [9]; Indiveri's follower needs only the
path and the point at Pi_K, so the block has no horizon output (issue 19).
"""

import dataclasses as dc
import math

import numpy as np
from pydrake.systems.framework import LeafSystem
from slipnav.systems.navigation.mixing.weights import logsig
from slipnav.systems.ranges import out_of_range, require_flag, require_in


@dc.dataclass
class StepSizeParameters:
    """Tuning of S(22)-(23) (§V's list).

    Args:
        delta_min: minimum step size (< 1): the speed reduction under slip; 0.75. A deeper cut (0.4) brakes
            hard inside the corner and saturates the friction circle, so that the robot slides more than
            without slip control (the corner's peak side slip with and without it: docs/results.md,
            section claims).
        delta_max: maximum step size (> 1): how fast the trajectory is recovered; 1.4.
        q_delta: geometric growth factor of the step size after a reduction; 1.05 per T_C (too large
            gives the limit cycle the paper warns of).
        a4: steepness of the side-slip switch (1/rad); 150 gives a 10 %-90 % transition over 1.7 deg.
        b4: side-slip threshold (rad); 1.5 deg: react early, while braking is still cheap. False triggers
            on straights are excluded by S(20), which zeroes alpha below c_alpha.
        delta_rem: step size after overshooting the trajectory (< 1); 0.9.
        c_delta, d_delta: upper/lower thresholds on K - Pi_K (control samples) of S(23); 0.5 and -0.5.
        k_s: arc-length lag gain of the speed command (1/s); 2.
        delayed_step_size: the speed command at t_K uses delta_K-1, the step size the controller set at
            the previous control instant (its state: one T_C late). False: delta_K, computed at t_K from
            C1 and alpha in force, paces the reference at once, as S(22), (24), (25) print (x_ref at
            Pi_K + i delta_K).
        after_navigation: the control's instant t_K follows the navigation's sample k, as a program
            that runs the navigation first and then the control: S(22) reads C1_K and alpha_K of the
            batch that ends at t_K (S(12), S(19)), the follower the pose and v_t the navigation holds
            after that sample; the command reaches the robot when it does without (diagrams.closed_loop
            control_offset). False: the control reads the navigation as it stood before its sample k,
            C1_K-1 and alpha_K-1 of the previous batch (one T_C late). Trajectory mode only.
    """

    delta_min: float = 0.75
    delta_max: float = 1.4
    q_delta: float = 1.05
    a4: float = 150.0
    b4: float = math.radians(1.5)
    delta_rem: float = 0.9
    c_delta: float = 0.5
    d_delta: float = -0.5
    k_s: float = 2.0
    delayed_step_size: bool = True
    after_navigation: bool = False

    def __post_init__(self):
        for name in ("delayed_step_size", "after_navigation"):
            require_flag(f"slip_control.{name}", getattr(self, name))
        for name, allowed in (
            ("delta_min", "(0, 1)"),
            ("delta_max", "(1, 10]"),
            ("q_delta", "(1, 10]"),
            ("a4", "(0, inf)"),
            ("b4", "(0, pi/2)"),
            ("delta_rem", "(0, 1)"),
        ):
            require_in(f"slip_control.{name}", getattr(self, name), allowed)
        if not math.isfinite(self.c_delta):
            raise out_of_range("slip_control.c_delta", self.c_delta, "finite")
        require_in("slip_control.k_s", self.k_s, "[0, inf)")
        if not self.d_delta < self.c_delta:
            raise out_of_range("slip_control.d_delta", self.d_delta, f"(-inf, c_delta={self.c_delta})")


def max_step_size(lag: float, p: StepSizeParameters) -> float:
    """S(23) on lag = K - Pi_K: delta_max behind, 1 near, delta_rem ahead of the trajectory."""
    if lag > p.c_delta:
        return p.delta_max
    if lag > p.d_delta:
        return 1.0
    return p.delta_rem


def step_size(delta_prev: float, c1: float, alpha: float, lag: float, p: StepSizeParameters) -> float:
    """S(22): delta_K = min(max(delta_K-1 (delta_min + min(C1, logsig(a4(|alpha| - b4))) (q - delta_min)),
    delta_min), delta_max,K)."""
    safe = min(c1, logsig(p.a4, abs(alpha), p.b4))
    grown = delta_prev * (p.delta_min + safe * (p.q_delta - p.delta_min))
    return min(max(grown, p.delta_min), max_step_size(lag, p))


def interpolate(table: np.ndarray, index: float) -> np.ndarray:
    """S(25): ^T x(floor(i)) + (i - floor(i)) (^T x(ceil(i)) - ^T x(floor(i))), clamped to the table."""
    last = len(table) - 1
    index = min(max(index, 0.0), float(last))
    lo = int(math.floor(index))
    hi = min(lo + 1, last)
    return table[lo] + (index - lo) * (table[hi] - table[lo])


class StepSizeController(LeafSystem):
    """Step size S(22)-(23) and progress S(24) every T_C.

    .. pydrake_system::

        name: StepSizeController
        input_ports:
        - C1
        - side_slip_angle
        output_ports:
        - step_size
        - progress
        - pace

    - C1: the navigation's tangential-slip mixing parameter; side_slip_angle: alpha_K of S(19).
    - step_size: delta_K (state); progress: Pi_K (state), the position on the pre-planned trajectory.
    - pace: the step size the interpolator expands the reference's speed by at t_K: the state delta_K-1
      (``delayed_step_size``, default; then a state output port), or delta_K of S(22) computed at t_K
      from the inputs (direct feedthrough; the state between control instants), as printed.

    Update at t_K = K T_C (+ ``offset``): delta_K from delta_K-1, C1 and alpha (S(22)) bounded by S(23)
    on K - Pi_K, then Pi_K+1 = Pi_K + delta_K (S(24)). ``enabled=False`` keeps delta = 1 (Pi_K = K):
    slip control off. K counts from ``start_time`` (s, a multiple of T_C; the robot stands until then).
    ``offset`` (s, in [0, T_C)): the update's delay after t_K (StepSizeParameters.after_navigation).
    """

    def __init__(
        self,
        params: StepSizeParameters,
        T_C: float,
        enabled: bool = True,
        start_time: float = 0.0,
        offset: float = 0.0,
    ):
        super().__init__()
        self._p, self._T_C, self._enabled, self._start = params, T_C, enabled, start_time + offset
        self._c1 = self.DeclareVectorInputPort("C1", 1)
        self._alpha = self.DeclareVectorInputPort("side_slip_angle", 1)
        self._delta = self.DeclareDiscreteState([1.0])
        self._progress = self.DeclareDiscreteState([0.0])
        self.DeclareStateOutputPort("step_size", self._delta)
        self.DeclareStateOutputPort("progress", self._progress)
        if params.delayed_step_size:  # pace is the state delta_K-1: no Python call to read it
            self.DeclareStateOutputPort("pace", self._delta)
        else:
            self.DeclareVectorOutputPort("pace", 1, self._calc_pace)
        self.DeclarePeriodicDiscreteUpdateEvent(T_C, offset, self._update)

    def _control_instant(self, context) -> int | None:
        """K at a control instant t_K + offset = start + offset + K T_C, else None."""
        t = context.get_time()
        if t < self._start - 1e-9:
            return None
        K = round((t - self._start) / self._T_C)
        return K if abs(t - self._start - K * self._T_C) < 1e-9 else None

    def _next_step_size(self, context, K: int) -> float:
        """delta_K of S(22)-(23) from the state and the inputs at t_K (1 with slip control off)."""
        if not self._enabled:
            return 1.0
        progress = context.get_discrete_state(self._progress).get_value()[0]
        delta = context.get_discrete_state(self._delta).get_value()[0]
        return step_size(
            delta, self._c1.Eval(context)[0], self._alpha.Eval(context)[0], K - progress, self._p
        )

    def _calc_pace(self, context, output):  # delayed_step_size false: delta_K at t_K
        K = self._control_instant(context)
        if K is None:
            output.SetFromVector(context.get_discrete_state(self._delta).get_value())
        else:
            output.SetFromVector([self._next_step_size(context, K)])

    def _update(self, context, discrete_state):
        K = self._control_instant(context)
        if K is None:
            return  # standing still
        progress = context.get_discrete_state(self._progress).get_value()[0]
        delta = self._next_step_size(context, K)
        discrete_state.set_value(self._delta, [delta])
        discrete_state.set_value(self._progress, [progress + delta])


class TrajectoryInterpolator(LeafSystem):
    """Reference pose S(25) at Pi_K (i = 0; no horizon: there is no predictive tracker) and the follower's
    speed command.

    .. pydrake_system::

        name: TrajectoryInterpolator
        input_ports:
        - step_size
        - progress
        - virtual_target
        output_ports:
        - reference_pose
        - speed

    - step_size, progress: the StepSizeController's pace and Pi_K (read at t_K: Pi_K set at the previous
      control instant, and delta_K-1, or delta_K with ``delayed_step_size`` false).
    - virtual_target: the follower's s.
    - reference_pose: [x, y, phi] at Pi (direct feedthrough).
    - speed: u = delta v_ref(Pi) + k_s (s_ref(Pi) - s), zero once the trajectory's end is reached.

    Args:
        trajectory: scenarios.trajectories.Trajectory (sampled at T_C). params: StepSizeParameters.
    """

    def __init__(self, trajectory, params: StepSizeParameters):
        super().__init__()
        self._table = np.column_stack(
            [trajectory.x, trajectory.y, trajectory.phi, trajectory.v, trajectory.s]
        )
        self._end = float(len(self._table) - 1)
        self._k_s = params.k_s
        self._delta = self.DeclareVectorInputPort("step_size", 1)
        self._progress = self.DeclareVectorInputPort("progress", 1)
        self._s = self.DeclareVectorInputPort("virtual_target", 1)
        self.DeclareVectorOutputPort(
            "reference_pose",
            3,
            lambda c, o: o.SetFromVector(interpolate(self._table, self._pi(c))[0:3]),
            prerequisites_of_calc={self._progress.ticket()},
        )
        self.DeclareVectorOutputPort("speed", 1, self._calc_speed)

    def _pi(self, context):
        return self._progress.Eval(context)[0]

    def _calc_speed(self, context, output):
        pi = self._pi(context)
        ref = interpolate(self._table, pi)
        if pi >= self._end:
            output.SetFromVector([0.0])
            return
        u = self._delta.Eval(context)[0] * ref[3] + self._k_s * (ref[4] - self._s.Eval(context)[0])
        output.SetFromVector([max(u, 0.0)])
