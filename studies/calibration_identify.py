"""The calibration's identifications (studies/calibration.py), one per group of parameters: the
standstill's biases and noise, the gyro's scale, the geometry (rolling radii, track width), the
accelerometers' scale errors and misalignments, the tyres' peak acceleration and the shoes' drag."""

from __future__ import annotations

import math

import numpy as np
from slipnav.scenarios.config import ScenarioError
from slipnav.studies.calibration_manoeuvres import HEADING_STD, STANDSTILL_PREFIX, Manoeuvre
from slipnav.studies.calibration_signals import (
    accelerometer_predictions,
    allan_deviation,
    bias_line,
    block_means,
    body_kinematics,
    coast_position,
    correct_accelerometers,
    creep_speeds,
    dead_reckoning_end,
    fit_least_squares,
    shoe_forces_per_mass,
    smooth,
    standstill_biases,
    wheel_increments,
)

PEAK_WINDOW = 0.5
"""s: a_peak is the largest mean of the tyres' force over this window (identify_peak_acceleration). The
force near the friction limit stays within ~0.6 % of its peak for over a second, while the commotion's
means over 0.1 s scatter by 0.1 m/s^2 (Kurt3D at 2.5 m/s): the largest of many short means read up to
+15 % (Kurt3D draw 3), the 0.5 s means within +-1.6 %."""


def identify_standstill(m: Manoeuvre, T_N: float) -> dict:
    """Biases, white noise and the gyro's Allan deviation from the standstill log."""
    data = np.column_stack([m.log.gyro, m.log.accelerometers])
    mean = np.nanmean(data, axis=0)
    std = np.nanstd(data, axis=0)
    taus, adev = allan_deviation(m.log.gyro, T_N)
    # Standard error of a mean over the record: the Allan deviation at the longest tau bounds the drift.
    se = np.maximum(std / math.sqrt(len(data)), 0.0)
    return {
        "gyro_bias": mean[0],
        "gyro_bias_se": se[0],
        "accel_bias": mean[1:],
        "accel_bias_se": se[1:],
        "gyro_noise_std": std[0],
        "accel_noise_std": std[1:],
        "gyro_white_noise_std": float(adev[0]),
        "allan_tau": taus,
        "allan_deviation": adev,
    }


def _turn_data(m: Manoeuvre, T_N: float):
    """(integrated de-biased gyro, its standard deviation, duration) of a manoeuvre after its prefix."""
    n = int(round(STANDSTILL_PREFIX / T_N))
    bias, bias_se = standstill_biases(m.log, STANDSTILL_PREFIX, T_N)
    g = m.log.gyro[n:]
    duration = len(g) * T_N
    integral = float(np.nansum(g - bias[0]) * T_N)
    return integral, float(bias_se[0] * duration), duration


def identify_gyro_scale(manoeuvres: list[Manoeuvre], T_N: float, noise_std: float) -> tuple[float, float]:
    """Gyro scale error s from the spot turns: integral of (gyro - bias) = (1 + s) * measured turn."""
    rows = []
    for m in manoeuvres:
        if m.kind != "spot_turn":
            continue
        integral, bias_part, duration = _turn_data(m, T_N)
        sigma = math.sqrt(HEADING_STD**2 + bias_part**2 + noise_std**2 * T_N * duration)
        rows.append((integral, m.measured_pose[2], sigma))
    data = np.array(rows)

    def residuals(p):
        return (data[:, 0] - (1.0 + p[0]) * data[:, 1]) / data[:, 2]

    x, se, _ = fit_least_squares(residuals, [0.0])
    return float(x[0]), float(se[0])


def identify_geometry(manoeuvres: list[Manoeuvre], robot, counts_per_revolution: int, T_N: float):
    """(r_R, r_L, b), their standard errors and chi^2/dof, by least squares of the dead-reckoned final
    poses of the straight runs and UMBmark squares (x, y, phi) and the spot turns (phi) against the
    hand-measured ones. The tyres' creep (creep_speeds) is computed with the nominal geometry, then
    again with the first fit's, and held fixed in each fit."""
    step = 2.0 * math.pi / counts_per_revolution
    r0, b0 = robot.wheel_radius, robot.track_width
    used = [m for m in manoeuvres if m.kind in ("spot_turn", "straight", "square")]
    increments = [wheel_increments(m.log.encoder_counts, step) for m in used]
    geometry = (r0, r0, b0)
    for _ in range(2):
        slips = [creep_speeds(d, *geometry, robot, T_N) for d in increments]

        def residuals(p, slips=slips):
            r_R, r_L, b = r0 * (1 + p[0]), r0 * (1 + p[1]), b0 * (1 + p[2])
            out = []
            for m, d, slip in zip(used, increments, slips, strict=True):
                end = dead_reckoning_end(d, slip, r_R, r_L, b, T_N)
                sp, sh = m.pose_std
                if m.kind != "spot_turn":
                    out += [(end[0] - m.measured_pose[0]) / sp, (end[1] - m.measured_pose[1]) / sp]
                out.append((end[2] - m.measured_pose[2]) / sh)
            return np.array(out)

        x, se, chi2 = fit_least_squares(residuals, [0.0, 0.0, 0.0])
        geometry = (r0 * (1 + x[0]), r0 * (1 + x[1]), b0 * (1 + x[2]))
    errors = np.array([r0 * se[0], r0 * se[1], b0 * se[2]])
    return np.array(geometry), errors, chi2


def identify_peak_acceleration(
    m: Manoeuvre,
    T_N: float,
    robot,
    geometry,
    gyro_scale: float,
    counts_per_revolution: int,
    window=PEAK_WINDOW,
    accel=None,
):
    """a_peak: the largest mean over ``window`` s of the tyres' force per unit mass on the friction
    circle, |m a - F_shoes| / m: a the de-biased mean of the two accelerometers (free of the rotational
    terms; each component averaged over 0.02 s first, so that the commotion does not add to the modulus),
    the shoes' force (nominal shoes) at the body velocity from odometry (v_t), gyro (omega) and v_n
    integrated from dv_n/dt = a_n - v_t omega. This is the quantity the navigation compares with a_peak
    (mixing.combined_slip). ``accel``: the identified (s1, gamma1, s2, gamma2) that correct_accelerometers
    takes off the readings (None: taken as perfect). Returns (a_peak, its standard error from the
    samples' scatter in the window)."""
    bias, _ = standstill_biases(m.log, STANDSTILL_PREFIX, T_N)
    start = int(round(STANDSTILL_PREFIX / T_N))
    acc = (m.log.accelerometers - bias[1:])[start:]
    if accel is not None:
        acc = correct_accelerometers(acc, accel)
    a_t, a_n = 0.5 * (acc[:, 0] + acc[:, 2]), 0.5 * (acc[:, 1] + acc[:, 3])
    omega = np.nan_to_num((m.log.gyro[start:] - bias[0]) / (1.0 + gyro_scale))
    counts = m.log.encoder_counts[start - 1 :] * (2.0 * math.pi / counts_per_revolution)
    d = np.diff(counts, axis=0)
    v_t = 0.5 * (geometry[0] * d[:, 0] + geometry[1] * d[:, 1]) / T_N
    short = max(int(round(0.02 / T_N)), 1)
    v_t = smooth(np.nan_to_num(v_t), short)
    v_n = np.cumsum(np.nan_to_num(a_n) - v_t * omega) * T_N
    shoe_x, shoe_y = shoe_forces_per_mass(v_t, v_n, omega, robot)
    f_x = smooth(np.nan_to_num(a_t - shoe_x), short)
    f_y = smooth(np.nan_to_num(a_n - shoe_y), short)
    force = np.hypot(f_x, f_y)
    n = max(int(round(window / T_N)), 1)
    mean = smooth(force, n)
    k = int(np.argmax(mean))
    lo, hi = max(k - n // 2, 0), min(k + n // 2 + 1, len(force))
    spread = float(np.std(force[lo:hi]))
    return float(mean[k]), spread / math.sqrt(max((hi - lo) / short, 1.0))


ACCEL_KINDS = ("spin",)
"""Manoeuvres that scale the accelerometers: steady spins, whose centripetal omega^2 p the gyro gives
exactly. Not the gyro's slower spot turns (0.25 m/s^2 over 6 s: the biases' drift counts 4 x as much).
Not the straights' launches: the simulated accelerometers sample the body's acceleration at the
instants of the 1 kHz speed loop's voltage steps (no anti-aliasing filter), a sawtooth of the T_C command
steps whose samples read ~5 % below its mean; nor the spirals, which slide sideways unseen by the
encoders."""


ACCEL_STEADY = 0.5
"""rad/s^2: only blocks whose yaw acceleration |omega_dot| stays below this (steady spin) and whose yaw rate
reaches half the run's largest are fitted."""


ACCEL_WINDOW = 0.05
"""s: the accelerometers and their predictions are compared as means over blocks of this length."""


def identify_accelerometers(manoeuvres, T_N: float, robot, geometry, gyro_scale: float, counts, position):
    """Each accelerometer's scale error s and misalignment gamma: its de-biased reading z' = t' + i n'
    against the prediction z = t + i n from the encoders and the gyro (body_kinematics,
    accelerometer_predictions; nominal mounting position), z' = (1 + s) exp(-i gamma) z
    (systems.robot.sensors.sensor_frame), by least squares over the ACCEL_WINDOW block means of each steady
    spin segment of the ACCEL_KINDS runs (a segment: the blocks between two pauses). The biases' drift between
    the pauses (piecewise linear, bias_line) errs by the same amount over a whole segment, so each segment is
    fitted on its own and the estimate is the segments' mean, its standard error their scatter / sqrt(count).

    Returns ((s1, gamma1, s2, gamma2), their standard errors, the segments' estimates (K, 4))."""
    n = max(int(round(ACCEL_WINDOW / T_N)), 1)
    skip = int(round(STANDSTILL_PREFIX / T_N))
    segments = []
    for m in manoeuvres:
        if m.kind not in ACCEL_KINDS:
            continue
        kin = body_kinematics(m, T_N, robot, geometry, gyro_scale, counts)
        predicted = accelerometer_predictions(kin, position)
        read = m.log.accelerometers - bias_line(m.log, T_N, slice(1, 5))
        predicted, read = block_means(predicted[skip:], n), block_means(read[skip:], n)
        omega, omega_dot = block_means(kin[skip:, 1], n), np.abs(block_means(kin[skip:, 4], n))
        good = np.all(np.isfinite(predicted), axis=1) & np.all(np.isfinite(read), axis=1)
        good &= (omega_dot < ACCEL_STEADY) & (np.abs(omega) > 0.5 * np.nanmax(np.abs(omega)))
        edges = np.flatnonzero(np.diff(np.concatenate([[0], good.astype(int), [0]])))
        for a, b in zip(edges[::2], edges[1::2], strict=True):
            if b - a >= 4:
                segments.append((predicted[a:b], read[a:b]))
    if len(segments) < 2:
        raise ScenarioError("calibration needs at least two steady spin segments for the accelerometers")
    estimates = np.empty((len(segments), 4))
    for j, (p, r) in enumerate(segments):
        for i in range(2):
            z, zr = p[:, 2 * i] + 1j * p[:, 2 * i + 1], r[:, 2 * i] + 1j * r[:, 2 * i + 1]

            def residuals(q, z=z, zr=zr):
                e = zr - (1.0 + q[0]) * np.exp(-1j * q[1]) * z
                return np.concatenate([e.real, e.imag])

            x, _, _ = fit_least_squares(residuals, [0.0, 0.0])
            estimates[j, 2 * i : 2 * i + 2] = x
    values = estimates.mean(axis=0)
    errors = estimates.std(axis=0, ddof=1) / math.sqrt(len(segments))
    return values, errors, estimates


COAST_MIN_SPEED = 0.1
"""m/s: the coasting fit stops here (below, the shoes' regularised Coulomb friction and the encoders'
resolution)."""


COAST_SETTLE = 0.1
"""s after the switch-off left out of the coasting fit (the tyres' push relaxes)."""


def identify_drag(manoeuvres, T_N: float, robot, geometry, counts_per_revolution: int):
    """The drag per unit mass the tyres push against (MixingParameters: drag_acceleration + drag_per_speed
    |v|) from the coasting runs: with the motors off the robot rolls out on its shoes, m_eff dv/dt =
    -(m (d_0 + d_1 v) + 2 b_w v / r^2), m_eff = m + 2 J / r^2: the wheels' inertia J and bearing drag
    b_w (the nominal robot's, data sheet) are taken off. The distance rolled (the encoders' mean ground
    position with the identified radii, COAST_SETTLE after the switch-off until COAST_MIN_SPEED) is fitted
    by coast_position with one (A, B) for all runs and each run's start position and speed, weighted by the
    encoders' quantisation; d_0 = A m_eff / m, d_1 = (B m_eff - 2 b_w / r^2) / m.

    Returns ((d_0, d_1), their standard errors, chi^2/dof)."""
    r_R, r_L, _ = geometry
    step = 2.0 * math.pi / counts_per_revolution
    runs = []
    for m in manoeuvres:
        if m.kind != "coast" or m.motors_off is None:
            continue
        counts = m.log.encoder_counts.astype(float) * step
        s = 0.5 * (r_R * counts[:, 0] + r_L * counts[:, 1])
        t = np.arange(len(s)) * T_N
        v = np.gradient(smooth(s, max(int(round(0.02 / T_N)), 1)), T_N)
        start, end = m.motors_off[0] + COAST_SETTLE, m.motors_off[1]
        window = (t >= start) & (t < end) & np.isfinite(s)
        stop = np.flatnonzero(window & (np.abs(v) < COAST_MIN_SPEED))
        if len(stop):
            window &= t < t[stop[0]]
        if window.sum() < 20:
            continue
        k0 = int(np.flatnonzero(window)[0])
        sign = math.copysign(1.0, v[k0])
        runs.append((t[window] - t[k0], sign * (s[window] - s[k0]), float(abs(v[k0]))))
    if not runs:
        raise ScenarioError("calibration needs a coasting run that rolls out above 0.1 m/s: none found")
    sigma = 0.5 * (r_R + r_L) * step / math.sqrt(12.0)

    def residuals(p):
        A, B = p[0], p[1]
        out = []
        for j, (t, s, _) in enumerate(runs):
            out.append((s - p[2 + 2 * j] - coast_position(t, p[3 + 2 * j], A, B)) / sigma)
        return np.concatenate(out)

    x0 = [0.5, 0.3]
    for _, _, v0 in runs:
        x0 += [0.0, v0]
    x, se, chi2 = fit_least_squares(residuals, x0)
    r = robot.wheel_radius
    m_eff = robot.mass + 2.0 * robot.wheel_inertia / r**2
    d0 = x[0] * m_eff / robot.mass
    d1 = (x[1] * m_eff - 2.0 * robot.bearing_drag / r**2) / robot.mass
    se = se[:2]
    if len(runs) > 1:  # the quantisation alone understates it: at least the runs' scatter
        single = [
            fit_least_squares(
                lambda p, t=t, s=s: (s - p[2] - coast_position(t, p[3], p[0], p[1])) / sigma,
                [x[0], x[1], 0.0, v0],
            )[0][:2]
            for t, s, v0 in runs
        ]
        se = np.maximum(se, np.std(single, axis=0, ddof=1) / math.sqrt(len(runs)))
    return np.array([d0, d1]), np.asarray(se) * m_eff / robot.mass, chi2
