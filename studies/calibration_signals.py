"""What the calibration's identifications read off the logs: biases and still segments, smoothed and
dead-reckoned wheel speeds with the tyres' creep, the body's kinematics, the accelerometers' predictions
and corrections, the coasting position; and the least-squares fit with its standard errors."""

from __future__ import annotations

import math

import numpy as np
from slipnav.scenarios.model import SensorCalibration
from slipnav.scenarios.sensor_log import SensorLog
from slipnav.studies.calibration_manoeuvres import STANDSTILL_PREFIX, Manoeuvre
from slipnav.systems.navigation.sensor_correction import corrected_accelerometers


def fit_least_squares(residuals, x0, **kwargs):
    """least_squares and the standard errors of its solution ((J^T J)^-1 scaled by max(1, chi^2/dof))."""
    from scipy.optimize import least_squares  # scipy.optimize's import time only where a fit runs

    result = least_squares(residuals, x0, method="lm", x_scale="jac", **kwargs)
    J = result.jac
    dof = max(len(result.fun) - len(x0), 1)
    chi2 = float(result.fun @ result.fun)
    cov = np.linalg.inv(J.T @ J) * max(1.0, chi2 / dof)
    return result.x, np.sqrt(np.diag(cov)), chi2 / dof


def allan_deviation(samples: np.ndarray, T_N: float, taus: int = 12) -> tuple[np.ndarray, np.ndarray]:
    """Overlapping Allan deviation at tau = 2^j T_N (j = 0 .. while 2 tau fits 9 times in the record)."""
    x = np.cumsum(np.asarray(samples, float)) * T_N
    x = np.concatenate([[0.0], x])
    out_tau, out_dev = [], []
    for j in range(taus):
        m = 2**j
        if 2 * m * 9 > len(samples):
            break
        d = x[2 * m :] - 2.0 * x[m:-m] + x[: -2 * m]
        tau = m * T_N
        out_tau.append(tau)
        out_dev.append(math.sqrt(np.mean(d * d) / (2.0 * tau * tau)))
    return np.array(out_tau), np.array(out_dev)


def standstill_biases(log: SensorLog, seconds: float, T_N: float) -> tuple[np.ndarray, np.ndarray]:
    """Mean and its standard error of [gyro, a_t1, a_n1, a_t2, a_n2] over the first ``seconds``."""
    n = int(round(seconds / T_N))
    data = np.column_stack([log.gyro[:n], log.accelerometers[:n]])
    return np.nanmean(data, axis=0), np.nanstd(data, axis=0) / math.sqrt(n)


def smooth(x: np.ndarray, n: int) -> np.ndarray:
    return np.convolve(x, np.ones(n) / n, mode="same") if n > 1 else x


def wheel_increments(counts: np.ndarray, step: float) -> np.ndarray:
    """(K, 2) wheel-angle increments of the valid rows (a missing row is spanned by the next valid one)."""
    good = np.all(np.isfinite(counts), axis=1)
    return np.diff(counts[good] * step, axis=0)


def creep_speeds(d: np.ndarray, r_R: float, r_L: float, b: float, robot, T_N: float) -> np.ndarray:
    """(K, 2) slip speeds r theta_dot - v of the right and left tyre (m/s) that the nominal robot's tyres
    need to push it along the wheel motion ``d`` (angle increments): the body's inertia plus the felt
    shoes' drag and yaw moment (systems.robot.contact.shoe_force with the nominal shoes), each wheel's force
    through the inverse of the nominal tyre curve (mixing.tyre_slip) at the slip's reference speed
    max(|v|, slip_speed_floor). Rubber tyres creep ahead of the body whenever they push: ~0.7 % of the
    distance at cruise for Tinyphoon's shoes, which a calibration that ignored it would put into the
    radii. The nominal robot is the belief (data sheet), never the plant."""
    p = robot
    n = max(int(round(0.02 / T_N)), 1)
    v_R, v_L = smooth(r_R * d[:, 0] / T_N, n), smooth(r_L * d[:, 1] / T_N, n)
    v, omega = 0.5 * (v_R + v_L), (v_R - v_L) / b
    a_t, omega_dot = np.gradient(v, T_N), np.gradient(omega, T_N)
    force_x = p.mass * a_t
    moment = p.yaw_inertia * omega_dot
    n_shoe = p.shoe_normal_load
    for x_shoe in (p.shoe_offset, -p.shoe_offset):
        u_x, u_y = v, omega * x_shoe
        speed = np.hypot(u_x, u_y)
        with np.errstate(invalid="ignore", divide="ignore"):
            coulomb = np.where(
                speed > 1e-12, p.shoe_friction * n_shoe * np.tanh(speed / p.shoe_slip_speed) / speed, 0.0
            )
        scale = coulomb + p.shoe_viscous_drag
        force_x = force_x + scale * u_x  # the tyres push against the shoes' drag ...
        moment = moment + x_shoe * scale * u_y  # ... and turn against their yaw moment
    peak = p.tyre_friction * p.wheel_normal_load
    out = np.empty((len(v), 2))
    for i, (force, speed) in enumerate(
        ((0.5 * force_x + moment / b, v_R), (0.5 * force_x - moment / b, v_L))
    ):
        u = np.clip(np.abs(force) / peak, 0.0, 0.999)
        sigma = np.tan(np.arcsin(u) / p.tyre_shape_factor) / p.tyre_stiffness_factor
        out[:, i] = np.sign(force) * sigma * np.maximum(np.abs(speed), p.slip_speed_floor)
    return out


def dead_reckoning_end(d: np.ndarray, slip: np.ndarray, r_R: float, r_L: float, b: float, T_N: float):
    """Final (x, y, phi) of the dead reckoning (midpoint heading) from the start pose 0: each wheel's
    ground increment r dtheta minus its creep speed times T_N."""
    dR = r_R * d[:, 0] - slip[:, 0] * T_N
    dL = r_L * d[:, 1] - slip[:, 1] * T_N
    ds, dphi = 0.5 * (dR + dL), (dR - dL) / b
    phi = np.concatenate([[0.0], np.cumsum(dphi)])
    mid = phi[:-1] + 0.5 * dphi
    return np.array([np.sum(ds * np.cos(mid)), np.sum(ds * np.sin(mid)), phi[-1]])


def shoe_forces_per_mass(v_t, v_n, omega, robot) -> tuple[np.ndarray, np.ndarray]:
    """The nominal felt shoes' force per unit mass on the body (x, y) at body velocities (arrays), as
    systems.robot.contact.shoe_force (tanh-regularised Coulomb plus viscous, at +- shoe_offset)."""
    p = robot
    fx, fy = np.zeros_like(v_t), np.zeros_like(v_t)
    for x_shoe in (p.shoe_offset, -p.shoe_offset):
        u_x, u_y = v_t, v_n + omega * x_shoe
        speed = np.hypot(u_x, u_y)
        with np.errstate(invalid="ignore", divide="ignore"):
            coulomb = np.where(
                speed > 1e-12,
                p.shoe_friction * p.shoe_normal_load * np.tanh(speed / p.shoe_slip_speed) / speed,
                0.0,
            )
        fx -= (coulomb + p.shoe_viscous_drag) * u_x
        fy -= (coulomb + p.shoe_viscous_drag) * u_y
    return fx / p.mass, fy / p.mass


def block_means(x: np.ndarray, n: int) -> np.ndarray:
    """Means of consecutive non-overlapping blocks of n rows (the last incomplete block dropped)."""
    k = len(x) // n
    return x[: k * n].reshape(k, n, *x.shape[1:]).mean(axis=1)


def still_segments(log: SensorLog, T_N: float, margin: float = 0.1, shortest: float = 0.2) -> list:
    """(start, end) row ranges where the robot stands still: neither encoder moves by more than 2 counts
    (a wheel resting on a count's edge flickers) from ``margin`` s before to ``margin`` s after, at least
    ``shortest`` s long."""
    counts = np.asarray(log.encoder_counts, float)
    m = int(round(margin / T_N))
    still = np.zeros(len(counts), bool)
    if len(counts) > 2 * m:
        span = np.abs(counts[2 * m :] - counts[: -2 * m])
        still[m:-m] = np.all(span <= 2.0, axis=1)
    edges = np.flatnonzero(np.diff(np.concatenate([[0], still.astype(int), [0]])))
    return [(a, b) for a, b in zip(edges[::2], edges[1::2], strict=True) if b - a >= shortest / T_N]


def bias_line(log: SensorLog, T_N: float, columns: slice) -> np.ndarray:
    """(N, c) bias of the given gyro/accelerometer columns ([gyro, a_t1, a_n1, a_t2, a_n2]) at every row:
    the means of the still segments (still_segments) at their centres, linear in between, flat outside."""
    data = np.column_stack([log.gyro, log.accelerometers])[:, columns]
    segments = still_segments(log, T_N)
    if not segments:
        n0 = int(round(STANDSTILL_PREFIX / T_N))
        segments = [(0, n0)]
    centres = np.array([0.5 * (a + b - 1) for a, b in segments])
    means = np.array([np.nanmean(data[a:b], axis=0) for a, b in segments])
    rows = np.arange(len(data))
    return np.column_stack([np.interp(rows, centres, means[:, j]) for j in range(data.shape[1])])


def body_kinematics(m: Manoeuvre, T_N: float, robot, geometry, gyro_scale: float, counts_per_revolution: int):
    """Per-row (v_t, omega, a_t, a_n, omega_dot) of the body from the encoders (each wheel's ground
    position r theta minus its creep, creep_speeds with the identified geometry), the gyro (de-biased with
    bias_line, divided by 1 + the identified scale error): a_t = dv_t/dt, a_n = v_t omega (v_n ~ 0 on the
    tyres' own path), omega_dot = d omega/dt. Rows with a missing sample are NaN."""
    r_R, r_L, b = geometry
    step = 2.0 * math.pi / counts_per_revolution
    counts = m.log.encoder_counts.astype(float) * step
    good = np.all(np.isfinite(counts), axis=1)
    d = np.diff(counts, axis=0)
    d[~np.isfinite(d)] = 0.0
    slip = creep_speeds(d, r_R, r_L, b, robot, T_N)
    ground = np.column_stack([r_R * d[:, 0], r_L * d[:, 1]]) - slip * T_N
    v_half = 0.5 * (ground[:, 0] + ground[:, 1]) / T_N  # at t_k - T_N / 2
    v_t = 0.5 * (np.concatenate([[v_half[0]], v_half]) + np.concatenate([v_half, [v_half[-1]]]))
    n = max(int(round(0.01 / T_N)), 1)
    a_t = np.gradient(smooth(v_t, n), T_N)
    omega = (m.log.gyro - bias_line(m.log, T_N, slice(0, 1))[:, 0]) / (1.0 + gyro_scale)
    omega_dot = np.gradient(smooth(np.nan_to_num(omega), n), T_N)
    out = np.column_stack([v_t, omega, a_t, v_t * omega, omega_dot])
    out[~good] = np.nan
    return out


def accelerometer_predictions(kinematics: np.ndarray, position) -> np.ndarray:
    """(N, 4) true readings [t1, n1, t2, n2] at body kinematics rows (v_t, omega, a_t, a_n, omega_dot), as
    systems.robot.sensors.accelerometer_truth with the nominal mounting position (x, y) of accelerometer 1."""
    _, omega, a_t, a_n, omega_dot = kinematics.T
    px, py = position
    w2 = omega * omega
    dt, dn = -omega_dot * py - w2 * px, omega_dot * px - w2 * py
    return np.column_stack([a_t + dt, a_n + dn, a_t - dt, a_n - dn])


def correct_accelerometers(acc: np.ndarray, values) -> np.ndarray:
    """De-biased readings [t1, n1, t2, n2] (rows) back to the body axes, z = z' exp(i gamma) / (1 + s):
    the navigation's own correction (systems.navigation.sensor_correction.corrected_accelerometers) on each
    row; ``values``: (s1, gamma1, s2, gamma2)."""
    s1, gamma1, s2, gamma2 = values
    calibration = SensorCalibration(
        accel1_scale_error=s1, accel1_misalignment=gamma1, accel2_scale_error=s2, accel2_misalignment=gamma2
    )
    rows = [corrected_accelerometers(calibration, row) for row in np.asarray(acc, float)]
    return np.array(rows, float).reshape(np.shape(acc))


def coast_position(t: np.ndarray, v0: float, A: float, B: float) -> np.ndarray:
    """Distance rolled in t from speed v0 under dv/dt = -(A + B v): (v0 + A/B)(1 - e^-Bt)/B - A t/B."""
    if abs(B) < 1e-9:
        return v0 * t - 0.5 * A * t * t
    return (v0 + A / B) * (-np.expm1(-B * t)) / B - A / B * t
