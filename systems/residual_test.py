"""One residual test for every channel: residual -> normalised innovation -> test -> decision.

A witness predicts what a channel should read; the residual r = y - y_hat and its predicted variance
S = var(y) + var(y_hat) give the normalised innovation z = r / sqrt(S), N(0, 1) while the channel and
its witnesses are healthy. Two tests judge z:

1. a chi-square gate per sample (abrupt faults): z^2 (or the sum of squares of ``dof`` independent
   innovations) beyond the (1 - false_alarm) quantile of chi-square with ``dof`` degrees of freedom
   (chi_square_gate);
2. a two-sided CUSUM (Page's test, slow faults): g+ <- max(0, g+ + z_c - k), g- <- max(0, g- - z_c - k)
   with z_c = z clipped to +-clip (one outlier moves the sums by at most clip - k, so only a
   persistent shift reaches the threshold) and an alarm when either sum exceeds h (cusum_step). The
   drift k is half the shift (in sigma) the test is to detect soonest; h follows from the mean number
   of healthy samples between false alarms by Siegmund's approximation of the average run length
   (cusum_threshold). A shift of delta sigma is detected after about (h + 1.166) / (delta - k)
   samples (at most clip). Each side also counts the samples since it last stood at zero (Page's
   estimate of the change point).
"""

import dataclasses as dc
import functools
import math

import numpy as np
from pydrake.common.containers import namedview
from scipy.special import gammaincinv
from slipnav.systems.compiled import jitable
from slipnav.systems.ranges import out_of_range, require_in

CusumState = namedview("CusumState", ["upper", "lower", "upper_count", "lower_count"])
"""The two one-sided sums g+ (shift up) and g- (shift down), in sigma; per side the samples since it last
stood at zero."""
CUSUM_SIZE = len(CusumState.get_fields())
"""CusumState's number of values."""

SIEGMUND_CORRECTION = 1.166
"""Siegmund's boundary correction of the CUSUM's threshold for Gaussian increments (in sigma)."""


def chi_square_quantile(probability: float, dof: int) -> float:
    """The value a chi-square variable of ``dof`` degrees of freedom stays below with ``probability``:
    2 P^-1(dof / 2, probability), P the regularised lower incomplete gamma function (scipy.stats.chi2.ppf's
    formula, bit for bit, without scipy.stats's import time)."""
    return float(2 * gammaincinv(dof / 2, probability))


def chi_square_gate(false_alarm: float, dof: int = 1) -> float:
    """The gate on the sum of squares of ``dof`` normalised innovations that a healthy channel exceeds
    with probability ``false_alarm`` (in (0, 1))."""
    require_in("false_alarm", false_alarm, "(0, 1)")
    return chi_square_quantile(1.0 - false_alarm, dof)


def cusum_run_length(threshold: float, drift: float) -> float:
    """Siegmund's approximation of a one-sided CUSUM's mean run length (samples) between false alarms on
    N(0, 1) increments: (exp(2 k b) - 2 k b - 1) / (2 k^2) with b = h + 1.166."""
    b = threshold + SIEGMUND_CORRECTION
    x = 2.0 * drift * b
    return (math.expm1(x) - x) / (2.0 * drift * drift)


@functools.lru_cache(maxsize=64)
def cusum_threshold(run_length: float, drift: float) -> float:
    """The threshold h (sigma) at which the two-sided CUSUM of drift k raises a false alarm once in
    ``run_length`` healthy samples on average (each side once in 2 run_length; bisection of
    cusum_run_length, remembered per (run_length, drift): the calibration asks for it every batch)."""
    require_in("run_length", run_length, "(1, inf) samples")
    require_in("drift", drift, "(0, inf) sigma")
    low, high = 0.0, 1.0
    while cusum_run_length(high, drift) < 2.0 * run_length:
        high *= 2.0
    for _ in range(60):
        middle = 0.5 * (low + high)
        low, high = (middle, high) if cusum_run_length(middle, drift) < 2.0 * run_length else (low, middle)
    return high


@dc.dataclass(frozen=True)
class CusumTest:
    """A two-sided CUSUM on a normalised innovation (module docstring, 2.).

    Args:
        drift: k, half the shift (sigma) to detect soonest.
        threshold: h (sigma), from cusum_threshold.
        clip: |z| beyond this counts as this (sigma), > drift.
    """

    drift: float
    threshold: float
    clip: float

    @classmethod
    def from_run_length(cls, run_length: float, drift: float, clip: float) -> "CusumTest":
        """The test raising one false alarm per ``run_length`` healthy samples on average."""
        if not (math.isfinite(clip) and clip > drift):
            raise out_of_range("clip", clip, f"({drift}, inf) sigma")
        return cls(drift, cusum_threshold(run_length, drift), clip)


def cusum_initial_state() -> CusumState:
    """Both sums at zero."""
    return CusumState([0.0] * CUSUM_SIZE)


def cusum_step(state: CusumState, z: float, test: CusumTest) -> tuple:
    """One normalised innovation ``z``: returns (the next CusumState, +1 / -1 when the upper / lower sum
    exceeds the threshold, else 0). The sums are not reset here: the caller decides what an alarm
    changes and restarts the test with cusum_initial_state."""
    sums = np.array(state[:], dtype=float)
    alarm = cusum_update(sums, z, test.drift, test.threshold, test.clip)
    return CusumState(sums), alarm


@jitable
def cusum_update(sums, z: float, drift: float, threshold: float, clip: float) -> int:
    """cusum_step on the plain array ``sums`` (CusumState's order), updated in place: the form the
    compiled sensor checks call (systems/compiled.py). Returns +1 / -1 / 0 as cusum_step."""
    clipped = min(max(z, -clip), clip)
    upper = max(0.0, sums[0] + clipped - drift)
    lower = max(0.0, sums[1] - clipped - drift)
    sums[2] = sums[2] + 1.0 if upper > 0.0 else 0.0
    sums[3] = sums[3] + 1.0 if lower > 0.0 else 0.0
    sums[0], sums[1] = upper, lower
    return 1 if upper > threshold else (-1 if lower > threshold else 0)
