"""What the navigation reads from the online yaw-rate calibration (systems/navigation/yaw_calibration.py):
the calibrated gyro gyro - b_g, the calibrated odometry omega_o + D v_o / b and the share of the
odometric yaw rate in S(14)'s mix from both signals' heading errors.

The calibration learns theta = [b_g, D] from batches where gyro - omega_o = b_g + D v_o / b. At one speed
the batches pin that sum but not its parts (at the TurtleBot's near-constant 0.2 m/s, b_g and D v/b are
not separable); the covariance P of theta says so. Where S(14)'s C3 says the two agree (no slip), the
yaw rate omega = w omega_o + (1 - w) omega_g integrates into the heading; over a horizon T each calibrated
signal accumulates the heading error

    gyro:   E_g = (b_g - b_g^) T + sum of its white noise,  Var E_g = P_bb T^2 + sigma_g^2 T_N T
    wheels: E_o = (D^ - D) (v_o / b) T,                     Var E_o = h^2 P_DD T^2,  h = v_o / b

with Cov(E_g, E_o) = -h P_bD T^2 (sigma_g: the believed gyro's white noise per T_N sample, rad/s). The
wheels' quantisation telescopes: their heading is off by at most one count per wheel whatever T (Tinyphoon
2.3e-4 rad, the TurtleBot 1.2e-4 rad), not counted. w E_o + (1 - w) E_g has the least variance at

    w* = (P_bb + h P_bD + W) / (h P h' + W),  h = [1, v_o / b],  W = sigma_g^2 T_N / T.

The horizon T is the calibration's memory of b_g, T = P_bb / q_b^2 (q_b: the believed bias random walk,
bias_drift_density): the time in which the bias's walk adds the variance the estimate has. Over it the
calibration's errors stay what they are (D's, with no random walk, at least as long); beyond it the
batches renew b_g, and both signals' heading errors grow like random walks, in the same ratio. So
W = sigma_g^2 T_N q_b^2 / P_bb (0 for a bias without random walk). W matters where b_g is known to better
than its walk over the white noise's averaging: Tinyphoon (sigma_g 0.014 rad/s at T_N 2 ms, q_b 5e-4)
after a standstill, sqrt(P_bb) ~ 1e-3 rad/s and T ~ 4 s, W ~ 1e-7 (rad/s)^2, a tenth of P_bb.
w* = 1 where the calibration knows D v/b at least as well as b_g, e.g. a turn on the spot (v_o = 0) or
a robot whose speed changes separated the two; w* ~ 0 where it knows b_g much better than D v/b. Mixed as
C3 w*: the odometric yaw rate wins over the gyro only where its heading error is the smaller one.
"""

import math


def calibrated_gyro(gyro: float, theta, p) -> float:
    """gyro - b_g; the raw gyro when calibration is off (``p``: YawCalibrationParameters)."""
    return gyro - theta[0] if p.enabled else gyro


def calibrated_odometry(odo, theta, track_width: float, p) -> list:
    """[v_o, omega, v_R, v_L] with omega = omega_o + D v_o / b and the wheel speeds v_o +- omega b/2 that
    give it; the raw odometry when calibration is off (``p``: YawCalibrationParameters)."""
    if not p.enabled:
        return list(odo)
    v = odo[0]
    omega = odo[1] + theta[1] * v / track_width
    half = 0.5 * track_width
    return [v, omega, v + omega * half, v - omega * half]


def gyro_white_variance(p_bb: float, p, T_N: float) -> float:
    """W of the module docstring ((rad/s)^2, >= 0): the gyro's white noise sigma_g (``p.gyro_noise_std``,
    rad/s per sample of ``T_N`` s) averaged over the horizon T = P_bb / q_b^2 (``p.bias_drift_density``,
    rad/s per sqrt(s)), sigma_g^2 T_N q_b^2 / P_bb; 0 without white noise or bias random walk, inf while
    P_bb (``p_bb``, (rad/s)^2) is 0 (``p``: YawCalibrationParameters with the believed gyro's figures,
    yaw_calibration.believed_gyro)."""
    density = p.gyro_noise_std**2 * T_N * p.bias_drift_density**2
    if density == 0.0:
        return 0.0
    return density / p_bb if p_bb > 0.0 else math.inf


def odometric_yaw_share(covariance, v: float, track_width: float, p, T_N: float) -> float:
    """w* of the module docstring in [0, 1]: the odometric yaw rate's share where S(14) says gyro and wheels
    agree, from the calibration's ``covariance`` of [b_g, D] (row-major, 4 values; rad^2/s^2, rad/s,
    1), the odometric speed ``v`` (m/s) and the gyro's white noise over the horizon (gyro_white_variance,
    samples of ``T_N`` s); 1 when calibration is off (``p``: YawCalibrationParameters with the believed
    gyro's figures; the paper's S(14)), at v = 0, while the white noise's share W is unbounded, or while
    h P h' + W vanishes (the two errors are one)."""
    if not p.enabled:
        return 1.0
    h = v / track_width
    p_bb, p_bd, p_dd = covariance[0], covariance[1], covariance[3]
    white = gyro_white_variance(p_bb, p, T_N)
    if math.isinf(white):
        return 1.0
    gyro_part = p_bb + h * p_bd + white
    difference = gyro_part + h * (p_bd + h * p_dd)
    if not difference > 1e-6 * (p_bb + white):
        return 1.0
    return min(max(gyro_part / difference, 0.0), 1.0)
