"""A change of the gyro bias, judged by the calibration's CUSUM (systems/residual_test.py) and measured
against the estimate as it stood at the change point (measurement history replay).

Between a change's onset and the CUSUM's alarm the calibration keeps learning from the batches whose
innovation lies within its gate, and at speed the radius difference D takes its share of each: b_g and
D v_o / b are one measurement's two regressors, and D's prior is the wider. A mean residual against the
estimate that learned meanwhile measures only what is left of the change. So each side of the CUSUM keeps,
from the batch at which it starts to count (Page's estimate of the change point), theta_j and P_j as they
stood before that batch, the batches' summed measurements y = gyro - omega_o and regressors h = v_o / b,
and the batches passed since. On that side's alarm after N tested batches the estimate returns to the
change point and the change is measured there:

    # predict step: P_j plus the random walks over the batches since the change point
    # shift: m = mean(y) - theta_j[0] - mean(h) theta_j[1]
    # update step: bias_step_update(theta_j, P_j, m, R / N)

The batches since the change point are the change's evidence, learned from through m alone.
"""

import numpy as np
from slipnav.systems.residual_test import CusumState, CusumTest
from slipnav.systems.state_layout import layout_size, layout_slices

NUM_THETA = 2
"""theta = [b_g, D]."""
SIDES = 2
"""The CUSUM's sides: 0 the upper sum (a rise of the residual), 1 the lower."""

CHANGE_LAYOUT = (
    ("theta", SIDES * NUM_THETA),
    ("covariance", SIDES * NUM_THETA * NUM_THETA),
    ("measurement_sum", SIDES),
    ("regressor_sum", SIDES),
    ("batches", SIDES),
)
"""Per side (upper, lower): theta and P (row-major) before the batch at which the side started to count,
the sums of the tested batches' y (rad/s) and h (1/s) since, and the batches passed since (tested or
not)."""
_SLICES = layout_slices(CHANGE_LAYOUT)
CHANGE_STATE_SIZE = layout_size(CHANGE_LAYOUT)


def bias_change_test(p) -> CusumTest:
    """The CUSUM that judges the calibration's normalised innovations for a change of the gyro bias
    (``p``: YawCalibrationParameters' change_run_length, change_drift, change_clip)."""
    return CusumTest.from_run_length(p.change_run_length, p.change_drift, p.change_clip)


def _side_counts(cusum: CusumState) -> tuple:
    return (cusum.upper_count, cusum.lower_count)


def _side(values, side: int):
    """One side's share of a per-side part of CHANGE_LAYOUT (a view)."""
    size = len(values) // SIDES
    return values[side * size : (side + 1) * size]


def change_points_age(change, cusum: CusumState) -> None:
    """A batch begins: each side that counts has one more batch since its change point (``change``: the
    CHANGE_LAYOUT view, updated in place)."""
    batches = change[_SLICES["batches"]]
    for side, count in enumerate(_side_counts(cusum)):
        if count > 0:
            batches[side] += 1.0


def change_points_step(change, cusum: CusumState, theta, P, measurement: float, regressor: float) -> None:
    """After a tested batch's CUSUM step (``cusum``): a side that starts to count keeps ``theta`` and
    ``P`` (before this batch's update) and restarts its sums; a counting side adds the batch's
    ``measurement`` y and ``regressor`` h; a side at zero holds nothing."""
    thetas = change[_SLICES["theta"]]
    covariances = change[_SLICES["covariance"]]
    measurements, regressors = change[_SLICES["measurement_sum"]], change[_SLICES["regressor_sum"]]
    batches = change[_SLICES["batches"]]
    for side, count in enumerate(_side_counts(cusum)):
        if count == 1:  # the change point
            _side(thetas, side)[:] = theta
            _side(covariances, side)[:] = np.ravel(P)
            measurements[side] = regressors[side] = batches[side] = 0.0
        if count >= 1:
            measurements[side] += measurement
            regressors[side] += regressor


def bias_change_update(change, cusum: CusumState, alarm: int, R: float, walk) -> tuple:
    """The alarm ``alarm`` (+1: upper, -1: lower) of ``cusum``: theta and P at that side's change point,
    P plus ``walk`` (the random walks' variances over one batch) times the batches since, the shift m of
    the N tested batches since (module docstring) taken by bias_step_update with R / N. Returns the new
    (theta, P)."""
    side = 0 if alarm > 0 else 1
    count = _side_counts(cusum)[side]
    theta = _side(change[_SLICES["theta"]], side).copy()
    P = _side(change[_SLICES["covariance"]], side)
    # predict step: the random walks since the change point
    P = P.reshape(NUM_THETA, NUM_THETA) + np.asarray(walk) * change[_SLICES["batches"]][side]
    # shift: the batches' mean measurement less the change point's prediction
    mean_measurement = change[_SLICES["measurement_sum"]][side] / count
    mean_regressor = change[_SLICES["regressor_sum"]][side] / count
    shift = mean_measurement - theta[0] - mean_regressor * theta[1]
    return bias_step_update(theta, P, shift, R / count)


def bias_step_update(theta, P, shift: float, variance: float) -> tuple:
    """A measured change ``shift`` of b_g (rad/s) with ``variance`` (rad^2/s^2): b_g's variance widens
    by shift^2 (the change's size), and the shift is the measurement y = m of b_g's change
    (H = [1, 0], R = variance). Returns the new (theta, P)."""
    P = np.array(P, dtype=float)
    P[0, 0] += shift * shift
    H = np.array([1.0, 0.0])
    S = H @ P @ H + variance
    gain = P @ H / S
    theta = np.asarray(theta, dtype=float) + gain * shift
    I_KH = np.eye(NUM_THETA) - np.outer(gain, H)
    return theta, I_KH @ P @ I_KH.T + np.outer(gain, gain) * variance
