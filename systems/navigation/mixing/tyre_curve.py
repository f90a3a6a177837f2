"""The nominal tyre curve the mixer believes (Pacejka's magic formula per unit mass, the two tyres lumped
at the axle centre): the steady-turn side slip of S(17), the side slip and the longitudinal creep at the
forces the accelerometers measure (S(15), S(17)), and the tyres' utilisation that sets S(17)'s inertial
relaxation.
"""

import math

from slipnav.systems.navigation.mixing.parameters import MixingParameters


def tyre_utilisation(v_t: float, omega: float, p: MixingParameters) -> float:
    """|a_n| / a_peak with the steady-turn lateral acceleration a_n = v_t omega, capped at 1."""
    return min(abs(v_t * omega) / p.tyre_peak_acceleration, 1.0)


def tyre_slip(utilisation: float, p: MixingParameters) -> float:
    """The inverse magic formula: the slip sigma = tan(asin(u) / C) / B at which the tyre curve
    a_peak sin(C atan(B sigma)) gives the share u (<= 1) of its peak."""
    return math.tan(math.asin(utilisation) / p.tyre_shape_factor) / p.tyre_stiffness_factor


def lateral_velocity_model(v_t: float, omega: float, p: MixingParameters) -> float:
    """Side-slip velocity v_n in a steady turn at lateral acceleration a_n = v_t omega (S(2) with
    dv_n/dt = 0): the inverse of the lateral magic formula |a_n| = a_peak sin(C atan(B tan|alpha|)),
    tan(alpha) = v_n/|v_t|, capped at the peak (|a_n| >= a_peak); zero for a_peak = inf.

    In the linear range tan(alpha) = -a_n/K_alpha with K_alpha = a_peak B C (Tinyphoon: 107 m/s^2/rad).
    The two tyres are lumped at the axle centre, which holds while |omega| track/2 << |v_t|. v_t omega,
    from odometry and gyro, is used rather than the EKF's a_n: it carries none of the accelerometers'
    commotion, which would otherwise reach v_n as noise on the straights."""
    ratio = tyre_utilisation(v_t, omega, p)
    tan_alpha = tyre_slip(ratio, p)
    return -abs(v_t) * math.copysign(tan_alpha, v_t * omega)


DRAG_SPEED_SCALE = 0.01
"""m/s: the drag's direction follows tanh(v_t / DRAG_SPEED_SCALE) (Coulomb friction, regularised)."""


def tyre_force_per_mass(speed: float, a_t: float, a_n: float, p: MixingParameters) -> tuple[float, float]:
    """The tyres' force per unit mass (a_x, a_n) that accelerates the body at (a_t, a_n) against the
    drag at ``speed`` v: a_x = a_t + (drag_acceleration + drag_per_speed |v|) tanh(v / 0.01) (the shoes'
    small lateral drag, ~drag sin(alpha), is neglected)."""
    drag = p.drag_acceleration + p.drag_per_speed * abs(speed)
    return a_t + drag * math.tanh(speed / DRAG_SPEED_SCALE), a_n


def combined_slip(a_x: float, a_n: float, p: MixingParameters) -> tuple[float, float]:
    """Combined-slip magic formula (Pacejka's similarity method): the tyres that carry the force (a_x,
    a_n) per unit mass slip by sigma = tyre_slip(|a| / a_peak) (capped at the peak) in the force's
    direction. Returns (sigma, |a| / a_peak) (uncapped; 0, 0 for a_peak = inf)."""
    if math.isinf(p.tyre_peak_acceleration):
        return 0.0, 0.0
    utilisation = math.hypot(a_x, a_n) / p.tyre_peak_acceleration
    return tyre_slip(min(utilisation, 1.0), p), utilisation


def longitudinal_slip_speed(wheel_speed: float, a_t: float, a_n: float, p: MixingParameters) -> float:
    """Steady slip speed r theta_dot - v_t of the tyres that push the body at (a_t, a_n) against the drag.

    The combined slip (combined_slip) of the tyre force (tyre_force_per_mass at the wheel speed v) has the
    longitudinal part kappa = sigma a_x / |a|; the slip speed is kappa max(|v|, tyre_reference_speed).
    Zero for a_peak = inf or without odometry_slip_compensation. The two tyres are lumped (their mean
    slip)."""
    if not p.odometry_slip_compensation:
        return 0.0
    a_x, a_n = tyre_force_per_mass(wheel_speed, a_t, a_n, p)
    sigma, utilisation = combined_slip(a_x, a_n, p)
    if utilisation == 0.0:
        return 0.0
    return sigma * a_x / math.hypot(a_x, a_n) * max(abs(wheel_speed), p.tyre_reference_speed)


def side_slip_from_accelerations(v_t: float, wheel_speed: float, a_t: float, a_n: float, p: MixingParameters):
    """Side-slip velocity of the tyres that carry the force the accelerometers measure (a quasi-static
    tyre, no relaxation length): the lateral part of the combined slip, tan(alpha) = sigma a_n / |a|
    (combined_slip of tyre_force_per_mass(v_t, a_t, a_n)), v_n = -v_ref tan(alpha) with the slip's
    reference speed v_ref = max(|v_t|, |wheel_speed|, tyre_reference_speed), as the tyre curve was
    identified.

    In the linear range and a pure turn tan(alpha) = -a_n / K_alpha, as lateral_velocity_model at
    a_n = v_t omega; braking or driving takes friction from the turn and the same a_n needs more slip.

    Returns:
        (v_n, |a| / a_peak): the slip and the tyres' utilisation (uncapped; 0, 0 for a_peak = inf).
    """
    a_x, a_n = tyre_force_per_mass(v_t, a_t, a_n, p)
    sigma, utilisation = combined_slip(a_x, a_n, p)
    if utilisation == 0.0:
        return 0.0, 0.0
    reference = max(abs(v_t), abs(wheel_speed), p.tyre_reference_speed)
    return -reference * sigma * a_n / math.hypot(a_x, a_n), utilisation


def inertial_relaxation(utilisation: float, p: MixingParameters) -> float:
    """q_I = 1 - (1 - q2_inertial) sqrt(1 - u^2) of S(17)'s inertial branch (mix), u capped at 1."""
    return 1.0 - (1.0 - p.q2_inertial) * math.sqrt(1.0 - min(utilisation, 1.0) ** 2)


def mixing_utilisation(v_t: float, omega: float, a_t: float, a_n: float, p: MixingParameters) -> float:
    """The tyres' utilisation u that sets q_I in mix, from the mixed v_t, omega and ^I a_t, ^I a_n:
    |a| / a_peak of tyre_force_per_mass (side_slip_from_accelerations), else tyre_utilisation."""
    if not p.side_slip_from_accelerations:
        return tyre_utilisation(v_t, omega, p)
    if math.isinf(p.tyre_peak_acceleration):
        return 0.0
    a_x, a_n = tyre_force_per_mass(v_t, a_t, a_n, p)
    return math.hypot(a_x, a_n) / p.tyre_peak_acceleration
