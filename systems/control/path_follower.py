"""Lyapunov path follower with a virtual target (Indiveri, Nüchter & Lingemann §III, after Soetanto,
Lapierre & Pascoal), the wheel-speed bounded speed law I(24) and a curvature-preserving saturator.

Notation: Indiveri's b is half the wheel distance; here ``half_track = track_width / 2``.

Which speed u (ambiguous in the print). The paper writes one symbol u for the robot's linear speed of
I(3) (from the velocities of wheels "assumed to roll perfectly"), the speed of I(11)-(12), the u of the
law I(15)-(16), the u of the commands I(18)-(19) and the u that I(24) chooses. On its kinematic unicycle
(ideal actuators, §I) they are one signal. On a robot whose speed v lags the command u they part, and
the print does not say which of them I(15)-(16) read. Here I(15)-(16) read the robot's speed (the
localisation's v_t) and I(18)-(19) the command u of I(24), in both modes: only then does I(17), the
derivative of V1 along I(11)-(13), hold. With the command u in I(15)-(16) as well, dV1/dt gains
(v - u) (s1 cos theta + y1 sin theta) plus a heading term through delta_dot: a robot slower than u lets
the virtual target lead (s1 < 0), V1 grows, and I(24)'s switch on V1 = epsilon becomes a sliding
surface, crossed every few T_C (Kurt3D: V_m/2 <-> V_m, the robot held near V_m/2;
tests/test_analysis.py). ``follower.use_estimated_speed = false`` runs that single-u reading.

Sign of the approach angle: with y1 positive to the left of the path (I(12): dy1/dt = ... + u sin theta),
assumption iii) of I(14), y1 u sin(delta) <= 0, holds for delta = -sign(u) k3 tanh(y1); the paper's
printed "sign(u) k3 tanh(y1)" implies the opposite orientation of y1. We use the form that satisfies iii).
"""

import dataclasses as dc
import math

from pydrake.systems.framework import LeafSystem
from slipnav.systems.ranges import require_flag, require_in


@dc.dataclass
class PathFollowerParameters:
    """Gains of I(14)-(16).

    Args:
        gamma: weight of the heading error in V1 of I(14); 0.5.
        k1: virtual-target gain of I(16) (1/s); 2.
        k2: heading-error gain of I(15) (1/s); 3.
        k3: approach-angle amplitude of delta (rad); 0.5 (~29 deg approach from far away).
            Linearised on a straight line (y1' = u theta, theta' = -(k3 u + k2) theta - (gamma u + k2 k3) y1)
            omega_n = 3.7 rad/s, zeta = 0.67 at u = 4 m/s; gamma = 2, k3 = 0.8 (zeta 0.48) makes Kurt3D
            weave at V_m with the T_C hold and the 100 Hz speed loop in the loop.
        epsilon: speed-law threshold on V1 of I(24) (m^2); 0.05, tuned as the paper suggests by watching
            the wheel speeds: a smaller epsilon lets the navigation noise hold V1 above it much of the
            time, and each crossing switches u between V_m/2 and full speed, which slows the run (the long
            path's time against the constant law: docs/results.md, section claims).
        use_estimated_speed: I(15)-(16) read the robot's speed (the localisation's v_t), the speed of
            I(11)-(12), under which I(17) holds (module docstring); false: the command u of I(24), the
            same u as I(18)-(19) (the print's one symbol read as one signal).
        delayed_speed_law: I(24) at t_K reads V1 of the follower's previous update (t_K-1, one T_C
            late). False: V1 of the pose and virtual target of t_K, the instant whose errors the commands
            act on, as I(24) prints u(t) of V1(t).
    """

    gamma: float = 0.5
    k1: float = 2.0
    k2: float = 3.0
    k3: float = 0.5
    epsilon: float = 0.05
    use_estimated_speed: bool = True
    delayed_speed_law: bool = True

    def __post_init__(self):
        for name in ("gamma", "k1", "k2", "epsilon"):
            require_in(f"follower.{name}", getattr(self, name), "(0, inf)")
        for name in ("use_estimated_speed", "delayed_speed_law"):
            require_flag(f"follower.{name}", getattr(self, name))
        require_in("follower.k3", self.k3, "[0, pi/2)")


def wrap_angle(a: float) -> float:
    return (a + math.pi) % (2.0 * math.pi) - math.pi


def frenet_errors(pose, path_pose):
    """(s1, y1, theta): the robot's position in the Serret-Frenet frame at the path point, and its heading
    relative to the path tangent (Indiveri Fig. 3)."""
    x, y, heading = pose
    xp, yp, phip = path_pose
    c, s = math.cos(phip), math.sin(phip)
    dx, dy = x - xp, y - yp
    return c * dx + s * dy, -s * dx + c * dy, wrap_angle(heading - phip)


def approach_angle(y1, u: float, k3: float, ops=math):
    """delta(y1, u) = -sign(u) k3 tanh(y1) and d delta / d y1 (``ops``: math or pydrake.math)."""
    sgn = math.copysign(1.0, u) if u != 0.0 else 0.0
    t = ops.tanh(y1)
    return -sgn * k3 * t, -sgn * k3 * (1.0 - t * t)


def lyapunov_value(s1: float, y1: float, theta: float, delta: float, gamma: float) -> float:
    """I(14): V1 = (s1^2 + y1^2)/2 + (theta - delta)^2 / (2 gamma)."""
    return 0.5 * (s1 * s1 + y1 * y1) + (theta - delta) ** 2 / (2.0 * gamma)


def path_following_law(s1, y1, theta, kappa, u, p: PathFollowerParameters, ops=math):
    """I(15)-(16): (s_dot, theta_dot, V1) for the errors, reference curvature kappa and speed u.

    ``ops`` supplies sin, cos, tanh: ``math`` for floats, ``pydrake.math`` for AutoDiff (Linearize).
    """
    delta, ddelta_dy1 = approach_angle(y1, u, p.k3, ops)
    s_dot = u * ops.cos(theta) + p.k1 * s1
    y1_dot = -kappa * s_dot * s1 + u * ops.sin(theta)
    e = theta - delta
    # (sin theta - sin delta)/(theta - delta) -> cos(delta) as theta -> delta.
    sinc = ops.cos(delta) if abs(float(_value(e))) < 1e-9 else (ops.sin(theta) - ops.sin(delta)) / e
    theta_dot = ddelta_dy1 * y1_dot - p.gamma * y1 * u * sinc - p.k2 * e
    return s_dot, theta_dot, lyapunov_value(s1, y1, theta, delta, p.gamma)


def _value(x):
    """The float value of a float or an AutoDiffXd."""
    return x.value() if hasattr(x, "value") else x


def wheel_commands(u: float, kappa: float, s_dot: float, theta_dot: float, half_track: float):
    """I(18)-(19): v_r = u + b (kappa s_dot + theta_dot), v_l = u - b (...) with b = half_track."""
    w = kappa * s_dot + theta_dot
    return u + half_track * w, u - half_track * w


def bounded_speed(V1: float, kappa: float, V_m: float, half_track: float, epsilon: float) -> float:
    """I(24): u = V_m/2 while V1 >= epsilon, else V_m / (1 + b |kappa_r(s)|)."""
    if V1 >= epsilon:
        return 0.5 * V_m
    return V_m / (1.0 + half_track * abs(kappa))


def speed_law(pose, s: float, path, p: PathFollowerParameters, V_m: float, half_track: float):
    """I(24) at a control instant: (u, V1) with V1 of I(14) from ``pose`` and the virtual target ``s`` of
    the same instant (the errors I(15)-(16) act on at that instant), delta for u > 0 (I(24)'s u is
    positive): I(24) as printed, u(t) of V1(t), sampled at T_C."""
    s1, y1, theta = frenet_errors(pose, path.pose(s))
    delta, _ = approach_angle(y1, 1.0, p.k3)
    V1 = lyapunov_value(s1, y1, theta, delta, p.gamma)
    return bounded_speed(V1, path.curvature(s), V_m, half_track, p.epsilon), V1


def saturate_wheel_speeds(v_R: float, v_L: float, V_m: float):
    """Scale both commands by V_m / max(|v_R|, |v_L|) when that exceeds V_m: the commanded curvature
    (v_R - v_L)/(v_R + v_L) is preserved (I(5)), only the speed is reduced."""
    peak = max(abs(v_R), abs(v_L))
    if peak <= V_m:
        return v_R, v_L
    scale = V_m / peak
    return v_R * scale, v_L * scale


def check_path_curvature(max_abs_curvature: float, track_width: float) -> None:
    """I(7): |kappa_r| < 1/b (b = track_width/2), else the bounded speed law cannot hold the path."""
    limit = 2.0 / track_width
    if not max_abs_curvature < limit:
        raise ValueError(
            f"path curvature max |kappa|={max_abs_curvature:.4g} 1/m violates I(7): allowed "
            f"|kappa| < 1/b = 2/track_width = {limit:.4g} 1/m"
        )


FollowerState = ["s", "cmd_R", "cmd_L", "V1", "s1", "y1", "theta"]


class LyapunovPathFollower(LeafSystem):
    """Indiveri I(11)-(16), (18)-(19) with the virtual target s integrated every T_C.

    .. pydrake_system::

        name: LyapunovPathFollower
        input_ports:
        - estimated_pose
        - estimated_speed
        - speed
        output_ports:
        - wheel_speed_command
        - lyapunov_value
        - virtual_target
        - frenet_errors
        - path_point

    - estimated_pose: navigation pose [x, y, phi] (never the true one).
    - estimated_speed: the localisation's v_t (m/s), the robot's speed: the u of I(15)-(16).
    - speed: commanded u of I(24) (or of the trajectory mode), the u of I(18)-(19).
    - wheel_speed_command: [v_R, v_L] of I(18)-(19), held over T_C (before saturation).
    - lyapunov_value: V1 of I(14) at the last update. virtual_target: s. frenet_errors: [s1, y1, theta].
    - path_point: [x, y, phi] of the path at s (the virtual target's pose).

    Update every T_C from start_time on (before it nothing changes): errors to the path point at s,
    I(15)-(16), s <- s + s_dot T_C. When s reaches the end of the path the commands are zero (the path
    is complete).

    Args:
        params: PathFollowerParameters. path: scenarios.trajectories.Path-like (pose(s), curvature(s),
        length). track_width: m. T_C: s. s0: initial virtual target. start_time: the first update (s, a
        multiple of T_C): until then the commands are zero and the robot stands (standstill_time).
        offset: the updates' delay after each t_K (s, in [0, T_C); StepSizeParameters.after_navigation).
    """

    def __init__(
        self,
        params: PathFollowerParameters,
        path,
        track_width: float,
        T_C: float,
        s0=0.0,
        start_time: float = 0.0,
        offset: float = 0.0,
    ):
        super().__init__()
        check_path_curvature(path.max_abs_curvature, track_width)
        self._p, self._path, self._half, self._T_C = params, path, 0.5 * track_width, T_C
        self._pose = self.DeclareVectorInputPort("estimated_pose", 3)
        self._measured_speed = self.DeclareVectorInputPort("estimated_speed", 1)
        self._speed = self.DeclareVectorInputPort("speed", 1)
        # State groups in FollowerState order; V1 = +inf until the first update (I(24) starts at V_m/2).
        self._s = self.DeclareDiscreteState([s0])
        self._command = self.DeclareDiscreteState(2)
        self._V1 = self.DeclareDiscreteState([math.inf])
        self._errors = self.DeclareDiscreteState(3)
        self.DeclareStateOutputPort("wheel_speed_command", self._command)
        self.DeclareStateOutputPort("lyapunov_value", self._V1)
        self.DeclareStateOutputPort("virtual_target", self._s)
        self.DeclareStateOutputPort("frenet_errors", self._errors)
        self.DeclareVectorOutputPort(
            "path_point",
            3,
            lambda c, o: o.SetFromVector(path.pose(c.get_discrete_state(self._s).get_value()[0])),
            prerequisites_of_calc={self.xd_ticket()},
        )
        self._start = start_time
        self.DeclarePeriodicDiscreteUpdateEvent(T_C, offset, self._update)

    def _update(self, context, discrete_state):
        if context.get_time() < self._start - 1e-9:
            return  # standing still: the state (zero commands) is kept
        s = context.get_discrete_state(self._s).get_value()[0]
        u = self._speed.Eval(context)[0]
        u_measured = self._measured_speed.Eval(context)[0]
        step = follower_step(
            s, self._pose.Eval(context), u, self._path, self._p, self._half, self._T_C, u_measured
        )
        discrete_state.set_value(self._s, step[0:1])
        discrete_state.set_value(self._command, step[1:3])
        discrete_state.set_value(self._V1, step[3:4])
        discrete_state.set_value(self._errors, step[4:7])


def follower_step(
    s, pose, u, path, p: PathFollowerParameters, half_track: float, T_C: float, u_measured=None
):
    """One T_C sample of the follower: returns the next state in FollowerState order.

    I(15)-(16) use ``u_measured`` (the robot's speed; ``None`` or ``p.use_estimated_speed`` false: the
    command u), I(18)-(19) u.
    """
    s1, y1, theta = frenet_errors(pose, path.pose(s))
    kappa = path.curvature(s)
    speed = u if u_measured is None or not p.use_estimated_speed else u_measured
    s_dot, theta_dot, V1 = path_following_law(s1, y1, theta, kappa, speed, p)
    if s >= path.length:
        return [s, 0.0, 0.0, V1, s1, y1, theta]
    v_R, v_L = wheel_commands(u, kappa, s_dot, theta_dot, half_track)
    return [min(s + s_dot * T_C, path.length), v_R, v_L, V1, s1, y1, theta]


class WheelSpeedSaturator(LeafSystem):
    """Speed law I(24) (or the constant u = V_m/2) and the curvature-preserving clip to V_m.

    .. pydrake_system::

        name: WheelSpeedSaturator
        input_ports:
        - lyapunov_value
        - estimated_pose
        - virtual_target
        - wheel_speed_command
        output_ports:
        - speed
        - saturated_command

    - speed: u of I(24) and kappa_r(s) of the follower's virtual target s (direct feedthrough). V1: the
      follower's ``lyapunov_value`` of its last update (``delayed_speed_law``, one T_C late), or
      (``delayed_speed_law`` false) speed_law's V1 from the pose the follower reads, at this instant.
      With ``law="constant"`` u = V_m/2 throughout; 0 once s reaches the path's end.
    - saturated_command: the follower's [v_R, v_L] scaled so that neither exceeds V_m.

    Args:
        path: the follower's path. V_m: wheel-speed bound (m/s). track_width: m. params:
        PathFollowerParameters (epsilon, delayed_speed_law; gamma, k3 for V1). law: ``bounded``
        (I(24)) or ``constant``.
    """

    def __init__(self, path, V_m: float, track_width: float, params: PathFollowerParameters, law="bounded"):
        super().__init__()
        if law not in ("bounded", "constant"):
            raise ValueError(f"speed law {law!r} is unknown: allowed 'bounded', 'constant'")
        self._path, self._V_m, self._half, self._p, self._law = path, V_m, 0.5 * track_width, params, law
        self._V1 = self.DeclareVectorInputPort("lyapunov_value", 1)
        self._pose = self.DeclareVectorInputPort("estimated_pose", 3)
        self._s = self.DeclareVectorInputPort("virtual_target", 1)
        self._cmd = self.DeclareVectorInputPort("wheel_speed_command", 2)
        V1_source = self._V1 if params.delayed_speed_law else self._pose
        self.DeclareVectorOutputPort(
            "speed", 1, self._calc_speed, prerequisites_of_calc={V1_source.ticket(), self._s.ticket()}
        )
        self.DeclareVectorOutputPort(
            "saturated_command", 2, self._calc_command, prerequisites_of_calc={self._cmd.ticket()}
        )

    def _calc_speed(self, context, output):
        s = self._s.Eval(context)[0]
        if s >= self._path.length:
            output.SetFromVector([0.0])
        elif self._law == "constant":
            output.SetFromVector([0.5 * self._V_m])
        elif self._p.delayed_speed_law:
            kappa, V1 = self._path.curvature(s), self._V1.Eval(context)[0]
            output.SetFromVector([bounded_speed(V1, kappa, self._V_m, self._half, self._p.epsilon)])
        else:
            pose = self._pose.Eval(context)
            output.SetFromVector([speed_law(pose, s, self._path, self._p, self._V_m, self._half)[0]])

    def _calc_command(self, context, output):
        output.SetFromVector(saturate_wheel_speeds(*self._cmd.Eval(context), self._V_m))
