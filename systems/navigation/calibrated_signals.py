"""What the navigation reads from the online yaw-rate calibration (systems/navigation/yaw_calibration.py):
the calibrated gyro gyro - b_g, the calibrated odometry omega_o + D v_o / b and the share of the
odometric yaw rate in S(14)'s mix that the calibration's covariance gives.

The calibration learns theta = [b_g, D] from batches where gyro - omega_o = b_g + D v_o / b. At one speed
the batches pin that sum but not its parts (at the TurtleBot's near-constant 0.2 m/s, b_g and D v/b are
not separable); the covariance P of theta says so. The calibrated signals' slowly varying errors are
e_g = b_g - b_g^ (the gyro) and e_o = (D^ - D) v_o / b (the odometry). Where S(14)'s C3 says the two agree
(no slip), omega = w omega_o + (1 - w) omega_g has the error w e_o + (1 - w) e_g, whose variance under P
is smallest at

    w* = h_g P h' / (h P h'),  h = [1, v_o / b],  h_g = [1, 0]

(h P h' the variance of the difference e_g - e_o, the part the batches measure; h_g P h' the covariance
of e_g with it). w* = 1 where the calibration knows D v/b at least as well as b_g, e.g. a turn on the
spot (v_o = 0) or a robot whose speed changes separated the two; w* ~ 0 where it knows b_g better than
D v/b. Mixed as C3 w*: the odometric yaw rate wins over the gyro only where its predicted error is the
smaller one.
"""


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


def odometric_yaw_share(covariance, v: float, track_width: float, p) -> float:
    """w* of the module docstring in [0, 1]: the odometric yaw rate's share where S(14) says gyro and wheels
    agree, from the calibration's ``covariance`` of [b_g, D] (row-major, 4 values; rad^2/s^2, rad/s,
    1) and the odometric speed ``v`` (m/s); 1 when calibration is off (``p``: YawCalibrationParameters;
    the paper's S(14)) or while h P h' vanishes (the two errors are one)."""
    if not p.enabled:
        return 1.0
    h = v / track_width
    p_bb, p_bd, p_dd = covariance[0], covariance[1], covariance[3]
    gyro_part = p_bb + h * p_bd
    difference = gyro_part + h * (p_bd + h * p_dd)
    if not difference > 1e-6 * p_bb:
        return 1.0
    return min(max(gyro_part / difference, 0.0), 1.0)
