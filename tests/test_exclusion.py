"""Exclusion ends on evidence (systems/health/): a channel stays out until its readings agree
with the other witnesses again, and a gyro that comes back at a new level hands that level to the
calibration as a bias step (gyro_bias_step_block, bias_change.bias_step_update); numbers by hand."""

import numpy as np
import pytest
from slipnav.scenarios.config import load_scenario
from slipnav.scenarios.metrics import final_position_error
from slipnav.scenarios.runner import run_scenario
from slipnav.systems.health import (
    JUMP,
    RECOVERING,
    SensorHealthParameters,
    gyro_bias_step,
    health_initial_state,
    health_step,
)
from slipnav.systems.health.gyro import BIAS_STEP_SIGMAS
from slipnav.systems.navigation.bias_change import (
    CHANGE_STATE_SIZE,
    bias_change_update,
    bias_step_update,
    change_points_age,
    change_points_step,
)
from slipnav.systems.navigation.yaw_calibration import (
    YawCalibrationParameters,
    calibration_parameters,
    yaw_calibration_initial_state,
    yaw_calibration_step,
)
from slipnav.systems.residual_test import CusumState
from slipnav.systems.robot.faults import FaultEvent

from tests.test_faults import GEOMETRY, STEP, T_N, B, R, stream


def check_with_bias(rows, params=None, v0=1.0):
    """The checks over ``rows`` with a calibration that adds each handed-over bias step to b_g (as
    yaw_calibration_step does at once): (codes, the handed-over steps by sample)."""
    params = params or SensorHealthParameters()
    state = health_initial_state(GEOMETRY, v0)
    bias, codes, steps = 0.0, [], {}
    for k, row in enumerate(rows):
        state, _, code = health_step(state, row, params, GEOMETRY, yaw_calibration=(bias, 0.0))
        codes.append(code)
        if gyro_bias_step(state) != 0.0:
            steps[k] = gyro_bias_step(state)
            bias += steps[k]
    return np.array(codes), steps


def test_a_gyro_back_at_a_new_level_on_a_straight_hands_the_step_to_the_calibration():
    """The gyro reads 0.8 rad/s more from sample 500 while the robot drives straight at 1 m/s: the jump
    (0.8 > 0.5 rad/s) excludes it; the block of bias_step_samples (25) from the jump on measures the
    step within its standard error (0.014 / 5 rad/s, plus the replacement's quantisation) and hands it
    over at sample 524; the gyro less the new b_g then agrees, and the re-admission block (5) lets it in
    at sample 529. No second step follows."""
    rows = stream(1500, 1.0, 0.0)
    rows[500:, 4] += 0.8
    codes, steps = check_with_bias(rows)
    assert codes[500, 4] == JUMP and np.all(codes[501:525, 4] == RECOVERING)
    assert list(steps) == [524]
    counts = STEP * 2 * R / (B * T_N)  # one count of each wheel in one sample, as a yaw rate
    assert steps[524] == pytest.approx(0.8, abs=BIAS_STEP_SIGMAS * 0.014 / 5 + counts / 25)
    assert np.all(codes[525:529, 4] == RECOVERING) and not codes[529:, 4].any()


def test_a_gyro_off_in_a_turn_measures_no_step_and_stays_out():
    """The same 0.8 rad/s in a 0.5 rad/s turn: the replacement is beyond bias_step_yaw_rate (0.15), where
    a scale error would read as a bias, so no step is measured and the gyro stays out to the end (no
    exclusion ends on a timer)."""
    rows = stream(1500, 1.0, 0.5)
    rows[500:, 4] += 0.8
    codes, steps = check_with_bias(rows)
    assert steps == {} and np.all(codes[501:, 4] == RECOVERING)
    for bad in (1, 501, 2.5, True):
        with pytest.raises(ValueError, match=r"bias_step_samples=.*allowed integers in \[2, 500\]"):
            SensorHealthParameters(bias_step_samples=bad)


def test_a_noisy_gyro_measures_no_step():
    """A gyro whose readings spread 0.5 rad/s about a 0.8 rad/s offset is no bias: beyond
    BIAS_STEP_SIGMAS (4) x 0.014 plus the quantisation (0.227 rad/s), so nothing is handed over."""
    rows = stream(1500, 1.0, 0.0)
    rows[500:, 4] += 0.8 + 0.5 * np.random.default_rng(1).standard_normal(1000)
    codes, steps = check_with_bias(rows)
    assert steps == {} and np.all(codes[500:, 4] > 0)


def test_a_sign_flipped_encoder_stays_out_to_the_end():
    """The left encoder counts backwards from sample 300 on (its angle mirrored there): each increment is
    2 v T_N / r off the prediction from the right wheel and the gyro, so it stays excluded for the
    remaining 2.4 s, its replacement serving: the output follows the true wheel within the gyro's noise."""
    clean = stream(1500, 1.0, 0.0)
    rows = clean.copy()
    rows[300:, 6] = 2.0 * clean[299, 6] - clean[300:, 6]
    codes, _ = check_with_bias(rows)
    assert np.all(codes[300:, 6] > 0) and not codes[:300].any()


def test_bias_change_update_measures_from_the_change_point_by_hand():
    """The lower side counted 3 tested batches since its change point, 4 batches ago, where theta was
    [0.01, 0.002] and P diag(1e-6, 4e-6); their mean measurement y = 0.08 rad/s at h = v / b = 10 1/s
    gives the shift 0.08 - 0.01 - 10 x 0.002 = 0.05; P there plus 4 batches of the walk diag(1e-8, 0),
    widened by 0.05^2, takes it with R / 3."""
    change = np.zeros(CHANGE_STATE_SIZE)
    cusum = CusumState([0.0, 12.0, 0.0, 3.0])
    change_points_step(
        change, CusumState([0.0, 1.0, 0.0, 1.0]), [0.01, 0.002], np.diag([1e-6, 4e-6]), 0.07, 10.0
    )
    for y in (0.09, 0.08):
        change_points_age(change, cusum)
        change_points_step(change, CusumState([0.0, 5.0, 0.0, 2.0]), [9.0, 9.0], np.eye(2), y, 10.0)
    change_points_age(change, cusum)
    change_points_age(change, cusum)
    theta, P = bias_change_update(change, cusum, -1, 1e-4, np.diag([1e-8, 0.0]))
    P00 = 1e-6 + 4e-8 + 0.05**2
    gain = P00 / (P00 + 1e-4 / 3)
    np.testing.assert_allclose(theta, [0.01 + gain * 0.05, 0.002], rtol=1e-12)
    np.testing.assert_allclose(P, np.diag([(1 - gain) * P00, 4e-6]), rtol=1e-9)


def test_bias_step_update_by_hand():
    """A step m = 0.5 with variance 1e-4 on P_bb = 1e-6: P_bb widens to 0.250001, the gain is
    0.250001 / 0.250101, so b_g moves by 0.5 x 0.9996 and P_bb falls to about 1e-4."""
    theta, P = bias_step_update([0.01, 0.002], np.diag([1e-6, 4e-6]), 0.5, 1e-4)
    gain = 0.250001 / 0.250101
    assert theta[0] == pytest.approx(0.01 + gain * 0.5, rel=1e-12) and theta[1] == 0.002
    assert P[0, 0] == pytest.approx(0.250001 * 1e-4 / 0.250101, rel=1e-9) and P[1, 1] == pytest.approx(4e-6)


@pytest.mark.parametrize(
    "event, channel",
    [
        (FaultEvent("bias", "gyro", 1.5, 100.0, 0.6), "gyro"),  # a bias step while driving straight
        (FaultEvent("scale", "encoder_L", 1.5, 100.0, -2.0), "encoder_L"),  # counts backwards
    ],
)
def test_closed_loop_persistent_faults_end_as_the_evidence_says(event, channel):
    """The corner with a fault to the end of the run: the bias step is estimated (b_g within 0.02 rad/s
    of the truth, 0.6) and the gyro re-admitted within 0.2 s; the sign-flipped encoder stays out to the
    end. The run completes and the fused final error is below both baselines'."""
    run = run_scenario(load_scenario("corner"), seed=0, faults=[event])
    a = run.arrays
    codes, t = a[f"health_{channel}"], a["t"]
    assert np.any(codes[(t >= 1.5) & (t < 1.6)] > 0)
    if channel == "gyro":
        assert not np.any(codes[t > 1.7])
        assert abs(a["est_gyro_bias"][-1] - a["true_gyro_bias"][-1] - 0.6) < 0.02
    else:
        assert np.all(codes[t >= 1.55] > 0)
    fused = final_position_error(a, "est")
    assert fused < min(final_position_error(a, "odo"), final_position_error(a, "gyro"))
    assert run.summary["completed"]


def test_the_calibration_counts_a_handed_over_step_as_a_bias_change():
    """yaw_calibration_step with bias_step 0.3: b_g moves by the step at once and the change is counted."""
    p = YawCalibrationParameters()
    state = yaw_calibration_initial_state(p)
    state = yaw_calibration_step(state, 0.3, [1.0, 0.0, 1.0, 1.0], 1.0, True, B, p, T_N, 10, None, 0.3)
    b_g, _, sigma_b, _, _, _, changes = calibration_parameters(state)
    assert b_g == pytest.approx(0.3 * (0.09 + 0.0035**2) / (0.09 + 0.0035**2 + 1e-4), rel=1e-9)
    assert changes == 1 and sigma_b < 0.011
