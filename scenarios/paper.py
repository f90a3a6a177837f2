"""Paper mode: the equations of Seyr & Jakubek and Indiveri et al. exactly as printed.

``paper_mode(scenario)`` switches every extension of this package off and every deviation from the
printed equations back to the print, on top of the scenario (scenario key ``paper: true``, ``slipnav run
--paper``, ``slipnav accuracy --paper``). Everything else (robot, trajectory, seeds, the tuning the papers
give no number for) stays the scenario's. The papers' own tuning, T_N = 2 ms and T_C = 20 ms (S §IV), is
the default already. DEVIATIONS is the table of README "Paper mode", one row per switch.

Where the print is ambiguous, paper mode takes the reading the papers' own derivations need and the
default shares it: I(15)-(16) read the robot's speed, the u of I(11)-(12), under which I(17) holds
(systems/control/path_follower.py; ``follower.use_estimated_speed: false`` runs the command u there instead).
"""

import dataclasses as dc
import math
import typing

from slipnav.systems.navigation.mixing.parameters import MixingParameters

PER_SAMPLE_C3 = {"a3": 60.0, "b3": 0.05}
"""S(14)'s steepness and threshold for the single sample's yaw-rate residual (the defaults a3 = 200,
b3 = 0.02 suit the residual's PT1; one encoder count is 0.11 rad/s of yaw rate per 2 ms sample on
Tinyphoon): the error budget's "paper's heading" (studies/error_budget.papers_heading). A scenario
that sets its own a3 or b3 keeps them (the Kurt3D scenarios: 200, 0.4)."""


def _nav(scenario, part: str, **changes):
    """``scenario`` with ``navigation.<part>`` fields changed."""
    nav = scenario.navigation
    return dc.replace(
        scenario, navigation=dc.replace(nav, **{part: dc.replace(getattr(nav, part), **changes)})
    )


def _per_sample_c3(scenario):
    """S(14) on the single sample; the per-sample thresholds PER_SAMPLE_C3 unless the scenario sets its
    own a3, b3."""
    m, defaults = scenario.navigation.mixing, MixingParameters()
    own = (m.a3, m.b3) != (defaults.a3, defaults.b3)
    return _nav(scenario, "mixing", c3_residual_time_constant=0.0, **({} if own else PER_SAMPLE_C3))


@dc.dataclass(frozen=True)
class Deviation:
    """One extension or deviation from the printed equations: what this package does, what the paper
    prints, the scenario key that switches it (with its value in paper mode) and ``to_paper``, the
    function that sets it to the print."""

    name: str
    ours: str
    printed: str
    key: str
    to_paper: typing.Callable


DEVIATIONS = (
    Deviation(
        "health",
        "sensor checks: every channel checked, a faulty one replaced",
        "none (S §IV)",
        "navigation.health.enabled: false (the NaN/inf guard only)",
        lambda s: _nav(s, "health", enabled=False),
    ),
    Deviation(
        "yaw_calibration",
        "gyro bias and rolling-radius difference learned; EKF gets gyro - b",
        "S(3): the raw gyro; S(10) as is",
        "navigation.yaw_calibration.enabled: false",
        lambda s: _nav(s, "yaw_calibration", enabled=False),
    ),
    Deviation(
        "c3_residual",
        "S(14) on the yaw-rate residual's PT1 (one T_C)",
        "S(14): this sample's residual",
        "navigation.mixing.c3_residual_time_constant: 0 (a3: 60, b3: 0.05)",
        _per_sample_c3,
    ),
    Deviation(
        "gyro_turn",
        "a turn's yaw rate the gyro's: C3 times logsig(a3 (|PT1 of ^I omega| - gyro_turn_rate))",
        "S(14): the disagreement alone",
        "navigation.mixing.gyro_turn_rate: .inf",
        lambda s: _nav(s, "mixing", gyro_turn_rate=math.inf),
    ),
    Deviation(
        "s11",
        "S(11)'s acceleration term integrated since the batch start",
        "S(11): (a_t1,k + a_t2,k) T_N/2",
        "navigation.mixing.delta_v_running_integral: false",
        lambda s: _nav(s, "mixing", delta_v_running_integral=False),
    ),
    Deviation(
        "dv_memory",
        "S(12) also sees the leaky sum of the batches' dv",
        "S(12): |dv_K|",
        "navigation.mixing.dv_memory: 0",
        lambda s: _nav(s, "mixing", dv_memory=0.0),
    ),
    Deviation(
        "creep",
        "S(15): ^O v_t less the tyres' creep",
        "S(15): ^O v_t",
        "navigation.mixing.odometry_slip_compensation: false",
        lambda s: _nav(s, "mixing", odometry_slip_compensation=False),
    ),
    Deviation(
        "tyre_curve",
        "S(17): v_n relaxed towards the tyre curve's side slip (at the measured force above b2)",
        "S(17): relaxed to 0 below b2, integrated above",
        "navigation.mixing.tyre_peak_acceleration: .inf, q2_inertial: 1, side_slip_from_accelerations: false",
        lambda s: _nav(
            s, "mixing", tyre_peak_acceleration=math.inf, q2_inertial=1.0, side_slip_from_accelerations=False
        ),
    ),
    Deviation(
        "tyre_model_check",
        "S(17): the free integral of the lateral kinematics outweighs the tyre curve where they part by "
        "more than 2.5 deg (a floor with less grip)",
        "S(17): no tyre curve to check",
        "navigation.mixing.tyre_model_gate_deg: .inf",
        lambda s: _nav(s, "mixing", tyre_model_gate_deg=math.inf),
    ),
    Deviation(
        "tyre_peak",
        "the tyre curve's peak mu g f_w identified online from the slip and the force the tyres carry",
        "no tyre curve (S(17)); here: the data sheet's peak throughout",
        "navigation.mixing.tyre_peak_identification: false",
        lambda s: _nav(s, "mixing", tyre_peak_identification=False),
    ),
    Deviation(
        "sideways_push",
        "S(17): while the perturbation monitor flags a sideways push on the body (no turn demand, no wheel "
        "or yaw flag), v_n is the free integral of the lateral kinematics",
        "S(17) whatever pushes the body",
        "perturbation_monitor.push_demand: 0",
        lambda s: dc.replace(s, perturbation_monitor=dc.replace(s.perturbation_monitor, push_demand=0.0)),
    ),
    Deviation(
        "standstill_measurement",
        "standstill is a measurement: while wheels and inertial sensors agree the robot stands, the "
        "estimate is zero (ZUPT) and the accelerometers' biases are learned",
        "S(2)-(17) at rest as while rolling",
        "navigation.standstill.enabled: false",
        lambda s: _nav(s, "standstill", enabled=False),
    ),
    Deviation(
        "gyrodometry",
        "Gyrodometry's c1 test on the odometric rate's PT1 (0.05 s)",
        "I Algorithm 1: the sample's rotation",
        "navigation.gyrodometry.rate_time_constant: 0",
        lambda s: _nav(s, "gyrodometry", rate_time_constant=0.0),
    ),
    Deviation(
        "standstill",
        "1 s standstill before the controller starts (bias learned)",
        "none",
        "standstill_time: 0",
        lambda s: dc.replace(s, standstill_time=0.0),
    ),
    Deviation(
        "step_size_delay",
        "the reference paced by delta_K-1 (one T_C late)",
        "S(22), S(25): delta_K at once",
        "slip_control.delayed_step_size: false",
        lambda s: dc.replace(s, slip_control=dc.replace(s.slip_control, delayed_step_size=False)),
    ),
    Deviation(
        "s22_inputs",
        "S(22) on C1_K-1 and alpha_K-1: the navigation as it stood before its sample k (one T_C late)",
        "S(22): C1_K and alpha_K of batch K",
        "slip_control.after_navigation: true",
        lambda s: dc.replace(s, slip_control=dc.replace(s.slip_control, after_navigation=True)),
    ),
    Deviation(
        "speed_law_delay",
        "I(24) on V1 of the follower's previous update (one T_C late)",
        "I(24): u(t) of V1(t)",
        "follower.delayed_speed_law: false",
        lambda s: dc.replace(s, follower=dc.replace(s.follower, delayed_speed_law=False)),
    ),
)
"""Every extension and deviation, in the order of README's Paper mode table."""


@dc.dataclass
class _NavigationOnly:
    """What DEVIATIONS' navigation rows read and change of a scenario: its ``navigation``."""

    navigation: object


def paper_navigation(navigation):
    """NavigationParameters with every navigation extension off (DEVIATIONS' navigation rows)."""
    scenario = _NavigationOnly(navigation)
    for deviation in DEVIATIONS:
        if deviation.key.startswith("navigation."):
            scenario = deviation.to_paper(scenario)
    return scenario.navigation


def paper_mode(scenario):
    """``scenario`` (scenarios.config.Scenario) with every DEVIATIONS switch set to the print and
    ``paper = True``; idempotent. Returns a validated copy."""
    for deviation in DEVIATIONS:
        scenario = deviation.to_paper(scenario)
    return dc.replace(scenario, paper=True).validate()


def one_deviation(scenario, name: str):
    """``scenario`` with the single deviation ``name`` (Deviation.name) set to the print (not validated
    as paper mode: ``paper`` stays as it was)."""
    for deviation in DEVIATIONS:
        if deviation.name == name:
            return deviation.to_paper(scenario).validate()
    raise ValueError(f"deviation {name!r} is unknown: allowed {[d.name for d in DEVIATIONS]}")
