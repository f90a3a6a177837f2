"""The wheels' witness of the gyro and the yaw test (systems/health/yaw_witness.py): the residual's variance,
the tyres' grip, the yaw lag, the decision with the accelerometer pair, and the gyro held out by the
test until a turn agrees again (systems/health/); numbers by hand."""

import dataclasses as dc
import math
from types import SimpleNamespace

import numpy as np
import pytest
from slipnav.scenarios.config import load_scenario
from slipnav.scenarios.metrics import final_position_error
from slipnav.scenarios.runner import run_scenario
from slipnav.systems.health import (
    INCONSISTENT,
    HealthConstants,
    SensorHealthParameters,
    health_constants,
)
from slipnav.systems.health.accelerometer_pair import pair_omega_squared
from slipnav.systems.health.check import health_step
from slipnav.systems.health.gyro import pair_witnesses
from slipnav.systems.health.layout import health_initial_state
from slipnav.systems.health.yaw_witness import (
    CUSUM,
    LATERAL_GYRO,
    LATERAL_WHEELS,
    MIN_YAW_LAG_STEPS,
    YAW_CLIP,
    YAW_DRIFT,
    gyro_yaw_test,
    lateral_update,
    lateral_variance,
    side_log_likelihood,
    tyre_grip,
    yaw_lag_at_floor,
    yaw_residual_variance,
    yaw_test_initial_state,
    yaw_test_threshold,
)
from slipnav.systems.navigation.parameters import NavigationParameters, health_geometry
from slipnav.systems.robot.faults import FaultEvent
from slipnav.systems.robot.parameters import kurt3d, tinyphoon

from tests.test_exclusion import check_with_bias
from tests.test_faults import GEOMETRY, STEP, T_N, B, R, stream

CONSTANTS = HealthConstants(*health_constants(SensorHealthParameters(), GEOMETRY))


def test_the_residual_variance_by_hand():
    """S = 0.014^2 + q^2 / 3 + (0.2 w)^2 + (0.02 w')^2 with q = (2 pi / 6144) 0.015 / (0.068 0.002) =
    0.1128 rad/s."""
    q = STEP * R / (B * T_N)
    assert q == pytest.approx(0.11280, abs=1e-5)
    for witness, rate in ((0.0, 0.0), (3.0, 0.0), (1.0, 30.0)):
        expected = 0.014**2 + q * q / 3 + (0.2 * witness) ** 2 + (0.02 * rate) ** 2
        assert yaw_residual_variance(witness, rate, CONSTANTS) == pytest.approx(expected, rel=1e-12)


def test_the_threshold_gives_one_false_alarm_an_hour():
    """h for 3600 s / 2 ms = 1.8e6 samples between false alarms at k = 0.5 (Siegmund): about 13.2."""
    assert yaw_test_threshold(3600.0, T_N) == pytest.approx(13.24, abs=0.01)
    assert (YAW_DRIFT, YAW_CLIP) == (0.5, 4.0)


def test_the_tyres_grip_in_their_linear_range_and_not_past_the_peak():
    """Tinyphoon's curve (B 15, C 1.3): at zero slip the stiffness ratio is 1; a wheel at 1.02 m/s on
    ground at 1 m/s slips 0.02 / 1.02, B sigma = 0.294: cos(1.3 atan 0.294) / 1.0865 = 0.857; at -0.1
    it is cos(1.3 atan 1.5) / 3.25 = 0.157 (past half)."""
    robot = tinyphoon()
    g = SimpleNamespace(track_width=0.068, tyre_stiffness_factor=15.0, tyre_shape_factor=1.3)
    g.slip_speed_floor = 0.3
    assert robot.tyre_stiffness_factor == 15.0 and robot.tyre_shape_factor == 1.3
    assert tyre_grip(1.0, 1.0, 1.0, 0.0, 0.0, g) == pytest.approx(1.0)
    b_sigma = 15.0 * 0.02 / 1.02
    ratio = math.cos(1.3 * math.atan(b_sigma)) / (1.0 + b_sigma * b_sigma)
    assert tyre_grip(1.02, 1.0, 1.0, 0.0, 0.0, g) == pytest.approx(ratio, rel=1e-9)
    assert ratio == pytest.approx(0.857, abs=1e-3)
    past_peak = math.cos(1.3 * math.atan(1.5)) / 3.25
    assert tyre_grip(0.9, 0.9, 1.0, 0.0, 0.0, g) == pytest.approx(past_peak, rel=1e-9)
    assert past_peak < 0.5


def test_the_yaw_lag_decides_whether_the_yaw_dynamics_witness():
    """I_z / ((b/2)^2 2 mu N C B / 0.3): Tinyphoon 2.27 ms and Kurt3D 1.85 ms step at T_N = 2 ms; a
    TurtleBot's 0.23 m track with Tinyphoon's yaw inertia lags 0.20 ms, below a quarter sample."""
    assert yaw_lag_at_floor(tinyphoon()) == pytest.approx(2.271e-3, rel=1e-3)
    assert yaw_lag_at_floor(kurt3d()) == pytest.approx(1.851e-3, rel=1e-3)
    turtle = dc.replace(tinyphoon(), track_width=0.23)
    assert yaw_lag_at_floor(turtle) == pytest.approx(0.1985e-3, rel=1e-3)
    assert yaw_lag_at_floor(turtle) < MIN_YAW_LAG_STEPS * T_N < yaw_lag_at_floor(kurt3d())
    no_tyres = SimpleNamespace(tyre_friction=0.0, wheel_normal_load=1.0, tyre_shape_factor=1.3)
    no_tyres.tyre_stiffness_factor, no_tyres.yaw_inertia, no_tyres.track_width = 15.0, 1e-3, 0.1
    assert yaw_lag_at_floor(no_tyres) == math.inf


def test_a_gyro_half_again_too_large_in_a_turn_raises_the_alarm_in_its_fifth_sample():
    """A 3 rad/s turn read as 4.5: z = 1.5 / sqrt(0.014^2 + 0.1128^2 / 3 + 0.6^2) = 2.485 per sample, so
    the CUSUM gains 1.985 a sample and passes h = 13.24 in the seventh, which restarts the sums; a pair
    whose |omega| (4.5 +- its noise) is nearer the wheels' 3.0 blames the gyro, one that sides with the
    gyro exonerates it, and without the pair (NaN) the two witnesses cannot be told apart: the gyro
    stays in."""
    z = 1.5 / math.sqrt(yaw_residual_variance(3.0, 0.0, CONSTANTS))
    assert z == pytest.approx(2.485, abs=0.001)
    state = np.array(yaw_test_initial_state())
    alarms = [gyro_yaw_test(state, 4.5, 3.0, 0.0, 3.0**2, 1.0, CONSTANTS) for _ in range(7)]
    assert alarms == [False] * 6 + [True] and not state[CUSUM].any()
    state = np.array(yaw_test_initial_state())
    alarms = [gyro_yaw_test(state, 4.5, 3.0, 0.0, math.nan, 1.0, CONSTANTS) for _ in range(6)]
    assert not any(alarms) and state[CUSUM].any()
    assert not gyro_yaw_test(state, 4.5, 3.0, 0.0, math.nan, 1.0, CONSTANTS) and not state[CUSUM].any()
    state = np.array(yaw_test_initial_state())
    alarms = [gyro_yaw_test(state, 4.5, 3.0, 0.0, 4.5**2, 0.0, CONSTANTS) for _ in range(7)]
    assert not any(alarms)


def test_the_lateral_variance_by_hand():
    """At 1 m/s and v_t omega = 1 m/s^2 on Tinyphoon's data sheet: the commotion's correlation phi =
    exp(-0.002 / 0.005) = 0.67032 multiplies 0.3^2 by 1.67032 / 0.32968 = 5.0665; with the white noise
    (0.062^2) over two sensors and 2 x 15 - 1 samples, (0.003844 + 0.45599) / 58 = 0.0079282; the mean's
    initial bias 0.05^2 / 2 = 0.00125 and the side slip (0.1 x 1)^2 = 0.01: 0.0191782 m^2/s^4."""
    assert lateral_variance(1.0, 1.0, CONSTANTS) == pytest.approx(0.0191782, rel=1e-5)
    assert lateral_variance(0.0, 0.0, CONSTANTS) == pytest.approx(0.003844 / 58 + 0.00125, rel=1e-5)


def test_the_lateral_acceleration_decides_between_the_gyro_and_the_wheels():
    """A turn at 1 m/s whose accelerometers read a_n = v_t omega = 1 m/s^2 (omega = 1 rad/s), no pair:
    - the wheels read 1.6 rad/s (a scaled encoder): the averages of a_n - v_t omega are 0 (gyro) and
      -0.6 (wheels); at v_t omega = 1.6 the variance is 0.0079282 + 0.00125 + 0.16^2 = 0.0347782 and the
      log-likelihood ratio 0.36 / (2 x 0.0347782) = 5.176 > 2 for the gyro: on the alarm it stays in;
    - the gyro reads -1 (a sign flip): the averages are 2 (gyro) and 0 (wheels), the ratio
      -4 / (2 x 0.0191782) = -104.3: on the alarm the gyro is blamed;
    - no a_n (NaN) restarts the averages and leaves no third witness: the gyro stays in."""
    state = np.array(yaw_test_initial_state())
    lateral_update(state, 1.0, 1.0, 1.0, 1.6, CONSTANTS)
    assert (state[LATERAL_GYRO], state[LATERAL_WHEELS]) == pytest.approx((0.0, -0.6))
    assert side_log_likelihood(state, 1.0, 1.6, math.nan, 1.0, CONSTANTS) == pytest.approx(5.176, abs=1e-3)
    alarms = [gyro_yaw_test(state, 1.0, 1.6, 0.0, math.nan, 1.0, CONSTANTS) for _ in range(40)]
    assert not any(alarms) and state[CUSUM].any()  # alarms restart the sums, the gyro stays in
    state = np.array(yaw_test_initial_state())
    for _ in range(3):
        lateral_update(state, 1.0, 1.0, -1.0, 1.0, CONSTANTS)
    assert side_log_likelihood(state, -1.0, 1.0, math.nan, 1.0, CONSTANTS) == pytest.approx(-104.3, abs=0.1)
    alarms = [gyro_yaw_test(state, -1.0, 1.0, 0.0, math.nan, 1.0, CONSTANTS) for _ in range(4)]
    assert alarms == [False] * 3 + [True] and not state[CUSUM].any()  # |z| clipped at 4: 3.5 a sample
    lateral_update(state, math.nan, 1.0, -1.0, 1.0, CONSTANTS)
    assert math.isnan(state[LATERAL_GYRO])
    assert math.isnan(side_log_likelihood(state, -1.0, 1.0, math.nan, 1.0, CONSTANTS))


def test_the_pair_witnesses_only_apart_finite_two_and_not_copied():
    g = SimpleNamespace(accelerometer_position=(0.02, 0.015), accelerometer_sets=2)
    assert pair_witnesses((0.1, 0.2, 0.3, 0.4, 1.0, 0.0, 0.0), g)
    assert not pair_witnesses((0.1, 0.2, 0.1, 0.2, 1.0, 0.0, 0.0), g)  # one IMU in both sets
    assert pair_witnesses((0.1, 0.2, 0.1, 0.25, 1.0, 0.0, 0.0), g)
    assert not pair_witnesses((0.1, math.nan, 0.3, 0.4, 1.0, 0.0, 0.0), g)
    at_one_point = SimpleNamespace(accelerometer_position=(0, 0), accelerometer_sets=2)
    assert not pair_witnesses((0.1, 0.2, 0.3, 0.4, 1.0, 0.0, 0.0), at_one_point)
    one_set = SimpleNamespace(accelerometer_position=(0.02, 0.015), accelerometer_sets=1)
    assert not pair_witnesses((0.1, 0.2, 0.3, 0.4, 1.0, 0.0, 0.0), one_set)  # set 2's columns not read
    assert math.isnan(pair_omega_squared((0.1, 0.2, 0.3, 0.4), (0.0, 0.0)))


def test_a_scaled_gyro_is_not_held_out_when_one_imu_fills_both_sets():
    """The turn of test_a_scaled_gyro_is_held_out_until_a_turn_agrees with accelerometer 1's readings
    copied into accelerometer 2's: the wheels and the gyro disagree, nothing tells which one is wrong,
    and the gyro stays in."""
    rows = stream(1500, 1.0, 0.8)
    rows[500:800, 4] *= 1.5
    rows[:, 2:4] = rows[:, 0:2]
    codes, _ = check_with_bias(rows)
    assert not codes[:, 4].any()


def test_a_scaled_gyro_is_held_out_until_a_turn_agrees():
    """The checks on a 0.8 rad/s turn at 1 m/s with the gyro x1.5 from sample 500 to 800 (0.4 rad/s off,
    within the jump bound): z = 0.4 / sqrt(0.014^2 + 0.1128^2 / 3 + 0.16^2) = 2.3 holds it out
    (inconsistent) from within 10 samples of the onset to its end, and it is re-admitted by the first
    block that turned 0.05 rad (32 samples at 0.8 rad/s) and agrees in sum, which ends after it. The
    same gyro x1.5 in a straight (no turn) raises nothing: the test judges turns."""
    rows = stream(1500, 1.0, 0.8)
    rows[500:800, 4] *= 1.5
    codes, _ = check_with_bias(rows)
    flagged = np.flatnonzero(codes[:, 4])
    assert not codes[:500].any() and 500 < flagged[0] <= 510
    assert np.all(codes[flagged[0] : 800, 4] == INCONSISTENT)
    assert 800 + 5 <= flagged[-1] <= 800 + 45 and not codes[flagged[-1] + 1 :].any()
    rows = stream(1500, 1.0, 0.0)
    rows[500:800, 4] = 1.5 * rows[500:800, 4]
    codes, _ = check_with_bias(rows)
    assert not codes.any()


@pytest.mark.parametrize("side_slip", [-0.1, -0.3])
def test_the_gyro_is_judged_whatever_side_slip_the_navigation_integrated(side_slip):
    """On Tinyphoon's tyre curve the 0.8 rad/s turn at 1 m/s with the gyro x1.3 from sample 500: the
    navigation that integrates a_n - v_t omega with that gyro gains a side slip of 0.24 m/s^2 (-0.1 m/s in
    0.4 s), which puts its tyres past the peak (B sigma = 15 x 0.1 = 1.5). The test reads the wheels'
    grip along their rolling direction: the gyro is held out from within 15 samples of the onset to the
    fault's end, as with no side slip, and re-admitted within 45 samples of it (the replacement's yaw
    dynamics read the side slip)."""
    geometry = health_geometry(NavigationParameters(), R, B, T_N, robot=tinyphoon())
    rows = stream(1500, 1.0, 0.8)
    rows[500:800, 4] *= 1.3
    flagged = {}
    for v_n in (0.0, side_slip):
        state, codes = health_initial_state(geometry, 1.0), []
        for row in rows:
            state, _, code = health_step(state, row, SensorHealthParameters(), geometry, velocity=(1.0, v_n))
            codes.append(code[4])
        flagged[v_n] = np.flatnonzero(codes)
    assert 500 < flagged[0.0][0] <= 515
    for v_n in (0.0, side_slip):
        held = flagged[v_n][flagged[v_n] < 800]
        np.testing.assert_array_equal(held, np.arange(flagged[0.0][0], 800))
        assert 800 < flagged[v_n][-1] <= 800 + 45


@pytest.mark.parametrize("scale", [1.05, 1.1])
def test_a_scaled_encoder_in_a_turn_leaves_the_gyro_in(scale):
    """The 0.8 rad/s turn at 1 m/s with the right encoder's increments x1.05 (x1.1) from sample 500: the
    wheel reads 1.0272 x 0.05 = 0.051 m/s more, so the wheels' yaw rate runs 0.755 (1.51) rad/s above the
    gyro's 0.8 and the yaw test alarms; the accelerometers' a_n = v omega = 0.8 m/s^2 fits the gyro
    (a_n - v omega 0) and not the wheels (-0.755), a log-likelihood ratio of 0.57 / (2 x 0.0334) = 8.5
    for the gyro at the first: the gyro is never held out."""
    rows = stream(1500, 1.0, 0.8)
    rows[500:, 5] = rows[499, 5] + scale * (rows[500:, 5] - rows[499, 5])
    codes, _ = check_with_bias(rows)
    assert not codes[:, 4].any()


@pytest.mark.parametrize("value", [-2.0, 0.5, -0.5])
def test_closed_loop_gyro_scale_faults_are_caught_in_the_first_turn(value):
    """The corner with the gyro x(1 + value) from 1.5 s to the end (a sign flip, x1.5, x0.5): flagged
    inconsistent within 0.1 s of the turn's start (2.0 s), the run completes and the fused final error is
    below both baselines'."""
    event = FaultEvent("scale", "gyro", 1.5, 100.0, value)
    run = run_scenario(load_scenario("corner"), seed=0, faults=[event])
    a = run.arrays
    t, codes = a["t"], a["health_gyro"]
    first = t[np.flatnonzero(codes == INCONSISTENT)[0]]
    assert 2.0 < first < 2.2
    assert run.summary["completed"]
    fused = final_position_error(a, "est")
    assert fused < min(final_position_error(a, "odo"), final_position_error(a, "gyro"))


def test_a_gyro_the_yaw_test_holds_out_is_readmitted_by_that_tests_allowance():
    """The 0.8 rad/s turn at 1 m/s with the gyro x1.28 from sample 500 to the end (0.22 rad/s off, within
    the jump bound): z = 0.22 / sqrt(0.014^2 + 0.1128^2 / 3 + 0.16^2) = 1.25 a sample holds it out within
    20 samples, and it stays out to the end: its re-admission block sums 28 % of the replacement's yaw
    rate, beyond the 20 % (yaw_slip_fraction) the test allows the tyres' differential slip."""
    rows = stream(1500, 1.0, 0.8)
    rows[500:, 4] *= 1.28
    codes, _ = check_with_bias(rows)
    flagged = np.flatnonzero(codes[:, 4])
    assert not codes[:500].any() and 500 < flagged[0] <= 520
    assert np.all(codes[flagged[0] :, 4] == INCONSISTENT)
