"""The calibration's confirmed estimate (systems/navigation/confirmed_estimate.py): the yaw test's verdict
on the gyro, the estimate kept at each confirmed batch, and the return to it when the gyro is blamed."""

import numpy as np
import pytest
from slipnav.scenarios.config import load_scenario
from slipnav.scenarios.metrics import final_position_error
from slipnav.scenarios.runner import run_scenario
from slipnav.systems.health import (
    INCONSISTENT,
    SensorHealthParameters,
    health_initial_state,
    health_step,
    yaw_verdict,
)
from slipnav.systems.navigation.yaw_calibration import (
    YawCalibrationParameters,
    calibration_parameters,
    yaw_calibration_initial_state,
    yaw_calibration_step,
)
from slipnav.systems.robot.faults import FaultEvent

from tests.test_faults import GEOMETRY, T_N, B, stream

BATCH = 10
STANDING = [0.0, 0.0, 0.0, 0.0]
STRAIGHT = [1.0, 0.0, 1.0, 1.0]  # [v_o, omega_o, v_R, v_L] at 1 m/s


def _verdicts(rows):
    state, verdicts, codes = health_initial_state(GEOMETRY, 1.0), [], []
    for row in rows:
        state, _, code = health_step(state, row, SensorHealthParameters(), GEOMETRY)
        verdicts.append(yaw_verdict(state))
        codes.append(code[4])
    return np.array(verdicts), np.array(codes)


def test_the_yaw_test_confirms_a_gyro_over_a_turn_and_blames_it_once():
    """The 0.8 rad/s turn at 1 m/s (gyro noise 0.014 rad/s) with the gyro x1.5 from sample 500 to 800: the
    test judges from the second sample and confirms the gyro once the judged turn reaches 0.05 rad (32
    samples of 1.6 mrad: sample 32), then on most samples (its sums at zero); it blames the gyro on one
    sample, the first flagged one, confirms nothing from the fault's onset until the gyro is back and has
    turned 0.05 rad again, and never judges a straight."""
    rows = stream(1500, 1.0, 0.8)
    rows[500:800, 4] *= 1.5
    verdicts, codes = _verdicts(rows)
    confirmed = np.flatnonzero(verdicts == 1)
    flagged = np.flatnonzero(codes)
    assert confirmed[0] == 32 and np.mean(verdicts[32:500] == 1) > 0.8
    np.testing.assert_array_equal(np.flatnonzero(verdicts == -1), flagged[:1])
    assert codes[flagged[0]] == INCONSISTENT
    assert not np.any(verdicts[500 : flagged[-1] + 32] == 1) and np.any(verdicts[flagged[-1] + 32 :] == 1)
    verdicts, _ = _verdicts(stream(1500, 1.0, 0.0))
    assert not verdicts.any()


def _batch(state, gyro, odo, p, standing=False, verdicts=(), fault=False):
    """One batch of BATCH samples; ``verdicts``: {sample: verdict}."""
    verdicts = dict(verdicts)
    for k in range(BATCH):
        state = yaw_calibration_step(
            state, gyro, odo, 1.0, fault, B, p, T_N, BATCH, standing, 0.0, True, verdicts.get(k, 0.0)
        )
    return state


def _theta_and_variances(state):
    b_g, D, sigma_b, sigma_D = calibration_parameters(state)[0:4]
    return np.array([b_g, D, sigma_b**2, sigma_D**2])


def test_a_blame_returns_the_calibration_to_its_last_confirmed_batch():
    """A rest (gyro 0.004 rad/s) learns b_g (the prior 0.0035^2 plus one batch's walk against R = 0.005^2)
    and is confirmed; three straight batches at 1 m/s whose gyro reads 0.05 rad/s (the residual of a gyro
    that reads a correction's yaw rate wrong) move D, and b_g a little; a blame returns theta to the
    rest's and P to the rest's plus three batches of the bias's random walk (0.0005^2 rad^2/s^3 x 0.02 s
    each; D has none). A straight batch the yaw test confirmed becomes the confirmed estimate; one it
    confirmed but on which a reading was replaced does not."""
    p = YawCalibrationParameters()
    state = _batch(yaw_calibration_initial_state(p), 0.004, STANDING, p, standing=True)
    rest = _theta_and_variances(state)
    prior = 0.0035**2 + 0.0005**2 * BATCH * T_N
    assert rest[0] == pytest.approx(0.004 * prior / (prior + 0.005**2), rel=1e-12) and rest[1] == 0.0
    for _ in range(3):
        state = _batch(state, 0.05, STRAIGHT, p)
    moved = _theta_and_variances(state)
    assert abs(moved[0] - rest[0]) > 1e-5 and abs(moved[1]) > 1e-3
    state = yaw_calibration_step(state, 0.05, STRAIGHT, 1.0, True, B, p, T_N, BATCH, False, 0.0, True, -1.0)
    walk = 3 * 0.0005**2 * BATCH * T_N
    np.testing.assert_allclose(_theta_and_variances(state), rest + [0.0, 0.0, walk, 0.0], rtol=0, atol=1e-15)
    state = _batch(yaw_calibration_initial_state(p), 0.004, STANDING, p, standing=True)
    state = _batch(state, 0.05, STRAIGHT, p, verdicts={3: 1.0})
    confirmed = _theta_and_variances(state)
    state = _batch(state, 0.05, STRAIGHT, p, verdicts={3: 1.0}, fault=True)
    state = _batch(state, 0.05, STRAIGHT, p, verdicts={0: -1.0}, fault=True)  # blamed: out
    np.testing.assert_allclose(_theta_and_variances(state)[0:2], confirmed[0:2], rtol=0, atol=1e-15)


@pytest.mark.parametrize("scenario", ["corner", "square"])
def test_a_gyro_flipped_on_a_straight_does_not_leave_its_calibration_behind(scenario):
    """The gyro's sign flipped (x(1 - 2)) from 1.2 s for 2 s, on the straight before the first turn: while
    the path follower corrects, the calibration takes the flipped gyro's residual into b_g and D (|D|
    above 5e-4); the yaw test blames the gyro in the turn, and theta returns to the start's rest, where
    D is not learned (0) and b_g is the rest's. The run completes with the fused final error below both
    baselines'."""
    event = FaultEvent("scale", "gyro", 1.2, 2.0, -2.0)
    run = run_scenario(load_scenario(scenario), seed=0, faults=[event])
    a = run.arrays
    t, D, b_g = a["t"], a["est_radius_difference"], a["est_gyro_bias"]
    blamed = np.flatnonzero(a["health_gyro"] == INCONSISTENT)[0]
    assert 2.0 < t[blamed] < 2.4
    assert abs(D[blamed - 1]) > 5e-4 and D[blamed + 1] == 0.0
    assert b_g[blamed + 1] == pytest.approx(b_g[np.searchsorted(t, 1.0)], abs=2e-4)
    assert run.summary["completed"]
    fused = final_position_error(a, "est")
    assert fused < min(final_position_error(a, "odo"), final_position_error(a, "gyro"))
