"""The accelerometer pair's gain test: a scale fault on one sensor makes the pair's disagreement (beyond
S(3)'s rotational terms and the learned offset) proportional to that sensor's own signal, which the
consistency test's averages miss while it stays below their bound. The test regresses the disagreement
on each sensor's signal over the last gain_samples informative samples (pair_gain_ratio): a x2 scale on
one sensor is a gain of 0.67 on the pair's mean, flagged beyond gain_tolerance once the evidence passes
gain_threshold.
"""

import math

from slipnav.systems.compiled import jitable
from slipnav.systems.health.layout import (
    GAIN_BLOCK_DISAGREEMENT,
    GAIN_BLOCK_HALF_ROTATION,
    GAIN_BLOCK_MEAN,
    GAIN_BLOCK_OTHER,
    GAIN_COUNT,
    GAIN_NUMBERS,
    GAIN_POSITION,
    GAIN_PRODUCTS,
    GAIN_SAMPLE_NUMBER,
    GAIN_SERIES,
    GAIN_SUMS,
    GAIN_WINDOW_MAX,
)

GAIN_CORRELATION = 16.0
"""The gain test's sums add neighbouring samples whose noise is correlated (the block averages, the
commotion's 5 ms): the variance of a sum is taken as this many times that of independent samples."""
GAIN_HORIZON = 2
"""The gain test's evidence is at most this many times gain_samples samples old: a standstill after a
fault (nothing informative comes in) re-admits the sensor within it."""
GAIN_HOLD = 2.0
"""A pair's hold (the state's analog_hold) set by the gain test alone; the averages' is 1."""
GAIN_RELEASE_SIGMAS = 1.0
"""The gain test's upper bound on a gain (pair_gain_upper_bound): this many standard deviations above."""


@jitable
def averaged_omega_dot_std(gain: float, g) -> float:
    """The noise of omega' from the gyro's sample-to-sample difference after an exponential average with
    ``gain`` (1/n): sigma g sqrt(1 + g / (2 - g)) / T_N, sigma the gyro's white noise."""
    return gain * g.gyro_noise_std / g.T_N * math.sqrt(1.0 + gain / (2.0 - gain))


def gain_constants(c) -> dict:
    """The gain test's figures of the record ``c`` (HealthConstants) for pair_gain_block_variance:
    gain_block_gain b = 1 / gain_block_samples; the variances the block average leaves of the white noise
    (gain_block_white), of the commotion per unit of its variance (gain_block_coloured) and, per axis
    [t, n], of the gyro's omega' on the lever 2 y for t, 2 x for n (gain_block_rotation)."""
    b = 1.0 / c.gain_block_samples
    phi = math.exp(-c.T_N / c.accel_vibration_time_constant) * (1.0 - b)
    white = b / (2.0 - b)  # an exponential average's variance over its input's
    omega_dot_std = averaged_omega_dot_std(b, c)
    return {
        "gain_block_gain": b,
        "gain_block_white": 2.0 * c.accel_noise_std**2 * white,
        "gain_block_coloured": white * (1.0 + phi) / (1.0 - phi),  # the same for the commotion (first order)
        "gain_block_rotation": tuple(
            (2.0 * abs(c.accelerometer_position[1 - axis]) * omega_dot_std) ** 2 for axis in (0, 1)
        ),
    }


@jitable
def pair_gain_block_variance(s, axis: int, disagreement, mean, rotation, other, speed, p, g) -> float:
    """Averages the disagreement and the regressors' parts over gain_block_samples (exponential) and
    returns the noise variance of the averaged disagreement: white and commotion at ``speed`` as the
    block average leaves them, omega' from the gyro's difference on the lever (gain_constants), the
    other axis's acceleration times gain_cross_coupling ((m/s^2)^2)."""
    b = p.gain_block_gain
    block_disagreement = s[GAIN_BLOCK_DISAGREEMENT]
    block_mean = s[GAIN_BLOCK_MEAN]
    block_half_rotation = s[GAIN_BLOCK_HALF_ROTATION]
    block_other = s[GAIN_BLOCK_OTHER]
    block_disagreement[axis] += (disagreement - block_disagreement[axis]) * b
    block_mean[axis] += (mean - block_mean[axis]) * b
    block_half_rotation[axis] += (0.5 * rotation - block_half_rotation[axis]) * b
    block_other[axis] += (other - block_other[axis]) * b
    commotion = g.accel_vibration_per_speed * speed
    return (
        (p.gain_cross_coupling * block_other[axis]) ** 2
        + p.gain_block_white
        + 2.0 * commotion**2 * p.gain_block_coloured
        + p.gain_block_rotation[axis]
    )


@jitable
def pair_gain_ratio(
    s, axis: int, disagreement, mean, rotation, other, speed, moving: bool, update: bool, p, g
) -> float:
    """The gain test on ``axis`` (0: t, 1: n), its statistic over gain_threshold (> 1 flags; 0 while off
    or not ``update``d: the gyro's omega' unknown). The gain beta of the block-averaged disagreement on
    each regressor r = mean +- rotation / 2 (sensor 1's or sensor 2's own signal) is sum d r / var over
    sum r^2 / var in the window (pair_gain_window; ``moving``: the wheels turned, at rest the mean is the
    sensors' biases). The statistic is the larger regressor's (|beta| - gain_tolerance -
    gain_offset_allowance sum |r| / var / sum r^2 / var) over beta's standard deviation
    sqrt(GAIN_CORRELATION / sum r^2 / var); the allowance is what an offset error puts into beta."""
    if math.isinf(p.gain_threshold) or not update:
        return 0.0
    variance = pair_gain_block_variance(s, axis, disagreement, mean, rotation, other, speed, p, g)
    pair_gain_window(s, axis, moving, variance, p)
    sums = s[GAIN_SUMS]
    worst = 0.0
    for k in range(2):
        energy = sums[GAIN_SERIES * axis + 3 * k + 1]
        if energy > 0.0:
            beta = sums[GAIN_SERIES * axis + 3 * k] / energy
            allowance = (
                p.gain_tolerance + p.gain_offset_allowance * sums[GAIN_SERIES * axis + 3 * k + 2] / energy
            )
            spread = math.sqrt(GAIN_CORRELATION / energy)
            worst = max(worst, max(abs(beta) - allowance, 0.0) / spread)
    return worst / p.gain_threshold


@jitable
def pair_gain_window(s, axis: int, moving: bool, variance: float, p) -> None:
    """The window holds the last gain_samples informative samples (moving, a regressor above the noise) of
    the last GAIN_HORIZON gain_samples samples: a signal's zero crossing keeps the evidence, a standstill
    lets it expire. Each sample's products (per regressor d r / var, r^2 / var, |r| / var) replace the
    oldest in the ring and in the sums, which are recomputed from the ring whenever it wraps."""
    n = p.gain_samples
    sums = s[GAIN_SUMS]
    products = s[GAIN_PRODUCTS]
    numbers = s[GAIN_NUMBERS]
    first_sum = GAIN_SERIES * axis
    series_ring = GAIN_SERIES * axis * GAIN_WINDOW_MAX  # the axis's products, series by series
    number_ring = GAIN_WINDOW_MAX * axis
    sample_numbers = s[GAIN_SAMPLE_NUMBER]
    positions = s[GAIN_POSITION]
    counts = s[GAIN_COUNT]
    sample_numbers[axis] += 1.0  # this sample's number
    number = sample_numbers[axis]
    position, count = int(positions[axis]), int(counts[axis])
    while count > 0:  # expire the oldest entries
        oldest = (position - count) % n
        if numbers[number_ring + oldest] > number - GAIN_HORIZON * n:
            break
        for i in range(GAIN_SERIES):
            sums[first_sum + i] -= products[series_ring + i * GAIN_WINDOW_MAX + oldest]
            products[series_ring + i * GAIN_WINDOW_MAX + oldest] = 0.0
        count -= 1
    if count == 0:
        for i in range(GAIN_SERIES):
            sums[first_sum + i] = 0.0
    mean = s[GAIN_BLOCK_MEAN][axis]
    half_rotation = s[GAIN_BLOCK_HALF_ROTATION][axis]
    regressors = (mean + half_rotation, mean - half_rotation)
    if moving and variance > 0.0 and max(regressors[0] ** 2, regressors[1] ** 2) > variance:
        disagreement = s[GAIN_BLOCK_DISAGREEMENT][axis]
        for k in range(2):
            r = regressors[k]
            values = (disagreement * r / variance, r * r / variance, abs(r) / variance)
            for j in range(3):
                series = 3 * k + j
                slot = series_ring + series * GAIN_WINDOW_MAX + position
                sums[first_sum + series] += values[j] - products[slot]
                products[slot] = values[j]
                if position == n - 1:
                    start, total = series_ring + series * GAIN_WINDOW_MAX, 0.0
                    for i in range(n):  # in order (np.sum's pairwise order is not numba's)
                        total += products[start + i]
                    sums[first_sum + series] = total
        numbers[number_ring + position] = number
        position, count = (position + 1) % n, min(count + 1, n)
    positions[axis] = float(position)
    counts[axis] = float(count)


@jitable
def pair_gain_reset(s):
    """Empties the gain test's windows and block averages (both axes): while an accelerometer is out for
    its own fault (NaN, saturated, stuck, jumping) the pair is not judged, and the evidence from before it
    is stale when it returns. The sample numbers run on."""
    parts = (GAIN_BLOCK_DISAGREEMENT, GAIN_BLOCK_MEAN, GAIN_BLOCK_HALF_ROTATION, GAIN_BLOCK_OTHER)
    sums = s[GAIN_SUMS]
    products = s[GAIN_PRODUCTS]
    for axis in range(2):
        empty = s[GAIN_COUNT][axis] == 0.0 and s[GAIN_POSITION][axis] == 0.0
        if empty and s[parts[0]][axis] == 0.0 and s[parts[1]][axis] == 0.0:
            if s[parts[2]][axis] == 0.0 and s[parts[3]][axis] == 0.0:
                continue  # emptied already (an empty window's ring holds no products): not every sample
        for part in parts:
            s[part][axis] = 0.0
        for i in range(GAIN_SERIES):
            sums[GAIN_SERIES * axis + i] = 0.0
        s[GAIN_COUNT][axis] = 0.0
        series_ring = GAIN_SERIES * axis * GAIN_WINDOW_MAX
        for i in range(GAIN_SERIES * GAIN_WINDOW_MAX):
            products[series_ring + i] = 0.0
        s[GAIN_POSITION][axis] = 0.0


@jitable
def pair_gain_upper_bound(s, axis: int, update: bool, p) -> float:
    """The gain test's evidence of health on ``axis`` after pair_gain_ratio's update: the larger regressor's
    |beta| + GAIN_RELEASE_SIGMAS standard deviations (0: nothing informative in the window, or not
    ``update``d, or the test off). A pair the gain test flagged is released when this is below
    gain_release as well as the statistic below half its threshold: cleared on the statistic alone, a
    doubled sensor comes back at a dip of its evidence; on the bound alone, a well-measured moderate gain
    is flagged and cleared on alternate samples."""
    if math.isinf(p.gain_threshold) or not update:
        return 0.0
    sums = s[GAIN_SUMS]
    upper = 0.0
    for k in range(2):
        energy = sums[GAIN_SERIES * axis + 3 * k + 1]
        if energy > 0.0:
            beta = sums[GAIN_SERIES * axis + 3 * k] / energy
            upper = max(upper, abs(beta) + GAIN_RELEASE_SIGMAS * math.sqrt(GAIN_CORRELATION / energy))
    return upper
