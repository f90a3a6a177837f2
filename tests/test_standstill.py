"""Standstill as a measurement (systems/navigation/standstill.py): the test against hand-computed values, the
accelerometer biases' Kalman filter, and the navigation at rest with drifting biases."""

import math

import numpy as np
import pytest
from slipnav.systems.navigation.loop import NavigationLoop, run_navigation_loop
from slipnav.systems.navigation.parameters import NavigationBelief, NavigationParameters, health_geometry
from slipnav.systems.navigation.standstill import (
    StandstillParameters,
    StandstillState,
    accelerometer_biases,
    bias_free,
    standstill_constants,
    standstill_initial_state,
    standstill_step,
    standstill_test,
    zero_velocity_update,
)
from slipnav.systems.rates import SampleRates
from slipnav.systems.robot.sensors import SensorParameters

T_N = 0.002
RATES = SampleRates(T_N, 0.02)
GEOMETRY = health_geometry(NavigationParameters(), 0.015, 0.068, T_N)  # Tinyphoon's data sheet


def constants(**changes):
    return standstill_constants(StandstillParameters(**changes), GEOMETRY, T_N)


def test_constants_follow_the_data_sheet():
    c = constants()
    a = T_N / (0.02 + T_N)
    assert c.average_gain == pytest.approx(a)
    assert c.gate == pytest.approx(-2 * math.log(1e-3))  # chi-square, 2 dof: 1 - F(x) = exp(-x / 2)
    assert c.accel_mean_average_variance == pytest.approx(0.062**2 / 2 * a / (2 - a))
    assert c.bias_drift_variance == pytest.approx(0.0065**2 * T_N)
    assert c.still_samples == 25


def test_wheels_witness_a_standstill_only_after_still_time():
    c = constants()
    state = standstill_initial_state(c)
    quiet = [0.0] * 4
    for k in range(c.still_samples):
        standing, test = standstill_test(state, quiet, 0.0, [1.0, 2.0], c)
        # the first sample sees the angles for the first time (the initial angles are NaN)
        assert test[0] == k
        assert not standing
        state = standstill_step(state, quiet, [1.0, 2.0], standing, test, c)
    standing, _ = standstill_test(state, quiet, 0.0, [1.0, 2.0], c)
    assert standing
    # one encoder count resets the wheels' witness
    standing, test = standstill_test(state, quiet, 0.0, [1.0, 2.0 + 1e-3], c)
    assert not standing and test[0] == 0.0


def stood_state(c, **fields):
    state = standstill_initial_state(c)
    view = StandstillState(state)
    view.still_samples, view.theta_R, view.theta_L = c.still_samples, 0.0, 0.0
    for name, value in fields.items():
        setattr(view, name, value)
    return state


def test_inertial_statistic_against_the_gate():
    c = constants()
    state = stood_state(c)
    a = c.average_gain
    sigma_b2 = 0.05**2  # the initial bias variance of every axis
    variance_t = c.accel_mean_average_variance + 0.25 * 2 * sigma_b2
    # a lateral mean reading m moves the average to a m; the statistic is (a m)^2 / variance_t
    m_edge = math.sqrt(c.gate * variance_t) / a
    standing, test = standstill_test(state, [0.0, 0.99 * m_edge, 0.0, 0.99 * m_edge], 0.0, [0, 0], c)
    assert standing and test[3] == pytest.approx(a * 0.99 * m_edge)
    standing, _ = standstill_test(state, [0.0, 1.01 * m_edge, 0.0, 1.01 * m_edge], 0.0, [0, 0], c)
    assert not standing
    # both axes count: at 0.8 of the edge on each the statistic is 1.28 times the gate
    assert not standstill_test(state, [0.8 * m_edge] * 4, 0.0, [0, 0], c)[0]
    # the gyro is outvoted by the two witnesses: a bias of 0.1 rad/s does not stop the ZUPT, and its
    # average is the gyro's residual
    standing, test = standstill_test(state, [0.0] * 4, 0.1, [0, 0], c)
    assert standing and test[1] == pytest.approx(0.1 * a)


def test_locked_wheels_in_a_slide_are_no_standstill():
    c = constants()
    state = stood_state(c, a_t_average=-6.0)  # braking at the friction limit with the wheels locked
    assert not standstill_test(state, [-7.0, 0.0, -7.0, 0.0], 0.0, [0, 0], c)[0]


def test_bias_kalman_filter_by_hand():
    c = constants()
    state = stood_state(c)
    reading = [0.1, -0.2, 0.05, 0.0]
    standing, test = standstill_test(state, bias_free(state, reading), 0.0, [0, 0], c)
    after = standstill_step(state, reading, [0, 0], True, test, c)
    P = 0.05**2 + 0.0065**2 * T_N
    K = P / (P + 0.062**2)
    assert accelerometer_biases(after) == pytest.approx([K * r for r in reading])
    assert StandstillState(after).variance_t1 == pytest.approx((1 - K) * P)
    # moving: prediction only
    moving = standstill_step(state, reading, [0, 0], False, test, c)
    assert accelerometer_biases(moving) == [0.0] * 4
    assert StandstillState(moving).variance_n2 == pytest.approx(P)
    assert bias_free(after, reading) == pytest.approx([(1 - K) * r for r in reading])


def test_zero_velocity_update_restarts_the_check_from_rest():
    mixed, check = zero_velocity_update(np.array([0.1, 0.2, 0.3, 0.4, 0.5]), (0.3, 0.2, 5.5, 1.0, 2.0))
    assert mixed.tolist() == [0.0] * 5 and check == (0.0, 0.0, 5.5, 1.0, 2.0)


def rest_streams(seconds, seed, drift_density, gyro_bias=0.002, gyro_step=0.0):
    """Sensor rows of a robot at rest: white noise (Tinyphoon's data sheet) on biases that random-walk at
    ``drift_density`` (m/s^2 per sqrt(s)) from the data sheet's initial spread; encoders still."""
    rng = np.random.default_rng(seed)
    sheet = SensorParameters()
    N = int(round(seconds / T_N))
    steps = drift_density * math.sqrt(T_N) * rng.standard_normal((N, 4))
    bias = sheet.accel_initial_bias_std * rng.standard_normal(4) + np.cumsum(steps, axis=0)
    accelerometers = bias + sheet.accel_noise_std * rng.standard_normal((N, 4))
    gyro_walk = np.cumsum(sheet.gyro_drift_density * math.sqrt(T_N) * rng.standard_normal(N))
    gyro = gyro_bias + gyro_walk + sheet.gyro_noise_std * rng.standard_normal(N)
    gyro[N // 2 :] += gyro_step
    return accelerometers, gyro, np.zeros((N, 2)), bias


def test_the_pose_holds_at_rest_while_the_biases_drift():
    """60 s at rest with the biases drifting sqrt(10) times faster than the data sheet says (as far as
    10 min at the data sheet's density): the pose moves < 1 cm and the biases are tracked."""
    accelerometers, gyro, encoders, bias = rest_streams(60.0, 3, 0.0065 * math.sqrt(10.0))
    loop = NavigationLoop(NavigationBelief(NavigationParameters(), 0.015, 0.068, RATES))
    out = run_navigation_loop(loop, accelerometers, gyro, encoders)
    moved = math.hypot(out["est_x"][-1], out["est_y"][-1])
    assert moved < 0.01
    assert abs(out["est_phi"][-1]) < 0.01
    assert out["standstill"][1000:].mean() > 0.99
    learned = np.array([out[f"est_accel_bias_{axis}"][-1] for axis in ("t1", "n1", "t2", "n2")])
    assert np.abs(learned - bias[-1]).max() < 0.03  # the drift over the last seconds, several sigma
    # without the measurement the first 10 s of the same streams already move the pose farther
    params = NavigationParameters()
    params.standstill.enabled = False
    loop = NavigationLoop(NavigationBelief(params, 0.015, 0.068, RATES))
    off = run_navigation_loop(loop, accelerometers[:5000], gyro[:5000], encoders[:5000])
    assert off["standstill"].max() == 0.0
    assert math.hypot(off["est_x"][-1], off["est_y"][-1]) > 10 * moved


def test_rejections_at_rest_stay_near_the_false_rejection_rate():
    """Fault-free rest: after the biases have settled the accelerometers' test rejects about
    false_rejection of the samples (the PT1's samples are correlated, so a factor 5 of margin). 25 s
    settled, 12 500 samples: rejected 0.06 % (seeds 1 and 2: 0.05 %, 0.12 %; over 55 s before: 0.05 %)."""
    accelerometers, gyro, encoders, _ = rest_streams(30.0, 7, 0.0065)
    loop = NavigationLoop(NavigationBelief(NavigationParameters(), 0.015, 0.068, RATES))
    out = run_navigation_loop(loop, accelerometers, gyro, encoders)
    rejected = 1.0 - out["standstill"][2500:].mean()  # from 5 s on
    assert rejected < 5 * StandstillParameters().false_rejection


def test_a_gyro_bias_step_at_rest_moves_neither_position_nor_heading():
    """At rest the wheels and the accelerometers outvote a gyro whose bias stepped by 0.1 rad/s: the
    ZUPT holds the heading (the yaw calibration's gate does not learn so large a step)."""
    accelerometers, gyro, encoders, _ = rest_streams(10.0, 5, 0.0065, gyro_step=0.1)
    loop = NavigationLoop(NavigationBelief(NavigationParameters(), 0.015, 0.068, RATES))
    out = run_navigation_loop(loop, accelerometers, gyro, encoders)
    assert out["standstill"][2500:].mean() > 0.99
    assert abs(out["est_phi"][-1]) < 1e-3 and math.hypot(out["est_x"][-1], out["est_y"][-1]) < 1e-4
    assert abs(out["odo_phi"][-1]) < 1e-12  # the odometry-only baseline holds as well
