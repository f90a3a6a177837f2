"""The wheels' DC motors and their sampled PI wheel-speed loop.

Motors: DC motors referred to the wheel shaft (k = torque constant = back-EMF constant incl. gearing),
armature resistance, current limit, supply-voltage limit, bearing drag. A PI wheel-speed loop sampled at
``speed_loop_period`` (zero-order-hold PWM, as the Kurt3D motor controller of Indiveri §IV-A) turns the
commanded circumferential wheel speeds into voltages.
"""

from __future__ import annotations

from pydrake.common.containers import namedview
from slipnav.systems.compiled import jitable
from slipnav.systems.robot.parameters import RobotParameters

SpeedLoopState = namedview("SpeedLoopState", ["integral_R", "integral_L", "voltage_R", "voltage_L"])
"""Discrete state of the sampled PI wheel-speed loop: error integrals (rad) and held voltages (V)."""


MOTORS_ON = (1.0, 1.0)
"""The motor_enable input when nothing is switched off: [enable_R, enable_L], 1 driven, 0 switched off (the
H-bridge open: no current, no back-EMF braking, the speed loop's integral and voltage cleared), so that the
wheel free-wheels on its bearings (a coasting run, studies/calibration.py)."""


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
