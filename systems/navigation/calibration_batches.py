"""Which batches the online yaw-rate calibration (systems/navigation/yaw_calibration.py) learns from and
how far it believes them.

A moving batch's residual gyro - omega_o - b_g - D v_o / b carries the gyro's noise over the batch, the
encoders' quantisation and whatever the robot's body adds: its rocking on the castor, the streams'
relative lag at a turn's start and end, a loggers' encoder rate below 1/T_C (one count or none per
batch). The data sheet's measurement_std states the first two; the rest shows only in the residuals.
The calibration therefore takes as a moving batch's measurement variance the larger of measurement_std^2
and what the residuals show beyond the estimate's own uncertainty (Mehra's innovation-based adaptive
estimate): R = max(measurement_std^2, R^), with R^ the running mean of innovation^2 - H P H' over the
learned moving batches. A robot whose residuals are as quiet as its data sheet says keeps R =
measurement_std^2; a noisier one learns b_g and D no faster than its residuals allow, and the covariance P
says so.

A yaw acceleration alpha needs a difference of the wheels' drive forces, I alpha = (F_R - F_L) b / 2, and
the tyres' longitudinal slip gives it: on the linear part of the tyre curve F = (m a_p / 2) B C s per side
(a_p = mu g f_w, B and C Pacejka's), so s_R - s_L = 4 I alpha / (b m a_p B C). The wheels then read the
yaw rate high by (s_R - s_L) v / b: a batch's residual carries - kappa v alpha with

    kappa = 4 I / (b^2 m a_p B C)    (s; Kurt3D 0.0062: 0.05 rad/s at 4 m/s and 2 rad/s^2),

alpha the change of the gyro's batch mean from the previous batch over T_C. The believed tyres are not the
true ones, so the calibration does not take the term out: it counts it in the batch's variance,
R = max(measurement_std^2, R^) + (kappa v alpha)^2 (slip_variance), and Mehra's R^ is what the residuals
show beyond H P H' and that term. A turn's end at speed, where the wheels lead the body by several
measurement_std for a few hundred milliseconds, then neither moves b_g nor raises the bias-change alarm.
"""

import dataclasses as dc
import math

from slipnav.systems.robot.sensors import SensorParameters


def batch_selection(gyro: float, wheels: float, moving: bool, steady: bool, p) -> tuple:
    """(learn, test) of a batch from its mean gyro less b_g and its calibrated odometric yaw rate
    ``wheels``: it is learned from while the gyro says the robot stands or drives straight (within
    straight_yaw_rate), and it tests b_g for a change while the wheels stand still, or say it drives
    straight (within change_yaw_rate) at a ``steady`` yaw rate (steady_yaw_acceleration) while the gyro
    stays within straight_yaw_rate + largest_bias_step."""
    learn = abs(gyro) <= p.straight_yaw_rate
    if not moving:
        return learn, True
    straight = abs(wheels) <= p.change_yaw_rate and steady
    return learn, straight and abs(gyro) <= p.straight_yaw_rate + p.largest_bias_step


def measurement_variance(stated: float, observed: float) -> float:
    """A moving batch's measurement variance R (rad^2/s^2): the ``stated`` one (measurement_std^2) or the
    ``observed`` one (observed_variance_step; 0: none yet), whichever is larger."""
    return max(stated, observed)


def observed_variance_step(observed: float, innovation: float, predicted: float, S: float, gate: float, n):
    """The observed measurement variance of the learned moving batches (rad^2/s^2; 0: none yet) after a
    batch's ``innovation`` (rad/s) whose ``predicted`` part H P H' the estimate's own uncertainty
    explains: the running mean over ``n`` batches of innovation^2 - H P H' (Mehra's estimate of R), fed
    only by innovations within ``gate`` sigmas of the batch's S (H P H' + R with R from
    measurement_variance): an outlier (a slide, a fault the checks missed) does not widen it."""
    if not math.isfinite(innovation) or innovation * innovation > gate * gate * S:
        return observed
    return observed + (innovation * innovation - predicted - observed) / n


def believed_gyro(p, sensors: SensorParameters | None = None):
    """``p`` (YawCalibrationParameters) with the gyro bias's prior and random walk and the gyro's white
    noise that it leaves open (None) taken from the believed gyro's data sheet ``sensors`` (None: the
    nominal SensorParameters())."""
    names = {
        "initial_bias_std": "gyro_initial_bias_std",
        "bias_drift_density": "gyro_drift_density",
        "gyro_noise_std": "gyro_noise_std",
    }
    open_names = [name for name in names if getattr(p, name) is None]
    if not open_names:
        return p
    sensors = sensors or SensorParameters()
    return dc.replace(p, **{name: getattr(sensors, names[name]) for name in open_names})


def tyre_slip_time(robot, mixing, track_width: float) -> float:
    """kappa of the module docstring (s, >= 0): 4 I / (b^2 m a_p B C) from the ``robot``'s yaw inertia I
    (kg m^2) and mass m (kg), the believed tyre curve of ``mixing`` (MixingParameters'
    tyre_peak_acceleration a_p, m/s^2; tyre_stiffness_factor B; tyre_shape_factor C) and the believed
    ``track_width`` b (m); 0 without a robot (None)."""
    if robot is None:
        return 0.0
    stiffness = (
        robot.mass * mixing.tyre_peak_acceleration * mixing.tyre_stiffness_factor * mixing.tyre_shape_factor
    )
    return 4.0 * robot.yaw_inertia / (track_width * track_width * stiffness)


def believed_tyre_slip(p, robot, mixing, track_width: float):
    """``p`` (YawCalibrationParameters) with its yaw_slip_time, if open (None), the believed robot's
    (tyre_slip_time of ``robot``, ``mixing`` and ``track_width``; 0 without a robot)."""
    if p.yaw_slip_time is not None:
        return p
    return dc.replace(p, yaw_slip_time=tyre_slip_time(robot, mixing, track_width))


def slip_variance(slip_time, v: float, yaw_acceleration: float) -> float:
    """(kappa v alpha)^2 (rad^2/s^2) of a batch at the odometric speed ``v`` (m/s) and the gyro's
    ``yaw_acceleration`` alpha (rad/s^2): what the tyres' differential slip may add to its residual; 0
    where alpha is unknown (NaN: no previous batch) or ``slip_time`` kappa (s) is 0 or None."""
    if not slip_time or not math.isfinite(yaw_acceleration):
        return 0.0
    return (slip_time * v * yaw_acceleration) ** 2
