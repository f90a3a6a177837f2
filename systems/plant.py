"""Planar differential-drive robot with real tyre slip, DC motors and a sampled wheel-speed loop.

The body obeys Seyr & Jakubek's kinematics S(1) with body-frame velocities (v_t, v_n, omega) and the
absolute accelerations a_t = dv_t/dt - v_n*omega, a_n = dv_n/dt + v_t*omega that S(2) assumes. Unlike S(1)
the velocities are not imposed: they follow from the forces of two rubber tyres and two felt shoes.

Tyres: Pacejka's simplified "magic formula" on the combined (theoretical) slip
sigma = sqrt(kappa^2 + tan(alpha)^2), F = mu*N*sin(C*atan(B*sigma)), split along (kappa, -tan alpha)
(H. B. Pacejka, *Tire and Vehicle Dynamics*, 3rd ed., 2012, §4.3.2 "combined slip, similarity method").
kappa is the longitudinal slip ratio (r*w - v_x)/v_ref and tan(alpha) = v_y/v_ref, with
v_ref = max(|v_x|, |r*w|, slip_speed_floor); the floor regularises the slip at standstill (below it the
tyre acts as a stiff viscous contact), as is usual for simulation-grade tyre models. Because the force is
anti-parallel to the contact slip velocity the tyre only ever dissipates energy.

Felt shoes: Coulomb friction regularised with tanh plus viscous drag, at +/- shoe_offset on the body axis.

Motors: DC motors referred to the wheel shaft (k = torque constant = back-EMF constant incl. gearing),
armature resistance, current limit, supply-voltage limit, bearing drag. A PI wheel-speed loop sampled at
``speed_loop_period`` (zero-order-hold PWM, as the Kurt3D motor controller of Indiveri §IV-A) turns the
commanded circumferential wheel speeds into voltages.

Conventions: body x forward (t), y to the left (n); the right wheel sits at y = -track_width/2, so rolling
without slip gives omega = (v_R - v_L)/track_width (Seyr's b, Indiveri's 2b). Centre of gravity on the axle.
"""

from __future__ import annotations

import collections
import dataclasses as dc
import functools
import math

import numpy as np
from pydrake.common.containers import namedview
from pydrake.systems.framework import BasicVector, LeafSystem
from slipnav.systems.compiled import compiled, jitable

GRAVITY = 9.81

DEFAULT_TIME_STEP = 5e-4
"""Default semi-implicit step of the discrete plant (s). Against the continuous model (DOP853, rtol 1e-9),
first-order convergence; at 0.5 ms: corner 0.44 mm / 1.5 mm/s, square 0.39 mm / 1.6 mm/s (max position /
speed error over the run), circle (Kurt3D) 0.02 mm until its final emergency stop, 13 mm / 0.06 m/s after."""

PlantState = namedview(
    "PlantState",
    ["x", "y", "phi", "v_t", "v_n", "omega", "theta_R", "theta_L", "w_R", "w_L"],
)
"""Continuous plant state: pose, body velocities, wheel angles (rad) and wheel angular speeds (rad/s)."""

SpeedLoopState = namedview("SpeedLoopState", ["integral_R", "integral_L", "voltage_R", "voltage_L"])
"""Discrete state of the sampled PI wheel-speed loop: error integrals (rad) and held voltages (V)."""


def _require(name: str, value: float, low: float, high: float = math.inf, *, low_open=True):
    ok_low = value > low if low_open else value >= low
    if not (ok_low and value <= high and math.isfinite(value)):
        bracket = "(" if low_open else "["
        raise ValueError(f"{name}={value!r} is out of range: allowed {bracket}{low}, {high}]")


@dc.dataclass(frozen=True)
class RobotParameters:
    """Physical parameters of a differential-drive robot (SI units).

    Args:
        name: label used in reports.
        mass: total mass (kg).
        yaw_inertia: moment of inertia about the vertical axis through the centre of gravity (kg m^2).
        track_width: full distance between the wheel contact points (Seyr's b, Indiveri's 2b) (m).
        wheel_radius: nominal wheel radius (m): the motor controller's speed loop converts the commanded
            circumferential speeds to wheel rates with it (its firmware knows only the data sheet).
        wheel_inertia: wheel + gearbox + rotor inertia reflected to the wheel shaft (kg m^2).
        wheel_load_fraction: share of the weight carried by the two wheels; the rest rests on the shoes.
        tyre_friction: peak tyre/ground friction coefficient mu.
        tyre_stiffness_factor: Pacejka B (1/unit slip).
        tyre_shape_factor: Pacejka C, in (1, 2); sliding friction is mu*sin(C*pi/2) of the peak.
        slip_speed_floor: regularising reference speed of the slip definitions (m/s).
        shoe_offset: distance of the front and rear felt shoes from the axle (m).
        shoe_friction: Coulomb coefficient of the felt shoes.
        shoe_viscous_drag: viscous drag of each shoe (N s/m).
        shoe_slip_speed: speed scale of the tanh-regularised Coulomb friction (m/s).
        motor_constant: torque constant = back-EMF constant referred to the wheel (N m/A = V s/rad).
        motor_resistance: armature resistance (ohm).
        motor_current_limit: current (hence torque) limit of the motor driver (A).
        supply_voltage: H-bridge supply, the voltage limit (V).
        bearing_drag: viscous drag of each wheel's bearings and gearbox (N m s/rad).
        speed_loop_period: sampling period of the PI wheel-speed loop (s).
        speed_loop_kp: proportional gain on the wheel angular-speed error (V s/rad).
        speed_loop_ki: integral gain (V/rad).
        wheel_speed_limit: V_m, the largest circumferential wheel speed the controller may command (m/s).
        rolling_radius_R, rolling_radius_L: the wheels' true rolling radii (m), where the tyres touch the
            ground; None: wheel_radius. A real robot's differ from the nominal by tyre wear, load and
            manufacture (Borenstein & Feng's UMBmark: unequal wheel diameters, the dominant systematic
            odometry error).
    """

    name: str
    mass: float
    yaw_inertia: float
    track_width: float
    wheel_radius: float
    wheel_inertia: float
    wheel_load_fraction: float
    tyre_friction: float
    tyre_stiffness_factor: float
    tyre_shape_factor: float
    slip_speed_floor: float
    shoe_offset: float
    shoe_friction: float
    shoe_viscous_drag: float
    shoe_slip_speed: float
    motor_constant: float
    motor_resistance: float
    motor_current_limit: float
    supply_voltage: float
    bearing_drag: float
    speed_loop_period: float
    speed_loop_kp: float
    speed_loop_ki: float
    wheel_speed_limit: float
    rolling_radius_R: float | None = None
    rolling_radius_L: float | None = None

    def __post_init__(self):
        _require("mass", self.mass, 0.0)
        _require("yaw_inertia", self.yaw_inertia, 0.0)
        _require("track_width", self.track_width, 0.0)
        _require("wheel_radius", self.wheel_radius, 0.0)
        _require("wheel_inertia", self.wheel_inertia, 0.0)
        _require("wheel_load_fraction", self.wheel_load_fraction, 0.0, 1.0)
        _require("tyre_friction", self.tyre_friction, 0.0, 2.0)
        _require("tyre_stiffness_factor", self.tyre_stiffness_factor, 0.0)
        _require("tyre_shape_factor", self.tyre_shape_factor, 1.0, 2.0)
        _require("slip_speed_floor", self.slip_speed_floor, 0.0)
        _require("shoe_offset", self.shoe_offset, 0.0, low_open=False)
        _require("shoe_friction", self.shoe_friction, 0.0, 2.0, low_open=False)
        _require("shoe_viscous_drag", self.shoe_viscous_drag, 0.0, low_open=False)
        _require("shoe_slip_speed", self.shoe_slip_speed, 0.0)
        _require("motor_constant", self.motor_constant, 0.0)
        _require("motor_resistance", self.motor_resistance, 0.0)
        _require("motor_current_limit", self.motor_current_limit, 0.0)
        _require("supply_voltage", self.supply_voltage, 0.0)
        _require("bearing_drag", self.bearing_drag, 0.0, low_open=False)
        _require("speed_loop_period", self.speed_loop_period, 0.0, 0.1)
        _require("speed_loop_kp", self.speed_loop_kp, 0.0, low_open=False)
        _require("speed_loop_ki", self.speed_loop_ki, 0.0, low_open=False)
        _require("wheel_speed_limit", self.wheel_speed_limit, 0.0)
        for name in ("rolling_radius_R", "rolling_radius_L"):
            if getattr(self, name) is not None:
                _require(name, getattr(self, name), 0.0)
        if self.wheel_speed_limit > self.no_load_speed:
            raise ValueError(
                f"wheel_speed_limit={self.wheel_speed_limit} exceeds the motors' no-load "
                f"circumferential speed {self.no_load_speed:.3f} m/s: allowed (0, {self.no_load_speed:.3f}]"
            )

    @property
    def radius_R(self) -> float:
        """Rolling radius of the right wheel (m)."""
        return self.wheel_radius if self.rolling_radius_R is None else self.rolling_radius_R

    @property
    def radius_L(self) -> float:
        """Rolling radius of the left wheel (m)."""
        return self.wheel_radius if self.rolling_radius_L is None else self.rolling_radius_L

    @property
    def no_load_speed(self) -> float:
        """Circumferential wheel speed at full supply voltage and zero torque (m/s)."""
        return self.wheel_radius * self.supply_voltage / self.motor_constant

    @property
    def wheel_normal_load(self) -> float:
        """Static normal force on each wheel (N)."""
        return 0.5 * self.wheel_load_fraction * self.mass * GRAVITY

    @property
    def shoe_normal_load(self) -> float:
        """Static normal force on each felt shoe (N)."""
        return 0.5 * (1.0 - self.wheel_load_fraction) * self.mass * GRAVITY

    @property
    def traction_limit_acceleration(self) -> float:
        """Largest acceleration the tyres can transmit, mu * N_wheels / m (m/s^2), shoes neglected."""
        return self.tyre_friction * self.wheel_load_fraction * GRAVITY

    def replace(self, **changes) -> RobotParameters:
        return dc.replace(self, **changes)

    @functools.cached_property
    def constants(self) -> tuple:
        """The floats the plant's arithmetic reads, in PlantConstants' order (computed once; the
        compiled plant_advance takes them as one tuple)."""
        return tuple(float(getattr(self, name)) for name in PlantConstants._fields)


PlantConstants = collections.namedtuple(
    "PlantConstants",
    "mass yaw_inertia track_width wheel_radius wheel_inertia tyre_friction tyre_stiffness_factor "
    "tyre_shape_factor slip_speed_floor shoe_offset shoe_friction shoe_viscous_drag shoe_slip_speed "
    "motor_constant motor_resistance motor_current_limit supply_voltage bearing_drag speed_loop_period "
    "speed_loop_kp speed_loop_ki radius_R radius_L wheel_normal_load shoe_normal_load",
)
"""RobotParameters' numbers as the plant's pure functions read them (``p.mass``, ``p.radius_R``, ...):
every one of them takes either."""


def tinyphoon() -> RobotParameters:
    """Seyr & Jakubek's Tinyphoon (§II): 75 mm cube, ~0.4 kg, 22.5 W/kg, ~4 m/s, rubber tyres.

    Motor figures follow a Faulhaber 2224-006SR class coreless motor (4.5 W, rotor 3.8 g cm^2) on a 3:1
    gearhead; 2 x 4.5 W / 0.4 kg = 22.5 W/kg. Yaw inertia of a uniform 75 mm square plate. The felt shoes are
    assumed to carry 20 % of the weight. The speed loop runs at 1 kHz on the DSP (assumption).
    """
    k = 6.0 / 280.0  # V s/rad at the wheel: 6 V gives 280 rad/s = 4.2 m/s no-load
    return RobotParameters(
        name="tinyphoon",
        mass=0.4,
        yaw_inertia=0.4 * 2 * 0.075**2 / 12,
        track_width=0.068,
        wheel_radius=0.015,
        wheel_inertia=3.7e-6,
        wheel_load_fraction=0.8,
        tyre_friction=0.7,
        tyre_stiffness_factor=15.0,
        tyre_shape_factor=1.3,
        slip_speed_floor=0.3,
        shoe_offset=0.03,
        shoe_friction=0.25,
        shoe_viscous_drag=0.05,
        shoe_slip_speed=0.01,
        motor_constant=k,
        motor_resistance=6.0**2 / (4 * 4.5),  # max mechanical power V^2/(4R) = 4.5 W
        motor_current_limit=1.5,
        supply_voltage=6.0,
        bearing_drag=2e-6,
        speed_loop_period=1e-3,
        speed_loop_kp=0.4,
        speed_loop_ki=40.0,
        wheel_speed_limit=4.0,
    )


def kurt3d() -> RobotParameters:
    """Indiveri et al.'s high-speed indoor Kurt3D (§IV-A): 2 x 90 W, V_m = 4.1 m/s, speed loop at 100 Hz.

    Six 16 cm wheels lumped into one wheel per side (skid steering treated as differential drive, as the
    paper does); no shoes. Mass ~22 kg and a 0.45 m x 0.4 m box for the yaw inertia (assumptions).
    """
    v_no_load = 5.0  # headroom above V_m = 4.1 m/s so that the speed loop can hold V_m
    k = 24.0 * 0.08 / v_no_load
    return RobotParameters(
        name="kurt3d",
        mass=22.0,
        yaw_inertia=22.0 * (0.45**2 + 0.4**2) / 12,
        track_width=0.4,
        wheel_radius=0.08,
        wheel_inertia=0.02,
        wheel_load_fraction=1.0,
        tyre_friction=0.8,
        tyre_stiffness_factor=12.0,
        tyre_shape_factor=1.3,
        slip_speed_floor=0.3,
        shoe_offset=0.0,
        shoe_friction=0.0,
        shoe_viscous_drag=0.0,
        shoe_slip_speed=0.01,
        motor_constant=k,
        motor_resistance=24.0**2 / (4 * 90.0),
        motor_current_limit=12.0,
        supply_voltage=24.0,
        bearing_drag=1e-3,
        speed_loop_period=1e-2,
        speed_loop_kp=6.0,
        speed_loop_ki=60.0,
        wheel_speed_limit=4.1,
    )


ROBOTS = {"tinyphoon": tinyphoon, "kurt3d": kurt3d}


def robot_parameters(name: str) -> RobotParameters:
    """The named reference robot's parameters."""
    try:
        return ROBOTS[name]()
    except KeyError:
        raise ValueError(f"robot={name!r} is unknown: allowed {sorted(ROBOTS)}") from None


# ---------------------------------------------------------------------------------------------------
# Pure maths


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


@jitable
def motor_current(voltage: float, wheel_rate: float, p: RobotParameters) -> float:
    """Armature current (V - k*w)/R, clipped to the driver's current limit (A)."""
    current = (voltage - p.motor_constant * wheel_rate) / p.motor_resistance
    return min(max(current, -p.motor_current_limit), p.motor_current_limit)


@jitable
def motor_currents(loop_state, state, p: RobotParameters, motor_enable=(1.0, 1.0)) -> tuple:
    """(i_R, i_L): motor_current at the loop's held voltages, zero for a switched-off motor."""
    i_R = motor_current(loop_state[2], state[8], p) if motor_enable[0] else 0.0
    i_L = motor_current(loop_state[3], state[9], p) if motor_enable[1] else 0.0
    return (i_R, i_L)


NO_DISTURBANCE = (1.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
"""The disturbance input when nothing acts: [contact_R, contact_L, held_R, held_L, torque_R, torque_L,
force_t, force_n] (systems/faults.py's perturbations: a wheel lifted (contact 0), held by a hand, pushed
with a torque (N m); a push on the body (N, body axes))."""
HOLD_TIME_CONSTANT = 0.001
"""A hand holds a wheel against every torque on it: w_dot = -w / HOLD_TIME_CONSTANT (s) while held."""
MOTORS_ON = (1.0, 1.0)
"""The motor_enable input when nothing is switched off: [enable_R, enable_L], 1 driven, 0 switched off (the
H-bridge open: no current, no back-EMF braking, the speed loop's integral and voltage cleared), so that the
wheel free-wheels on its bearings (a coasting run, studies/calibration.py)."""


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


@jitable
def plant_derivatives(state, currents, p: RobotParameters, disturbance=NO_DISTURBANCE):
    """Time derivative of the continuous plant state.

    Args:
        state: sequence in PlantState order.
        currents: (i_R, i_L) motor currents (A); zeros model motors switched off (open circuit).
        disturbance: perturbations (NO_DISTURBANCE's layout).

    Returns:
        (xdot as a list in PlantState order, (a_t, a_n, omega_dot) absolute body accelerations)
    """
    x, y, phi, v_t, v_n, omega, _, _, w_R, w_L = state
    (a_t, a_n, omega_dot), (fx_R, _), (fx_L, _) = contact_forces(state, p, disturbance)
    i_R, i_L = currents
    k = p.motor_constant
    w_R_dot = (k * i_R - p.radius_R * fx_R - p.bearing_drag * w_R + disturbance[4]) / p.wheel_inertia
    w_L_dot = (k * i_L - p.radius_L * fx_L - p.bearing_drag * w_L + disturbance[5]) / p.wheel_inertia
    if disturbance[2]:
        w_R_dot = -w_R / HOLD_TIME_CONSTANT
    if disturbance[3]:
        w_L_dot = -w_L / HOLD_TIME_CONSTANT
    c, s = math.cos(phi), math.sin(phi)
    xdot = [
        v_t * c - v_n * s,
        v_t * s + v_n * c,
        omega,
        a_t + v_n * omega,
        a_n - v_t * omega,
        omega_dot,
        w_R,
        w_L,
        w_R_dot,
        w_L_dot,
    ]
    return xdot, (a_t, a_n, omega_dot)


@jitable
def plant_substep(
    state, voltages, h: float, p: RobotParameters, disturbance=NO_DISTURBANCE, motor_enable=MOTORS_ON
):
    """One semi-implicit Euler step of length h of the plant ODE (plant_derivatives) at fixed voltages.

    The wheel speeds take an exponential-Euler step in their own stiff slip mode: with the damping
    D = -d(w_dot)/dw >= 0 (tyre slip stiffness, back-EMF unless the current is limited, bearing drag),
    w+ = w + (1 - exp(-h D))/D w_dot, exact for the linearised mode and stable at any h (the tyre's slip
    mode reaches D ~ 4000 1/s at low speed). The body velocities step explicitly; positions and wheel
    angles use the new velocities (symplectic Euler) and the pose the mid-step heading. This mirrors the
    implicit treatment of stiff contact in Drake's discrete MultibodyPlant, reduced to a diagonal part.
    A held wheel (disturbance) decays exactly as w_dot = -w / HOLD_TIME_CONSTANT. A switched-off motor
    (``motor_enable`` 0, MOTORS_ON's layout) carries no current and adds no back-EMF damping.
    Returns (state+, (a_t, a_n, omega_dot) at state).
    """
    x, y, phi, v_t, v_n, omega, th_R, th_L, w_R, w_L = state
    (a_t, a_n, omega_dot), (fx_R, kx_R), (fx_L, kx_L) = contact_forces(state, p, disturbance)
    w_R_new = wheel_step(
        w_R, fx_R, kx_R, voltages[0], p.radius_R, disturbance[2], disturbance[4], motor_enable[0], h, p
    )
    w_L_new = wheel_step(
        w_L, fx_L, kx_L, voltages[1], p.radius_L, disturbance[3], disturbance[5], motor_enable[1], h, p
    )
    v_t_new = v_t + h * (a_t + v_n * omega)
    v_n_new = v_n + h * (a_n - v_t * omega)
    omega_new = omega + h * omega_dot
    phi_mid = phi + 0.5 * h * omega_new
    c, s = math.cos(phi_mid), math.sin(phi_mid)
    new_state = (
        x + h * (v_t_new * c - v_n_new * s),
        y + h * (v_t_new * s + v_n_new * c),
        phi + h * omega_new,
        v_t_new,
        v_n_new,
        omega_new,
        th_R + h * w_R_new,
        th_L + h * w_L_new,
        w_R_new,
        w_L_new,
    )
    return new_state, (a_t, a_n, omega_dot)


@jitable
def wheel_step(
    w: float,
    fx: float,
    kx: float,
    voltage: float,
    r: float,
    held: float,
    torque: float,
    enabled: float,
    h: float,
    p: RobotParameters,
) -> float:
    """One wheel's speed after plant_substep's exponential-Euler step: w (rad/s) under the tyre's force fx
    and slip stiffness kx (contact_forces), the motor at ``voltage``, rolling radius r, ``held`` by a hand,
    pushed by ``torque``, the motor ``enabled``."""
    k, J, R_m, b = p.motor_constant, p.wheel_inertia, p.motor_resistance, p.bearing_drag
    current = (voltage - k * w) / R_m
    limited = abs(current) > p.motor_current_limit
    current = min(max(current, -p.motor_current_limit), p.motor_current_limit)
    if not enabled:  # open circuit: no current, no back-EMF damping
        current, limited = 0.0, True
    if held:
        return w * math.exp(-h / HOLD_TIME_CONSTANT)
    w_dot = (k * current - r * fx - b * w + torque) / J
    damping = (r * r * max(kx, 0.0) + b + (0.0 if limited else k * k / R_m)) / J
    gain = -math.expm1(-h * damping) / damping if damping * h > 1e-12 else h
    return w + gain * w_dot


def kinetic_energy(state, p: RobotParameters) -> float:
    """Translational + yaw + wheel rotational kinetic energy (J)."""
    s = PlantState(np.asarray(state, dtype=float))
    return 0.5 * (
        p.mass * (s.v_t**2 + s.v_n**2) + p.yaw_inertia * s.omega**2 + p.wheel_inertia * (s.w_R**2 + s.w_L**2)
    )


@jitable
def speed_loop_update(
    loop_state, wheel_speed_command, wheel_rates, p: RobotParameters, motor_enable=MOTORS_ON
):
    """One sample of the PI wheel-speed loop with conditional-integration anti-windup.

    Args:
        loop_state: SpeedLoopState-ordered (integral_R, integral_L, voltage_R, voltage_L).
        wheel_speed_command: commanded circumferential speeds (v_R, v_L) (m/s).
        wheel_rates: measured wheel angular speeds (w_R, w_L) (rad/s).
        motor_enable: MOTORS_ON's layout; a switched-off wheel's integral and voltage are cleared.

    Returns:
        the next loop state (tuple).
    """
    integral_R, voltage_R = _pi_sample(loop_state[0], wheel_speed_command[0], wheel_rates[0], p)
    integral_L, voltage_L = _pi_sample(loop_state[1], wheel_speed_command[1], wheel_rates[1], p)
    if not motor_enable[0]:
        integral_R = voltage_R = 0.0
    if not motor_enable[1]:
        integral_L = voltage_L = 0.0
    return (integral_R, integral_L, voltage_R, voltage_L)


@jitable
def _pi_sample(integral: float, command: float, wheel_rate: float, p: RobotParameters):
    """One wheel's (integral, voltage) of speed_loop_update."""
    limit = p.supply_voltage
    error = command / p.wheel_radius - wheel_rate
    new_integral = integral + error * p.speed_loop_period
    voltage = p.speed_loop_kp * error + p.speed_loop_ki * new_integral
    if abs(voltage) > limit:
        new_integral = integral  # freeze the integral while saturated
        voltage = p.speed_loop_kp * error + p.speed_loop_ki * new_integral
    return new_integral, min(max(voltage, -limit), limit)


def substeps_per(period: float, time_step: float, name: str) -> int:
    """period / time_step as an integer >= 1, or a ValueError naming ``name``."""
    n = round(period / time_step)
    if n < 1 or abs(n * time_step - period) > 1e-9 * period:
        raise ValueError(
            f"plant time_step={time_step!r} must divide {name}={period!r} s: allowed {name}/n, n = 1, 2, ..."
        )
    return n


def plant_advance(
    state,
    loop_state,
    command,
    step_index: int,
    num_steps: int,
    time_step: float,
    p,
    disturbance=NO_DISTURBANCE,
    motor_enable=MOTORS_ON,
):
    """Advance the discrete plant by ``num_steps`` semi-implicit steps of ``time_step`` (plant_substep),
    the ``disturbance`` and ``motor_enable`` held over them.

    The PI speed loop samples (speed_loop_update) whenever the global step index ``step_index + i`` is a
    multiple of speed_loop_period / time_step, from the wheel rates at that instant, and its voltage
    holds until the next sample: the same timing as the continuous plant's periodic event.

    Returns:
        (state, loop_state, body acceleration [a_t, a_n, omega_dot] at the final state with the held
        voltages), lists.
    """
    per_loop = substeps_per(p.speed_loop_period, time_step, "speed_loop_period")
    state, loop_state, acceleration = _plant_steps(
        tuple([float(v) for v in state]),
        tuple([float(v) for v in loop_state]),
        tuple([float(v) for v in command]),
        int(step_index),
        int(num_steps),
        per_loop,
        float(time_step),
        p.constants,
        tuple([float(v) for v in disturbance]),
        tuple([float(v) for v in motor_enable]),
    )
    return list(state), list(loop_state), list(acceleration)


@compiled
def _plant_steps(
    state,
    loop_state,
    command,
    step_index,
    num_steps,
    per_loop,
    time_step,
    constants,
    disturbance,
    motor_enable,
):
    """plant_advance's steps: tuples of floats in and out, the PI loop sampled every ``per_loop`` steps
    (compiled with numba when available: systems/compiled.py)."""
    p = PlantConstants(*constants)
    for i in range(num_steps):
        if (step_index + i) % per_loop == 0:
            loop_state = speed_loop_update(loop_state, command, (state[8], state[9]), p, motor_enable)
        state, _ = plant_substep(
            state, (loop_state[2], loop_state[3]), time_step, p, disturbance, motor_enable
        )
    currents = motor_currents(loop_state, state, p, motor_enable)
    _, acceleration = plant_derivatives(state, currents, p, disturbance)
    return state, loop_state, acceleration


def tyre_slip(state, p: RobotParameters):
    """[kappa_R, kappa_L, alpha_R, alpha_L]: slip ratios and slip angles (rad) of the two tyres."""
    half = 0.5 * p.track_width
    _, _, k_R, ta_R = tyre_force(state[3] + state[5] * half, state[4], p.radius_R * state[8], 1.0, p)
    _, _, k_L, ta_L = tyre_force(state[3] - state[5] * half, state[4], p.radius_L * state[9], 1.0, p)
    return [k_R, k_L, math.atan(ta_R), math.atan(ta_L)]


# ---------------------------------------------------------------------------------------------------
# Drake shell


class DifferentialDrivePlant(LeafSystem):
    """Rigid-body robot with slipping tyres, felt shoes, DC motors and a sampled PI speed loop.

    .. pydrake_system::

        name: DifferentialDrivePlant
        input_ports:
        - wheel_speed_command
        - disturbance
        - motor_enable
        output_ports:
        - state
        - body_acceleration
        - wheel_angles
        - wheel_speeds
        - tyre_slip
        - motor_currents

    - wheel_speed_command: commanded circumferential wheel speeds [v_R, v_L] (m/s).
    - disturbance: perturbations in NO_DISTURBANCE's layout (optional: unconnected, nothing acts).
    - motor_enable: [enable_R, enable_L] in MOTORS_ON's layout (optional: unconnected, both driven); 0
      switches a motor off (open circuit, the wheel free-wheels; a coasting run).
    - state: PlantState [x, y, phi, v_t, v_n, omega, theta_R, theta_L, w_R, w_L].
    - body_acceleration: true absolute body-frame accelerations [a_t, a_n, omega_dot] (m/s^2, rad/s^2).
    - wheel_angles: [theta_R, theta_L] (rad), for the encoders.
    - wheel_speeds: circumferential speeds [r_R*w_R, r_L*w_L] with the true rolling radii (m/s).
    - tyre_slip: [kappa_R, kappa_L, alpha_R, alpha_L]: slip ratios and slip angles (rad).
    - motor_currents: the true armature currents [i_R, i_L] (A) at ``state`` with the voltages held since
      the last PI sample (motor_currents), for the drivers' current sense (systems/sensors.py).

    Two time models, as Drake's MultibodyPlant offers:

    - ``time_step = 0``: continuous state (PlantState) integrated by the simulator's integrator; the PI
      loop is a periodic discrete update at ``speed_loop_period`` holding the voltages (SpeedLoopState).
    - ``time_step > 0``: discrete state, advanced every ``update_period`` by plant_advance: semi-implicit
      steps of ``time_step`` with the PI loop sampled every ``speed_loop_period``. ``time_step`` must
      divide both periods. The body acceleration at the new state is part of the discrete state, so
      that the output at t_k is the acceleration at x(t_k) with the voltage held since the last PI sample,
      exactly as in the continuous model.

    Args:
        params: RobotParameters.
        initial_pose: (x, y, phi) of the default context.
        initial_speed: forward speed v_t of the default context (wheels rolling), m/s.
        time_step: 0 (continuous) or the semi-implicit integration step (s).
        update_period: period of the discrete update when ``time_step > 0`` (s), e.g. the sensors' T_N.
    """

    def __init__(
        self,
        params: RobotParameters,
        initial_pose=(0.0, 0.0, 0.0),
        initial_speed=0.0,
        time_step: float = 0.0,
        update_period: float | None = None,
    ):
        super().__init__()
        if not (math.isfinite(time_step) and 0.0 <= time_step <= 0.01):
            raise ValueError(
                f"plant time_step={time_step!r} is out of range: allowed 0 (continuous) or (0, 0.01] s"
            )
        self._params = params
        self._time_step = time_step
        x0 = np.zeros(10)
        x0[0:3] = initial_pose
        x0[3] = initial_speed
        x0[8], x0[9] = initial_speed / params.radius_R, initial_speed / params.radius_L
        self._command_port = self.DeclareVectorInputPort("wheel_speed_command", 2)
        self._disturbance_port = self.DeclareVectorInputPort("disturbance", len(NO_DISTURBANCE))
        self._enable_port = self.DeclareVectorInputPort("motor_enable", len(MOTORS_ON))
        if time_step > 0.0:
            self._declare_discrete(x0, time_step, update_period)
        else:
            self._declare_continuous(x0)
        self.DeclareVectorOutputPort(
            "wheel_angles", 2, self._calc_wheel_angles, prerequisites_of_calc={self._state_ticket}
        )
        self.DeclareVectorOutputPort(
            "wheel_speeds", 2, self._calc_wheel_speeds, prerequisites_of_calc={self._state_ticket}
        )
        self.DeclareVectorOutputPort(
            "tyre_slip", 4, self._calc_tyre_slip, prerequisites_of_calc={self._state_ticket}
        )

    def _declare_continuous(self, x0):
        self.DeclareContinuousState(BasicVector(x0), 0, 0, 10)
        self._loop = self.DeclareDiscreteState(4)
        self.DeclarePeriodicDiscreteUpdateEvent(
            period_sec=self._params.speed_loop_period, offset_sec=0.0, update=self._update_speed_loop
        )
        self._state_ticket = self.xc_ticket()
        self.DeclareVectorOutputPort("state", 10, self._calc_state, prerequisites_of_calc={self.xc_ticket()})
        self.DeclareVectorOutputPort(
            "motor_currents",
            2,
            self._calc_currents,
            prerequisites_of_calc={self.all_state_ticket(), self._enable_port.ticket()},
        )
        self.DeclareVectorOutputPort(
            "body_acceleration",
            3,
            self._calc_acceleration,
            prerequisites_of_calc={
                self.all_state_ticket(),
                self._disturbance_port.ticket(),
                self._enable_port.ticket(),
            },
        )

    def _declare_discrete(self, x0, time_step, update_period):
        if update_period is None:
            raise ValueError("update_period is required with a plant time_step > 0")
        substeps_per(self._params.speed_loop_period, time_step, "speed_loop_period")
        self._steps_per_update = substeps_per(update_period, time_step, "update_period")
        self._x = self.DeclareDiscreteState(x0)
        self._loop = self.DeclareDiscreteState(4)
        currents = (motor_current(0.0, x0[8], self._params), motor_current(0.0, x0[9], self._params))
        self._acc = self.DeclareDiscreteState(np.array(plant_derivatives(x0, currents, self._params)[1]))
        self._currents_state = self.DeclareDiscreteState(np.array(currents))
        self.DeclarePeriodicDiscreteUpdateEvent(update_period, 0.0, self._update_discrete)
        self._state_ticket = self.xd_ticket()
        self.DeclareStateOutputPort("state", self._x)
        self.DeclareStateOutputPort("body_acceleration", self._acc)
        self.DeclareStateOutputPort("motor_currents", self._currents_state)

    @property
    def params(self) -> RobotParameters:
        return self._params

    @property
    def time_step(self) -> float:
        return self._time_step

    def get_command_input_port(self):
        return self._command_port

    def _plant_state(self, context):
        if self._time_step > 0.0:
            return context.get_discrete_state(self._x).get_value()
        return context.get_continuous_state_vector().CopyToVector()

    def _disturbance(self, context):
        port = self._disturbance_port
        return port.Eval(context).tolist() if port.HasValue(context) else NO_DISTURBANCE

    def _motor_enable(self, context):
        port = self._enable_port
        return port.Eval(context).tolist() if port.HasValue(context) else MOTORS_ON

    def _currents(self, context, x):
        loop = context.get_discrete_state(self._loop).get_value()
        return motor_currents(loop, x, self._params, self._motor_enable(context))

    def DoCalcTimeDerivatives(self, context, derivatives):  # noqa: N802 (Drake API)
        if self._time_step > 0.0:
            return
        x = context.get_continuous_state_vector().CopyToVector()
        xdot, _ = plant_derivatives(x, self._currents(context, x), self._params, self._disturbance(context))
        derivatives.get_mutable_vector().SetFromVector(xdot)

    def _update_speed_loop(self, context, discrete_state):
        x = context.get_continuous_state_vector().CopyToVector()
        command = self._command_port.Eval(context)
        loop = context.get_discrete_state(self._loop).get_value()
        discrete_state.set_value(
            self._loop,
            speed_loop_update(loop, command, (x[8], x[9]), self._params, self._motor_enable(context)),
        )

    def _update_discrete(self, context, discrete_state):
        step_index = round(context.get_time() / self._time_step)
        enable = self._motor_enable(context)
        # Floats, not numpy scalars, into the pure functions (numpy scalar arithmetic is several times
        # slower); the update's buffer holds the block's own state at t_k.
        state, loop, acc = plant_advance(
            discrete_state.get_value(self._x).tolist(),
            discrete_state.get_value(self._loop).tolist(),
            self._command_port.Eval(context).tolist(),
            step_index,
            self._steps_per_update,
            self._time_step,
            self._params,
            self._disturbance(context),
            enable,
        )
        discrete_state.set_value(self._x, state)
        discrete_state.set_value(self._loop, loop)
        discrete_state.set_value(self._acc, acc)
        discrete_state.set_value(self._currents_state, motor_currents(loop, state, self._params, enable))

    def _calc_state(self, context, output: BasicVector):
        output.SetFromVector(context.get_continuous_state_vector().CopyToVector())

    def _calc_acceleration(self, context, output: BasicVector):
        x = context.get_continuous_state_vector().CopyToVector()
        _, acc = plant_derivatives(x, self._currents(context, x), self._params, self._disturbance(context))
        output.SetFromVector(acc)

    def _calc_currents(self, context, output: BasicVector):
        x = context.get_continuous_state_vector().CopyToVector()
        output.SetFromVector(self._currents(context, x))

    def _calc_wheel_angles(self, context, output: BasicVector):
        output.SetFromVector(self._plant_state(context)[6:8])

    def _calc_wheel_speeds(self, context, output: BasicVector):
        x = self._plant_state(context)
        output.SetFromVector([self._params.radius_R * x[8], self._params.radius_L * x[9]])

    def _calc_tyre_slip(self, context, output: BasicVector):
        output.SetFromVector(tyre_slip(self._plant_state(context), self._params))
