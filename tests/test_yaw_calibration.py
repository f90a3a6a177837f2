"""Online gyro/odometry calibration (systems/navigation/yaw_calibration.py): the Kalman filter against the
batch least-squares posterior, the plausibility gates, the LeafSystem against the step function, and the
convergence of the bias and the radius difference on scripted runs of the real diagram."""

import dataclasses as dc

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator
from slipnav.scenarios.config import load_scenario
from slipnav.scenarios.metrics import final_position_error
from slipnav.scenarios.runner import run_scenario
from slipnav.systems.navigation.bias_change import bias_change_test
from slipnav.systems.navigation.calibration_batches import believed_tyre_slip
from slipnav.systems.navigation.mixing.parameters import MixingParameters
from slipnav.systems.navigation.yaw_calibration import (
    YawCalibrationParameters,
    YawRateCalibration,
    batch_selection,
    believed_gyro,
    calibrated_gyro,
    calibrated_odometry,
    calibration_parameters,
    yaw_calibration_initial_state,
    yaw_calibration_step,
)
from slipnav.systems.robot.faults import FaultEvent
from slipnav.systems.robot.parameters import kurt3d
from slipnav.systems.robot.sensors import SensorParameters

from tests.shared import scenario_result

T_N, N_BATCH, TRACK = 0.002, 10, 0.068


def run_batches(state, batches, p, c1=1.0, fault=False, standing=None):
    """Feed batches of (gyro, omega_o, v_o) rows, N_BATCH samples each (constant within a batch)."""
    for gyro, omega, v in batches:
        for _ in range(N_BATCH):
            odo = [v, omega, 0.0, 0.0]
            state = yaw_calibration_step(state, gyro, odo, c1, fault, TRACK, p, T_N, N_BATCH, standing)
    return state


def test_static_filter_equals_the_batch_least_squares_posterior():
    """Without process noise the filter's theta and P equal the Bayesian linear regression posterior
    (information form) of y = gyro - omega_o on H = [1, v/b] with the Gaussian prior."""
    p = believed_gyro(YawCalibrationParameters(bias_drift_density=0.0, radius_drift_density=0.0))
    rng = np.random.default_rng(1)
    b0, D0 = 0.004, 0.01
    v = rng.uniform(0.0, 2.0, 40)
    noise = 0.005 * rng.standard_normal(40)
    omega_o = -D0 * v / TRACK  # straight: the true yaw rate is 0
    gyro = b0 + noise
    state = run_batches(yaw_calibration_initial_state(p), zip(gyro, omega_o, v, strict=True), p)
    H = np.column_stack([np.ones(40), v / TRACK])
    y = gyro - omega_o
    prior_info = np.diag([1 / p.initial_bias_std**2, 1 / p.initial_radius_difference_std**2])
    info = prior_info + H.T @ H / p.measurement_std**2
    theta = np.linalg.solve(info, H.T @ y / p.measurement_std**2)
    np.testing.assert_allclose(state[0:2], theta, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(state[2:6].reshape(2, 2), np.linalg.inv(info), rtol=1e-9)
    sigma = np.sqrt(np.diag(np.linalg.inv(info)))
    assert abs(theta[0] - b0) < 3 * sigma[0] and abs(theta[1] - D0) < 3 * sigma[1]


def test_standstill_learns_the_bias_alone():
    """No encoder count in a batch: the row [1, 0] with the gyro's noise alone (standstill_measurement_std);
    without drift the posterior is the prior's and the batches' information summed: 1 s pins the bias
    to sqrt(1 / (1/0.0035^2 + 50/0.005^2)) = 0.7 mrad/s, and D keeps its prior."""
    p = believed_gyro(YawCalibrationParameters(bias_drift_density=0.0))
    rng = np.random.default_rng(3)
    gyro = 0.003 + 0.0044 * rng.standard_normal(50)  # the batch means of the gyro's 0.014 rad/s noise
    state = run_batches(yaw_calibration_initial_state(p), [(g, 0.0, 0.0) for g in gyro], p)
    b, D, sigma_b, sigma_D, learned, rejected, changes = calibration_parameters(state)
    info = 1 / p.initial_bias_std**2 + 50 / p.standstill_measurement_std**2
    assert sigma_b == pytest.approx(info**-0.5, rel=1e-9) and sigma_b < 0.0008
    assert b == pytest.approx(np.sum(gyro) / p.standstill_measurement_std**2 / info, rel=1e-9)
    assert abs(b - 0.003) < 3 * sigma_b
    assert D == 0.0 and sigma_D == pytest.approx(p.initial_radius_difference_std, rel=1e-9)
    assert (learned, rejected, changes) == (50, 0, 0)
    moving = run_batches(yaw_calibration_initial_state(p), [(0.003, 0.0, 1e-3)] * 50, p)
    assert calibration_parameters(moving)[2] > 1.5 * sigma_b  # a counting encoder: measurement_std


def test_gates_keep_failed_data_out():
    """Turning (gyro - b above straight_yaw_rate), slipping (C1 low) or a faulty sample: nothing learned;
    an implausible batch (an encoder spike: 40 sigma) is counted as rejected and leaves theta as it was."""
    p = YawCalibrationParameters()
    learned = run_batches(yaw_calibration_initial_state(p), [(0.002, 0.0, 1.0)] * 100, p)
    theta = learned[0:2].copy()
    for batches, kwargs in (
        ([(1.0, 1.0, 1.0)] * 5, {}),  # a turn, gyro and odometry agreeing
        ([(0.002, 0.3, 1.0)] * 5, {"c1": 0.5}),
        ([(0.002, 0.3, 1.0)] * 5, {"fault": True}),
    ):
        state = run_batches(learned, batches, p, **kwargs)
        np.testing.assert_array_equal(state[0:2], theta)
        assert calibration_parameters(state)[4:] == calibration_parameters(learned)[4:]
    spiked = run_batches(learned, [(0.002, 0.4, 1.0)], p)
    np.testing.assert_array_equal(spiked[0:2], theta)
    assert calibration_parameters(spiked)[5] == calibration_parameters(learned)[5] + 1


def test_selection_by_both_witnesses():
    """Learned from: the gyro less b_g within straight_yaw_rate; tested for a bias change: the wheels stand
    still, or say straight within change_yaw_rate at a steady yaw rate while the gyro stays within the
    largest step's band."""
    p = YawCalibrationParameters()
    assert batch_selection(0.04, 0.0, False, False, p) == (True, True)
    assert batch_selection(0.5, 0.0, False, False, p) == (False, True)  # standing: the gyro is outvoted
    assert batch_selection(0.06, 0.1, True, True, p) == (False, True)  # a 0.06 step within the band
    assert batch_selection(0.06, 0.1, True, False, p) == (False, False)  # the wheels' yaw rate changes
    assert batch_selection(0.06, 0.2, True, True, p) == (False, False)  # the wheels turn
    assert batch_selection(0.3, 0.0, True, True, p) == (False, False)  # a slide
    assert batch_selection(-0.04, 0.3, True, True, p) == (True, False)  # the gyro alone says straight


def test_the_wheels_steadiness_spans_batches():
    """A batch is steady when the calibrated odometric yaw rate and the gyro's mean changed by at most
    steady_yaw_acceleration T_C since the previous batch (2.0 x 0.02 = 0.04 rad/s): a turn-in whose
    wheels lead the gyro by 0.07 rad/s for four batches (Kurt3D) raises no alarm; the same residual at a
    steady yaw rate does, once the CUSUM has gathered h / (change_clip - change_drift) batches after the
    step's own (unsteady) batch."""
    p = YawCalibrationParameters()
    learned = run_batches(yaw_calibration_initial_state(p), [(0.0, 0.0, 1.0)] * 100, p)
    turn_in = [(g, o, 1.0) for g, o in ((0.0, 0.05), (0.03, 0.1), (0.07, 0.14), (0.1, 0.17), (0.13, 0.2))]
    state = run_batches(learned, turn_in * 3, p)
    assert calibration_parameters(state)[6] == 0
    needed = int(np.ceil(bias_change_test(p).threshold / (p.change_clip - p.change_drift)))
    state = run_batches(learned, [(0.07, 0.0, 1.0)] * needed, p)
    assert calibration_parameters(state)[6] == 0
    state = run_batches(learned, [(0.07, 0.0, 1.0)] * (needed + 1), p)
    assert calibration_parameters(state)[6] == 1


@pytest.mark.parametrize("moving", [False, True])
def test_a_bias_step_is_detected_and_learned(moving):
    """After 100 batches learning b_g = 0.002, the gyro's bias steps by 0.06 (beyond straight_yaw_rate:
    no batch is learned any more). Every batch's normalised innovation is then 0.06 / sqrt(S) > the
    clip (2.5), so the CUSUM reaches h after ceil(h / (2.5 - 0.5)) batches (moving: after the step's own
    batch, whose gyro is not steady); the alarm widens b_g's variance by the change the batches since the
    change point measure and learns it from their mean: b_g within 10 % of the step. Moving at one speed,
    b_g and D v / b cannot be told apart: their sum, the yaw rate the calibration removes, settles on the
    step."""
    p = YawCalibrationParameters()
    v = 1.0 if moving else 0.0
    learned = run_batches(yaw_calibration_initial_state(p), [(0.002, 0.0, v)] * 100, p)
    test = bias_change_test(p)
    assert test.threshold == pytest.approx(10.9, abs=0.1)  # one false alarm per 180000 batches
    needed = int(np.ceil(test.threshold / (test.clip - test.drift))) + (1 if moving else 0)
    state = run_batches(learned, [(0.062, 0.0, v)] * (needed - 1), p)
    assert calibration_parameters(state)[6] == 0 and state[0] == learned[0]
    state = run_batches(state, [(0.062, 0.0, v)], p)
    b, _, sigma_b, _, _, _, changes = calibration_parameters(state)
    assert changes == 1 and b == pytest.approx(0.062, abs=0.006)
    settled = run_batches(state, [(0.062, 0.0, v)] * 50, p)
    assert settled[0] + settled[1] * v / TRACK == pytest.approx(0.062, abs=0.002)
    assert calibration_parameters(settled)[6] == 1


def test_a_bias_step_at_speed_is_measured_from_the_change_point():
    """1 s at rest (b_g = 0.002 learned), 1 s accelerating to 1 m/s (the varying speed learns D = 0), then
    at 1 m/s the gyro's bias steps by 0.03 rad/s. Each batch before the alarm lies within the learning
    gate, and D v / b, the wider of the two at speed, takes most of it; on the alarm the estimate returns
    to the change point and the batches since measure the step there (systems/navigation/bias_change.py):
    b_g ends within 0.003 of 0.032 and D within 0.0003 of 0."""
    p = YawCalibrationParameters()
    rest = [(0.002, 0.0, 0.0)] * 50
    accelerating = [(0.002, 0.0, 0.02 * (k + 1)) for k in range(50)]
    cruising = [(0.002 + (0.03 if k >= 20 else 0.0), 0.0, 1.0) for k in range(100)]
    state = run_batches(yaw_calibration_initial_state(p), rest + accelerating, p)
    b, D, sigma_b, sigma_D, *_ = calibration_parameters(state)
    assert abs(b - 0.002) < 1e-4 and abs(D) < 1e-4 and (1.0 / TRACK) ** 2 * sigma_D**2 < 0.01**2
    state = run_batches(state, cruising, p)
    b, D, *_, changes = calibration_parameters(state)
    assert changes == 1
    assert b == pytest.approx(0.032, abs=0.003) and D == pytest.approx(0.0, abs=3e-4)


def test_a_rest_counts_only_where_the_standstill_detector_confirms_it():
    """A batch whose wheels did not turn while the gyro reads a turn's start (0.012 rad/s, within the
    gates): with the detector's ``standing`` False it is neither learned from nor tested; with it True (or
    without a detector) it is a standstill batch, learned with standstill_measurement_std."""
    p = YawCalibrationParameters()
    learned = run_batches(yaw_calibration_initial_state(p), [(0.0, 0.0, 0.0)] * 50, p)
    skipped = run_batches(learned, [(0.012, 0.0, 0.0)] * 3, p, standing=False)
    np.testing.assert_array_equal(skipped[0:2], learned[0:2])
    assert calibration_parameters(skipped)[4:] == calibration_parameters(learned)[4:]
    for standing in (True, None):
        rest = run_batches(learned, [(0.012, 0.0, 0.0)] * 3, p, standing=standing)
        assert rest[0] > learned[0] + 1e-4 and calibration_parameters(rest)[4] == 53


def test_a_gyro_transient_raises_no_alarm():
    """The gyro jumps by 0.1 rad/s for three batches while the wheels stay straight (a body that wobbles
    at a turn's end): the jump's batch is not steady (the gyro's mean moved by more than
    steady_yaw_acceleration T_C), and the two steady ones reach at most 2 (change_clip - change_drift) =
    4 of the CUSUM's 10.9; the same jump held on raises the alarm."""
    p = YawCalibrationParameters()
    learned = run_batches(yaw_calibration_initial_state(p), [(0.0, 0.0, 1.0)] * 100, p)
    wobble = run_batches(learned, [(0.1, 0.0, 1.0)] * 3 + [(0.0, 0.0, 1.0)] * 20, p)
    assert calibration_parameters(wobble)[6] == 0
    held = run_batches(learned, [(0.1, 0.0, 1.0)] * 10, p)
    assert calibration_parameters(held)[6] == 1


def test_a_noisier_robot_raises_no_alarm_for_its_noise():
    """Residuals twice as noisy as measurement_std says (a real robot's gyro and wheels): normalised by
    the predicted S alone the CUSUM would alarm every few dozen batches; normalised by the larger of S and
    the variance the tested batches show (noise_batches), 20000 batches raise at most one."""
    p = YawCalibrationParameters()
    rng = np.random.default_rng(11)
    state = run_batches(yaw_calibration_initial_state(p), [(0.0, 0.0, 1.0)] * 10, p)
    for g in 0.02 * rng.standard_normal(20000):
        for _ in range(N_BATCH):
            state = yaw_calibration_step(state, g, [1.0, 0.0, 0.0, 0.0], 1.0, False, TRACK, p, T_N, N_BATCH)
    assert calibration_parameters(state)[6] <= 1


def test_healthy_batches_raise_no_bias_change():
    """20000 straight batches (400 s of driving) whose residuals are the measurement noise: the CUSUM,
    set for one false alarm per 180000 batches, raises none, and b_g stays within 3 sigma."""
    p = YawCalibrationParameters()
    rng = np.random.default_rng(7)
    gyro = 0.003 + 0.008 * rng.standard_normal(20000)  # within measurement_std = 0.01
    state = yaw_calibration_initial_state(p)
    for g in gyro:
        for _ in range(N_BATCH):
            state = yaw_calibration_step(state, g, [1.0, 0.0, 0.0, 0.0], 1.0, False, TRACK, p, T_N, N_BATCH)
    b, _, sigma_b, _, learned, rejected, changes = calibration_parameters(state)
    assert changes == 0 and learned == 20000 and rejected == 0
    assert abs(b - 0.003) < 3 * sigma_b


def test_calibrated_signals_and_the_paper_switch():
    p = YawCalibrationParameters()
    theta = [0.01, 0.02]
    assert calibrated_gyro(0.5, theta, p) == pytest.approx(0.49)
    v, omega = calibrated_odometry([1.0, 0.2, 1.0068, 0.9932], theta, TRACK, p)[0:2]
    assert v == 1.0 and omega == pytest.approx(0.2 + 0.02 / TRACK)
    off = dc.replace(p, enabled=False)
    assert calibrated_gyro(0.5, theta, off) == 0.5
    assert calibrated_odometry([1.0, 0.2, 3.0, 4.0], theta, TRACK, off) == [1.0, 0.2, 3.0, 4.0]


def test_block_equals_the_step_function():
    p = YawCalibrationParameters()
    block = YawRateCalibration(p, TRACK, T_N, N_BATCH * T_N)
    context = block.CreateDefaultContext()
    block.GetInputPort("gyro").FixValue(context, [0.013])
    block.GetInputPort("odometry").FixValue(context, [1.2, -0.05, 1.2, 1.2])
    block.GetInputPort("C1").FixValue(context, [1.0])
    block.GetInputPort("inertial_fault").FixValue(context, [0.0])
    block.GetInputPort("encoder_fault").FixValue(context, [0.0])
    simulator = Simulator(block, context)
    simulator.AdvanceTo(0.5)
    state = yaw_calibration_initial_state(p)
    for _ in range(int(round(0.5 / T_N))):  # the updates at t = 0, T_N, ..., 0.5 - T_N
        state = yaw_calibration_step(state, 0.013, [1.2, -0.05, 1.2, 1.2], 1.0, False, TRACK, p, T_N, N_BATCH)
    np.testing.assert_allclose(context.get_discrete_state(0).get_value(), state, atol=1e-15)
    theta = state[0:2]
    calibrated = block.GetOutputPort("calibrated").Eval(context)  # [gyro, odometry (4)]
    np.testing.assert_allclose(calibrated[0:1], [0.013 - theta[0]])
    np.testing.assert_allclose(calibrated[1:5], calibrated_odometry([1.2, -0.05, 1.2, 1.2], theta, TRACK, p))
    np.testing.assert_allclose(block.GetOutputPort("bias").Eval(context), theta[0:1])
    np.testing.assert_allclose(block.GetOutputPort("parameters").Eval(context), calibration_parameters(state))


def test_parameter_validation():
    for key, value in (("measurement_std", 0.0), ("trusted_c1", 1.5), ("bias_drift_density", -1.0)):
        with pytest.raises(ValueError, match=f"yaw_calibration.{key}"):
            YawCalibrationParameters(**{key: value})


@pytest.mark.parametrize("right_wheel", [0.0, 0.01])
def test_radius_difference_and_bias_converge_on_the_corner(right_wheel):
    """Closed-loop corner, the right wheel's rolling radius 0 or +1 % off the nominal the navigation
    believes. D converges to the true difference (within 0.002 and 3 sigma by 1 s), the bias to the gyro's
    true bias (within 2.5 mrad/s, its initial spread 3.5: with +1 % what D has not yet learned leaves a
    residual at speed that the change test reads as a bias change at 1.7 s, 2 mrad/s off; at constant
    speed b and D v / b cannot be told apart), and the fused estimate beats Gyrodometry and odometry-only
    (with +1 %: Gyrodometry 2.9 %, fused 0.7 %; before the calibration: fused 8.9 %)."""
    scenario = load_scenario("corner")
    scenario.plant.deviations.wheel_radius_R = right_wheel
    a = scenario_result(scenario, seed=0).arrays  # shared (tests/shared.py): 0 is the default corner
    true_difference = float(a["plant_wheel_radius_R"] / a["plant_wheel_radius_L"]) - 1.0
    one_second = np.searchsorted(a["t"], 1.0)
    D, sigma = a["est_radius_difference"][one_second], a["est_radius_difference_std"][one_second]
    assert abs(D - true_difference) < max(0.002, 3 * sigma)
    assert abs(a["est_radius_difference"][-1] - true_difference) < 0.002
    # the gyro's mean reading less the true yaw rate it sampled one T_N earlier (scale error 0)
    true_bias = np.mean(a["meas_gyro"][1:] - a["true_omega"][:-1])
    assert abs(a["est_gyro_bias"][-1] - true_bias) < 0.0025
    errors = {
        p: np.hypot(a[f"{p}_x"][-1] - a["true_x"][-1], a[f"{p}_y"][-1] - a["true_y"][-1])
        for p in ("est", "odo", "gyro")
    }
    assert errors["est"] < min(errors["odo"], errors["gyro"])
    assert errors["est"] < 0.01 * float(a["path_length"])


@pytest.mark.parametrize(("kind", "value"), [("bias", 0.05), ("ramp", 0.005)])
def test_gyro_bias_step_and_ramp_while_driving_on_the_square(kind, value):
    """The closed-loop square with the gyro's bias stepping by 0.05 rad/s, or growing at 0.005 rad/s^2,
    from 3 s on (while driving): the calibration detects the change (gyro_bias_changes_s), its estimate
    follows the fault, and the fused final error stays below both baselines' (odometry-only and
    Gyrodometry; without the change test the fused estimate ends 0.27 m off, Gyrodometry 0.25 m)."""
    scenario = load_scenario("square")
    result = run_scenario(scenario, seed=0, faults=[FaultEvent(kind, "gyro", 3.0, 3600.0, value)])
    a = result.arrays
    changes = result.summary["gyro_bias_changes_s"]
    assert changes and changes[0] > 3.0
    fault = value if kind == "bias" else value * (a["t"][-1] - 3.0)
    true_bias = a["true_gyro_bias"][-1] + fault
    assert abs(a["est_gyro_bias"][-1] - true_bias) < (0.005 if kind == "bias" else 0.015)
    errors = {p: final_position_error(a, p) for p in ("est", "odo", "gyro")}
    assert errors["est"] < min(errors["odo"], errors["gyro"])


def _straight_batches_with_a_residual_step(third_witness):
    """1 s at rest, then 4 s straight at 1 m/s whose gyro less odometry steps by 0.03 rad/s after 1 s;
    ``third_witness``: the pair's witness on every sample, or a function of the sample's index in its
    batch."""
    witness = third_witness if callable(third_witness) else (lambda sample: third_witness)
    p = YawCalibrationParameters()
    state = run_batches(yaw_calibration_initial_state(p), [(0.0, 0.0, 0.0)] * 50, p)
    for k in range(200):
        for sample in range(N_BATCH):
            gyro, odo = (0.03 if k >= 50 else 0.0), [1.0, 0.0, 0.0, 0.0]
            state = yaw_calibration_step(
                state, gyro, odo, 1.0, False, TRACK, p, T_N, N_BATCH, None, 0.0, witness(sample)
            )
    return calibration_parameters(state)


def test_two_witnesses_do_not_blame_the_gyro_while_moving():
    """With the accelerometer pair as a third yaw witness a moving step of gyro - odometry is the gyro's
    bias (one change, b_g within 10 % of it); with the wheels alone it is as likely theirs: no change is
    declared, and the filter shares the residual between b_g (its random walk since the rest) and D. A
    batch is witnessed only when the pair witnessed every one of its samples."""
    b, D, _, _, _, _, changes = _straight_batches_with_a_residual_step(third_witness=True)
    assert changes == 1 and b == pytest.approx(0.03, rel=0.1)
    b, D, _, _, _, _, changes = _straight_batches_with_a_residual_step(third_witness=False)
    assert changes == 0 and abs(b) < 0.01  # the rest pinned the bias: D v / b takes most of the step
    assert b + D * 1.0 / TRACK == pytest.approx(0.03, rel=0.25) and D * 1.0 / TRACK > 2 * b
    *_, changes = _straight_batches_with_a_residual_step(third_witness=lambda sample: sample != 3)
    assert changes == 0


def test_the_bias_prior_and_drift_are_the_believed_gyros():
    """believed_gyro fills what YawCalibrationParameters leaves open (None: the bias's prior and random walk,
    the white noise) from the believed sensors, and
    keeps what it states; the block reads the believed set's accelerometer count for its third witness."""
    sensors = SensorParameters(
        gyro_initial_bias_std=0.001, gyro_drift_density=3.2e-5, gyro_noise_std=0.004, accelerometer_sets=1
    )
    p = believed_gyro(YawCalibrationParameters(), sensors)
    assert (p.initial_bias_std, p.bias_drift_density, p.gyro_noise_std) == (0.001, 3.2e-5, 0.004)
    stated = believed_gyro(YawCalibrationParameters(bias_drift_density=0.0), sensors)
    assert (stated.initial_bias_std, stated.bias_drift_density) == (0.001, 0.0)
    nominal = believed_gyro(YawCalibrationParameters())
    nominal_figures = (nominal.initial_bias_std, nominal.bias_drift_density, nominal.gyro_noise_std)
    assert nominal_figures == (0.0035, 0.0005, 0.014)  # SensorParameters()
    state = yaw_calibration_initial_state(p)
    assert calibration_parameters(state)[2] == pytest.approx(0.001)
    block = YawRateCalibration(YawCalibrationParameters(), TRACK, T_N, N_BATCH * T_N, sensors)
    assert block._third_witness is False and block._p.bias_drift_density == 3.2e-5


def _kurt3d_turn_exit(p, bias_step=0.0):
    """Kurt3D (track 0.4 m) rests 1 s (b_g = 0.003), accelerates to 4 m/s in 2 s (D = 0 learned), drives
    straight for 1 s, turns at -0.3 rad/s for 0.2 s and leaves the turn at a yaw acceleration of 1.5
    rad/s^2 to 0.15 rad/s, where it stays for 0.4 s; while the yaw accelerates the wheels read the yaw rate
    high by the true tyres' kappa v alpha (0.037 rad/s, 3.7 measurement_std). ``bias_step``: the gyro's
    bias steps by this while the robot drives straight (rad/s). Returns calibration_parameters."""
    track, kappa, v = 0.4, 0.00617, 4.0
    rows = [(0.0, 0.0, 0.0)] * 50 + [(0.0, 0.0, 0.04 * (k + 1)) for k in range(100)]
    rows += [(0.0, 0.0, v)] * 50 + [(-0.3, -0.3, v)] * 10
    rows += [(-0.3 + 0.03 * k, -0.3 + 0.03 * k + kappa * v * 1.5, v) for k in range(1, 16)]
    rows += [(0.15, 0.15, v)] * 20
    if bias_step:
        rows = rows[:200] + [(0.0, 0.0, v)] * 20
    state = yaw_calibration_initial_state(p)
    for k, (omega, omega_o, speed) in enumerate(rows):
        gyro = omega + 0.003 + (bias_step if k >= 200 else 0.0)
        for _ in range(N_BATCH):
            state = yaw_calibration_step(
                state, gyro, [speed, omega_o, 0.0, 0.0], 1.0, False, track, p, T_N, N_BATCH
            )
    return calibration_parameters(state)


def test_the_tyres_slip_at_a_turns_exit_is_no_bias_change():
    """The believed Kurt3D's tyres give kappa = 4 I / (b^2 m a_p B C) = 0.0062 s
    (calibration_batches.tyre_slip_time). Without it in the batches' variance the turn's exit at 4 m/s
    (_kurt3d_turn_exit) raises the bias-change alarm and the step measured there moves b_g by the wheels'
    lead; with it the exit raises none and b_g stays within 0.001 of 0.003, and a 0.03 rad/s step of the
    gyro's bias on the straight still raises the alarm and is measured within 0.003."""
    mixing = MixingParameters(tyre_peak_acceleration=7.85, tyre_stiffness_factor=12.0, tyre_shape_factor=1.3)
    p = believed_tyre_slip(YawCalibrationParameters(), kurt3d(), mixing, 0.4)
    assert p.yaw_slip_time == pytest.approx(0.00617, rel=0.01)
    assert believed_tyre_slip(YawCalibrationParameters(), None, mixing, 0.4).yaw_slip_time == 0.0
    b, *_, changes = _kurt3d_turn_exit(dc.replace(p, yaw_slip_time=0.0))
    assert changes == 1 and b < -0.01
    b, *_, changes = _kurt3d_turn_exit(p)
    assert changes == 0 and b == pytest.approx(0.003, abs=0.001)
    b, *_, changes = _kurt3d_turn_exit(p, bias_step=0.03)
    assert changes == 1 and b == pytest.approx(0.033, abs=0.003)
