"""Contact forces on the body of the differential-drive robot: two rubber tyres and two felt shoes.

Tyres: Pacejka's simplified "magic formula" on the combined (theoretical) slip
sigma = sqrt(kappa^2 + tan(alpha)^2), F = mu*N*sin(C*atan(B*sigma)), split along (kappa, -tan alpha)
(H. B. Pacejka, *Tire and Vehicle Dynamics*, 3rd ed., 2012, §4.3.2 "combined slip, similarity method").
kappa is the longitudinal slip ratio (r*w - v_x)/v_ref and tan(alpha) = v_y/v_ref, with
v_ref = max(|v_x|, |r*w|, slip_speed_floor); the floor regularises the slip at standstill (below it the
tyre acts as a stiff viscous contact), as is usual for simulation-grade tyre models. Because the force is
anti-parallel to the contact slip velocity the tyre only ever dissipates energy.

Felt shoes: Coulomb friction regularised with tanh plus viscous drag, at +/- shoe_offset on the body axis.

Conventions: body x forward (t), y to the left (n); the right wheel sits at y = -track_width/2.
"""

from __future__ import annotations

import math

from slipnav.systems.compiled import jitable
from slipnav.systems.robot.parameters import RobotParameters


@jitable
def tyre_force(v_x: float, v_y: float, wheel_speed: float, normal_load: float, p: RobotParameters):
    """Tyre force on the body at one contact point, in body axes (Pacejka combined slip, see module).

    Args:
        v_x, v_y: velocity of the wheel centre in body axes (m/s).
        wheel_speed: circumferential wheel speed r*w (m/s).
        normal_load: N (N).

    Returns:
        (F_x, F_y, slip_ratio, tan_slip_angle)
    """
    v_ref = max(abs(v_x), abs(wheel_speed), p.slip_speed_floor)
    kappa = (wheel_speed - v_x) / v_ref
    tan_alpha = v_y / v_ref
    sigma = math.sqrt(kappa * kappa + tan_alpha * tan_alpha)  # not hypot: the same bits compiled (numba)
    if sigma < 1e-15:
        return 0.0, 0.0, kappa, tan_alpha
    force = (
        p.tyre_friction
        * normal_load
        * math.sin(p.tyre_shape_factor * math.atan(p.tyre_stiffness_factor * sigma))
    )
    return force * kappa / sigma, -force * tan_alpha / sigma, kappa, tan_alpha


@jitable
def tyre_force_and_stiffness(
    v_x: float, v_y: float, wheel_speed: float, normal_load: float, p: RobotParameters
):
    """tyre_force's (F_x, F_y) and dF_x/d(wheel_speed) (N s/m) at fixed v_ref: the stiffness of the wheel's
    slip mode that the semi-implicit step treats implicitly."""
    v_ref = max(abs(v_x), abs(wheel_speed), p.slip_speed_floor)
    kappa = (wheel_speed - v_x) / v_ref
    tan_alpha = v_y / v_ref
    sigma = math.sqrt(kappa * kappa + tan_alpha * tan_alpha)
    B, C = p.tyre_stiffness_factor, p.tyre_shape_factor
    peak = p.tyre_friction * normal_load
    if sigma < 1e-12:
        return 0.0, 0.0, peak * C * B / v_ref
    angle = C * math.atan(B * sigma)
    force = peak * math.sin(angle)
    slope = peak * math.cos(angle) * C * B / (1.0 + (B * sigma) * (B * sigma))  # dF/dsigma
    ck, ca = kappa / sigma, tan_alpha / sigma
    return force * ck, -force * ca, (slope * ck * ck + force / sigma * ca * ca) / v_ref


@jitable
def shoe_force(v_x: float, v_y: float, normal_load: float, p: RobotParameters):
    """Felt-shoe force: tanh-regularised Coulomb friction plus viscous drag, opposing the sliding velocity."""
    speed = math.sqrt(v_x * v_x + v_y * v_y)
    if speed < 1e-15:
        return 0.0, 0.0
    coulomb = p.shoe_friction * normal_load * math.tanh(speed / p.shoe_slip_speed) / speed
    scale = -(coulomb + p.shoe_viscous_drag)
    return scale * v_x, scale * v_y


@jitable
def shoe_drag(v_t: float, v_n: float, omega: float, p, force: float, moment: float):
    """The felt shoes' force along the heading and their yaw moment at body velocities (v_t, v_n, omega),
    added to ``force`` and ``moment`` (shoe_force at +-shoe_offset on the body axis; unchanged without
    shoes). ``p``: anything with RobotParameters' shoe fields (the estimators pass their nominal model)."""
    if p.shoe_friction > 0.0 or p.shoe_viscous_drag > 0.0:
        for x_shoe in (p.shoe_offset, -p.shoe_offset):
            sx, sy = shoe_force(v_t, v_n + omega * x_shoe, p.shoe_normal_load, p)
            force += sx
            moment += x_shoe * sy
    return force, moment


NO_DISTURBANCE = (1.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
"""The disturbance input when nothing acts: [contact_R, contact_L, held_R, held_L, torque_R, torque_L,
force_t, force_n] (systems/robot/faults.py's perturbations: a wheel lifted (contact 0), held by a hand, pushed
with a torque (N m); a push on the body (N, body axes))."""


@jitable
def contact_forces(state, p: RobotParameters, disturbance=NO_DISTURBANCE):
    """Tyre and shoe forces on the body at ``state`` (PlantState order), a lifted wheel's tyre force
    zero, plus a push on the body (``disturbance``, NO_DISTURBANCE's layout).

    Returns:
        ((a_t, a_n, omega_dot) absolute body accelerations, (F_x, dF_x/d(r w)) of the right tyre, the
        same of the left tyre); tyre_force_and_stiffness gives the stiffness.
    """
    _, _, _, v_t, v_n, omega, _, _, w_R, w_L = state
    half = 0.5 * p.track_width
    n_wheel = p.wheel_normal_load
    # Wheels at (0, -half) right and (0, +half) left.
    n_R, n_L = n_wheel * disturbance[0], n_wheel * disturbance[1]
    fx_R, fy_R, kx_R = tyre_force_and_stiffness(v_t + omega * half, v_n, p.radius_R * w_R, n_R, p)
    fx_L, fy_L, kx_L = tyre_force_and_stiffness(v_t - omega * half, v_n, p.radius_L * w_L, n_L, p)
    f_x = fx_R + fx_L + disturbance[6]
    f_y = fy_R + fy_L + disturbance[7]
    moment = half * (fx_R - fx_L)
    if p.shoe_friction > 0.0 or p.shoe_viscous_drag > 0.0:
        n_shoe = p.shoe_normal_load
        for x_shoe in (p.shoe_offset, -p.shoe_offset):
            sx, sy = shoe_force(v_t, v_n + omega * x_shoe, n_shoe, p)
            f_x += sx
            f_y += sy
            moment += x_shoe * sy
    accelerations = (f_x / p.mass, f_y / p.mass, moment / p.yaw_inertia)
    return accelerations, (fx_R, kx_R), (fx_L, kx_L)


def tyre_slip(state, p: RobotParameters):
    """[kappa_R, kappa_L, alpha_R, alpha_L]: slip ratios and slip angles (rad) of the two tyres."""
    half = 0.5 * p.track_width
    _, _, k_R, ta_R = tyre_force(state[3] + state[5] * half, state[4], p.radius_R * state[8], 1.0, p)
    _, _, k_L, ta_L = tyre_force(state[3] - state[5] * half, state[4], p.radius_L * state[9], 1.0, p)
    return [k_R, k_L, math.atan(ta_R), math.atan(ta_L)]
