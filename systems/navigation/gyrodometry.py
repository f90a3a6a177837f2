"""Gyrodometry (Indiveri, Nüchter & Lingemann §IV-B, Algorithm 1; after Solda et al. and Borenstein):
heading from the gyro while the odometry reports a rotation or the gyro disagrees, otherwise from the
odometry while the gyro drift e is learned; position by dead reckoning of the odometric speed.

Algorithm 1 tests the odometric rotation of each sample against c1. At 2 ms one encoder count between
the wheels is a yaw rate of 0.11 rad/s (Tinyphoon) or 0.15 rad/s (Kurt3D), above c1, so on single
samples driving straight looks like turning on every other sample: the gyro has the heading nearly always
and its drift is never learned. The test therefore reads the odometric rate's PT1 (rate_time_constant);
the increments themselves are still the sample's."""

import dataclasses as dc
import math

from slipnav.systems.ranges import require_in
from slipnav.systems.rates import pt1_step


@dc.dataclass
class GyrodometryParameters:
    """Thresholds of Algorithm 1, expressed as rates (multiplied by T_N to compare per-sample increments).

    Args:
        c1: |odometric yaw rate| above which the gyro is used (rad/s): 0.05 rad/s, above the odometric
            noise of a robot driving straight.
        c2: |gyro rate - drift| above which the gyro is used (rad/s): 0.1 rad/s, ~7 gyro noise sigmas /
            sqrt(N) is not needed at 2 ms, so a conservative multiple of the bias.
        drift_rate: lambda of the drift learning e <- lambda e + (1 - lambda)(d_gyro - d_odo); 0.999 per
            T_N averages over ~2 s.
        rate_time_constant: PT1 of the odometric yaw rate that the c1 test reads (s): 0.05, which filters
            the quantisation to < 0.01 rad/s (one count x T_N / tau) and keeps the turns' onsets within a
            few samples; 0: the sample's rate, as in Algorithm 1.
    """

    c1: float = 0.05
    c2: float = 0.1
    drift_rate: float = 0.999
    rate_time_constant: float = 0.05

    def __post_init__(self):
        for name in ("c1", "c2"):
            require_in(f"gyrodometry.{name}", getattr(self, name), "(0, inf)")
        require_in("gyrodometry.drift_rate", self.drift_rate, "[0, 1)")
        require_in("gyrodometry.rate_time_constant", self.rate_time_constant, "[0, inf) s")


def gyrodometry_step(
    state,
    odometric_v_t: float,
    odometric_omega: float,
    gyro_omega: float,
    p: GyrodometryParameters,
    T_N: float,
):
    """One step of Algorithm 1 plus S(21) with v_n = 0. state = [x, y, theta, e, w]: e the drift per
    sample (rad), w the PT1 of the odometric yaw rate (rad/s) that the c1 test reads (the sample's rate
    for rate_time_constant = 0)."""
    x, y, theta, e, rate = state
    c, s = math.cos(theta), math.sin(theta)
    x += odometric_v_t * c * T_N
    y += odometric_v_t * s * T_N
    rate = pt1_step(rate, odometric_omega, p.rate_time_constant, T_N)
    d_odo = odometric_omega * T_N
    d_gyro = gyro_omega * T_N
    if abs(rate) > p.c1 or abs(d_gyro - e) > p.c2 * T_N:
        theta += d_gyro - e
    else:
        e = p.drift_rate * e + (1.0 - p.drift_rate) * (d_gyro - d_odo)
        theta += d_odo
    return [x, y, theta, e, rate]
