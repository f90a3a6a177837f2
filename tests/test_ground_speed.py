"""The counter-rotation test (systems/health/ground_speed.py): an encoder that reads its wheel turning
against the ground beneath it, by hand and on synthetic streams."""

import math

import numpy as np
from slipnav.systems.health import INCONSISTENT, HealthConstants, SensorHealthParameters
from slipnav.systems.health.check import health_constants
from slipnav.systems.health.ground_speed import (
    counter_rotation_test,
    ground_speed_update,
    runs_against,
)
from slipnav.systems.health.layout import ENCODER_OPPOSED, ENCODER_SUSPECT, GROUND_SPEED, health_initial_state

from tests.test_faults import GEOMETRY, T_N, B, R, check, stream

CONSTANTS = HealthConstants(*health_constants(SensorHealthParameters(), GEOMETRY))


def increments(v_R, v_L):
    """The increments (rad) of the wheel speeds v_R, v_L (m/s) over one T_N."""
    return [v_R * T_N / R, v_L * T_N / R]


def test_runs_against_by_hand():
    """Opposite in sign to both witnesses, all three beyond 0.1 m/s."""
    assert runs_against(-0.2, 0.2, 0.3, 0.1)
    assert runs_against(0.2, -0.15, -0.11, 0.1)
    assert not runs_against(-0.2, 0.2, -0.3, 0.1)  # witness (c) agrees with the reading
    assert not runs_against(-0.2, -0.2, 0.3, 0.1)  # witness (a) agrees
    assert not runs_against(-0.1, 0.2, 0.3, 0.1)  # a reading at the floor
    assert not runs_against(-0.2, 0.2, 0.1, 0.1)  # a witness at the floor
    assert not runs_against(0.0, 0.2, 0.3, 0.1)  # a held wheel


def test_the_ground_speed_is_anchored_where_the_wheels_agree_by_hand():
    """Wheels at 0.5 m/s both, gyro 0: the yaw residual 0 is within 0.1 + 0.2 x 0 m/s, the witness is
    v_o = 0.5. Then v_R 0.5, v_L -0.5, gyro 0: the residual 1.0 m/s exceeds 0.1 + 0.2 x 1.0, so the
    witness advances by T_N x the tangential accelerometers' mean (1 + 3) / 2: 0.5 + 0.004. A wheel turning
    the robot in place at 2 rad/s (v_R - v_L = b x 2 = 0.136 m/s, residual 0) anchors on v_o again."""
    s = health_initial_state(GEOMETRY, 0.0)
    codes = [0] * 7
    raw = (1.0, 0.0, 3.0, 0.0, 0.0, 0.0, 0.0)
    ground_speed_update(s, raw, increments(0.5, 0.5), 0.0, 0.0, True, codes, CONSTANTS, CONSTANTS)
    assert s[GROUND_SPEED] == 0.5
    ground_speed_update(s, raw, increments(0.5, -0.5), 0.0, 0.0, True, codes, CONSTANTS, CONSTANTS)
    assert math.isclose(s[GROUND_SPEED], 0.504, rel_tol=1e-12)
    ground_speed_update(s, raw, increments(0.068, -0.068), 2.0, 0.0, True, codes, CONSTANTS, CONSTANTS)
    assert abs(s[GROUND_SPEED]) < 1e-15
    # an untrusted gyro or an encoder out: no anchoring, the accelerometers carry the witness on
    ground_speed_update(s, raw, increments(0.5, 0.5), 0.0, 0.0, False, codes, CONSTANTS, CONSTANTS)
    assert math.isclose(s[GROUND_SPEED], 0.004, rel_tol=1e-12)
    out = [0, 0, 0, 0, 0, 0, INCONSISTENT]
    ground_speed_update(s, raw, increments(0.5, 0.5), 0.0, 0.0, True, out, CONSTANTS, CONSTANTS)
    assert math.isclose(s[GROUND_SPEED], 0.008, rel_tol=1e-12)


def test_the_counter_rotation_count_by_hand():
    """Ground 0.3 m/s, gyro 0, v_R 0.3, v_L -0.3: the left reading runs against (a) v_R = 0.3 and (c)
    0.3; the right one runs with (c), so only the left counts. Flagged on the tenth sample in a row
    (2 x stuck_samples 5), its increment dropped; an agreeing sample restarts the count."""
    s = health_initial_state(GEOMETRY, 0.3)
    for n in range(1, 11):
        codes, inc = [0] * 7, increments(0.3, -0.3)
        counter_rotation_test(s, inc, 0.0, 0.0, True, codes, CONSTANTS, CONSTANTS)
        assert s[ENCODER_OPPOSED][1] == n and s[ENCODER_OPPOSED][0] == 0.0
        assert codes[6] == (INCONSISTENT if n == 10 else 0) and codes[5] == 0
    assert math.isnan(inc[1]) and s[ENCODER_SUSPECT][1] == 1.0
    codes, inc = [0] * 7, increments(0.3, 0.3)
    counter_rotation_test(s, inc, 0.0, 0.0, True, codes, CONSTANTS, CONSTANTS)
    assert s[ENCODER_OPPOSED][1] == 0.0 and not any(codes)
    # without a trusted gyro there is no test
    s[ENCODER_OPPOSED][1] = 9.0
    codes, inc = [0] * 7, increments(0.3, -0.3)
    counter_rotation_test(s, inc, 0.0, 0.0, False, codes, CONSTANTS, CONSTANTS)
    assert s[ENCODER_OPPOSED][1] == 0.0 and not any(codes)


def sign_flipped(rows, start):
    """The left encoder's increments negated from sample ``start`` on."""
    flipped = rows.copy()
    flipped[start:, 6] = rows[start - 1, 6] - (rows[start:, 6] - rows[start - 1, 6])
    return flipped


def test_a_sign_flipped_encoder_is_excluded_and_replaced():
    """At 0.15 m/s the flip changes the left wheel's speed by 0.30 m/s, within the jump bound (150 m/s^2
    x T_N + two counts = 0.315 m/s): the counter-rotation test flags it on its tenth flipped increment,
    and the output follows the wheel (v_R - b omega_gyro: the gyro's noise) while the count runs
    backward; the encoder stays out while it moves against the prediction."""
    v = 0.15
    clean = stream(600, v, 0.0)
    out, codes = check(sign_flipped(clean, 200), v0=v)
    assert not codes[:209].any() and codes[209, 6] == INCONSISTENT
    assert np.all(codes[209:, 6] != 0) and not codes[:, :6].any()
    drift = 3 * math.sqrt(400) * B * 0.014 * T_N / R + 9 * 2 * v * T_N / R  # noise; the 9 flipped samples
    assert np.max(np.abs(out[:, 6] - clean[:, 6])) < drift


def test_wheels_that_turn_with_the_ground_raise_no_flag():
    """A spin in place (0.136 m/s each way), a pivot about the held left wheel (the right at 0.2 m/s)
    and a slow turn: each wheel turns with the ground beneath it."""
    for v, omega in ((0.0, 4.0), (0.0, -4.0), (0.1, 2 * 0.1 / B), (0.3, 1.0)):
        _, codes = check(stream(800, v, omega), v0=v)
        assert not codes.any(), (v, omega)
