"""Sensor models (systems/robot/sensors.py): statistics measured from simulations, geometry, quantisation."""

import math

import numpy as np
import pytest
from slipnav.scenarios.config import load_scenario
from slipnav.scenarios.runner import run_scenario
from slipnav.systems.robot.parameters import tinyphoon
from slipnav.systems.robot.sensors import (
    NOISE_BLOCK,
    NOISE_CHANNELS,
    ProprioceptiveSensors,
    SensorNoise,
    SensorParameters,
    accelerometer_truth,
    current_noise,
    current_sense,
    initial_biases,
    sensor_noise,
    sensor_update,
)


def test_accelerometer_geometry_and_mean_cancels_rotation():
    a_t, a_n, omega_dot, omega = 1.0, -2.0, 30.0, 4.0
    px, py = 0.02, 0.015
    readings = accelerometer_truth((a_t, a_n, omega_dot), omega, (px, py))
    # Hand-computed: a_P = a + omega_dot x r + omega x (omega x r).
    assert readings[0] == pytest.approx(a_t - omega_dot * py - omega**2 * px)
    assert readings[1] == pytest.approx(a_n + omega_dot * px - omega**2 * py)
    # S(3): the mean of the symmetric pair is the centre's acceleration.
    assert 0.5 * (readings[0] + readings[2]) == pytest.approx(a_t)
    assert 0.5 * (readings[1] + readings[3]) == pytest.approx(a_n)


def test_noise_statistics_at_rest_from_simulation(open_loop):
    """At rest: std of each channel = its white noise; mean = the drawn initial bias."""
    p = tinyphoon()
    sensors = SensorParameters()
    seed = 7
    a = open_loop(p, np.zeros((2, 2)), 4.0, sensors=sensors, seed=seed)
    samples = a["t"] > 0.0
    bias0 = initial_biases(sensors, np.random.default_rng(seed))
    n = np.count_nonzero(samples)
    for i, key in enumerate(["meas_a_t1", "meas_a_n1", "meas_a_t2", "meas_a_n2"]):
        x = a[key][samples]
        assert np.std(x) == pytest.approx(sensors.accel_noise_std, rel=0.08)
        drift = sensors.accel_drift_density * math.sqrt(4.0)
        assert abs(np.mean(x) - bias0[i]) < 4 * sensors.accel_noise_std / math.sqrt(n) + 3 * drift
    gyro = a["meas_gyro"][samples]
    assert np.std(gyro) == pytest.approx(sensors.gyro_noise_std, rel=0.08)
    assert abs(np.mean(gyro) - bias0[4]) < 4 * sensors.gyro_noise_std / math.sqrt(n) + 3 * 1e-3
    # White: lag-1 autocorrelation ~ 0.
    g = gyro - gyro.mean()
    assert abs(np.dot(g[1:], g[:-1]) / np.dot(g, g)) < 0.06
    # Encoders at rest read exactly zero counts.
    assert np.all(a["meas_enc_R"] == 0.0) and np.all(a["meas_enc_L"] == 0.0)


def test_encoder_quantisation_step(open_loop):
    p = tinyphoon()
    sensors = SensorParameters()
    a = open_loop(p, np.tile([0.3, 0.2], (30, 1)), 0.5, sensors=sensors)
    step = 2 * math.pi / 6144
    counts = a["meas_enc_R"][1:] / step
    np.testing.assert_allclose(counts, np.round(counts), atol=1e-6)
    # Row k holds the sample taken at t_{k-1} (what a block updating at t_k reads): floor(theta/step)*step.
    np.testing.assert_array_equal(a["meas_enc_R"][1:], np.floor(a["true_theta_R"][:-1] / step) * step)
    np.testing.assert_array_equal(a["meas_enc_L"][1:], np.floor(a["true_theta_L"][:-1] / step) * step)
    error = a["true_theta_R"][:-1] - a["meas_enc_R"][1:]
    assert np.all(error >= 0.0) and np.all(error < step) and np.ptp(error) > 0.9 * step
    speeds = np.diff(a["meas_enc_R"]) / 0.002 * p.wheel_radius
    quantum = p.wheel_radius * step / 0.002  # odometric speed resolution, 7.7 mm/s
    np.testing.assert_allclose(speeds / quantum, np.round(speeds / quantum), atol=1e-6)


def test_vibration_grows_with_speed_and_drift_is_a_random_walk():
    params = SensorParameters()
    rng = np.random.default_rng(3)
    n = 20000
    state = np.zeros(10)
    state[3] = 2.0  # v_t
    internal = np.zeros(9)
    readings, biases = [], []
    for _ in range(n):
        internal, accel, _, _ = sensor_update(
            internal, state, (0, 0, 0), rng.standard_normal(NOISE_CHANNELS), params, 0.002
        )
        readings.append(accel[1])
        biases.append(internal[1])
    expected = math.hypot(params.accel_noise_std, params.accel_vibration_per_speed * 2.0)
    assert np.std(readings) == pytest.approx(expected, rel=0.08)
    # Random-walk bias: variance after n steps = density^2 * n * T_N.
    assert np.var(np.diff(biases)) == pytest.approx(params.accel_drift_density**2 * 0.002, rel=0.05)


@pytest.mark.parametrize(
    "field, value",
    [
        ("accel_noise_std", -0.1),
        ("gyro_range", 0.0),
        ("encoder_counts_per_revolution", 0),
        ("accel_vibration_time_constant", float("inf")),
        ("current_resolution", 0.0),
        ("current_noise_std", -0.01),
        ("current_scale_error", 1.0),
    ],
)
def test_sensor_parameter_validation(field, value):
    with pytest.raises(ValueError, match=rf"{field}=.*allowed"):
        SensorParameters(**{field: value})


def test_same_seed_gives_bit_identical_runs_and_seeds_differ():
    scenario = load_scenario("square")
    a = run_scenario(scenario, seed=11, duration=0.3).arrays
    b = run_scenario(scenario, seed=11, duration=0.3).arrays
    c = run_scenario(scenario, seed=12, duration=0.3).arrays
    for key in a:
        np.testing.assert_array_equal(a[key], b[key])
    assert not np.array_equal(a["meas_gyro"], c["meas_gyro"])
    assert not np.array_equal(a["meas_a_t1"], c["meas_a_t1"])


def test_sensor_noise_is_a_function_of_seed_and_sample():
    """SensorNoise: row k is the same however the rows are read (across block boundaries, backwards),
    standard normal, and a stream apart from the initial biases' default_rng(seed)."""
    whole = sensor_noise(5, 3 * NOISE_BLOCK)
    assert whole.shape == (3 * NOISE_BLOCK, NOISE_CHANNELS)
    noise = SensorNoise(5)
    np.testing.assert_array_equal(
        noise.rows(NOISE_BLOCK - 3, NOISE_BLOCK + 4), whole[NOISE_BLOCK - 3 : NOISE_BLOCK + 4]
    )
    for k in (2 * NOISE_BLOCK + 7, 3, NOISE_BLOCK, NOISE_BLOCK - 1, 3):  # any order
        assert noise.row(k) == whole[k].tolist()
        assert all(type(v) is float for v in noise.row(k))
    assert abs(np.mean(whole)) < 0.01 and abs(np.std(whole) - 1.0) < 0.01  # 43 008 draws
    assert not np.array_equal(sensor_noise(6, 10), whole[:10])
    assert not np.array_equal(np.random.default_rng(5).standard_normal(10), whole[:10, 0])


def test_current_sense_quantises_scales_and_reads_its_own_stream():
    """The drivers' current sense: (1 + scale error) i + white noise, rounded to ADC counts; its draws
    are the seed's current_noise stream, so the other sensors read the same noise with or without it;
    an unconnected current input reads NaN."""
    ideal = SensorParameters(current_noise_std=0.0, current_scale_error=0.02)
    q = ideal.current_resolution
    reading = current_sense([1.0, -0.3], [0.7, -2.0], ideal)
    np.testing.assert_allclose(reading, [round(1.02 / q) * q, round(-0.306 / q) * q], rtol=0, atol=1e-15)
    assert all(abs(r - 1.02 * i) <= 0.5 * q for r, i in zip(reading, [1.0, -0.3], strict=True))
    noisy = SensorParameters()
    draws = current_noise(3).row(0)
    sigma = noisy.current_noise_std
    expected = [round((i + sigma * n) / q) * q for i, n in zip([0.5, 0.2], draws, strict=True)]
    assert current_sense([0.5, 0.2], draws, noisy) == expected
    assert math.isnan(current_sense([math.nan, 0.1], [0.0, 0.0], noisy)[0])
    assert not np.array_equal(current_noise(3).rows(0, 5), SensorNoise(3).rows(0, 5)[:, :2])

    sensors = ProprioceptiveSensors(noisy, 0.002, noise=SensorNoise(3))
    context = sensors.CreateDefaultContext()
    context.SetTime(0.0)
    sensors.GetInputPort("plant_state").FixValue(context, np.zeros(10))
    sensors.GetInputPort("body_acceleration").FixValue(context, np.zeros(3))
    unconnected = sensors.EvalUniquePeriodicDiscreteUpdate(context)
    without = [unconnected.get_vector(i).CopyToVector() for i in range(unconnected.num_groups())]
    assert np.isnan(without[-1]).all()
    sensors.GetInputPort("motor_currents").FixValue(context, [0.5, 0.2])
    update = sensors.EvalUniquePeriodicDiscreteUpdate(context)
    np.testing.assert_array_equal(update.get_vector(update.num_groups() - 1).CopyToVector(), expected)
    for i in range(update.num_groups() - 1):  # the other sensors' readings do not depend on it
        np.testing.assert_array_equal(update.get_vector(i).CopyToVector(), without[i])
