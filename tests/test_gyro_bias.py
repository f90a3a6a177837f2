"""Gyro bias estimate (systems/gyro_bias.py): the weighted mean by hand, the gates, the encoders'
quantisation telescoping, the LeafSystem against the step function, and the square's heading."""

import dataclasses as dc
import math

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator
from slipnav.scenarios.config import load_scenario
from slipnav.scenarios.runner import run_scenario
from slipnav.studies.error_budget import papers_heading, replay
from slipnav.systems.gyro_bias import (
    GyroBiasEstimator,
    GyroBiasParameters,
    gyro_bias_initial_state,
    gyro_bias_step,
)
from slipnav.systems.odometry import odometry_step

T_N = 0.002


def run_steps(state, samples, p):
    """samples: iterable of (gyro, odometric omega, C1, fault)."""
    for gyro, omega, c1, fault in samples:
        state = gyro_bias_step(state, gyro, omega, c1, fault, p, T_N)
    return state


def test_bias_is_the_weighted_mean_of_gyro_minus_odometry():
    """Driving straight with a constant disagreement d: after n trusted samples b = d W / (W + T0), the
    prior-weighted mean, with W = T_N (1 - lambda^n) / (1 - lambda), lambda = exp(-T_N / averaging_time)."""
    p = GyroBiasParameters()
    d, n = 0.006, 1500
    state = run_steps(gyro_bias_initial_state(), [(d, 0.0, 1.0, False)] * n, p)
    lam = math.exp(-T_N / p.averaging_time)
    W = T_N * (1.0 - lam**n) / (1.0 - lam)
    assert state[1] == pytest.approx(W, rel=1e-12)
    assert state[2] == pytest.approx(d * W / (W + p.prior_time), rel=1e-12)
    assert state[2] == pytest.approx(d, rel=0.02)  # 3 s of straight driving: within 2 %
    # A drifting bias is followed with the forgetting time: 20 s after a step to 2 d, within 2 %.
    state = run_steps(state, [(2 * d, 0.0, 1.0, False)] * int(20.0 / T_N), p)
    assert state[2] == pytest.approx(2 * d, rel=0.02)
    # Disabled (the paper): nothing is learned.
    off = run_steps(gyro_bias_initial_state(), [(d, 0.0, 1.0, False)] * 100, dc.replace(p, enabled=False))
    assert off[2] == 0.0


def test_no_learning_while_turning_slipping_or_faulty():
    """The gates of gyro_bias_step: a spot turn (the gate's PT1 of gyro - b above straight_yaw_rate),
    C1 below trusted_c1 and a sensor fault leave b unchanged; after the turn, learning resumes when the
    PT1 has decayed below straight_yaw_rate, after tau ln(|turn rate| / straight_yaw_rate) by hand. The
    PT1 is of past samples (no selection on a sample's own noise), so a turn that starts as a step leaks
    its first sample in, T_N / (W + T0) of its disagreement."""
    p = GyroBiasParameters()
    learned = run_steps(gyro_bias_initial_state(), [(0.004, 0.0, 1.0, False)] * 1000, p)
    # The odometry scrubs 3 % in the turn: learning it would give b -> b - 0.09.
    turn = (3.0 + learned[2], 3.09, 1.0, False)
    first = gyro_bias_step(learned, *turn, p, T_N)
    lam = math.exp(-T_N / p.averaging_time)
    leak = (lam * learned[0] + (turn[0] - turn[1]) * T_N) / (lam * learned[1] + T_N + p.prior_time)
    assert first[2] == pytest.approx(leak, rel=1e-12) and abs(leak - learned[2]) < 1.2e-4
    b = first[2]
    state = run_steps(first, [turn] * 200, p)
    assert state[2] == b and state[0] == first[0]
    assert state[3] == pytest.approx(3.0, abs=1e-3)
    frozen = 0
    while True:
        nxt = gyro_bias_step(state, b, 0.01, 1.0, False, p, T_N)  # straight again, odometry off by 0.01
        if nxt[2] != b:
            break
        state, frozen = nxt, frozen + 1
    assert frozen == math.ceil(p.gate_time_constant / T_N * math.log(3.0 / p.straight_yaw_rate))
    for c1, fault in ((0.85, False), (1.0, True)):
        assert run_steps(learned, [(0.5, 0.0, c1, fault)] * 10, p)[2] == learned[2]


def test_quantised_odometry_telescopes():
    """Straight driving with gentle steering (|omega| < 0.03 rad/s) and a noise-free gyro with bias 4
    mrad/s: the odometric yaw rate from 6144-count encoders is off by up to 0.11 rad/s per sample, yet the
    sum over the stretch is off by one count, and b is the prior-weighted bias to 1e-4 rad/s. With the
    gyro's white noise (0.014 rad/s), within 3 sigma of its mean over the trusted time."""
    wheel_radius, track_width, step = 0.015, 0.068, 2 * math.pi / 6144
    t = np.arange(int(3.0 / T_N)) * T_N
    omega = 0.03 * np.sin(2 * np.pi * t / 1.3)
    v = 1.0 + 0.5 * np.sin(2 * np.pi * t / 2.0)
    heading_rate = np.cumsum(omega * T_N)
    dist = np.cumsum(v * T_N)
    theta_R = np.floor((dist + 0.5 * track_width * heading_rate) / wheel_radius / step) * step
    theta_L = np.floor((dist - 0.5 * track_width * heading_rate) / wheel_radius / step) * step
    odo_state = [math.nan, math.nan, 0.0, 1.0, 0.0, 1.0, 1.0]
    odometric = []
    for k in range(len(t)):
        odo_state, out, _ = odometry_step(odo_state, [theta_R[k], theta_L[k]], wheel_radius, track_width, T_N)
        odometric.append(out[1])
    odometric = np.array(odometric)
    assert np.max(np.abs(odometric - omega)) > 0.1  # per sample: a whole quantisation step
    p = GyroBiasParameters(averaging_time=math.inf)
    bias, rng = 0.004, np.random.default_rng(3)
    for noise_std in (0.0, 0.014):
        gyro = omega + bias + noise_std * rng.standard_normal(len(t))
        # The odometry's first sample has no difference yet (v from the initial state): skip it.
        samples = [(g, w, 1.0, False) for g, w in zip(gyro[1:], odometric[1:], strict=True)]
        state = run_steps(gyro_bias_initial_state(), samples, p)
        W = state[1]
        expected = (bias + np.mean(gyro[1:] - omega[1:] - bias)) * W / (W + p.prior_time)
        tolerance = 1e-4 if noise_std == 0.0 else 3 * noise_std * math.sqrt(T_N / W)
        assert abs(state[2] - expected) < 1e-4
        assert abs(state[2] - bias * W / (W + p.prior_time)) < tolerance + 1e-4


def test_block_equals_the_step_function():
    """GyroBiasEstimator (Simulator, FixValue): the gyro output is the input minus the bias learned up to
    the previous sample; the bias output follows gyro_bias_step; a fault flag stops the learning."""
    p = GyroBiasParameters()
    block = GyroBiasEstimator(p, T_N)
    simulator = Simulator(block)
    context = simulator.get_mutable_context()
    state = gyro_bias_initial_state()
    for k in range(60):
        gyro, omega, fault = 0.01 + 0.001 * math.sin(k), 0.002 * (k % 3), float(k in (20, 21))
        block.GetInputPort("gyro").FixValue(context, [gyro])
        block.GetInputPort("odometry").FixValue(context, [1.0, omega, 1.0, 1.0])
        block.GetInputPort("C1").FixValue(context, [1.0])
        block.GetInputPort("inertial_fault").FixValue(context, [fault])
        block.GetInputPort("encoder_fault").FixValue(context, [0.0])
        np.testing.assert_allclose(block.GetOutputPort("bias").Eval(context), [state[2]], rtol=0, atol=1e-15)
        np.testing.assert_allclose(block.GetOutputPort("gyro").Eval(context), [gyro - state[2]], atol=1e-15)
        state = gyro_bias_step(state, gyro, omega, 1.0, bool(fault), p, T_N)
        simulator.AdvanceTo((k + 1) * T_N)
    assert state[2] > 0.005


def test_parameter_validation():
    for name, bad, allowed in (
        ("averaging_time", 0.0, r"\(0, inf\] s"),
        ("averaging_time", math.nan, r"\(0, inf\] s"),
        ("prior_time", -1.0, r"\(0, inf\)"),
        ("straight_yaw_rate", math.inf, r"\(0, inf\)"),
        ("gate_time_constant", 0.0, r"\(0, inf\)"),
        ("trusted_c1", 1.5, r"\[0, 1\]"),
        ("enabled", 1, "true, false"),
    ):
        with pytest.raises(ValueError, match=rf"gyro_bias.{name}=.* out of range: allowed {allowed}"):
            GyroBiasParameters(**{name: bad})


def test_square_heading_with_the_bias_estimate():
    """The square (open loop, 4 spot turns of 90 deg at up to 3 rad/s) with a noise-free gyro, so that the
    true bias is meas_gyro_k - true_omega_k-1 (one sample of ADC latency): the estimate follows the bias
    (random walk included) within 25 % of it from the first turn on, and the fused heading ends within
    0.5 deg; replayed with the paper's heading (raw gyro, per-sample S(14)) the same run ends more than
    three times as far off."""
    scenario = load_scenario("square")
    scenario.sensor_overrides["gyro_noise_std"] = 0.0
    a = run_scenario(scenario, seed=2, open_loop=True).arrays
    true_bias = a["meas_gyro"][1:] - a["true_omega"][:-1]
    estimate = a["est_gyro_bias"][1:]
    first_turn = np.flatnonzero(np.abs(a["true_omega"]) > 0.5)[0]
    bias = abs(true_bias[first_turn])
    assert 0.003 < bias < 0.01  # a bias worth estimating (seed 2: 1.7 sigma)
    assert np.max(np.abs(estimate[first_turn:] - true_bias[first_turn:])) < 0.25 * bias
    heading_error = abs(math.degrees(a["est_phi"][-1] - a["true_phi"][-1]))
    assert heading_error < 0.5
    paper_phi = replay(a, scenario, navigation=papers_heading(scenario.navigation))["est_phi"]
    assert abs(math.degrees(paper_phi[-1] - a["true_phi"][-1])) > 3 * max(heading_error, 0.25)
