"""Sensor faults (systems/robot/faults.py) and the sensor checks (systems/health/): every fault class
injected, detected within 0.1 s, flagged with its class, excluded and recovered from; numbers by hand."""

import dataclasses as dc
import math

import numpy as np
import pytest
from slipnav.scenarios.config import ScenarioError, load_scenario, scenario_from_yaml, with_keys
from slipnav.scenarios.metrics import (
    POSE_DELAY_SAMPLES,
    final_position_error,
    position_errors,
    rms_position_error,
)
from slipnav.scenarios.runner import run_scenario
from slipnav.studies import faults as fault_study
from slipnav.studies.fault_cases import (
    NULL_FAULT_BIAS,
    fault_cases,
    fault_onset,
    null_fault_cases,
    perturbation_cases,
    select_cases,
)
from slipnav.studies.faults import fault_figures, print_report, run_fault, seed_mean_ratios
from slipnav.systems.health import (
    INCONSISTENT,
    JUMP,
    NONFINITE,
    RECOVERING,
    SATURATED,
    STUCK,
    HealthConstants,
    HealthGeometry,
    SensorHealthParameters,
    health_constants,
    health_flags,
    health_initial_state,
    health_step,
    travel_restored,
)
from slipnav.systems.health.accelerometer_pair import fast_pair_ratio, pair_omega_squared
from slipnav.systems.health.layout import PAIR_OFFSET, PAIR_OFFSET_VARIANCE
from slipnav.systems.health.pair_gain import pair_gain_ratio, pair_gain_reset, pair_gain_upper_bound
from slipnav.systems.health.yaw_witness import yaw_follow_step
from slipnav.systems.navigation.parameters import NavigationParameters, health_geometry
from slipnav.systems.robot.contact import contact_forces
from slipnav.systems.robot.dynamics import plant_derivatives, plant_substep
from slipnav.systems.robot.faults import FaultEvent, apply_sensor_faults, plant_disturbance
from slipnav.systems.robot.parameters import kurt3d, tinyphoon
from slipnav.systems.robot.sensors import accelerometer_truth

from tests.shared import scenario_result, scenario_run, shared_runs

T_N = 0.002
R, B = 0.015, 0.068
STEP = 2 * math.pi / 6144
GEOMETRY = HealthGeometry(R, R, B, T_N, STEP, (0.02, 0.015), 6.3)


# -- fault events ------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "fields, key",
    [
        ({"kind": "freeze"}, "kind"),
        ({"channel": "compass"}, "channel"),
        ({"kind": "stuck", "channel": "gyro"}, "channel"),
        ({"start": -0.1}, "start"),
        ({"duration": 0.0}, "duration"),
        ({"kind": "scale", "value": math.inf}, "value"),
        ({"kind": "saturation", "value": 0.0}, "value"),
        ({"kind": "bias", "value": math.nan}, "value"),
    ],
)
def test_a_fault_event_outside_its_range_is_a_clear_error(fields, key):
    with pytest.raises(ValueError, match=key):
        FaultEvent(**fields)


def test_scenario_faults_load_typed_and_bad_ones_name_their_index():
    base = "trajectory: {segments: [!Straight {length: 1.0, v_end: 1.0}]}\n"
    scenario = scenario_from_yaml(base + "faults: [{kind: dropout, channel: gyro, start: 2.0}]\n")
    assert scenario.faults == [FaultEvent("dropout", "gyro", 2.0, 0.5, 0.0)]
    with pytest.raises(ScenarioError, match=r"faults\[1\].*kind"):
        scenario_from_yaml(base + "faults: [{kind: nan}, {kind: smoke}]\n")
    with pytest.raises(ScenarioError, match="faults.*unknown key"):
        scenario_from_yaml(base + "faults: [{kind: nan, when: 1.0}]\n")


def test_apply_sensor_faults_by_hand():
    raw = [1.0, 2.0, 3.0, 4.0, 0.5, 10.0, 20.0]
    held = [9.0, 9.0, 9.0, 9.0, 0.4, 9.5, 19.0]
    previous = [0.0, 0.0, 0.0, 0.0, 0.0, 9.8, 19.9]

    def read(kind, channel, value=0.0, t=1.0):
        event = FaultEvent(kind, channel, start=1.0, duration=0.5, value=value)
        return apply_sensor_faults(t, raw, held, previous, [event], T_N, STEP)

    assert math.isnan(read("nan", "accel1_n")[1])
    assert read("inf", "gyro")[4] == math.inf
    assert read("dropout", "gyro")[4] == 0.4
    assert read("stuck", "encoder_L")[6] == 19.0
    assert read("bias", "accel2_t", 5.0)[2] == 8.0
    assert read("bias", "encoder_R", 100.0)[5] == pytest.approx(10.0 + 100 * STEP, rel=1e-15)
    assert read("scale", "gyro", 1.0)[4] == 1.0
    assert read("scale", "encoder_R", 1.0)[5] == pytest.approx(9.5 + 2.0 * 0.2, rel=1e-15)  # increments
    assert read("saturation", "accel2_n", 2.5)[3] == 2.5
    assert read("spike", "gyro", 3.0)[4] == 3.5
    assert read("spike", "gyro", 3.0, t=1.0 + T_N)[4] == 0.5  # one sample only
    assert read("bias", "gyro", 1.0, t=1.5)[4] == 0.5  # ended
    assert read("bias", "gyro", 1.0, t=0.999)[4] == 0.5  # not begun


# -- sensor checks on synthetic streams ----------------------------------------------------------------


def stream(n, v=1.0, omega=0.0, seed=0):
    """n samples of a rigid robot at speed v and yaw rate omega: noisy gyro and accelerometers
    (sigma 0.014 rad/s, 0.06 m/s^2), exact wheel angles."""
    rng = np.random.default_rng(seed)
    k = np.arange(1, n + 1)
    theta_R = (v + 0.5 * B * omega) / R * T_N * k
    theta_L = (v - 0.5 * B * omega) / R * T_N * k
    w2 = omega * omega
    acc = np.column_stack(
        [
            -w2 * 0.02 + 0 * k,
            v * omega - w2 * 0.015 + 0 * k,
            w2 * 0.02 + 0 * k,
            v * omega + w2 * 0.015 + 0 * k,
        ]
    )
    acc = acc + 0.06 * rng.standard_normal((n, 4))
    gyro = omega + 0.014 * rng.standard_normal(n)
    return np.column_stack([acc, gyro, theta_R, theta_L])


def check(rows, params=None, v0=1.0, geometry=GEOMETRY):
    params = params or SensorHealthParameters()
    state = health_initial_state(geometry, v0)
    outs, codes = [], []
    for row in rows:
        state, out, code = health_step(state, row, params, geometry)
        outs.append(out)
        codes.append(code)
    return np.array(outs), np.array(codes)


def test_fault_free_streams_raise_no_flag():
    for v, omega in ((0.0, 0.0), (1.0, 0.0), (2.0, 3.0), (0.5, -4.0)):
        out, codes = check(stream(1000, v, omega), v0=v)
        assert not codes.any(), (v, omega)
        np.testing.assert_array_equal(out, stream(1000, v, omega))


def test_nan_gyro_is_replaced_by_the_odometric_yaw_rate():
    rows = stream(200, 1.0, 2.0)
    rows[100:110, 4] = np.nan
    out, codes = check(rows)
    # Then a block of gyro_readmission_samples (5) within the bound: 110-113 recovering, 114 back.
    assert np.all(codes[100:110, 4] == NONFINITE) and np.all(codes[110:114, 4] == RECOVERING)
    assert not codes[114:, 4].any()
    omega_o = ((rows[100, 5] - rows[99, 5]) - (rows[100, 6] - rows[99, 6])) * R / T_N / B
    assert omega_o == pytest.approx(2.0, rel=1e-9)
    np.testing.assert_allclose(out[100:114, 4], omega_o, rtol=1e-9)
    np.testing.assert_array_equal(out[114:, 4], rows[114:, 4])


def unequal_wheels(n, v, omega, e_R, e_L, gyro_bias):
    """n samples of ``stream``'s robot on wheels whose rolling radii are R (1 + e_R), R (1 + e_L): the
    encoders count the true ground speeds v +- B omega / 2 over these radii; the gyro reads omega, its
    noise and ``gyro_bias``."""
    rows = stream(n, v, omega)
    k = np.arange(1, n + 1)
    rows[:, 5] = (v + 0.5 * B * omega) / (R * (1 + e_R)) * T_N * k
    rows[:, 6] = (v - 0.5 * B * omega) / (R * (1 + e_L)) * T_N * k
    rows[:, 4] += gyro_bias
    return rows


def checked(rows, calibration):
    state, outs, codes = health_initial_state(GEOMETRY, 1.0), [], []
    for row in rows:
        state, out, code = health_step(
            state, row, SensorHealthParameters(), GEOMETRY, yaw_calibration=calibration
        )
        outs.append(out)
        codes.append(code)
    return np.array(outs), np.array(codes)


def test_a_lost_gyros_replacement_reads_the_learned_radius_difference_and_bias():
    """Driving straight at 1.5 m/s on a right wheel 1 % larger than the left (D = e_R - e_L = 0.01), the
    nominal odometry turns at -D v / b = -0.22 rad/s (yaw_calibration's model). A lost gyro's replacement
    reads the calibration's [b_g, D]: omega_o + D v_o / b + b_g by hand (the nominal v_o), which is the
    true 0 rad/s plus the bias to second order in e (|D| e v / b); without it, the 0.22 rad/s."""
    e_R, e_L, v, bias = 0.005, -0.005, 1.5, 0.003
    D = e_R - e_L
    rows = unequal_wheels(200, v, 0.0, e_R, e_L, bias)
    rows[100:110, 4] = np.nan
    out, codes = checked(rows, (bias, D))
    assert np.all(codes[100:110, 4] == NONFINITE)
    v_R, v_L = (np.diff(rows[99:110, 5:7], axis=0) * R / T_N).T
    by_hand = (v_R - v_L) / B + D * 0.5 * (v_R + v_L) / B + bias
    np.testing.assert_allclose(out[100:110, 4], by_hand, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(out[100:110, 4], bias, rtol=0, atol=abs(D) * max(e_R, -e_L) * v / B)
    uncalibrated, _ = checked(rows, (0.0, 0.0))
    np.testing.assert_allclose(uncalibrated[100:110, 4], -D * v / B, rtol=0.02)


def test_a_biased_gyro_is_readmitted_against_its_replacement_plus_the_learned_bias():
    """Driving straight with a gyro whose bias the calibration has learned (0.15 rad/s, large on
    purpose): a 10-sample outage is replaced by the wheels' 0 rad/s plus b_g, and the re-admission block
    compares the gyro less b_g with it, so the gyro is back after the block of 5 (at 114). Without the
    bias the block's sum, 5 x 0.15 = 0.75 rad/s, exceeds its allowance (3 sigma sqrt(5) = 0.094 and two
    counts of each wheel, 0.45; the replacement's own travel is 0) and the gyro stays out."""
    bias = 0.15
    rows = stream(200, 1.0, 0.0)
    rows[:, 4] += bias
    rows[100:110, 4] = np.nan
    out, codes = checked(rows, (bias, 0.0))
    np.testing.assert_allclose(out[100:114, 4], bias, rtol=0, atol=1e-12)
    assert np.all(codes[110:114, 4] == RECOVERING) and not codes[114:, 4].any()
    _, unknown = checked(rows, (0.0, 0.0))
    assert np.all(unknown[110:130, 4] == RECOVERING)


def test_a_lost_encoders_replacement_reads_the_learned_radius_difference_and_bias():
    """In a 2 rad/s turn on unequal wheels (D = 0.01) the right encoder is lost: it advances by the left
    wheel's nominal speed v_L plus b (gyro - b_g) - D v_L (v_R - v_L = b omega - D v_o in the nominal
    radii, v_o taken as v_L), by hand; its travel then stays within the gyro's noise of the truth over
    the outage; without the calibration it misses D v_L + b b_g, 0.19 mm over these 10 samples."""
    e_R, e_L, v, omega, bias = 0.005, -0.005, 1.0, 2.0, 0.003
    D = e_R - e_L
    clean = unequal_wheels(300, v, omega, e_R, e_L, bias)
    rows = clean.copy()
    rows[100:110, 5] = np.nan
    out, codes = checked(rows, (bias, D))
    assert np.all(codes[100:110, 5] == NONFINITE)
    v_L = np.diff(rows[99:110, 6]) * R / T_N
    by_hand = (v_L + B * (rows[100:110, 4] - bias) - D * v_L) * T_N / R
    np.testing.assert_allclose(np.diff(out[99:110, 5]), by_hand, rtol=1e-12)
    noise = 3 * math.sqrt(10) * B * 0.014 * T_N  # the gyro's noise over the outage (m)
    drift = abs(out[109, 5] - clean[109, 5]) * R
    assert drift < noise
    uncalibrated, _ = checked(rows, (0.0, 0.0))
    missed = (uncalibrated[109, 5] - out[109, 5]) * R
    assert missed == pytest.approx(np.sum(D * v_L + B * bias) * T_N, rel=1e-9)


def test_saturated_and_stuck_gyro_are_flagged_and_excluded():
    rows = stream(200, 1.0, 1.0)
    full_scale = math.radians(300.0)
    rows[50:60, 4] = full_scale
    out, codes = check(rows)
    assert np.all(codes[50:60, 4] == SATURATED)
    np.testing.assert_allclose(out[50:60, 4], 1.0, rtol=1e-9)  # the odometric yaw rate
    rows = stream(200, 1.0, 1.0)
    rows[100:150, 4] = rows[99, 4]  # frozen: rows 99..103 are five equal readings
    out, codes = check(rows)
    assert not codes[:103, 4].any() and np.all(codes[103:150, 4] == STUCK)
    # Re-admitted once it moves and has agreed with the odometry for a block of 5 samples.
    assert np.all(codes[150:154, 4] == RECOVERING) and not codes[154:, 4].any()


@pytest.mark.parametrize("hold, first_flagged", [(0.0, 103), (0.01, 108), (0.0101, 109)])
def test_a_stream_that_holds_its_readings_is_stuck_only_beyond_its_hold(hold, first_flagged):
    """inertial_hold_time allows ceil(hold / T_N) repeats on top of stuck_samples - 1: 0.01 s at T_N 2 ms
    is 5 more (nine repeats, ten equal readings from row 99), 0.0101 s six more."""
    rows = stream(200, 1.0, 0.0)
    rows[100:150, 0] = rows[99, 0]  # accelerometer 1's t axis and the gyro frozen
    rows[100:150, 4] = rows[99, 4]
    _, codes = check(rows, geometry=dc.replace(GEOMETRY, inertial_hold_time=hold))
    for channel in (0, 4):
        assert not codes[:first_flagged, channel].any()
        assert np.all(codes[first_flagged:150, channel] == STUCK)


def test_one_imu_copied_into_both_sets_is_no_pair_to_judge():
    """A 4 rad/s spin with accelerometer 1's readings copied into accelerometer 2's while the checks
    believe the pair at +-(0.1, 0.05) m: the believed rotational difference 2 omega^2 x = 3.2 m/s^2 is
    beyond the pair's bound (1 m/s^2 at rest), but a copied sensor is no second witness: nothing is
    flagged. Two real sensors with that difference are flagged."""
    geometry = dc.replace(GEOMETRY, accelerometer_position=(0.1, 0.05))
    rows = stream(600, 0.0, 4.0)
    rows[:, 2:4] = rows[:, 0:2]
    _, codes = check(rows, v0=0.0, geometry=geometry)
    assert not codes[:, 0:4].any()
    rows[:, 2:4] += 0.01  # two sensors, nearly alike: they disagree with the believed geometry
    _, codes = check(rows, v0=0.0, geometry=geometry)
    assert codes[:, 0:4].any()


def test_a_frozen_gyros_missed_heading_is_paid_back_when_the_stuck_test_flags_it():
    """A gyro frozen while the yaw rate grows (10 rad/s^2) is trusted for stuck_samples - 1 = 4 equal
    readings (the last true one at 99 and the repeats 100-102; flagged at 103). The wheels' yaw rate
    (here the odometric one: no nominal robot) runs through the repeats; what they missed is paid back
    over the next 5 samples, so the output's sum over the fault is the true heading change, and the
    replacement starts from the wheels, not from the frozen reading. A gyro back before the payback ends
    (here a 3-sample freeze and a re-admission block of 1) still gets all of it, and a later outage none."""
    n, v, omega_dot = 200, 1.0, 10.0
    omega = omega_dot * T_N * np.arange(n)
    theta_R = np.cumsum((v + 0.5 * B * omega) / R * T_N)
    theta_L = np.cumsum((v - 0.5 * B * omega) / R * T_N)
    truth = np.array([accelerometer_truth((0.0, v * w, omega_dot), w, (0.02, 0.015)) for w in omega])
    rng = np.random.default_rng(4)
    gyro = omega + 0.014 * rng.standard_normal(n)
    rows = np.column_stack([truth + 0.06 * rng.standard_normal((n, 4)), gyro, theta_R, theta_L])
    rows[100:150, 4] = rows[99, 4]
    out, codes = check(rows, v0=v)
    assert not codes[:103, 4].any() and np.all(codes[103:150, 4] == STUCK)
    omega_o = (np.diff(theta_R, prepend=0.0) - np.diff(theta_L, prepend=0.0)) * R / T_N / B
    owed = np.sum(omega_o[100:103] - rows[99, 4])  # 3 repeats, 0.02-0.06 rad/s behind (and the noise)
    assert owed == pytest.approx(np.sum(omega[100:103] - rows[99, 4]), rel=1e-9)
    np.testing.assert_allclose(out[103:108, 4], omega_o[103:108] + owed / 5, rtol=1e-9)
    np.testing.assert_allclose(out[108:150, 4], omega_o[108:150], rtol=1e-9)
    # The heading over the fault is the truth's, to rounding (without the payback: owed * T_N short).
    assert np.sum(out[100:150, 4]) == pytest.approx(np.sum(omega[100:150]), abs=1e-9)
    short = rows.copy()
    short[100:150, 4] = gyro[100:150]
    short[100:104, 4] = short[99, 4]  # flagged at 103, the gyro moves again at 104
    short[160:165, 4] = np.nan  # a later outage
    out, codes = check(short, SensorHealthParameters(gyro_readmission_samples=1), v0=v)
    assert codes[103, 4] == STUCK and not codes[104:160, 4].any()
    owed = np.sum(omega_o[100:103] - short[99, 4])
    np.testing.assert_allclose(out[104:108, 4], short[104:108, 4] + owed / 5, rtol=1e-9)
    np.testing.assert_allclose(out[108:160, 4], short[108:160, 4], rtol=1e-12)
    np.testing.assert_allclose(out[160:165, 4], omega_o[160:165], rtol=1e-9)  # no stale payback


def test_gyro_bias_step_is_a_jump_excluded_until_it_ends():
    rows = stream(400, 1.0, 0.5)
    rows[100:250, 4] += 1.0
    out, codes = check(rows)
    assert codes[100, 4] == JUMP and np.all(codes[101:254, 4] == RECOVERING)
    assert not codes[254:, 4].any()
    np.testing.assert_allclose(out[100:254, 4], 0.5, rtol=1e-9)


def test_a_biased_gyro_is_not_readmitted_by_a_sample_that_meets_a_skidding_odometry():
    """In a skidding turn the odometric yaw rate reads high; a gyro with a +1 rad/s bias step meets it
    within gyro_max_step (0.5 rad/s) for a few samples. One sample re-admits it (gyro_readmission_samples
    = 1), and then the yaw test (systems/health/yaw_witness.py) holds it out again: 0.7 rad/s above the
    witness in a 2 rad/s turn is z = 0.7 / sqrt(0.014^2 + 0.1128^2 / 3 + 0.4^2) = 1.7 a sample, an alarm
    within 20 samples. A block of 5 keeps it out until the step ends."""
    rows = stream(400, 1.0, 2.0)
    rows[100:300, 4] += 1.0
    # The odometry over-reads by 0.3 rad/s (0.7 from the biased gyro, outside its bound) except at
    # samples 150-153 and 160-162, where the skid peaks and it reads 2.7 (within 0.3 rad/s of the biased
    # gyro, which is compared with the previous sample's replacement: agreement at 151-154, 161-163).
    skid = np.full(400, 0.3)
    skid[:100] = skid[300:] = 0.0
    skid[150:154] = 0.7
    skid[160:163] = 0.7
    rows[:, 5] += np.cumsum(0.5 * B * skid * T_N / R)
    rows[:, 6] -= np.cumsum(0.5 * B * skid * T_N / R)
    single = SensorHealthParameters(gyro_readmission_samples=1)
    out, codes = check(rows, single)
    assert codes[150, 4] == RECOVERING and codes[151, 4] == 0  # re-admitted at 151
    held = 151 + int(np.argmax(codes[151:, 4] == INCONSISTENT))
    assert held <= 171 and np.all(codes[held:300, 4] > 0)
    # Two blocks of 4 and 3 agreeing samples, 7 in all: the block is of consecutive ones.
    out, codes = check(rows)
    assert codes[100, 4] == JUMP and np.all(codes[101:300, 4] == RECOVERING)
    np.testing.assert_allclose(out[101:300, 4], 2.0 + skid[101:300], rtol=1e-9)  # the skidding odometry's
    assert not codes[304:, 4].any()
    for bad in (0, 51, 2.5, True):
        with pytest.raises(ValueError, match=r"gyro_readmission_samples=.*integers in \[1, 50\]"):
            SensorHealthParameters(gyro_readmission_samples=bad)


def test_a_doubled_gyro_is_not_readmitted_when_the_turn_slows_within_its_bound():
    """A gyro whose scale doubled at 1 rad/s is a jump; when the turn slows to 0.4 rad/s it reads 0.8,
    within gyro_max_step (0.5) of its replacement sample by sample. The block's summed difference (2.0
    rad/s over 5 samples) exceeds the noise (3 sigma sqrt(5) = 0.094), two counts of each wheel
    (2 STEP 2R / (B T_N) = 0.45) and gyro_readmission_fraction (0.3) of the replacement's own (0.6): it
    stays out until the scale ends (the corner's x2 gyro was re-admitted so, 0.5 deg of heading)."""
    first, second = stream(400, 1.0, 1.0), stream(400, 1.0, 0.4, seed=1)
    second[:, 5:] += first[149, 5:] - second[149, 5:]  # the wheels' angles continue
    rows = np.vstack([first[:150], second[150:]])
    rows[100:300, 4] *= 2.0
    assert np.all(np.abs(rows[150:300, 4] - 0.4) < 0.5)  # each sample within the jump bound
    out, codes = check(rows)
    assert codes[100, 4] == JUMP and np.all(codes[101:304, 4] == RECOVERING)
    assert not codes[304:, 4].any()
    np.testing.assert_allclose(out[150:304, 4], 0.4, rtol=1e-9)  # the odometric yaw rate
    # With the fraction at 1 the block passes (2.0 < 0.094 + 0.45 + 2.0): back at 154, and held out
    # again by the yaw test (0.4 rad/s over the witness at 0.4 rad/s: z = 0.4 / 0.105 = 3.8 a sample, an
    # alarm in 4 once the witness's own step from 1 to 0.4 rad/s has left its PT1 over 20 ms; a release
    # block at fraction 1 lets it back for a few samples before the test holds it again).
    out, codes = check(rows, SensorHealthParameters(gyro_readmission_fraction=1.0))
    assert np.all(codes[150:154, 4] == RECOVERING) and codes[154, 4] == 0
    held = 154 + int(np.argmax(codes[154:, 4] == INCONSISTENT))
    assert held <= 170 and np.mean(codes[held:300, 4] > 0) > 0.9  # a block at fraction 1 lets it back
    for bad in (-0.1, 1.5, math.nan, True):
        with pytest.raises(ValueError, match=r"gyro_readmission_fraction=.*allowed \[0, 1\]"):
            SensorHealthParameters(gyro_readmission_fraction=bad)


def test_after_a_long_outage_the_gyro_is_still_compared_with_its_replacement():
    """NaN for 1.2 s, then the gyro returns 1 rad/s off for 0.6 s in a 0.5 rad/s turn (no bias step is
    measured in a turn): it is not re-admitted on its first sample but when it agrees again, after the
    block of 5."""
    rows = stream(1500, 1.0, 0.5)
    rows[100:700, 4] = np.nan
    rows[700:1000, 4] += 1.0
    out, codes = check(rows)
    assert np.all(codes[100:700, 4] == NONFINITE) and np.all(codes[700:1004, 4] == RECOVERING)
    assert not codes[1004:, 4].any()
    np.testing.assert_allclose(out[700:1004, 4], 0.5, rtol=1e-9)  # the odometric yaw rate


def test_accelerometer_bias_is_isolated_by_the_pair_and_the_kinematics():
    """accel2_t reads +5 m/s^2: the pair's fast average (3 samples) passes 1.6 (1 + 1 v) plus the
    rotational allowance, 5 2 y 2.56 rad/s^2 = 0.38 m/s^2 (3.58 m/s^2), once 1 - (2/3)^k > 0.716, after
    ln(3.52) / ln(1.5) = 3.1 -> 4 samples (the 15-sample average alone passes 1 + 1 v = 2 m/s^2 after
    about 15 ln(5 / 3) = 8); the kinematic reference (dv/dt = 0) tells accel 2. The gain test (on by
    default) sees the step sooner: the pair's mean carries half of it, so the disagreement is twice
    its regressor, far beyond the noise of a 1 m/s drive."""
    rows = stream(400, 1.0, 0.0)
    rows[100:300, 2] += 5.0
    no_gain = SensorHealthParameters(gain_threshold=math.inf)
    slow_only = check(rows, dc.replace(no_gain, fast_consistency_factor=math.inf))[1]
    first_slow = np.flatnonzero(slow_only[:, 2])[0]
    assert 100 + 6 <= first_slow <= 100 + 10 and not slow_only[:, 0].any()
    fast = np.flatnonzero(check(rows, no_gain)[1][:, 2])
    assert 100 + 3 <= fast[0] <= 100 + 5
    out, codes = check(rows)
    flagged = np.flatnonzero(codes[:, 2])
    assert 100 <= flagged[0] <= fast[0] and codes[flagged[0], 2] == INCONSISTENT
    assert not codes[:, 0].any()  # accel 1 is never blamed
    assert np.all(codes[flagged[0] : 300, 2] == INCONSISTENT)
    # Replaced by accel 1 less the rotational difference a_t1 - a_t2 = -2 (omega^2 x + omega' y) (the
    # gyro's omega and its difference) and the pair's learned offset (zero here, but for the noise).
    k = slice(flagged[0], 300)
    omega_dot = np.diff(rows[:, 4], prepend=np.nan) / T_N
    expected = rows[k, 0] + 2 * rows[k, 4] ** 2 * 0.02 + 2 * omega_dot[k] * 0.015
    np.testing.assert_allclose(out[k, 2], expected, rtol=0, atol=0.03)
    np.testing.assert_allclose(np.diff(out[k, 2] - expected), 0.0, atol=1e-12)  # one offset throughout
    # cleared once the averages are below half their thresholds and the gain test's evidence has expired
    # (GAIN_HORIZON x 40 samples: at a constant 1 m/s nothing after the step is informative), the fast
    # test alone before 330
    last = np.flatnonzero(codes[:, 2])[-1]
    assert 300 + 80 <= last < 300 + 90
    assert np.flatnonzero(check(rows, no_gain)[1][:, 2])[-1] < 330


def test_the_fast_pair_bound_by_hand():
    """fast_pair_ratio: the bound is 1.6 x the slow test's bound plus 5 sigma of the gyro difference's
    noise in the rotational term: sigma_omega' = (1/3) 0.014 / 0.002 sqrt(1 + (1/3) / (5/3)) =
    2.556 rad/s^2, times 2 y = 0.03 m (t) or 2 x = 0.04 m (n). Off without a trusted gyro and at inf."""
    p = SensorHealthParameters()
    constants = HealthConstants(*health_constants(p, GEOMETRY))
    omega_dot_std = 0.014 / 0.002 / 3 * math.sqrt(1.2)
    limit = 2.6
    for axis, lever in ((0, 0.015), (1, 0.02)):
        bound = 1.6 * limit + 5 * 2 * lever * omega_dot_std
        assert fast_pair_ratio(bound, limit, axis, True, constants) == pytest.approx(limit)
        assert fast_pair_ratio(-0.5 * bound, limit, axis, True, constants) == pytest.approx(0.5 * limit)
        assert fast_pair_ratio(bound, limit, axis, False, constants) == 0.0
    off = HealthConstants(
        *health_constants(SensorHealthParameters(fast_consistency_factor=math.inf), GEOMETRY)
    )
    assert fast_pair_ratio(100.0, limit, 0, True, off) == 0.0
    for bad in (0, 51, True, 2.0):
        with pytest.raises(ValueError, match=r"fast_consistency_samples=.*integers in \[1, 50\]"):
            SensorHealthParameters(fast_consistency_samples=bad)
    for bad in (0.0, -1.0, True):
        with pytest.raises(ValueError, match=r"fast_consistency_factor=.*\(0, inf\]"):
            SensorHealthParameters(fast_consistency_factor=bad)


def test_the_pair_gain_test_by_hand():
    """pair_gain_ratio on constant inputs (1 m/s, a t-axis disagreement of 1 m/s^2 on a pair mean of 1.5:
    sensor 1 doubled on a 1 m/s^2 signal), once its block averages have settled: beta = 1 / 1.5 on both
    regressors (no rotation). The noise of the 5-sample averages: white 2 0.062^2 g / (2 - g), g = 0.2;
    commotion 2 (0.3 v)^2 g / (2 - g) (1 + phi) / (1 - phi), phi = e^-0.4 (1 - g); omega' (2 y 0.2 0.014 /
    0.002 sqrt(1 + g / (2 - g)))^2. Over 40 samples the statistic is (beta - 0.1 - 0.1 / r) / sqrt(16 /
    (40 r^2 / var)) over 4 (the tolerance, and an offset allowance, 0 by default). Nothing is learned
    while the wheels stand still."""
    p = SensorHealthParameters()
    constants = HealthConstants(*health_constants(p, GEOMETRY))
    state = health_initial_state(GEOMETRY)
    for _ in range(400):
        ratio = pair_gain_ratio(state, 0, 1.0, 1.5, 0.0, 0.0, 1.0, True, True, constants, constants)
    g = 0.2
    white = g / (2 - g)
    phi = math.exp(-0.4) * (1 - g)
    var = (
        2 * 0.062**2 * white
        + 2 * 0.3**2 * white * (1 + phi) / (1 - phi)
        + (2 * 0.015 * g * 0.014 / 0.002 * math.sqrt(1 + white)) ** 2
    )
    z = (1 / 1.5 - 0.1) / math.sqrt(16 / (40 * 1.5**2 / var))
    assert ratio == pytest.approx(z / 4, rel=1e-9)
    assert 1.2 < ratio < 1.35  # flagged
    # the evidence of a healthy gain: |beta| + 1 sigma, here far above gain_release (0.3)
    upper = 1 / 1.5 + math.sqrt(16 / (40 * 1.5**2 / var))
    assert pair_gain_upper_bound(state, 0, True, constants) == pytest.approx(upper, rel=1e-9)
    assert pair_gain_upper_bound(state, 0, False, constants) == 0.0  # not judged without omega'
    # an accelerometer out for its own fault empties the window: the evidence starts again
    emptied = state.copy()
    pair_gain_reset(emptied)
    assert pair_gain_upper_bound(emptied, 0, True, constants) == 0.0
    kept = pair_gain_ratio(state.copy(), 0, 1.0, 1.5, 0.0, 0.0, 1.0, True, True, constants, constants)
    again = pair_gain_ratio(emptied, 0, 1.0, 1.5, 0.0, 0.0, 1.0, True, True, constants, constants)
    assert kept > 1.0 and again < 0.5
    # with an offset allowance of 0.1 m/s^2 beyond the tolerance: 0.1 sum |r| / sum r^2 = 0.1 / 1.5
    allowing = HealthConstants(*health_constants(SensorHealthParameters(gain_offset_allowance=0.1), GEOMETRY))
    state = health_initial_state(GEOMETRY)
    for _ in range(400):
        ratio = pair_gain_ratio(state, 0, 1.0, 1.5, 0.0, 0.0, 1.0, True, True, allowing, allowing)
    z = (1 / 1.5 - 0.1 - 0.1 / 1.5) / math.sqrt(16 / (40 * 1.5**2 / var))
    assert ratio == pytest.approx(z / 4, rel=1e-9)
    # Not judged without the gyro's omega', nor when off; a gain within the tolerance reads 0.
    assert pair_gain_ratio(state.copy(), 0, 1.0, 1.5, 0.0, 0.0, 1.0, True, False, constants, constants) == 0.0
    off = HealthConstants(*health_constants(SensorHealthParameters(gain_threshold=math.inf), GEOMETRY))
    assert pair_gain_ratio(state.copy(), 0, 1.0, 1.5, 0.0, 0.0, 1.0, True, True, off, off) == 0.0
    state = health_initial_state(GEOMETRY)
    for _ in range(400):
        ratio = pair_gain_ratio(state, 1, 0.1, 1.5, 0.0, 0.0, 1.0, True, True, constants, constants)
    assert ratio == 0.0  # beta = 0.067 < 0.1
    at_rest = health_initial_state(GEOMETRY)
    for _ in range(400):
        ratio = pair_gain_ratio(at_rest, 0, 1.0, 1.5, 0.0, 0.0, 0.0, False, True, constants, constants)
    assert ratio == 0.0
    for name, bad, allowed in (
        ("gain_samples", 51, r"integers in \[2, 50\]"),
        ("gain_samples", 1, r"integers in \[2, 50\]"),
        ("gain_block_samples", 0, r"integers in \[1, 50\]"),
        ("gain_tolerance", 1.0, r"\[0, 1\)"),
        ("gain_threshold", 0.0, r"\(0, inf\]"),
        ("gain_cross_coupling", -0.1, r"\[0, inf\)"),
        ("gain_offset_allowance", math.nan, r"\[0, inf\)"),
        ("gain_release", 0.0, r"\(0, 1\]"),
        ("gain_release", 1.5, r"\(0, 1\]"),
        ("gain_release", 0.1, r"above gain_tolerance=0.1"),
    ):
        with pytest.raises(ValueError, match=rf"{name}=.*{allowed}"):
            SensorHealthParameters(**{name: bad})


def commotion_at(speed, rng):
    """Each accelerometer's commotion (S(3)'s model, systems/robot/sensors.py) at the samples' ``speed``: a
    first-order Gauss-Markov process of 5 ms and 0.3 |v| m/s^2, drawn from ``rng`` sample by sample."""
    phi = math.exp(-T_N / 0.005)
    commotion = np.zeros((len(speed), 4))
    for k in range(1, len(speed)):
        commotion[k] = phi * commotion[k - 1] + math.sqrt(1 - phi * phi) * 0.3 * speed[
            k
        ] * rng.standard_normal(4)
    return commotion


def accelerating_stream(n, seed=0, ripple=0.25):
    """n samples of a robot driving straight at v = 1 + ripple sin(2 pi t) (a_t up to 1.57 m/s^2 with
    the default ripple), its accelerometers with white noise (0.062 m/s^2) and commotion (0.3 v m/s^2,
    5 ms) each, its encoders exact."""
    rng = np.random.default_rng(seed)
    t = T_N * np.arange(1, n + 1)
    v = 1.0 + ripple * np.sin(2 * math.pi * t)
    a_t = ripple * 2 * math.pi * np.cos(2 * math.pi * t)
    travel = t + ripple / (2 * math.pi) * (1 - np.cos(2 * math.pi * t))
    commotion = commotion_at(v, rng)
    acc = np.column_stack([a_t, 0 * t, a_t, 0 * t]) + 0.062 * rng.standard_normal((n, 4)) + commotion
    gyro = 0.014 * rng.standard_normal(n)
    return np.column_stack([acc, gyro, travel / R, travel / R])


def test_a_doubled_accelerometer_the_averages_miss_is_flagged_by_the_gain_test():
    """accel1_t doubled for 0.5 s from an acceleration peak (t = 2 s) of accelerating_stream: the
    disagreement (a_t, up to 1.57 m/s^2) stays inside the averages' bounds (1 + v, fast 1.6 x that), which
    therefore never flag it; the gain test flags accel1_t (the farther from d v_o / dt) within 0.1 s,
    keeps it out while doubled, through the zero crossings of a_t where its evidence dips (released only
    on the evidence of a gain within gain_release: pair_gain_upper_bound), re-admits it within 0.1 s of
    its end and flags nothing fault-free (10 seeds). Released when the window's evidence of the fault
    dipped below half the threshold, seed 0 came back at sample 1210 (beta read 0.38 for 0.67), and 8
    of these 10 seeds came back in the middle of the fault."""
    for seed in range(10):
        assert not check(accelerating_stream(2000, seed))[1].any(), seed
    for seed in range(10):
        rows = accelerating_stream(2000, seed)
        rows[1000:1250, 0] *= 2.0
        if seed == 0:
            no_gain = check(rows, SensorHealthParameters(gain_threshold=math.inf))[1]
            assert not no_gain.any()
        out, codes = check(rows)
        flagged = np.flatnonzero(codes[:, 0])
        assert 1000 <= flagged[0] <= 1000 + 50 and codes[flagged[0], 0] == INCONSISTENT, seed
        assert np.all(codes[flagged[0] : 1250, 0] == INCONSISTENT), seed
        assert flagged[-1] < 1250 + 50, seed
        assert not np.delete(codes, 0, axis=1).any(), seed  # accel 2 is never blamed
    rows = accelerating_stream(2000)
    rows[1000:1250, 0] *= 2.0
    out, codes = check(rows)
    flagged = np.flatnonzero(codes[:, 0])
    # replaced by accel 2 plus the rotational difference -2 (omega^2 x + omega' y) from the gyro (noise
    # here) and the pair's learned offset
    k = slice(flagged[0], 1250)
    omega_dot = np.diff(rows[:, 4], prepend=np.nan) / T_N
    expected = rows[k, 2] - 2 * rows[k, 4] ** 2 * 0.02 - 2 * omega_dot[k] * 0.015
    np.testing.assert_allclose(out[k, 0], expected, rtol=0, atol=0.05)
    np.testing.assert_allclose(np.diff(out[k, 0] - expected), 0.0, atol=1e-12)  # one offset throughout


def test_a_bias_on_a_weakly_excited_axis_is_cleared_by_the_averages():
    """accel1_t 4 m/s^2 off for 0.2 s on a robot whose speed ripples by 0.03 m/s (a_t up to 0.19 m/s^2):
    the gain test may flag it first (a bias regresses on a signal with a mean), but the averages' evidence
    then takes the hold over, and the pair is cleared within 0.2 s of the fault's end, as the averages
    clear it; as a hold of the gain test alone it waited for a healthy gain the weak signal never shows
    (seed 1: 1.7 s)."""
    for seed in range(4):
        rows = accelerating_stream(2000, seed, ripple=0.03)
        rows[1000:1100, 0] += 4.0
        out, codes = check(rows)
        flagged = np.flatnonzero(codes[:, 0])
        assert 1000 <= flagged[0] <= 1010 and np.all(codes[flagged[0] : 1100, 0] == INCONSISTENT), seed
        assert flagged[-1] < 1100 + 100, seed
        assert not np.delete(codes, 0, axis=1).any(), seed


def test_a_gyro_readmitted_off_its_replacement_raises_no_accelerometer_flag():
    """After a gyro outage in a skid (the odometric yaw rate 0.45 rad/s high) the re-admitted gyro's first
    difference against its replacement is 0.45 / T_N = 225 rad/s^2 of omega', which the pair's rotational
    term 2 omega' x turns into 9 m/s^2 on the n axes for one sample: the fast test is judged only with the
    gyro trusted on the previous sample as well, so the healthy accelerometers stay unflagged."""
    rows = stream(400, 0.5, 3.0)
    rows[100:150, 4] = np.nan
    skid = 0.45 * B / R * T_N * np.arange(1, 61)  # the wheels' extra yaw over 100..159
    rows[100:160, 5] += 0.5 * skid
    rows[100:160, 6] -= 0.5 * skid
    rows[160:, 5] += 0.5 * skid[-1]
    rows[160:, 6] -= 0.5 * skid[-1]
    out, codes = check(rows, v0=0.5)
    assert codes[100:150, 4].all() and not codes[200:, 4].any()  # out, then re-admitted
    assert not codes[:, 0:4].any(), np.flatnonzero(codes[:, 0:4].any(axis=1))


def test_a_replaced_accelerometer_axis_keeps_the_pairs_yaw_acceleration_term():
    """A turn-in at omega' = 10 rad/s^2 (v = 1 m/s, noise-free): a_n1 - a_n2 = 2 (omega' x - omega^2 y)
    (systems/robot/sensors.accelerometer_truth). accel1_n reads NaN for 50 samples and is replaced by a_n2
    plus both rotational terms, omega' from the gyro's difference; the replacement is the true reading.
    Without the omega' term it was 2 omega' x = 0.4 m/s^2 off, and the pair's mean (the body's a_n that
    the EKF integrates) omega' x: v_n off by x omega at the end of the turn (open corner: 2 x 2.6 mm of
    final error)."""
    n, v, omega_dot, position = 200, 1.0, 10.0, (0.02, 0.015)
    omega = omega_dot * T_N * np.arange(n)
    heading_rate_R = np.cumsum((v + 0.5 * B * omega) / R * T_N)
    heading_rate_L = np.cumsum((v - 0.5 * B * omega) / R * T_N)
    truth = np.array([accelerometer_truth((0.0, v * w, omega_dot), w, position) for w in omega])
    rows = np.column_stack([truth, omega, heading_rate_R, heading_rate_L])
    rows[100:150, 1] = np.nan
    out, codes = check(rows, v0=v)
    assert np.all(codes[100:150, 1] == NONFINITE) and not codes[:, [0, 2, 3, 4, 5, 6]].any()
    np.testing.assert_allclose(out[100:150, 1], truth[100:150, 1], rtol=0, atol=1e-9)
    np.testing.assert_allclose(0.5 * (out[:, 1] + out[:, 3]), v * omega, rtol=0, atol=1e-9)


def test_an_accelerometer_clipped_within_its_noise_is_flagged_at_its_plateau():
    """accel1_n clipped at +-0.05 m/s^2 (an amplifier's rail far below the data sheet's 10 g) while it
    reads noise (sigma 0.06): about a third of the readings sit at the rail, never twice in a row for
    long, so neither the range nor the stuck test sees it. The third return to one magnitude, the largest
    within clip_window, is flagged saturated and replaced by a_n2 plus the rotational terms; the
    unclipped readings between are used; after the clip nothing is flagged."""
    rows = stream(600, 1.0, 0.0)
    clean = rows.copy()
    rows[100:300, 1] = np.clip(rows[100:300, 1], -0.05, 0.05)
    at_rail = np.flatnonzero(np.abs(rows[:, 1]) == 0.05)
    out, codes = check(rows)
    assert not codes[:, [0, 2, 3, 4, 5, 6]].any() and not codes[:100, 1].any() and not codes[300:, 1].any()
    flagged = np.flatnonzero(codes[:, 1])
    assert np.all(codes[flagged, 1] == SATURATED)
    assert flagged[0] == at_rail[2] and flagged[0] - 100 < 10  # the third sample at the rail
    np.testing.assert_array_equal(flagged, at_rail[2:])
    # Replaced by the partner plus the rotational terms (omega' from the gyro's difference) and the pair's
    # offset learned before (a few mm/s^2 of noise); unclipped readings kept.
    gyro, previous = rows[flagged, 4], rows[flagged - 1, 4]
    expected = rows[flagged, 3] - 2 * gyro**2 * 0.015 + 2 * (gyro - previous) / T_N * 0.02
    np.testing.assert_allclose(out[flagged, 1], expected, atol=0.01)
    kept = np.setdiff1d(np.arange(100, 300), at_rail)
    np.testing.assert_array_equal(out[kept, 1], clean[kept, 1])
    for name in ("clip_samples", "clip_window"):
        for bad in (1, 51, 2.5):
            with pytest.raises(ValueError, match=rf"{name}=.*integers in \[2, 50\]"):
                SensorHealthParameters(**{name: bad})
    out, codes = check(rows, SensorHealthParameters(clip_samples=0))  # off
    assert not codes.any()


def test_a_replaced_accelerometer_axis_carries_the_pairs_learned_offset():
    """The two accelerometers' lateral axes differ by 0.1 m/s^2 (a bias difference) in a steady turn:
    while both agree the checks learn the offset (pair_offset_update: a scalar Kalman filter from the
    prior 2 x 0.05^2, drifting by 2 x 0.0065^2 T_N a sample, whose measurement is the mean of a block of
    15 samples, weighed by 2 x 0.062^2 of white noise and 2 (0.3 v)^2 (1 + phi) / (1 - phi) of commotion
    at 1 m/s per sample, phi = exp(-T_N / 5 ms), and by the gyro's 2 (2 x 0.014 / T_N)^2 at the block's
    ends, all over 15^2; the gyro's omega' is known from the second sample on), and when
    accel1_n is lost after 5 s its replacement is a_n2 plus the rotational terms plus that offset, so the
    pair's mean keeps its level (without the offset it would move by 0.05 m/s^2, half the difference)."""
    n, v, omega, position = 3000, 1.0, 2.0, (0.02, 0.015)
    truth = np.array(accelerometer_truth((0.0, v * omega, 0.0), omega, position))
    rows = stream(n, v, omega)
    # A reading that never repeats (neither stuck nor clipped: an alternating dither returns to one value)
    dither = 1e-6 * np.random.default_rng(3).standard_normal(n)
    rows[:, 0:4] = truth + np.array([0.0, 0.1, 0.0, 0.0]) + dither[:, None]
    rows[:, 4] = omega + dither
    rows[2500:2600, 1] = np.nan
    out, codes = check(rows, v0=v)
    assert np.all(codes[2500:2600, 1] == NONFINITE) and not codes[:, [0, 2, 3, 4, 5, 6]].any()
    phi = math.exp(-T_N / 0.005)
    noise = 2 * 0.062**2 + 2 * (0.3 * v) ** 2 * (1 + phi) / (1 - phi)
    rotation = 2 * (2 * position[0] * 0.014 / T_N) ** 2
    learned, variance, count = 0.0, 2 * 0.05**2, 0
    for sample in range(2500):
        variance += 2 * 0.0065**2 * T_N
        count += sample >= 1
        if count == 15:
            count, block_noise = 0, (15 * noise + rotation) / 15**2
            gain = variance / (variance + block_noise)
            learned, variance = learned + gain * (0.1 - learned), variance * (1 - gain)
    assert 0.09 < learned < 0.095  # the commotion it expects at 1 m/s (none here) slows it
    np.testing.assert_allclose(out[2500:2600, 1], truth[3] + 2 * (-(omega**2) * 0.015) + learned, atol=1e-3)
    mean = 0.5 * (out[2500:2600, 1] + out[2500:2600, 3])
    np.testing.assert_allclose(mean, v * omega + 0.05 - 0.5 * (0.1 - learned), atol=1e-3)
    np.testing.assert_allclose(mean, v * omega + 0.05, atol=4e-3)  # the level, less what is unlearned


def driving_off(seed, n=1500, rest=500, v=1.6, difference=0.1):
    """n samples of a robot at rest for ``rest`` samples, then accelerating straight at 2 m/s^2 to v: its
    accelerometers with white noise (0.062 m/s^2) and commotion (0.3 v m/s^2, 5 ms) each, accel1_n
    ``difference`` above accel2_n (a bias difference), its gyro noise only, its encoders exact."""
    rng = np.random.default_rng(seed)
    speed = np.clip((np.arange(n) - rest) * T_N * 2.0, 0.0, v)
    commotion = commotion_at(speed, rng)
    acc = 0.062 * rng.standard_normal((n, 4)) + commotion
    accelerating = np.where((np.arange(n) > rest) & (speed < v), 2.0, 0.0)
    acc += np.column_stack([accelerating, 0 * speed + difference, accelerating, 0 * speed])
    travel = np.cumsum(speed) * T_N
    return np.column_stack([acc, 0.014 * rng.standard_normal(n), travel / R, travel / R])


def test_the_pairs_offset_is_learned_at_rest_and_kept_at_speed():
    """A bias difference of 0.1 m/s^2 between the lateral axes, 1 s at rest, then 1.8 s of driving with
    the commotion of 1.6 m/s: pair_offset_update learns the difference at rest, where the disagreement
    is the sensors' white noise and the gyro's omega' (which telescopes over each block), and the
    commotion moves it little, so that accel1_n lost at 2.8 s is replaced with an offset within
    0.01 m/s^2 of 0.1 on 5 seeds. A PT1 of 1 s on the same disagreements ends 0.06 m/s^2 off in RMS over
    these seeds."""
    errors, pt1_errors = [], []
    for seed in range(5):
        rows = driving_off(seed)
        rows[1400:1450, 1] = np.nan
        out, codes = check(rows, v0=0.0)
        assert np.all(codes[1400:1450, 1] == NONFINITE) and not np.delete(codes, 1, axis=1).any()
        assert not codes[:1400].any() and not codes[1450:].any()
        # the replacement: a_n2 plus the rotational difference (the gyro: its noise) plus the offset
        omega_dot = np.diff(rows[:, 4], prepend=np.nan) / T_N
        rotation = -2 * rows[:, 4] ** 2 * 0.015 + 2 * omega_dot * 0.02
        offset = out[1400:1450, 1] - rows[1400:1450, 3] - rotation[1400:1450]
        np.testing.assert_allclose(offset, offset[0], rtol=0, atol=1e-12)
        errors.append(offset[0] - 0.1)
        pt1 = 0.0
        for disagreement in (rows[:, 1] - rows[:, 3] - rotation)[1:1400]:
            pt1 += (disagreement - pt1) * T_N / 1.0
        pt1_errors.append(pt1 - 0.1)
    assert max(np.abs(errors)) < 0.01, errors
    assert np.sqrt(np.mean(np.square(pt1_errors))) > 0.03, pt1_errors


def test_a_long_lever_at_rest_keeps_the_pairs_offset_and_raises_no_flag():
    """Kurt3D's accelerometers at +-(0.1, 0.05) m, 20 s at rest: the gyro's noise (0.014 rad/s) puts
    2 x 0.1 x 0.014 sqrt(2) / T_N = 2 m/s^2 of omega' noise into each sample's n-axis disagreement, which
    the offset's blocks telescope (pair_offset_update). No sample is flagged, and the learned offsets stay
    within 4 of their standard deviations of the true 0 (the sensors' biases are equal)."""
    geometry = HealthGeometry(R, R, B, T_N, STEP, (0.1, 0.05), 6.3)
    state = health_initial_state(geometry, 0.0)
    params = SensorHealthParameters()
    for row in stream(10_000, 0.0, 0.0, seed=4):
        state, _, codes = health_step(state, row, params, geometry)
        assert not np.any(codes), codes
    offset, variance = state[PAIR_OFFSET], state[PAIR_OFFSET_VARIANCE]
    assert np.all(np.abs(offset) < 4.0 * np.sqrt(variance)) and np.all(np.sqrt(variance) < 0.02), (
        offset,
        variance,
    )


def test_encoder_spike_is_excluded_and_the_angle_stays_continuous():
    clean = stream(300, 1.0, 0.0)
    rows = clean.copy()
    rows[100, 5] += 1000 * STEP
    out, codes = check(rows)
    # Sample 101 spans the exclusion; 102-111 are the re-admission block (encoder_readmission_samples).
    assert codes[100, 5] == JUMP and np.all(codes[101:111, 5] == RECOVERING) and not codes[111:, 5].any()
    # Samples 100-110 advance by v_L + b omega_gyro: off by b x 0.014 rad/s noise x T_N / r each.
    np.testing.assert_array_equal(out[:100, 5], clean[:100, 5])
    atol = 3 * math.sqrt(11) * B * 0.014 * T_N / R
    np.testing.assert_allclose(out[:, 5], clean[:, 5], rtol=0, atol=atol)
    np.testing.assert_allclose(np.diff(out[111:, 5]), np.diff(clean[111:, 5]), rtol=0, atol=1e-12)


def test_a_doubled_encoder_is_not_readmitted_at_low_speed():
    """A NaN at sample 100, then the right encoder's increments doubled until sample 300 at 0.25 m/s:
    each doubled increment (0.25 m/s off the prediction v_L + b omega, 0.5 mm of travel) is within one
    sample's bound (150 m/s^2 x T_N + two counts = 0.315 m/s), but their sum over a block of 10 is 5 mm
    against a tolerance of two counts (0.03 mm) plus 0.2 x 5 mm: the encoder stays excluded, replaced by
    the prediction, until the doubling ends, and is re-admitted one block later."""
    v = 0.25
    clean = stream(500, v, 0.0)
    rows = clean.copy()
    doubled = slice(101, 301)
    rows[doubled, 5] = clean[100, 5] + 2.0 * (clean[doubled, 5] - clean[100, 5])
    rows[301:, 5] = clean[301:, 5] + (clean[300, 5] - clean[100, 5])
    rows[100, 5] = np.nan
    out, codes = check(rows, v0=v)
    assert codes[100, 5] == NONFINITE and np.all(codes[101:301, 5] == RECOVERING)
    readmitted = 101 + int(np.argmax(codes[101:, 5] == 0))
    assert 301 < readmitted <= 301 + 2 * 10 and not codes[readmitted:, 5].any()
    # The output follows the real wheel: the gyro's noise over the exclusion, not the doubled travel.
    drift = 3 * math.sqrt(readmitted - 100) * B * 0.014 * T_N / R
    assert np.max(np.abs(out[:readmitted, 5] - clean[:readmitted, 5])) < drift < 0.1 * v * 200 * T_N / R
    # One sample's test alone (a block of 1) re-admits the doubled encoder at once.
    single = SensorHealthParameters(encoder_readmission_samples=1, encoder_readmission_fraction=1.0)
    _, codes = check(rows, single, v0=v)
    assert codes[101, 5] == RECOVERING and not codes[102:, 5].any()
    for key, bad, allowed in (
        ("encoder_readmission_samples", 0, r"integers in \[1, 50\]"),
        ("encoder_readmission_samples", 2.5, r"integers in \[1, 50\]"),
        ("encoder_readmission_samples", 51, r"integers in \[1, 50\]"),
        ("encoder_readmission_fraction", -0.1, r"\[0, 1\]"),
        ("encoder_readmission_fraction", math.nan, r"\[0, 1\]"),
        ("encoder_readmission_fraction", 1.5, r"\[0, 1\]"),
    ):
        with pytest.raises(ValueError, match=f"{key}=.*allowed {allowed}"):
            SensorHealthParameters(**{key: bad})


def test_stuck_encoder_is_detected_and_its_missed_travel_restored():
    rows = stream(400, 1.0, 0.0)
    rows[100:250, 5] = rows[99, 5]
    out, codes = check(rows)
    # At 1 m/s the count's stop is a jump of the wheel speed (> 150 m/s^2 T_N): flagged at once, then
    # excluded until it agrees with v_L + b omega again; its resumption (a 150-sample lump) is a jump too.
    assert codes[100, 5] == JUMP and np.all(codes[101:250, 5] == RECOVERING)
    # Then a block of encoder_readmission_samples agreeing samples (252-261) re-admits it.
    assert codes[250, 5] == JUMP and np.all(codes[251:261, 5] == RECOVERING) and not codes[261:, 5].any()
    # Replaced by v_L + b omega_gyro: the gyro's noise (0.014 rad/s x b) integrates over 160 samples.
    assert abs(out[-1, 5] - rows[-1, 5]) * R < 1e-4


def test_slowly_stuck_encoder_is_stuck():
    """At 0.2 m/s the count's stop is a plausible deceleration: five still samples while v_L + b omega
    says 0.2 m/s make it stuck, and the travel missed meanwhile is added."""
    rows = stream(400, 0.2, 0.0)
    rows[100:250, 5] = rows[99, 5]
    out, codes = check(rows, v0=0.2)
    assert not codes[:104, 5].any() and np.all(codes[104:250, 5] == STUCK)
    assert abs(out[249, 5] - stream(400, 0.2, 0.0)[249, 5]) < 150 * 3 * B * 0.014 * T_N / R
    # The missed travel comes in the detection's sample: S(11) leaves that one sample out.
    state, restored = health_initial_state(GEOMETRY, 0.2), []
    for row in rows:
        state, _, code = health_step(state, row, SensorHealthParameters(), GEOMETRY)
        restored.append(travel_restored(state))
        assert health_flags(code, restored[-1])[2] == (1.0 if restored[-1] else 0.0)
    assert np.flatnonzero(restored).tolist() == [104]


def test_a_wheel_locked_by_hard_braking_is_not_a_stuck_encoder():
    """At 0.2 m/s the left count stops while the right wheel turns and the gyro reads no pivot: a frozen
    counter (flagged after five samples, test_slowly_stuck_encoder_is_stuck) or a wheel the brakes lock
    while the body slides on (the square's final braking: 5.8 m/s^2, the left wheel commanded to a stop).
    With stuck_braking_deceleration = 3 m/s^2 the accelerometers tell them apart: against a deceleration
    beyond it no still sample counts; the same standstill at 2.9 m/s^2 is a stuck counter again."""
    on = SensorHealthParameters(stuck_braking_deceleration=3.0)  # the default, inf, counts at any braking
    for deceleration, flagged in ((5.8, False), (2.9, True)):
        rows = stream(400, 0.2, 0.0)
        rows[100:250, 5] = rows[99, 5]
        rows[:, [0, 2]] -= deceleration
        _, codes = check(rows, on, v0=0.2)
        assert bool(codes[104:250, 5].any()) is flagged, deceleration
        assert not codes[:, 0:5].any()
    rows = stream(400, 0.2, 0.0)
    rows[100:250, 5] = rows[99, 5]
    rows[:, [0, 2]] -= 5.8
    rows[100:250, 0] = math.nan  # one accelerometer lost: the other still tells the braking
    _, codes = check(rows, on, v0=0.2)
    assert not codes[104:250, 5].any()  # (the synthetic count resumes with a lump at 250: a jump)
    assert np.all(check(rows, v0=0.2)[1][104:250, 5] == STUCK)  # the default
    for bad in (0.0, -1.0, math.nan, True):
        with pytest.raises(ValueError, match=r"stuck_braking_deceleration=.*allowed \(0, inf\] m/s\^2"):
            SensorHealthParameters(stuck_braking_deceleration=bad)


def test_a_stuck_encoders_restored_travel_never_becomes_s11s_reference():
    """The navigation at 0.2 m/s, encoder_L frozen from sample 305: it is found stuck at sample 310, a
    control instant, and its missed travel comes back in that one sample. S(11) leaves the sample out, and
    the next batch's reference is the last one carried by the inertial speed change, not that sample's
    speed (which gave dv = 0.40 m/s and C1 0.02, a slip that never was). dv stays within the noise of
    the other detections (0.044 m/s) and C1 above 0.6."""
    from slipnav.systems.navigation.loop import NavigationLoop, run_navigation_loop
    from slipnav.systems.navigation.parameters import (
        NavigationBelief,
        NavigationInitialState,
        NavigationParameters,
    )
    from slipnav.systems.rates import SampleRates

    n, v = 600, 0.2
    rng = np.random.default_rng(0)
    k = np.arange(1, n + 1)
    angles = np.round(np.column_stack([v / R * T_N * k] * 2) / STEP) * STEP
    angles[305:, 1] = angles[305, 1]
    belief = NavigationBelief(
        NavigationParameters(), R, B, SampleRates(T_N, 0.02), NavigationInitialState(speed=v)
    )
    loop = NavigationLoop(belief)
    out = run_navigation_loop(loop, rng.normal(0, 0.02, (n, 4)), rng.normal(0, 0.005, n), angles)
    detected = int(np.flatnonzero(out["health_encoder_L"] == STUCK)[0])
    assert detected == 310
    assert np.max(np.abs(out["delta_v"][detected : detected + 40])) < 0.05
    assert np.min(out["C1"][detected : detected + 60]) > 0.6


def test_a_wheel_held_by_hand_is_not_an_encoder_fault():
    """The robot pivots about the held right wheel: v_R = 0, v_L = -b omega (gyro agrees)."""
    v = 0.1
    rows = stream(300, v, -2 * v / B)  # omega = -2.9 rad/s, v_L = 0.2 m/s
    assert np.all(np.diff(rows[:, 5]) == 0.0)
    _, codes = check(rows, v0=v)
    assert not codes.any()


# -- the closed loop ---------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def corner_clean():
    return scenario_run("corner").arrays  # the default corner, shared (tests/shared.py)


@pytest.mark.parametrize(
    "kind, channel",
    [
        ("nan", "accel1_n"),
        ("inf", "gyro"),
        ("dropout", "gyro"),
        ("stuck", "encoder_L"),
        ("bias", "accel2_t"),
        ("scale", "gyro"),
        ("spike", "encoder_R"),
        ("saturation", "accel2_n"),
    ],
)
def test_closed_loop_fault_is_detected_bounded_and_recovered(corner_clean, kind, channel):
    """Corner, one 0.5 s fault of each class as slipnav faults injects it (from 0.1 s before the
    channel's largest reading): in the closed loop flagged within 0.1 s of its first visible effect, the
    channel re-admitted within 0.2 s of its end and the gyro bias within 3 sigma of the truth; the fused
    error within 3x the fault-free run's on the same path, open loop (the trajectory's wheel speeds fed
    forward). Closed, a fault moves the controller's path, and one run's final error scatters by nearly a
    factor 2 under a negligible fault: the open loop judges the estimator alone."""
    clean = corner_clean
    case = next(c for c in fault_cases(clean) if c["channel"] == channel and c["kind"] == kind)
    event = FaultEvent(kind, channel, case["start"], case["duration"], case["value"])
    a = run_scenario(load_scenario("corner"), faults=[event]).arrays
    codes = a[f"health_{channel}"]
    flagged = a["t"][np.flatnonzero(codes)]
    assert flagged[0] - fault_onset(clean, event) <= 0.1
    assert not np.any(codes[a["t"] > event.start + event.duration + 0.2])
    assert abs(a["est_gyro_bias"][-1] - a["true_gyro_bias"][-1]) <= 3 * a["est_gyro_bias_std"][-1]
    open_loop = run_scenario(load_scenario("corner"), faults=[event], open_loop=True).arrays
    clean_open_loop = scenario_run("corner", open_loop=True).arrays
    assert final_position_error(open_loop, "est") <= 3 * final_position_error(clean_open_loop, "est")


def test_closed_loop_frozen_gyro_at_turn_in_costs_a_tenth_of_trusting_it():
    """Frozen at the corner's turn-in (2.2 s): the odometry's differential slip there (10-15 %) costs
    about 1.7 deg of heading; trusting the frozen gyro (checks off, NaN only) costs tens of degrees."""
    scenario = load_scenario("corner")
    event = FaultEvent("dropout", "gyro", 2.2, 0.5)
    checked = run_scenario(scenario, faults=[event]).arrays
    trusting = dc.replace(
        scenario, navigation=dc.replace(scenario.navigation, health=SensorHealthParameters(enabled=False))
    )
    blind = run_scenario(trusting, faults=[event]).arrays
    assert not blind["health_gyro"].any()
    heading = abs(checked["est_phi"][-1] - checked["true_phi"][-1])
    assert heading < math.radians(3.0) < 0.1 * abs(blind["est_phi"][-1] - blind["true_phi"][-1])
    assert final_position_error(checked, "est") < 0.1 * final_position_error(blind, "est")


def test_fault_cases_and_the_report_line():
    clean = scenario_run("corner", duration=2.0).arrays  # shared with the next test (tests/shared.py)
    cases = fault_cases(clean)
    assert len(cases) == 5 * 7 + 2 * 6
    assert all(c["start"] >= float(clean["start_time"]) for c in cases)
    rows = [
        {**c, "scenario": "corner", "seed": 0, "latency_s": 0.004, "detected": True, "error_ratio": 1.5}
        | {
            "bias_error_sigma": 1.0,
            "fused_error_m": 0.01,
            "odometry_error_m": 0.1,
            "gyrodometry_error_m": 0.02,
        }
        for c in cases[:3]
    ]
    rows[1]["other_flags"] = 4  # a fault on one channel that flagged another (isolation's slip)
    import io

    out = io.StringIO()
    print_report(rows, [{"false_flags": 0}], 1.0, out)
    lines = out.getvalue().splitlines()
    assert lines[-1] == "faults detected=3/3 worst_error_ratio=1.500"
    crossed = f"sensor-fault runs that flagged another channel: 1 ({rows[1]['channel']} {rows[1]['kind']})"
    assert crossed in lines


def test_selected_faults_and_the_over_seeds_ratio(capsys):
    """``slipnav faults --channels --kinds`` runs only those faults (an unknown name is an error naming the
    allowed ones, before any run); over two or more seeds the report adds the faulted runs' mean fused
    error over the fault-free runs' mean per channel and class (by hand: (4 + 10) / (1 + 6) = 2)."""
    from slipnav.studies.cli import main

    cases = fault_cases(scenario_run("corner", duration=2.0).arrays)
    chosen = select_cases(cases, ["gyro"], ["nan", "bias"])
    assert [(c["channel"], c["kind"]) for c in chosen] == [("gyro", "nan"), ("gyro", "bias")]
    assert select_cases(cases) == cases
    with pytest.raises(ValueError, match=r"--channels: unknown 'compass'; allowed: accel1_t, accel1_n"):
        select_cases(cases, ["gyro", "compass"])
    with pytest.raises(ValueError, match=r"--kinds: unknown 'smoke'; allowed: nan, inf, dropout"):
        select_cases(cases, None, ["smoke"])
    with pytest.raises(ValueError, match=r"--channels gyro --kinds stuck: no such fault \(encoders: nan"):
        select_cases(cases, ["gyro"], ["stuck"])  # a stuck counter is an encoder's
    assert main(["faults", "corner", "--kinds", "nan, smoke"]) == 2  # names stripped
    assert "--kinds: unknown 'smoke'" in capsys.readouterr().err
    assert main(["faults", "corner", "--channels", ""]) == 2
    assert "--channels: unknown ''" in capsys.readouterr().err
    figures = {"latency_s": 0.0, "detected": True, "bias_error_sigma": 0.5, "odometry_error_m": 0.1}
    figures |= {"gyrodometry_error_m": 0.05, "error_ratio": 1.0}
    rows = [
        {**figures, "scenario": "corner", "seed": seed, "channel": "gyro", "kind": "nan", "fused_error_m": e}
        for seed, e in ((0, 0.004), (1, 0.010))
    ]
    rows.append({**rows[0], "kind": "bias"})  # one seed only: no mean ratio
    rows += [{**rows[0], "kind": "spike", "seed": s} for s in (0, 5)]  # no fault-free seed 5: none
    clean_rows = [
        {"scenario": "corner", "seed": s, "false_flags": 0, "fused_error_m": e}
        for s, e in ((0, 0.001), (1, 0.006))
    ]
    assert seed_mean_ratios(rows, clean_rows) == [pytest.approx((2.0, "corner", "gyro", "nan", 2))]
    import io

    out = io.StringIO()
    print_report(rows, clean_rows, 1.0, out)
    assert (
        "over seeds, the faulted runs' mean fused error / the fault-free runs' mean: worst 2.00 (corner gyro "
        "nan, 2 seeds), 0 of 1 above 3"
    ) in out.getvalue().splitlines()


def test_a_lost_gyro_on_a_toleranced_robot_costs_little(capsys, tmp_path):
    """``slipnav faults --tolerances``: the open corner on the tolerance preset's seed-0 robot (its right
    wheel 0.7 % larger than its left, track 1.7 % wide), the gyro lost for 0.5 s in the turn. Its
    replacement reads the learned D; with the nominal wheels it cost 72 mm, 13.8 x the fault-free 5.2
    mm, and 3.3 deg of heading. Now within 3 x, better than Gyrodometry and odometry-only on the same
    run, and the fault-free run raises no flag (the lateral test's bound once gave a false body flag)."""
    from slipnav.studies.cli import main

    options = ["--open-loop", "--tolerances", "--channels", "gyro", "--kinds", "nan", "--workers", "0"]
    assert main(["faults", "corner", *options, "--out", str(tmp_path)]) == 0
    assert (tmp_path / "faults.csv").exists() and (tmp_path / "faults.png").stat().st_size > 10_000
    lines = capsys.readouterr().out.splitlines()
    row = next(line.split() for line in lines if line.startswith("corner ") and " gyro " in line)
    latency_ms, ratio, fused, odometry, gyrodometry = float(row[4]), *map(float, row[5:6] + row[7:10])
    assert latency_ms <= 100 and ratio <= 3.0 and fused < min(odometry, gyrodometry)
    assert any("false flags in the fault-free runs: 0;" in line for line in lines)
    assert f"figure: {tmp_path / 'faults.png'}" in lines  # the last line stays the benchmark's
    assert lines[-1].startswith("faults detected=1/1 ")


def test_a_doubled_lateral_accelerometer_in_the_slide_is_blamed_right():
    """The closed corner on the tolerance preset's seed-1 robot, accel2_n doubled for 0.5 s in the slide
    (the benchmark's placement). Only the pair's gain test sees it (the disagreement stays inside the
    averages' bounds), and it blames by the distance from the kinematics alone: with the move from the
    level as well (one sample's commotion) it blamed accel1_n, and the doubled sensor replaced it (0.37 m,
    12.7 x the fault-free run). Flagged within 0.1 s, accel1_n never, within 3 x."""
    scenario = load_scenario("corner")
    clean = run_scenario(scenario, seed=1, tolerances=True).arrays
    case = next(c for c in fault_cases(clean) if c["channel"] == "accel2_n" and c["kind"] == "scale")
    event = FaultEvent("scale", "accel2_n", case["start"], case["duration"], case["value"])
    a = run_scenario(scenario, seed=1, faults=[event], tolerances=True).arrays
    flagged = a["t"][np.flatnonzero(a["health_accel2_n"])]
    assert flagged[0] - fault_onset(clean, event) <= 0.1
    assert not a["health_accel1_n"].any()
    assert final_position_error(a, "est") <= 3 * final_position_error(clean, "est")


def test_the_gain_test_learns_nothing_at_rest():
    """The open corner on the tolerance preset's seed-6 robot, fault-free: it stands still for its first
    second, where the pair's mean is the two sensors' biases and its disagreement their difference (0.18
    m/s^2, the offset not yet learned). Taken as signal, the gain test flagged accel2_t at 0.16 s (434
    samples); nothing at rest is informative now, and no channel is flagged."""
    a = run_scenario(load_scenario("corner"), seed=6, tolerances=True, open_loop=True).arrays
    for channel in ("accel1_t", "accel1_n", "accel2_t", "accel2_n", "gyro", "encoder_R", "encoder_L"):
        assert not a[f"health_{channel}"].any(), channel


def test_the_report_counts_the_runs_where_the_fusion_beats_each_baseline():
    """By hand: of two fault runs the fusion ends below odometry-only in both and below Gyrodometry in
    one (a run without a finite fused error is skipped); of two fault-free runs below both baselines in
    one: square seed 1's Gyrodometry ends closer."""
    from slipnav.studies.faults import baseline_line

    run = {"fused_error_m": 0.01, "odometry_error_m": 0.1}
    rows = [
        {**run, "gyrodometry_error_m": 0.02},
        {**run, "gyrodometry_error_m": 0.005},
        {"fused_error_m": 1.0},
        {**run, "fused_error_m": math.nan, "gyrodometry_error_m": 0.02},
    ]
    clean = [
        {"scenario": "corner", "seed": 0, **run, "gyrodometry_error_m": 0.03},
        {"scenario": "square", "seed": 1, **run, "gyrodometry_error_m": 0.009},
        {"scenario": "square", "seed": 2, "false_flags": 0},  # no figures: skipped
    ]
    assert baseline_line(rows, clean) == (
        "baselines on the same runs: the fused final error is below odometry-only's in 2/2 fault runs "
        "and 2/2 fault-free runs; below Gyrodometry's in 1/2 fault runs and 1/2 fault-free runs (fault-free "
        "runs where it is not below both: square seed 1)"
    )


def test_the_report_counts_the_runs_where_the_fusion_beats_each_baseline_along_the_run():
    """The same counts for the RMS and the maximum along the run, by hand: the fused RMS is below both
    baselines' in the one fault run, its maximum below odometry-only's only; nothing when no run has them."""
    from slipnav.studies.faults import along_run_baseline_line

    run = {"fused_rms_error_m": 0.01, "odometry_rms_error_m": 0.1, "gyrodometry_rms_error_m": 0.02}
    run |= {"fused_max_error_m": 0.03, "odometry_max_error_m": 0.2, "gyrodometry_max_error_m": 0.03}
    clean = [{**run, "fused_rms_error_m": 0.05}, {"false_flags": 0}]
    assert along_run_baseline_line([run, {"fused_error_m": 1.0}], clean) == (
        "along the run: the fused RMS is below odometry-only's in 1/1 fault runs and 1/1 fault-free runs, "
        "below Gyrodometry's in 1/1 fault runs and 0/1 fault-free runs; its maximum is below "
        "odometry-only's in 1/1 fault runs and 1/1 fault-free runs, below Gyrodometry's in 0/1 fault runs "
        "and 0/1 fault-free runs"
    )
    assert along_run_baseline_line([{"fused_error_m": 1.0}], [{"false_flags": 0}]) == ""


def test_null_faults_change_nothing_a_check_or_the_estimate_could_see():
    """A 1e-6 bias step for 0.5 s on the gyro: open loop, the estimate moves by rounding only and nothing
    is flagged, so a null fault's final-error ratio in closed loop is what chance gives the metric; the
    report prints its range apart from the faults' counts."""
    scenario = load_scenario("corner")
    clean = run_scenario(scenario, duration=2.5, open_loop=True).arrays
    nulls = null_fault_cases(fault_cases(clean))
    assert sorted(c["channel"] for c in nulls) == ["accel1_t", "gyro"]
    assert all(
        c["kind"] == "bias" and c["value"] == NULL_FAULT_BIAS and math.isnan(c["onset_s"]) for c in nulls
    )
    case = next(c for c in nulls if c["channel"] == "gyro")
    event = FaultEvent(case["kind"], case["channel"], case["start"], case["duration"], case["value"])
    a = run_scenario(scenario, duration=2.5, open_loop=True, faults=[event]).arrays
    figures = fault_figures(a, event, case["onset_s"], final_position_error(clean, "est"), 1.0)
    assert figures["flagged_samples"] == figures["other_flags"] == figures["perturbation_samples"] == 0
    assert not figures["detected"]
    moved = np.hypot(a["est_x"] - clean["est_x"], a["est_y"] - clean["est_y"])
    assert np.max(moved) < 1e-5  # a 1e-6 rad/s heading rate for 0.5 s over 1.6 m/s of travel: ~1e-6 m
    assert figures["error_ratio"] == pytest.approx(1.0, abs=1e-3)
    import io

    out = io.StringIO()
    rows = [{**figures, **case, "scenario": "corner", "seed": 0, "error_ratio": 1.2, "bias_error_sigma": 0.5}]
    nulls_rows = [{**figures, "error_ratio": r, "run_rms_ratio": 1.0} for r in (0.8, 3.6)]
    print_report(rows, [{"false_flags": 0}], 1.0, out, nulls_rows)
    lines = out.getvalue().splitlines()
    assert (
        "null faults (a 1e-06 bias step on gyro, accel1_t): 2 runs, final-error ratio 0.80-3.60 (1 above 3), "
        "RMS ratio 1.00-1.00, flagged 0"
    ) in lines
    assert lines[-1] == "faults detected=0/1 worst_error_ratio=1.200"  # null faults count in neither


# -- plant perturbations -----------------------------------------------------------------------------


def test_plant_perturbations_act_as_their_physics_says():
    """A lifted wheel transmits no tyre force, a hand's torque adds tau/J to the wheel's acceleration, a
    push F/m to the body's, and a held wheel stops with the hand's time constant."""
    p = tinyphoon()
    state = [0.0, 0.0, 0.0, 1.0, 0.05, 0.5, 0.0, 0.0, 1.1 / p.wheel_radius, 0.9 / p.wheel_radius]
    currents = (0.3, 0.2)
    base, acc = plant_derivatives(state, currents, p)
    lifted = plant_disturbance(1.0, [FaultEvent("wheel_lifted", "wheel_R", 0.5, 1.0)], T_N)
    assert lifted == (0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    (_, _, _), (fx_R, _), (fx_L, _) = contact_forces(state, p, lifted)
    assert fx_R == 0.0 and fx_L == contact_forces(state, p)[2][0]
    xdot, _ = plant_derivatives(state, currents, p, lifted)
    assert xdot[8] == pytest.approx((p.motor_constant * 0.3 - p.bearing_drag * state[8]) / p.wheel_inertia)
    pushed = plant_disturbance(1.0, [FaultEvent("wheel_pushed", "wheel_L", 0.5, 1.0, 0.002)], T_N)
    xdot, _ = plant_derivatives(state, currents, p, pushed)
    assert xdot[9] - base[9] == pytest.approx(0.002 / p.wheel_inertia, rel=1e-9)
    push = plant_disturbance(1.0, [FaultEvent("body_push", "body_n", 0.5, 1.0, 2.0)], T_N)
    _, acc_pushed = plant_derivatives(state, currents, p, push)
    assert acc_pushed[1] - acc[1] == pytest.approx(2.0 / p.mass, rel=1e-9) and acc_pushed[0] == acc[0]
    held = plant_disturbance(1.0, [FaultEvent("wheel_held", "wheel_R", 0.5, 1.0)], T_N)
    x = list(state)
    for _ in range(20):  # 10 ms = 10 time constants
        x, _ = plant_substep(x, (1.0, 1.0), 5e-4, p, held)
    assert x[8] == pytest.approx(state[8] * math.exp(-10.0), rel=1e-9) and x[9] > 0.5 * state[9]


def test_closed_loop_wheel_held_by_hand_is_followed():
    """Square, the right wheel held for 0.3 s while driving: the robot pivots about it with the left tyre
    slipping, so the held wheel's standstill disagrees with v_L - b omega_gyro and its encoder is
    excluded (replaced by that estimate); the heading stays within 2 deg and the robot completes
    (Indiveri Fig. 5's hand-stopped wheel). After the release the encoder is re-admitted only once a block
    of its increments agrees with v_L + b omega (the spinning-up wheel slips), so v_t does not follow
    it: RMS error over the 0.15 s after the release 7 mm/s (29 mm/s when one sample re-admitted it).

    The body skids on while both wheels slow: S(11)'s batches see it late, and the fused position is as
    far off as the baselines' at the release (55 against 52 mm); with the per-sample slide-onset test
    (mixing.slide_onset_jump) 23 against 67 mm. The final errors are not compared: after a perturbation
    the closed loop drives another path, and the square's final braking gives any estimate 4-30 mm."""
    scenario = load_scenario("square")
    event = FaultEvent("wheel_held", "wheel_R", 2.0, 0.3)
    result = run_scenario(scenario, faults=[event])
    a = result.arrays
    during = (a["t"] > 2.05) & (a["t"] < 2.3)
    assert np.max(np.abs(a["true_wheel_R"][during])) < 0.05  # held
    assert np.min(np.abs(a["true_omega"][during])) > 0.5  # pivoting
    assert not a["health_gyro"].any() and not a["health_encoder_L"].any()
    heading = np.abs(np.unwrap(a["est_phi"]) - np.unwrap(a["true_phi"]))
    assert np.max(heading) < math.radians(2.0)
    released = (a["t"] > 2.3) & (a["t"] < 2.45)
    assert np.max(np.abs(a["true_wheel_R"][released])) > 0.2  # turning again
    assert np.sqrt(np.mean((a["est_v_t"] - a["true_v_t"])[released] ** 2)) < 0.015
    assert result.summary["completed"]

    onset = run_scenario(with_keys(scenario, {"navigation.mixing.slide_onset_jump": 0.05}), faults=[event])
    b = onset.arrays
    k = int(np.searchsorted(b["t"], 2.45))

    def error(p):
        return math.hypot(b[f"{p}_x"][k] - b["true_x"][k], b[f"{p}_y"][k] - b["true_y"][k])

    assert error("est") < 0.5 * min(error("odo"), error("gyro"))
    assert onset.summary["completed"]


def test_the_accelerometer_pair_measures_omega_squared():
    """The sensors' rigid-body model (systems/robot/sensors.accelerometer_truth): the pair's rotational terms
    give omega^2 back exactly, whatever omega_dot and the centre's acceleration."""
    for omega, omega_dot in ((12.0, 50.0), (-9.0, -20.0), (3.0, 0.0)):
        acc = accelerometer_truth((1.5, 2.0, omega_dot), omega, (0.02, 0.015))
        assert pair_omega_squared(acc, (0.02, 0.015)) == pytest.approx(omega**2, rel=1e-12)


def test_a_gyro_beyond_its_range_reads_the_pairs_yaw_rate():
    """A spin at 12 rad/s, beyond the gyro's 5.2 rad/s: the gyro reads its full scale, flagged saturated,
    and is replaced by the pair's |omega| (averaged over 15 samples: within 2 % after 100) with the gyro's
    sign. (Below the full scale, odometry and pair agreeing, it would read the odometry's: see
    test_saturated_and_stuck_gyro_are_flagged_and_excluded.)"""
    rows = stream(200, 0.5, 12.0)
    rows[:, 4] = math.radians(300.0)
    out, codes = check(rows, v0=0.5)
    assert np.all(codes[:, 4] == SATURATED)
    np.testing.assert_allclose(out[100:, 4], 12.0, rtol=0.02)


@pytest.mark.parametrize("pair_omega, expected", [(5.5, 4.0), (12.0, 12.0)])
def test_a_railed_gyro_reads_the_pair_only_when_it_says_far_beyond_the_range(pair_omega, expected):
    """A doubled gyro (8 rad/s) rails while the wheels turn the body at 4 rad/s. Tinyphoon's pair, on its
    +-(0.02, 0.015) m lever, reads up to 5.4 rad/s in such a turn, above the 5.2 rad/s full scale: that
    alone made the pair's reading the replacement (open corner seed 9: 85 mm). It counts only beyond
    the full scale and PAIR_SPIN_MARGIN (1.5) x the odometric yaw rate: a spin the wheels do not see (12
    rad/s; a lifted wheel's spin reads the odometry near 0)."""
    rows = stream(200, 0.5, 4.0)
    truth = accelerometer_truth((0.0, 0.5 * 4.0, 0.0), pair_omega, (0.02, 0.015))
    rows[:, 0:4] = truth + 1e-4 * np.random.default_rng(5).standard_normal((200, 4))  # never repeats
    rows[:, 4] = 8.0
    out, codes = check(rows, v0=0.5)
    assert np.all(codes[:, 4] == SATURATED)
    np.testing.assert_allclose(out[100:, 4], expected, rtol=0.02)


def test_perturbation_cases_scale_with_the_robot():
    """Tinyphoon: the wheel pushed with 0.6 x k i_max = 0.6 x 6/280 V s x 1.5 A = 0.0193 N m, the body
    pushed with 5 m/s^2 x 0.4 kg = 2 N; Kurt3D's push 110 N; all 1 s after the controller starts."""
    corner = load_scenario("corner")
    cases = perturbation_cases(corner, {"start_time": np.array(1.0)})
    by_kind = {(c["kind"], c["channel"]): c for c in cases}
    assert by_kind[("wheel_pushed", "wheel_R")]["value"] == pytest.approx(0.6 * 6.0 / 280.0 * 1.5)
    assert by_kind[("body_push", "body_n")]["value"] == pytest.approx(2.0)
    assert by_kind[("body_push", "body_t")]["value"] == pytest.approx(-2.0)
    assert {c["start"] for c in cases} == {2.0} and len(cases) == 5
    kurt = perturbation_cases(load_scenario("circle"), {"start_time": np.array(1.0)})
    assert next(c["value"] for c in kurt if c["channel"] == "body_n") == pytest.approx(110.0)
    for c in cases + kurt:
        FaultEvent(c["kind"], c["channel"], c["start"], c["duration"], c["value"])  # valid events


def test_slip_detector_uses_a_replaced_tangential_axis_and_ignores_gyro_and_lateral_faults():
    """S(11) reads the tangential accelerometers and the encoders: it leaves a sample out only when both
    encoders, one while the gyro is excluded, or both tangential axes are excluded, and in the sample
    that restores a stuck encoder's missed travel. One
    excluded t axis reads its partner's (plus the rotational terms), an encoder excluded otherwise the
    other wheel's plus the gyro's yaw rate; a gyro or lateral fault does not touch it (open-loop square,
    seed 1: a 0.5 s accel1_n outage cost 4.2 x the fault-free error while S(11) left such samples out,
    accel1_t 5.4 x)."""
    for channel in range(7):
        codes = [0] * 7
        codes[channel] = NONFINITE
        inertial, encoder, s11 = health_flags(codes)
        assert s11 == 0.0, channel
        assert (inertial, encoder) == ((1.0, 0.0) if channel < 5 else (0.0, 1.0))
    assert health_flags([1, 0, 1, 0, 0, 0, 0]) == [1.0, 0.0, 1.0]  # both t axes out
    assert health_flags([0, 0, 0, 0, 0, JUMP, NONFINITE])[2] == 1.0  # both encoders out
    assert health_flags([0, 0, 0, 0, STUCK, 0, JUMP])[2] == 1.0  # an encoder without the gyro
    assert health_flags([0, 0, 0, 0, 0, STUCK, 0])[2] == 0.0  # the other wheel's and the gyro's
    assert health_flags([0, 0, 0, 0, 0, STUCK, 0], unusable=True)[2] == 1.0  # the missed travel
    assert health_flags([0, 0, 0, 0, 0, 0, RECOVERING])[2] == 0.0
    assert health_flags([0] * 7) == [0.0, 0.0, 0.0]


def test_an_encoder_outage_in_a_braking_slide_keeps_the_slip_detector_on_the_other_wheel():
    """Open-loop square, seed 0: encoder_L reads NaN for 0.5 s from 5.26 s, while the wheels spin up and
    then lock in the speed bump's braking (true slip -0.2 m/s at 5.6 s). With S(11) blind for an excluded
    encoder, C1 returned to the odometry within 0.1 s and the estimate ran 0.13 m/s slow in the braking
    slide (4.5 x the fault-free final error). The replaced encoder (the right wheel's increment and the
    gyro's yaw rate) carries the right wheel's slip, so S(11) sees the lock and C1 stays low with the
    fault-free run's; the final error stays within 1.5 x."""
    scenario = load_scenario("square")
    event = FaultEvent("nan", "encoder_L", 5.26, 0.5)
    clean = run_scenario(scenario, seed=0, open_loop=True).arrays
    a = run_scenario(scenario, seed=0, open_loop=True, faults=[event]).arrays
    t = a["t"]
    during = (t >= 5.26) & (t < 5.76)
    assert np.all(a["health_encoder_L"][during] > 0)
    assert np.all(np.isfinite(a["delta_v"]))
    slide = (t >= 5.55) & (t < 5.7)
    assert np.min(a["true_wheel_L"][slide] - a["true_v_t"][slide]) < -0.15  # the wheels lock
    assert np.max(a["C1"][slide]) < 0.05 and np.max(clean["C1"][slide]) < 0.05
    assert np.max(np.abs(a["est_v_t"] - a["true_v_t"])[slide]) < 0.05
    assert final_position_error(a, "est") <= 1.5 * final_position_error(clean, "est")


def test_a_batch_without_a_usable_sample_holds_c1_in_the_diagram():
    """Open-loop corner, both encoders NaN for 0.1 s from 2.0 s: the batches that lie wholly inside the
    outage (ending at 2.02 ... 2.10 s) have no sample S(11) can use: their dv is NaN (logged as such from
    the sample after each control instant, until 2.12 s) and C1 holds its value through them; the batches
    around them, partly usable, keep a finite dv, and C1 moves again."""
    events = [FaultEvent("nan", "encoder_R", 2.0, 0.1), FaultEvent("nan", "encoder_L", 2.0, 0.1)]
    a = run_scenario(load_scenario("corner"), seed=0, duration=2.3, open_loop=True, faults=events).arrays
    t = a["t"]
    blind = np.isnan(a["delta_v"])
    assert blind[(t > 2.021) & (t < 2.121)].all()
    assert not blind[(t < 2.021) | (t > 2.123)].any()
    held = a["C1"][(t > 2.021) & (t < 2.121)]
    assert np.all(held == held[0]) and held[0] > 0.9
    assert a["C1"][np.searchsorted(t, 2.125)] != held[0]  # and moves again with the next usable batch


def test_the_force_reference_blames_the_biased_accelerometer_in_a_hard_braking():
    """Open-loop square, seed 1: accel1_t biased by 5 m/s^2 from 3.608 s, while the square's speed bump
    brakes the body by 4.8 m/s^2 within the pair's window and the wheels slip. The healthy accel2_t
    "moved more" and the odometric reference slips: without the motor currents the healthy one was
    excluded (the biased one fed the estimate, 9.9 x the fault-free error). The force balance of the
    currents blames accel1_t, and the estimate stays within 1.1 x."""
    scenario = load_scenario("square")
    event = FaultEvent("bias", "accel1_t", 3.608, 0.5, 5.0)
    clean = run_scenario(scenario, seed=1, open_loop=True).arrays
    a = run_scenario(scenario, seed=1, open_loop=True, faults=[event]).arrays
    t = a["t"]
    during = (t >= 3.608) & (t < 4.108)
    first = t[np.argmax((a["health_accel1_t"] > 0) & during)]
    assert 3.608 < first <= 3.708 and np.any(a["health_accel1_t"][during] == INCONSISTENT)
    assert not np.any(a["health_accel2_t"] > 0)
    assert final_position_error(a, "est") <= 1.5 * final_position_error(clean, "est")


def yaw_constants(robot) -> HealthConstants:
    """The sensor checks' constants with ``robot`` as the nominal one (its yaw dynamics)."""
    g = health_geometry(NavigationParameters(), robot.wheel_radius, robot.track_width, T_N, robot=robot)
    return HealthConstants(*health_constants(SensorHealthParameters(), g))


@pytest.mark.parametrize("grip", [1.0, 0.5])
@pytest.mark.parametrize("robot", [tinyphoon(), kurt3d()], ids=["tinyphoon", "kurt3d"])
def test_the_gyro_replacement_follows_the_wheels_with_the_tyres_lag(robot, grip):
    """yaw_follow_step without shoes: a body yawing at 0.02 rad/s on wheels that drive straight (inside the
    tyres' linear range) closes the gap as the implicit Euler step of I_z omega' = (b^2/2) k (omega_o -
    omega) does, k = mu N_w B C / v the tyre's slip stiffness at zero slip: within 1 % of (1 + T_N /
    tau)^-n, tau = 2 I_z / (b^2 k), and within 5 % of exp(-t / tau) after one tau. An identified tyre
    peak half the nominal (grip 0.5) halves k and doubles the lag."""
    bare = dc.replace(robot, shoe_friction=0.0, shoe_viscous_drag=0.0)
    g = yaw_constants(bare)
    v, gap, omega_wheels = 1.6, 0.02, 0.0
    peak = grip * bare.tyre_friction * bare.wheel_normal_load  # mu N_w, scaled by the identified peak
    k = peak * bare.tyre_stiffness_factor * bare.tyre_shape_factor / v
    tau = 2.0 * bare.yaw_inertia / (bare.track_width**2 * k)
    n = max(1, round(tau / T_N))
    omega = omega_wheels + gap
    for _ in range(n):
        omega = yaw_follow_step(omega, v, v, v, 0.0, g, grip)
    left = (omega - omega_wheels) / gap
    assert left == pytest.approx((1.0 + T_N / tau) ** -n, rel=0.01)
    assert left == pytest.approx(math.exp(-n * T_N / tau), rel=0.05 + (T_N / tau) ** 2 * n)


def test_the_gyro_replacement_settles_where_the_plant_stops_turning_faster():
    """With Tinyphoon's felt shoes the body settles below its wheels' yaw rate (the shoes' scrub), where
    the plant's own equations (systems/robot/contact.contact_forces) give no yaw acceleration."""
    robot = tinyphoon()
    g = yaw_constants(robot)
    v, omega_wheels, half = 1.0, 2.0, 0.5 * robot.track_width
    u_R, u_L = v + omega_wheels * half, v - omega_wheels * half
    omega = omega_wheels
    for _ in range(500):
        omega = yaw_follow_step(omega, u_R, u_L, v, 0.0, g)
    assert 0.9 * omega_wheels < omega < 0.999 * omega_wheels  # 0.5 % below
    r = robot.wheel_radius
    state = (0.0, 0.0, 0.0, v, 0.0, omega, 0.0, 0.0, u_R / r, u_L / r)
    (_, _, omega_dot), _, _ = contact_forces(state, robot)
    (_, _, at_wheels), _, _ = contact_forces(state[:5] + (omega_wheels,) + state[6:], robot)
    assert abs(omega_dot) < 1e-6 * abs(at_wheels)


@pytest.fixture(scope="module")
def open_corner_seed_1():
    return run_scenario(load_scenario("corner"), seed=1, open_loop=True).arrays


@pytest.mark.parametrize(
    "kind, value, flagged_from, flagged_until",
    [("nan", 0.0, 2.31, 2.8), ("dropout", 0.0, 2.32, 2.8), ("scale", 1.0, 2.31, 2.7)],
)
def test_a_gyro_lost_in_the_open_corners_slide_costs_little_heading(
    open_corner_seed_1, kind, value, flagged_from, flagged_until
):
    """slipnav faults --open-loop's worst cases: corner seed 1, the gyro faulty for 0.5 s from 2.31 s, in
    the sliding turn.
    - NaN: the odometry under-reads as the turn ends (the body's inertia) and cost 4.4 deg and 63 mm
      (42 x the fault-free 1.5 mm); the yaw dynamics from the wheels and the navigation's v_t, v_n keep
      the heading within 0.5 deg and the final error within the issue's 3 x.
    - Frozen (dropout): trusted for 3 repeats before the stuck test (8 ms); the repeats' missed heading
      is paid back and the replacement starts from the wheels' yaw rate run through them (3.5 x before).
    - x2: flagged at once; the block sum keeps it out as the turn slows below the jump bound (re-admitted
      at 0.36 rad/s before: 4.9 x)."""
    clean = open_corner_seed_1
    faulty = run_scenario(
        load_scenario("corner"), seed=1, open_loop=True, faults=[FaultEvent(kind, "gyro", 2.31, 0.5, value)]
    ).arrays
    t = faulty["t"]
    assert np.all(faulty["health_gyro"][(t > flagged_from) & (t < flagged_until)] > 0)
    during = (t > flagged_from) & (t < flagged_until)  # the x2 is back at 0.2 rad/s (0.2 off till 0)
    assert np.max(np.abs(faulty["est_omega"] - faulty["true_omega"])[during]) < 0.15  # rad/s; odometry 0.45
    assert abs(math.degrees(faulty["est_phi"][-1] - faulty["true_phi"][-1])) < 0.5
    assert final_position_error(faulty, "est") <= 3.0 * final_position_error(clean, "est")


def test_open_loop_faults_keep_the_path_and_judge_the_estimate_alone():
    """``slipnav faults --open-loop``: the trajectory's wheel speeds are fed forward, so a sensor fault
    changes the estimate but not one sample of the true path; run_fault takes the job's open_loop."""
    scenario = load_scenario("corner")
    clean = scenario_run("corner", seed=0, open_loop=True).arrays  # shared (tests/shared.py)
    event = FaultEvent("nan", "gyro", 2.2, 0.5)
    faulty = scenario_result(scenario, seed=0, open_loop=True, faults=[event]).arrays
    for key in ("true_x", "true_y", "true_phi"):
        np.testing.assert_array_equal(faulty[key], clean[key])
    assert not np.array_equal(faulty["est_phi"], clean["est_phi"])
    job = {
        "scenario": "corner",
        "seed": 0,
        "open_loop": True,
        "channel": "gyro",
        "kind": "nan",
        "start": 2.2,
        "duration": 0.5,
        "value": 0.0,
        "onset_s": 2.2,
        "clean_fused_error_m": final_position_error(clean, "est"),
        "clean_fused_run_rms_m": rms_position_error(clean, "est", POSE_DELAY_SAMPLES),
    }
    with shared_runs(fault_study):  # the faulted run above, if run_fault runs the same (tests/shared.py)
        figures = run_fault(job)
    assert figures["detected"] and figures["latency_s"] == 0.0
    assert figures["fused_error_m"] == pytest.approx(final_position_error(faulty, "est"), rel=1e-12)
    # The RMS over the run counts the heading the outage cost on the rest of the path; against the truth
    # of the instant the pose describes, which leaves out the lag's travel that both runs share.
    ratio = rms_position_error(faulty, "est", POSE_DELAY_SAMPLES) / rms_position_error(
        clean, "est", POSE_DELAY_SAMPLES
    )
    assert figures["run_rms_ratio"] == pytest.approx(ratio, rel=1e-12)
    assert ratio != pytest.approx(rms_position_error(faulty, "est") / rms_position_error(clean, "est"))
    # each estimate's final, RMS and maximum error along the run, the faulted run's own
    for label, prefix in (("fused", "est"), ("odometry", "odo"), ("gyrodometry", "gyro")):
        errors = position_errors(faulty, prefix)
        assert figures[f"{label}_rms_error_m"] == errors["rms"]
        assert figures[f"{label}_max_error_m"] == errors["max"]
    assert figures["fused_rms_error_m"] == rms_position_error(faulty, "est", POSE_DELAY_SAMPLES)
    # the outage's heading cost, the yaw dynamics standing in for the gyro in the turn (1.7 deg with the
    # odometric yaw rate)
    cost = (faulty["est_phi"][-1] - faulty["true_phi"][-1]) - (clean["est_phi"][-1] - clean["true_phi"][-1])
    assert 0.0 < abs(math.degrees(cost)) < 1.0


def test_a_ramp_grows_from_its_start():
    """A ramp adds value x (t - start) to an analog channel while active, nothing before or after; an
    encoder cannot ramp."""
    ramp = FaultEvent("ramp", "gyro", 1.0, 2.0, 0.01)
    raw = [0.0, 0.0, 0.0, 0.0, 0.5, 1.0, 2.0]
    for t, added in ((0.998, 0.0), (1.0, 0.0), (2.5, 0.015), (2.998, 0.01998)):
        out = apply_sensor_faults(t, raw, raw, raw, [ramp], 0.002, 0.001)
        assert out[4] == pytest.approx(0.5 + added, abs=1e-12) and out[5:] == raw[5:]
    assert apply_sensor_faults(3.0, raw, raw, raw, [ramp], 0.002, 0.001)[4] == 0.5
    with pytest.raises(ValueError, match="cannot 'ramp'"):
        FaultEvent("ramp", "encoder_R", 1.0, 1.0, 1.0)


def spin_through_the_rail(n=400, v=0.5, pair_excess=0.7):
    """A spin slowing from 6 to 4 rad/s (-3.3 rad/s^2) through the gyro's full scale with the left
    encoder lost from sample 20: rows whose gyro is clipped at the full scale and whose accelerometer pair
    reads the spin ``pair_excess`` rad/s high (Tinyphoon's short lever reads up to a third high); the
    full scale."""
    omega = np.linspace(6.0, 4.0, n)
    rows = stream(n, v, 0.0)
    pair = omega + pair_excess
    rows[:, 0:4] = np.column_stack(
        [-(pair**2) * 0.02, v * pair - pair**2 * 0.015, pair**2 * 0.02, v * pair + pair**2 * 0.015]
    )
    rows[:, 0:4] += 0.06 * np.random.default_rng(2).standard_normal((n, 4))
    rows[:, 5] = np.cumsum(v + 0.5 * B * omega) / R * T_N
    rows[:, 6] = np.cumsum(v - 0.5 * B * omega) / R * T_N
    rows[20:, 6] = np.nan
    full_scale = math.radians(300.0) * SensorHealthParameters().saturation_fraction
    noisy = omega + 0.014 * np.random.default_rng(1).standard_normal(n)
    rows[:, 4] = np.clip(noisy, -full_scale, full_scale)
    return rows, full_scale


@pytest.mark.parametrize("exit_kind", ["continuous", "nan", "jump"])
def test_a_gyro_off_its_rail_is_readmitted_without_a_witness(exit_kind):
    """The railed gyro, the left encoder lost, is flagged saturated and reads at least its full scale
    (here the pair's spin, 0.7 rad/s above the gyro's exit). Its first reading below the rail continues
    from it within gyro_max_step: that is the sensor's own reading, trusted again at once; compared with
    the replacement held at the rail (a constant nothing checks, 0.7 rad/s off) it would never agree
    again. A NaN sample at the exit keeps the rail's reading as the one the next continues. A reading
    that steps off the rail by more than gyro_max_step (1 rad/s here) is no exit but a jump: it stays
    out against the held replacement."""
    rows, full_scale = spin_through_the_rail()
    railed = rows[:, 4] >= full_scale
    below = int(np.flatnonzero(railed)[-1]) + 1
    back = below
    if exit_kind == "nan":
        rows[below, 4], back = np.nan, below + 1
    elif exit_kind == "jump":
        rows[below:, 4] -= 1.0
    out, codes = check(rows, v0=0.5)
    assert np.all(codes[20:below][railed[20:below], 4] == SATURATED)
    assert np.all(out[20:below][railed[20:below], 4] >= full_scale)
    if exit_kind == "jump":
        assert np.all(codes[below:, 4] == RECOVERING)
        return
    assert not codes[back:, 4].any()
    np.testing.assert_array_equal(out[back:, 4], rows[back:, 4])
