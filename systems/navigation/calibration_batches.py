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
"""

import math


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
