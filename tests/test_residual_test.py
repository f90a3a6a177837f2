"""The residual test every channel shares (systems/residual_test.py): the chi-square gate against the
normal distribution's closed form, Siegmund's run length against the tabulated CUSUM figures and a Monte
Carlo of healthy innovations, and Page's recursion by hand."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.stats import norm
from slipnav.systems.residual_test import (
    CusumTest,
    chi_square_gate,
    cusum_initial_state,
    cusum_run_length,
    cusum_step,
    cusum_threshold,
)


def test_the_one_dof_gate_is_the_two_sided_normal_quantile_squared():
    """chi2(1) is z^2: P(|z| > g) = alpha at g = Phi^-1(1 - alpha/2); two dof: -2 ln(alpha)."""
    for alpha in (0.1, 1e-3, 1e-6):
        assert chi_square_gate(alpha) == pytest.approx(norm.ppf(1 - alpha / 2) ** 2, rel=1e-9)
        assert chi_square_gate(alpha, 2) == pytest.approx(-2 * math.log(alpha), rel=1e-9)
    with pytest.raises(ValueError, match="false_alarm=0"):
        chi_square_gate(0.0)


def test_siegmund_run_length_matches_the_tabulated_cusum():
    """Montgomery's table of the one-sided CUSUM (k = 0.5) gives ARL0 = 336 at h = 4 and 930 at h = 5;
    the approximation 2 (e^b - b - 1) with b = h + 1.166 gives 338 and 938; the threshold inverts it."""
    assert cusum_run_length(4.0, 0.5) == pytest.approx(2 * (math.exp(5.166) - 6.166), rel=1e-12)
    assert cusum_run_length(4.0, 0.5) == pytest.approx(336, rel=0.01)
    assert cusum_run_length(5.0, 0.5) == pytest.approx(930, rel=0.01)
    h = cusum_threshold(cusum_run_length(5.0, 0.5) / 2, 0.5)  # two-sided: each side twice as long
    assert h == pytest.approx(5.0, abs=1e-9)
    with pytest.raises(ValueError, match="run_length"):
        cusum_threshold(0.5, 0.5)


def test_page_recursion_by_hand():
    """g+ = max(0, g+ + clip(z) - k), g- = max(0, g- - clip(z) - k); alarm beyond h."""
    test = CusumTest(drift=0.5, threshold=3.0, clip=2.0)
    state = cusum_initial_state()
    state, alarm = cusum_step(state, 1.5, test)
    assert (state.upper, state.lower, alarm) == (1.0, 0.0, 0)
    state, alarm = cusum_step(state, 10.0, test)  # clipped to 2: one outlier adds 1.5
    assert (state.upper, state.lower, alarm) == (2.5, 0.0, 0)
    state, alarm = cusum_step(state, -0.5, test)
    assert (state.upper, state.lower, alarm) == (1.5, 0.0, 0)
    state, alarm = cusum_step(state, 2.0, test)
    state, alarm = cusum_step(state, 2.0, test)
    assert state.upper == 4.5 and alarm == 1
    state, alarm = cusum_step(cusum_initial_state(), -4.0, test)
    state, alarm = cusum_step(state, -4.0, test)
    assert state.lower == 3.0 and alarm == 0  # not beyond h
    state, alarm = cusum_step(state, -1.0, test)
    assert alarm == -1


def test_the_change_point_counts_by_hand():
    """Each side counts the samples since its sum last stood at zero, and an alarm resets nothing (k =
    0.5, h = 3.5, clip 2): z = -1 lifts only g- (0.5); 1.5, 10 (clipped to 2) and 2 lift g+ to 1, 2.5
    and 4 (an alarm, its run 3 samples long) while g- falls back to zero; -5 (clipped to -2) takes g+ to
    1.5 (4 samples) and g- to 1.5, the next -5 g+ to zero (its run ends) and g- to 3 (2 samples)."""
    test = CusumTest(drift=0.5, threshold=3.5, clip=2.0)
    state = cusum_initial_state()
    expected = (
        (-1.0, (0.0, 0.5, 0.0, 1.0), 0),
        (1.5, (1.0, 0.0, 1.0, 0.0), 0),
        (10.0, (2.5, 0.0, 2.0, 0.0), 0),
        (2.0, (4.0, 0.0, 3.0, 0.0), 1),
        (-5.0, (1.5, 1.5, 4.0, 1.0), 0),
        (-5.0, (0.0, 3.0, 0.0, 2.0), 0),
    )
    for z, sums, alarm in expected:
        state, raised = cusum_step(state, z, test)
        assert (tuple(state[:]), raised) == (sums, alarm)
    assert (state.upper_count, state.lower_count) == (0.0, 2.0)


def first_alarms(test: CusumTest, z: np.ndarray) -> np.ndarray:
    """Per stream (rows), the index of the first alarm (len if none), Page's recursion vectorised."""
    upper = np.zeros(z.shape[0])
    lower = np.zeros(z.shape[0])
    first = np.full(z.shape[0], z.shape[1])
    clipped = np.clip(z, -test.clip, test.clip)
    for k in range(z.shape[1]):
        upper = np.maximum(0.0, upper + clipped[:, k] - test.drift)
        lower = np.maximum(0.0, lower - clipped[:, k] - test.drift)
        hit = ((upper > test.threshold) | (lower > test.threshold)) & (first == z.shape[1])
        first[hit] = k + 1
    return first


def test_healthy_innovations_raise_false_alarms_at_the_stated_rate():
    """2000 streams of N(0, 1) innovations: the mean run length to the first false alarm is the one the
    threshold was set for (Siegmund's approximation is within a few percent)."""
    test = CusumTest.from_run_length(200.0, 0.5, 4.0)
    z = np.random.default_rng(0).standard_normal((2000, 2000))
    first = first_alarms(test, z)
    assert np.all(first < z.shape[1])
    assert first.mean() == pytest.approx(200.0, rel=0.1)


@settings(max_examples=25, deadline=None)
@given(shift=st.floats(1.5, 6.0), seed=st.integers(0, 2**16))
def test_a_shift_is_detected_within_the_predicted_delay(shift, seed):
    """A persistent shift of delta sigma reaches h after about (h + 1.166) / (min(delta, clip) - k)
    samples; on 200 noisy streams the median delay stays within 30 % of it."""
    test = CusumTest.from_run_length(1e5, 0.5, 4.0)
    z = shift + np.random.default_rng(seed).standard_normal((200, 200))
    delay = np.median(first_alarms(test, z))
    predicted = (test.threshold + 1.166) / (min(shift, test.clip) - test.drift)
    assert delay == pytest.approx(predicted, rel=0.3)
