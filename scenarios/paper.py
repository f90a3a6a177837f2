"""Paper mode: the equations of Seyr & Jakubek and Indiveri et al. exactly as printed.

``paper_mode(scenario)`` switches every extension of this package off and every deviation from the
printed equations back to the print, on top of the scenario (scenario key ``paper: true``, ``slipnav run
--paper``, ``slipnav accuracy --paper``). Everything else (robot, trajectory, seeds, the tuning the papers
give no number for) stays the scenario's. The papers' own tuning, T_N = 2 ms and T_C = 20 ms (S §IV), is
the default already. DEVIATIONS is the table of README "Paper mode", one row per switch.
"""

import dataclasses as dc
import math

from slipnav.systems.mixing import MixingParameters

PER_SAMPLE_C3 = {"a3": 60.0, "b3": 0.05}
"""S(14)'s steepness and threshold for the single sample's yaw-rate residual (the defaults a3 = 200,
b3 = 0.02 suit the residual's PT1; one encoder count is 0.11 rad/s of yaw rate per 2 ms sample on
Tinyphoon): the error budget's "paper's heading" (studies/error_budget.papers_heading). A scenario
that sets its own a3 or b3 keeps them (the Kurt3D scenarios: 15, 0.4)."""

DEVIATIONS = (
    # (deviation, the paper's equation, key: value in paper mode)
    (
        "sensor checks: every channel checked, faulty ones replaced",
        "none (S §IV: no checks)",
        "navigation.health.enabled: false (the NaN/inf guard only)",
    ),
    (
        "gyro bias and radius difference learned (YawRateCalibration)",
        "S(3): the raw gyro",
        "navigation.yaw_calibration.enabled: false",
    ),
    (
        "S(14) on the yaw-rate residual's PT1",
        "S(14): this sample's |^O w - ^I w|",
        "navigation.mixing.c3_residual_time_constant: 0 (a3: 60, b3: 0.05)",
    ),
    (
        "S(11) acceleration term integrated since the batch start",
        "S(11): (a_t1,k + a_t2,k) T_N/2",
        "navigation.mixing.delta_v_running_integral: false",
    ),
    ("S(12) sees the leaky sum of the batches' dv", "S(12): |dv_K|", "navigation.mixing.dv_memory: 0"),
    ("S(15) less the tyres' creep", "S(15): ^O v_t", "navigation.mixing.odometry_slip_compensation: false"),
    (
        "S(17) relaxes v_n to the tyre curve's side slip",
        "S(17): relaxed to 0, integrated above b2",
        "navigation.mixing.tyre_peak_acceleration: .inf, q2_inertial: 1, side_slip_from_accelerations: false",
    ),
    (
        "Gyrodometry's c1 test on the odometric rate's PT1",
        "I Algorithm 1: the sample's rotation",
        "navigation.gyrodometry.rate_time_constant: 0",
    ),
    ("standstill before the controller starts", "none", "standstill_time: 0"),
    (
        "the reference paced by delta_K-1 (one T_C late)",
        "S(22), S(25): delta_K",
        "slip_control.delayed_step_size: false",
    ),
    (
        "I(15)-(16) with the estimated speed",
        "I(15)-(16): the commanded u",
        "follower.use_estimated_speed: false",
    ),
)


def paper_mixing(mixing: MixingParameters) -> MixingParameters:
    """S(11)-(17) as printed: no leaky sum, S(14) per sample, no creep, no tyre curve in S(17)."""
    defaults = MixingParameters()
    c3 = {} if (mixing.a3, mixing.b3) != (defaults.a3, defaults.b3) else dict(PER_SAMPLE_C3)
    return dc.replace(
        mixing,
        delta_v_running_integral=False,
        dv_memory=0.0,
        c3_residual_time_constant=0.0,
        odometry_slip_compensation=False,
        side_slip_from_accelerations=False,
        tyre_peak_acceleration=math.inf,
        q2_inertial=1.0,
        **c3,
    )


def paper_navigation(navigation):
    """NavigationParameters with every navigation extension off (DEVIATIONS' navigation rows)."""
    return dc.replace(
        navigation,
        health=dc.replace(navigation.health, enabled=False),
        yaw_calibration=dc.replace(navigation.yaw_calibration, enabled=False),
        mixing=paper_mixing(navigation.mixing),
        gyrodometry=dc.replace(navigation.gyrodometry, rate_time_constant=0.0),
    )


def paper_mode(scenario):
    """``scenario`` (scenarios.config.Scenario) with the papers' equations as printed (DEVIATIONS) and
    ``paper = True``; idempotent. Returns a validated copy."""
    return dc.replace(
        scenario,
        paper=True,
        standstill_time=0.0,
        navigation=paper_navigation(scenario.navigation),
        slip_control=dc.replace(scenario.slip_control, delayed_step_size=False),
        follower=dc.replace(scenario.follower, use_estimated_speed=False),
    ).validate()
