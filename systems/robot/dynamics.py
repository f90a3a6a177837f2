"""Rigid-body dynamics of the planar differential-drive robot: the plant ODE, its semi-implicit step and
the discrete plant's advance over an update period.

The body obeys Seyr & Jakubek's kinematics S(1) with body-frame velocities (v_t, v_n, omega) and the
absolute accelerations a_t = dv_t/dt - v_n*omega, a_n = dv_n/dt + v_t*omega that S(2) assumes. Unlike S(1)
the velocities are not imposed: they follow from the forces of two rubber tyres and two felt shoes
(systems/robot/contact.py) and the wheels' DC motors under the PI speed loop (systems/robot/motors.py).

Conventions: body x forward (t), y to the left (n); the right wheel sits at y = -track_width/2, so rolling
without slip gives omega = (v_R - v_L)/track_width (Seyr's b, Indiveri's 2b). Centre of gravity on the axle.
"""

from __future__ import annotations

import math

import numpy as np
from pydrake.common.containers import namedview
from slipnav.systems.compiled import compiled, jitable
from slipnav.systems.robot.contact import NO_DISTURBANCE, contact_forces
from slipnav.systems.robot.motors import MOTORS_ON, motor_currents, speed_loop_update
from slipnav.systems.robot.parameters import PlantConstants, RobotParameters

PlantState = namedview(
    "PlantState",
    ["x", "y", "phi", "v_t", "v_n", "omega", "theta_R", "theta_L", "w_R", "w_L"],
)
"""Continuous plant state: pose, body velocities, wheel angles (rad) and wheel angular speeds (rad/s)."""

HOLD_TIME_CONSTANT = 0.001
"""A hand holds a wheel against every torque on it: w_dot = -w / HOLD_TIME_CONSTANT (s) while held."""


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
