"""Aligning a real robot's streams with each other and with its ground truth (docs/robot-logs.md).

Each function estimates one thing from the data, with no constant of a particular file:

- ``estimate_lag``: the residual lag of a stream's clock behind a reference, from the cross-correlation
  of one signal both see (the yaw rate);
- ``select_gyro_axis``: which gyro axis, with which sign, is the yaw rate (the largest correlation);
- ``fit_truth_offset``: the rigid offset of a motion-capture object's frame from the robot's (angle of
  the robot's forward axis in the object's frame and the wheel axle's centre in it), from the wheels'
  kinematics: the axle's centre moves along the heading at the wheels' mean speed;
- ``vertical_axis`` and ``fit_accelerometer_rotation``: the accelerometer's vertical axis (gravity) and
  the angle of its horizontal axes about it, against the truth's accelerations;
- ``fresh_counts``, ``counts_on_grid``, ``on_grid``: resampling streams onto the navigation's T_N grid,
  linearly interpolated or held.
"""

from __future__ import annotations

import math

import numpy as np

GRAVITY = 9.80665
"""Standard gravity (m/s^2): one g of an accelerometer that reads in g."""


def unwrap_counter(values, bits: int = 16) -> np.ndarray:
    """A wrapping ``bits``-bit counter as a cumulative count (a step over half the range is a wrap)."""
    return np.unwrap(np.asarray(values, float), period=float(2**bits))


def uniform_grid(t0: float, t1: float, step: float) -> np.ndarray:
    """t0, t0 + step, ... up to t1 (inclusive within 1e-9 step)."""
    n = int(math.floor((t1 - t0) / step + 1e-9)) + 1
    return t0 + step * np.arange(max(n, 0))


def centred_mean(x, samples: int) -> np.ndarray:
    """The mean of ``x`` (N,) or (N, k) over ``samples`` (odd) consecutive samples centred on each one,
    the end values held beyond the ends."""
    x = np.asarray(x, float)
    half = samples // 2
    if half == 0:
        return x.copy()
    padded = np.concatenate([np.repeat(x[:1], half, axis=0), x, np.repeat(x[-1:], half, axis=0)])
    sums = np.cumsum(np.concatenate([np.zeros((1, *x.shape[1:])), padded]), axis=0)
    return (sums[2 * half + 1 :] - sums[: -2 * half - 1]) / (2 * half + 1)


def average_common_travel(ticks, samples: int) -> np.ndarray:
    """[theta_R, theta_L] (N, 2) with their mean averaged over ``samples`` (centred_mean) and
    their half difference kept."""
    mean = centred_mean(0.5 * (ticks[:, 0] + ticks[:, 1]), samples)
    half = 0.5 * (ticks[:, 0] - ticks[:, 1])
    return np.column_stack([mean + half, mean - half])


def smooth(x, step: float, window: float, deriv: int = 0) -> np.ndarray:
    """Savitzky-Golay (order 2) value or derivative of a uniformly sampled signal over ``window`` s."""
    x = np.asarray(x, float)
    n = max(5, int(round(window / step)) | 1)
    if n > len(x):
        n = len(x) if len(x) % 2 else len(x) - 1
    from scipy.signal import savgol_filter  # scipy.signal's import time only where a signal is smoothed

    return savgol_filter(x, n, 2, deriv=deriv, delta=step, axis=0)


def _correlation(a: np.ndarray, b: np.ndarray) -> float:
    a, b = a - a.mean(), b - b.mean()
    denominator = math.sqrt(float(a @ a) * float(b @ b))
    return float(a @ b) / denominator if denominator > 0 else 0.0


def estimate_lag(t_ref, ref, t, x, max_lag: float = 0.3, step: float = 0.002) -> tuple[float, float]:
    """(lag, correlation): how far (s) the stamps ``t`` of signal ``x`` run behind the reference's
    (``x`` stamped t matches ``ref`` at t - lag), from the largest correlation of ``ref`` with ``x`` at the
    shifted stamps, over lags within +-``max_lag`` (a grid of ``step``, refined by a parabola through the
    best three). The correlation is signed: a yaw rate read with the opposite sense gives -1."""
    t_ref, ref, t, x = (np.asarray(v, float) for v in (t_ref, ref, t, x))
    inside = (t_ref > t[0] + max_lag) & (t_ref < t[-1] - max_lag)
    if inside.sum() < 10:
        raise ValueError("the streams overlap too little to estimate a lag (fewer than 10 samples)")
    t_in, r_in = t_ref[inside], ref[inside]
    lags = np.arange(-max_lag, max_lag + step / 2, step)
    values = np.array([_correlation(r_in, np.interp(t_in, t - lag, x)) for lag in lags])
    k = int(np.argmax(np.abs(values)))
    lag = float(lags[k])
    if 0 < k < len(lags) - 1:
        y0, y1, y2 = np.abs(values[k - 1 : k + 2])
        curvature = y0 - 2 * y1 + y2
        if curvature < 0:
            lag += step * 0.5 * (y0 - y2) / curvature
    return lag, _correlation(r_in, np.interp(t_in, t - lag, x))


def select_gyro_axis(t_ref, yaw_rate, t, gyro) -> dict:
    """The gyro axis (0, 1, 2: x, y, z) whose reading correlates most with the reference's yaw rate, its
    sign, its lag (estimate_lag) and every axis's correlation."""
    gyro = np.asarray(gyro, float)
    fits = [estimate_lag(t_ref, yaw_rate, t, gyro[:, i]) for i in range(gyro.shape[1])]
    axis = int(np.argmax([abs(c) for _, c in fits]))
    lag, corr = fits[axis]
    return {
        "axis": axis,
        "sign": 1 if corr > 0 else -1,
        "lag_s": lag,
        "correlation": abs(corr),
        "axis_correlations": [c for _, c in fits],
    }


def rotate(angle, v) -> np.ndarray:
    """Rotate the (N, 2) vectors ``v`` by ``angle`` (scalar or (N,)) counter-clockwise."""
    c, s = np.cos(angle), np.sin(angle)
    return np.column_stack([c * v[:, 0] - s * v[:, 1], s * v[:, 0] + c * v[:, 1]])


def heading_of(rotation, angle: float) -> np.ndarray:
    """The unwrapped heading (rad) of the axis at ``angle`` in the x-y plane of the frames ``rotation``
    (N, 3, 3; object to world), projected on the world's horizontal plane."""
    c, s = math.cos(angle), math.sin(angle)
    return np.unwrap(
        np.arctan2(
            rotation[:, 1, 0] * c + rotation[:, 1, 1] * s, rotation[:, 0, 0] * c + rotation[:, 0, 1] * s
        )
    )


def _offset_for_angle(angle, rotation, rotation_rate, velocity, speed):
    """Least-squares object-frame offset d (3) of the axle's centre for one angle, and the residual sum:
    the centre's horizontal velocity P' + R' d is zero across the heading and the wheels' ``speed`` along
    it."""
    heading = heading_of(rotation, angle)
    cos, sin = np.cos(heading), np.sin(heading)
    e, n = np.column_stack([cos, sin]), np.column_stack([-sin, cos])
    horizontal = rotation_rate[:, :2, :]
    A = np.vstack([np.einsum("ni,nij->nj", n, horizontal), np.einsum("ni,nij->nj", e, horizontal)])
    b = -np.concatenate([np.sum(n * velocity[:, :2], 1), np.sum(e * velocity[:, :2], 1) - speed])
    normal, right = np.einsum("ki,kj->ij", A, A), np.einsum("ki,k->i", A, b)  # (no threaded BLAS: tall A)
    d = np.linalg.pinv(normal, rcond=1e-10) @ right  # an offset the motion cannot show (vertical): 0
    return d, float(b @ b - 2.0 * d @ right + d @ normal @ d)


def fit_truth_offset(rotation, rotation_rate, velocity, speed) -> dict:
    """The rigid offset of the truth's object frame from the robot's, from samples of the object's
    orientation (N, 3, 3; object to world), its time derivative, its origin's world velocity (N, 2 or 3;
    m/s) and the wheels' mean speed (m/s), all at the same instants.

    Returns ``angle`` (rad: the robot's forward axis in the object's x-y plane; heading_of gives the
    robot's heading), ``offset`` (m: the axle's centre in the object's frame, 3 components: an object whose
    origin sits high on a robot that rocks moves sideways with the rocking) and ``rms_m_s`` (the velocity
    residuals' RMS). The angle is searched over the whole circle (1 degree, then refined), the offset is
    solved linearly for each: no starting guess. The forward axis's sense comes from the wheels' speed, the
    offset along the heading from turning (the centre does not move sideways), across it from the wheels'
    speed while turning, the vertical one from the rocking (unobservable without it: then 0)."""
    rotation, rotation_rate = np.asarray(rotation, float), np.asarray(rotation_rate, float)
    velocity, speed = np.asarray(velocity, float), np.asarray(speed, float)

    def cost(a):
        return _offset_for_angle(a, rotation, rotation_rate, velocity, speed)[1]

    coarse = [cost(a) for a in np.radians(np.arange(360.0))]
    best = math.radians(float(np.argmin(coarse)))
    from scipy.optimize import minimize_scalar

    res = minimize_scalar(
        cost,
        bounds=(best - math.radians(1.0), best + math.radians(1.0)),
        method="bounded",
        options={"xatol": 1e-7},
    )
    angle = math.remainder(float(res.x), 2 * math.pi)
    d, sse = _offset_for_angle(angle, rotation, rotation_rate, velocity, speed)
    return {
        "angle": angle,
        "offset": tuple(float(v) for v in d),
        "rms_m_s": math.sqrt(sse / (2 * len(speed))),
    }


def truth_pose(rotation, position, angle: float, offset) -> tuple[np.ndarray, np.ndarray]:
    """(heading (N,), axle centre (N, 2)) of the robot from the object's orientation (N, 3, 3) and origin
    (N, 3) and the rigid offset (fit_truth_offset)."""
    rotation = np.asarray(rotation, float)
    centre = np.asarray(position, float) + rotation @ np.asarray(offset, float)
    return heading_of(rotation, angle), centre[:, :2]


def vertical_axis(accelerometer) -> tuple[int, int]:
    """(axis, sign) of the accelerometer axis gravity lies along (the largest mean reading's): the
    reading is the specific force, +g along the axis that points up."""
    mean = np.nanmean(np.asarray(accelerometer, float), axis=0)
    axis = int(np.argmax(np.abs(mean)))
    return axis, 1 if mean[axis] > 0 else -1


def horizontal_axes(vertical: int, sign: int) -> tuple[int, int]:
    """The two horizontal axes (i, j) in the order that makes (i, j, up) right-handed."""
    i, j = (vertical + 1) % 3, (vertical + 2) % 3
    return (i, j) if sign > 0 else (j, i)


def fit_accelerometer_rotation(reading, a_t, a_n, yaw_rate, yaw_acceleration) -> dict:
    """The angle (rad, counter-clockwise about up) of the accelerometer's first horizontal axis in the
    robot's frame, from its horizontal readings (N, 2) against the truth's body accelerations a_t, a_n of
    the axle's centre: the reading turned by the angle equals a_t - omega^2 r_x - omega' r_y + b_t,
    a_n + omega' r_x - omega^2 r_y + b_n, with the sensor's lever (r_x, r_y) and biases fitted linearly
    for each angle (0.01 degree over the circle). Returns ``angle``, ``quarter_turns`` (the
    nearest multiple of 90 degrees), ``lever`` (m), ``bias`` (m/s^2) and ``r2`` (the share of the
    readings' variance the fit explains)."""
    reading = np.asarray(reading, float)
    w2, wd = np.asarray(yaw_rate, float) ** 2, np.asarray(yaw_acceleration, float)
    one, zero = np.ones_like(w2), np.zeros_like(w2)
    A = np.vstack([np.column_stack([-w2, -wd, one, zero]), np.column_stack([wd, -w2, zero, one])])
    target = np.concatenate([np.asarray(a_t, float), np.asarray(a_n, float)])
    # The reading turned by the angle is cos * u + sin * v: the residual after the linear fit of lever and
    # biases (projection onto A's complement) is cos * U + sin * V - T.
    u = np.concatenate([reading[:, 0], reading[:, 1]])
    v = np.concatenate([-reading[:, 1], reading[:, 0]])
    pinv = np.linalg.pinv(A)

    def complement(y):
        return y - A @ (pinv @ y)

    U, V, T = complement(u), complement(v), complement(target)
    grid = np.radians(np.arange(0.0, 360.0, 0.01))
    c, s = np.cos(grid), np.sin(grid)
    cost = c * c * (U @ U) + s * s * (V @ V) + T @ T + 2 * c * s * (U @ V) - 2 * c * (U @ T) - 2 * s * (V @ T)
    angle = math.remainder(float(grid[int(np.argmin(cost))]), 2 * math.pi)
    p = pinv @ (math.cos(angle) * u + math.sin(angle) * v - target)
    sse = float(np.min(cost))
    centred = reading - reading.mean(axis=0)
    total = float(np.sum(centred * centred))
    return {
        "angle": angle,
        "quarter_turns": int(round(angle / (math.pi / 2))) % 4,
        "lever": (float(p[0]), float(p[1])),
        "bias": (float(p[2]), float(p[3])),
        "r2": 1.0 - sse / total if total > 0 else math.nan,
    }


def fresh_counts(t, counts, gap_factor: float = 3.0) -> tuple[np.ndarray, np.ndarray, float]:
    """The instants at which a polled counter's reading is new: (times, counts (M, k), median interval).

    A logger that polls a counter faster than the counter's source updates repeats the last reading; a
    reading is fresh where any column differs from the message before (the first message is fresh). Where
    fresh readings are more than ``gap_factor`` median intervals apart (the robot stood), the old reading is
    taken to hold until one median interval before the next one, and the last reading until the last
    message: interpolating between the returned knots then spreads a count over the interval it was
    counted in, not over a standstill."""
    t, counts = np.asarray(t, float), np.asarray(counts, float)
    counts = counts.reshape(len(t), -1)
    fresh = np.r_[True, np.any(np.diff(counts, axis=0) != 0, axis=1)]
    tf, cf = t[fresh], counts[fresh]
    interval = float(np.median(np.diff(tf))) if len(tf) > 2 else float(np.median(np.diff(t)))
    times, values = [tf[:1]], [cf[:1]]
    for k in range(1, len(tf)):
        if tf[k] - tf[k - 1] > gap_factor * interval:
            times.append([tf[k] - interval])
            values.append(cf[k - 1 : k])
        times.append(tf[k : k + 1])
        values.append(cf[k : k + 1])
    if t[-1] > tf[-1]:
        times.append(t[-1:])
        values.append(cf[-1:])
    return np.concatenate(times), np.vstack(values), interval


def longest_hold(t, values) -> float:
    """The longest time (s) over which a stream stamped ``t`` repeats its reading exactly: from the first
    message of a run of equal values to the last (0 when no two consecutive values are equal)."""
    t, values = np.asarray(t, float), np.asarray(values, float)
    longest, start = 0.0, 0
    for k in range(1, len(values)):
        if values[k] != values[k - 1]:
            start = k
        else:
            longest = max(longest, float(t[k] - t[start]))
    return longest


def on_grid(t_grid, t, values, mode: str) -> np.ndarray:
    """``values`` (N,) or (N, k) stamped ``t`` at the instants ``t_grid``: ``interpolate`` (linear between
    the neighbouring samples) or ``hold`` (the latest sample at or before the instant; the first sample
    before it). Outside the samples' span the end values are held."""
    t, values = np.asarray(t, float), np.asarray(values, float)
    if mode == "hold":
        index = np.clip(np.searchsorted(t, t_grid, side="right") - 1, 0, len(t) - 1)
        return values[index]
    if mode != "interpolate":
        raise ValueError(f"resampling {mode!r} is unknown: allowed interpolate, hold")
    if values.ndim == 1:
        return np.interp(t_grid, t, values)
    return np.column_stack([np.interp(t_grid, t, values[:, i]) for i in range(values.shape[1])])
