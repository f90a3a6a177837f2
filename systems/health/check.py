"""One sample of the sensor checks: every channel of [a_t1, a_n1, a_t2, a_n2, omega, theta_R, theta_L]
judged, a channel that fails excluded (flagged with the class of the failure: parameters.HEALTH_CLASSES)
and replaced by what the other sensors say it should read, until it agrees with them again.

The order within a sample:

1. each analog channel alone (systems/health/analog.py), and the excluded gyro's re-admission and
   bias-step blocks (systems/health/gyro.py);
2. the encoders against the other wheel and the gyro (systems/health/encoders.py), against the ground
   beneath them (systems/health/ground_speed.py), and their outputs;
3. the gyro against the wheels' witness (the frozen gyro's shadow, the yaw test) and its replacement's
   yaw rate (systems/health/gyro.py);
4. the accelerometer pair against each other and the kinematics (systems/health/accelerometer_pair.py,
   systems/health/pair_gain.py);
5. the analog outputs: the reading, else its replacement.

The replacements read the online calibration's [b_g, D] (systems/navigation/yaw_calibration.py) as it stood
before the sample: the gyro's reference and replacement are the gyro less b_g, and an excluded gyro's output
carries b_g back, which the navigation removes.
"""

import math

import numpy as np
from slipnav.systems.compiled import compiled, element_view, jitable, record_maker
from slipnav.systems.health.accelerometer_pair import (
    all_in,
    force_reference,
    pair_check,
    pair_constants,
    pair_omega_squared_update,
    pair_rotational_terms,
)
from slipnav.systems.health.analog import analog_checks, analog_constants, analog_outputs, checks_off
from slipnav.systems.health.encoders import (
    encoder_constants,
    encoder_increments,
    encoder_outputs,
    encoder_stuck_test,
    predicted_increment,
    previous_encoder_output,
)
from slipnav.systems.health.ground_speed import counter_rotation_test, ground_speed_update, wheel_speeds
from slipnav.systems.health.gyro import (
    body_yaw_rate,
    frozen_gyro_shadow,
    gyro_readmission,
    gyro_yaw_check,
    pair_witnesses,
    wheels_yaw_rate,
)
from slipnav.systems.health.layout import (
    ANALOG_EXCLUDED,
    ANALOG_REFERENCE,
    ENCODER_INCREMENT,
    PAIR_WITNESS,
    PREVIOUS_ODOMETRIC_SPEED,
    YAW_WITNESS,
)
from slipnav.systems.health.pair_gain import gain_constants
from slipnav.systems.health.parameters import (
    GYRO,
    NO_CURRENTS,
    NO_VELOCITY,
    NO_YAW_CALIBRATION,
    NUM_CHANNELS,
    SATURATED,
    HealthConstants,
    HealthGeometry,
    SensorHealthParameters,
    health_record,
)
from slipnav.systems.health.yaw_witness import yaw_constants


def health_constants(p: SensorHealthParameters, g: HealthGeometry) -> tuple:
    """The parameters and the geometry (health_record), with the figures the checks derive from them once
    (parameters.DERIVED_FIELDS: analog_constants, encoder_constants, pair_constants, gain_constants,
    yaw_constants), as one plain tuple in HealthConstants' order, as health_check takes them (a plain
    tuple crosses numba's boundary faster than a named tuple)."""
    record = health_record(p, g)
    derived = {}
    for constants in (analog_constants, encoder_constants, pair_constants, gain_constants, yaw_constants):
        derived.update(constants(record))
    return tuple(record._replace(**derived))


_health_record = record_maker(HealthConstants)
"""health_check's constants tuple as the HealthConstants named tuple."""


def health_step(
    state,
    raw,
    p: SensorHealthParameters,
    g: HealthGeometry,
    currents=NO_CURRENTS,
    velocity=NO_VELOCITY,
    tyre_peak: float = math.nan,
    yaw_calibration=NO_YAW_CALIBRATION,
):
    """Check one sample (module docstring): health_check with ``p`` and ``g``; ``currents``: the motor
    drivers' readings [i_R, i_L] (A) of the sample; ``velocity``: the navigation's body velocity
    (v_t, v_n) of the previous sample (m/s) and ``tyre_peak`` its identified tyre peak (m/s^2; NaN: the
    nominal), for the excluded gyro's replacement; ``yaw_calibration``: the online calibration's
    [b_g, D] as it stood before the sample, which the replacements of the gyro and an encoder read.

    Returns:
        (next state, accepted sample [a_t1, a_n1, a_t2, a_n2, omega, theta_R, theta_L], health codes (7)).
    """
    return health_check(
        np.asarray(state, float),
        tuple([float(v) for v in raw]),
        (float(currents[0]), float(currents[1])),
        health_constants(p, g),
        (float(velocity[0]), float(velocity[1])),
        float(tyre_peak),
        (float(yaw_calibration[0]), float(yaw_calibration[1])),
    )


@compiled
def health_check(
    state,
    raw: tuple,
    currents: tuple,
    constants: tuple,
    velocity: tuple = NO_VELOCITY,
    tyre_peak: float = math.nan,
    yaw_calibration: tuple = NO_YAW_CALIBRATION,
):
    """health_step with the parameters and the geometry as health_constants' tuple, the sample, the
    currents, the velocity and the yaw calibration as tuples of floats and the tyre peak a float
    (compiled with numba when available: systems/compiled.py)."""
    p = g = _health_record(constants)  # the parameters (p) and the geometry (g), one record
    bias, radius_difference = yaw_calibration  # b_g, D: what the replacements add to the nominal figures
    checked = state.copy()
    s = element_view(checked)  # indexed element by element (systems/compiled.py)
    if not p.enabled:  # NaN/inf only: hold the last valid value
        out, codes = checks_off(s, raw)
        return checked, out, codes
    codes = [0] * NUM_CHANNELS
    # 1. each analog channel alone; the excluded gyro's re-admission
    analog_checks(s, raw, bias, codes, p)
    gyro_readmission(s, raw, bias, codes, p, g)
    gyro_ok = codes[GYRO] == 0
    # 2. the encoders against the other wheel and the gyro
    gyro = raw[GYRO] - bias
    previous_output = previous_encoder_output(s)
    inc, first, in_block = encoder_increments(s, raw, gyro, radius_difference, gyro_ok, codes, p, g)
    counter_rotation_test(s, inc, gyro, radius_difference, gyro_ok, codes, p, g)
    ground_speed_update(s, raw, inc, gyro, radius_difference, gyro_ok, codes, p, g)
    predicted = [math.nan, math.nan]
    for w in range(2):
        if math.isfinite(inc[1 - w]) and gyro_ok:
            predicted[w] = predicted_increment(w, inc[1 - w], gyro, radius_difference, g)
    missed = encoder_stuck_test(s, raw, inc, predicted, codes, p, g)
    previous_increments = (s[ENCODER_INCREMENT][0], s[ENCODER_INCREMENT][1])
    out = list(raw)
    used = encoder_outputs(s, codes, inc, predicted, first, in_block, missed, previous_output, out)
    wheels, v_o = wheel_motion(used, radius_difference, velocity, tyre_peak, g)
    encoders_ok = codes[5] == 0 and codes[6] == 0
    # 3. the gyro against the wheels' witness
    model = encoders_ok and g.yaw_inertia > 0.0
    previous_omega = s[ANALOG_REFERENCE][GYRO]  # the pair's omega' differences against what it last used
    frozen_gyro_shadow(s, raw, bias, codes, wheels, encoders_ok, model, p, g)
    omega_wheels = wheels_yaw_rate(s, gyro_ok, wheels, model, g)
    if gyro_yaw_check(s, raw, bias, codes, wheels, encoders_ok, v_o, p, g):
        gyro_ok, omega_wheels = False, s[YAW_WITNESS]
    # 4. the accelerometer pair
    yaw_rate = gyro if gyro_ok else omega_wheels
    a_force = math.nan
    if encoders_ok:
        a_force = force_reference(currents, used, previous_increments, first, v_o, yaw_rate, g)
    pair_squared = pair_omega_squared_update(s, raw, p, g)
    omega_o = wheels[4]
    omega = body_yaw_rate(s, raw, bias, codes, gyro_ok, encoders_ok, omega_wheels, omega_o, pair_squared, p)
    rot, rot_dot = pair_rotational_terms(omega, previous_omega, g)
    # the fast test needs the gyro's omega' on this sample: a gyro trusted on the previous one too (the
    # first sample after a re-admission differences the gyro against its replacement)
    fast_known = gyro_ok and math.isfinite(s[ANALOG_REFERENCE][GYRO]) and s[ANALOG_EXCLUDED][GYRO] == 0.0
    moving = used[0] != 0.0 or used[1] != 0.0  # the wheels turned
    pair_check(s, raw, codes, rot, rot_dot, omega, a_force, v_o, moving, fast_known, p, g)
    s[PREVIOUS_ODOMETRIC_SPEED] = v_o
    s[PAIR_WITNESS] = 1.0 if all_in(codes[0:4], (0,)) and pair_witnesses(raw, g) else 0.0
    # 5. the analog outputs
    if codes[GYRO] == SATURATED:
        replacement = omega  # the pair's yaw rate, or the wheels'
    elif encoders_ok:
        replacement = omega_wheels
    else:
        replacement = s[ANALOG_REFERENCE][GYRO]
    rotation = (rot[0] + rot_dot[0], rot[1] + rot_dot[1])
    analog_outputs(s, raw, bias, codes, replacement, rotation, p.analog_present, out)
    return checked, out, codes


@jitable
def wheel_motion(used, radius_difference: float, velocity, tyre_peak: float, g) -> tuple:
    """The wheels' motion from this sample's encoder increments ``used`` (rad): ((v_R, v_L, v_t, v_n,
    omega_o, grip), v_o). v_R, v_L are calibrated by the rolling-radius difference D (m/s) and omega_o =
    (v_R - v_L) / b their yaw rate, omega_o + D v_o / b (rad/s); v_t, v_n the navigation's body velocity
    (``velocity``; the odometric v_o and no v_n when NaN); grip the identified ``tyre_peak`` over the
    nominal curve's (1 when NaN or none)."""
    v_R, v_L = wheel_speeds(used, g)
    v_o = 0.5 * (v_R + v_L)
    v_R, v_L = v_R + 0.5 * radius_difference * v_o, v_L - 0.5 * radius_difference * v_o  # calibrated
    omega_o = (v_R - v_L) / g.track_width
    v_t, v_n = (velocity[0], velocity[1]) if math.isfinite(velocity[0] + velocity[1]) else (v_o, 0.0)
    grip = tyre_peak / g.tyre_peak_acceleration if g.tyre_peak_acceleration > 0.0 else math.nan
    grip = grip if 0.0 < grip < math.inf else 1.0
    return (v_R, v_L, v_t, v_n, omega_o, grip), v_o
