"""The tyre peak a_peak = mu g f_w identified online (mixing.tyre_peak_step; issue 15: the floor's grip
is not the data sheet's): the curve's inverse at the slip, the lower bound of the force the tyres carried,
what it must not learn from, and the closed loop on floors of other grip."""

import dataclasses as dc
import math
import re

import numpy as np
import pytest
from slipnav.scenarios.config import load_scenario, with_keys
from slipnav.scenarios.plain_loop import run_scenario_plain_loop
from slipnav.systems.navigation.mixing.parameters import MixingParameters
from slipnav.systems.navigation.mixing.tyre_identification import peak_slip, tyre_peak_step

T_N = 0.002
NOMINAL = MixingParameters(drag_acceleration=0.0, drag_per_speed=0.0)  # |a| = |a_n| below
SPEED = 2.0  # m/s: above tyre_model_gate_speed, so the slip is referred to it


def curve_share(sigma: float, p: MixingParameters = NOMINAL) -> float:
    """sin(C atan(B sigma)): the share of its peak the tyre curve gives at the slip sigma."""
    return math.sin(p.tyre_shape_factor * math.atan(p.tyre_stiffness_factor * sigma))


def drive(state, seconds: float, sigma: float, force: float, p: MixingParameters = NOMINAL, learn=True):
    """tyre_peak_step for ``seconds`` of a side slip tan(alpha) = sigma (free integral) at the lateral
    force per unit mass ``force``, wheels rolling at the body's speed (kappa = 0)."""
    for _ in range(int(round(seconds / T_N))):
        state = tyre_peak_step(state, SPEED, SPEED, -sigma * SPEED, 0.0, -force, learn, p, T_N)
    return state


def test_peak_slip_is_where_the_curve_peaks():
    sigma = peak_slip(NOMINAL)
    assert sigma == pytest.approx(math.tan(math.pi / 2.6) / 15.0)
    assert curve_share(sigma) == pytest.approx(1.0, abs=1e-15)
    assert curve_share(0.99 * sigma) < 1.0 and curve_share(1.01 * sigma) < 1.0


@pytest.mark.parametrize("true_peak", [3.924, 7.063])  # friction 0.5 and 0.9 on Tinyphoon (mu g 0.8)
def test_a_slide_past_the_peak_identifies_it(true_peak):
    """The tyres slide at 1.5 sigma_peak and carry what the curve at the true peak gives there: a_peak
    follows the curve's inverse |a| / share from the nominal 5.49 to the true value, each sample's read
    limited to 1.2 x, in well under a second."""
    sigma = 1.5 * peak_slip(NOMINAL)
    force = true_peak * curve_share(sigma)
    state = drive((5.49, 0.0, 0.0), 0.5, sigma, force)
    np.testing.assert_allclose(state[0], true_peak, rtol=1e-4)
    first = drive((5.49, 0.0, 0.0), T_N, sigma, force)[0]  # one sample: 1/25 of a read within 1.2 x
    np.testing.assert_allclose(
        first, 5.49 + 0.04 * (min(max(force / curve_share(sigma), 5.49 / 1.2), 5.49 * 1.2) - 5.49)
    )


def test_evidence_weighs_in_from_a_share_of_the_peak_slip():
    """Below 0.4 sigma_peak the free integral's drift makes the read unreliable: no evidence. Between 0.4
    and 0.9 sigma_peak the weight rises linearly."""
    low = drive((5.49, 0.0, 0.0), 1.0, 0.39 * peak_slip(NOMINAL), 2.0)
    assert low[0] == 5.49
    sigma = 0.65 * peak_slip(NOMINAL)  # weight 0.5
    force = 4.0
    one = tyre_peak_step((5.49, 0.0, 0.0), SPEED, SPEED, -sigma * SPEED, 0.0, -force, True, NOMINAL, T_N)
    read = max(force / curve_share(sigma), 5.49 / 1.2)
    np.testing.assert_allclose(one[0], 5.49 + 0.5 * 0.04 * (read - 5.49), rtol=1e-12)


def test_the_force_the_tyres_carried_is_a_lower_bound():
    """A floor with more grip: the tyres carry 6.5 m/s^2 without slipping past 0.4 sigma_peak (no slip
    evidence); a_peak is at least the force's PT1 (0.1 s)."""
    state = drive((5.49, 0.0, 0.0), 1.0, 0.0, 6.5)
    np.testing.assert_allclose(state[0], 6.5 * (1.0 - math.exp(-10.0)), rtol=1e-12)
    np.testing.assert_allclose(state[1], state[0], rtol=1e-12)
    capped = drive((5.49, 0.0, 0.0), 1.0, 0.0, 20.0)  # a push, not the tyres: at most 1.5 x nominal
    assert capped[0] == pytest.approx(1.5 * 5.49)


def test_the_held_lower_bound_outlasts_a_slide_that_ends():
    """As a slide ends the force drops before the free integral's slip does (its 0.25 s relaxation): the
    stale slip with a small force must not drag a_peak down. The force held from the slide (decay 10 s)
    keeps it; with a hold of 1 ms it falls to the floor of 0.5 x nominal (an open corner at friction 0.5
    read 2.75 that way)."""
    sigma = peak_slip(NOMINAL)
    slid = drive((5.49, 0.0, 0.0), 0.5, sigma, 3.924)
    np.testing.assert_allclose(slid[0], 3.924, rtol=1e-3)
    stale = drive(slid, 0.3, sigma, 1.0)
    held = 3.924 * (1.0 - math.exp(-5.0)) * math.exp(-0.3 / 10.0)
    assert stale[0] >= held * (1 - 1e-9) and stale[0] < 3.924
    forgetful = dc.replace(NOMINAL, tyre_peak_hold_time=0.001)
    assert drive(slid, 0.3, sigma, 1.0, forgetful)[0] == pytest.approx(0.5 * 5.49)


def test_nothing_is_learnt_from_a_failed_check_a_non_finite_sample_or_without_a_curve():
    state = (4.5, 3.0, 3.5)
    assert drive(state, 0.1, peak_slip(NOMINAL), 2.0, learn=False) == state
    assert tyre_peak_step(state, SPEED, SPEED, 0.0, math.nan, 1.0, True, NOMINAL, T_N) == state
    assert tyre_peak_step(state, SPEED, SPEED, math.inf, 0.0, 1.0, True, NOMINAL, T_N) == state
    paper = dc.replace(NOMINAL, tyre_peak_acceleration=math.inf)
    assert drive((math.inf, 0.0, 0.0), 0.1, 0.3, 2.0, paper) == (math.inf, 0.0, 0.0)
    off = dc.replace(NOMINAL, tyre_peak_identification=False)
    assert drive((5.49, 0.0, 0.0), 0.1, peak_slip(NOMINAL), 2.0, off) == (5.49, 0.0, 0.0)


@pytest.mark.parametrize(
    "key, value, allowed",
    [
        ("tyre_peak_identification", 1, "true, false"),
        ("tyre_peak_force_time_constant", 0.0, "(0, inf)"),
        ("tyre_peak_hold_time", math.inf, "(0, inf)"),
        ("tyre_peak_identification_time_constant", -1.0, "(0, inf)"),
        ("tyre_peak_candidate_bound", math.nan, "(0, inf)"),
        ("tyre_peak_evidence_slip", 0.0, "(0, inf)"),
        ("tyre_peak_full_evidence_slip", 0.4, "(tyre_peak_evidence_slip=0.4, inf)"),
        ("tyre_peak_min_ratio", 1.2, "(0, 1]"),
        ("tyre_peak_max_ratio", 0.9, "[1, inf)"),
    ],
)
def test_bad_identification_parameters_are_named(key, value, allowed):
    with pytest.raises(ValueError, match=rf"mixing\.{key}=.*allowed {re.escape(allowed)}"):
        MixingParameters(**{key: value})


def test_the_closed_square_identifies_the_floor_and_its_estimate_gains():
    """Square, plain closed loop (the diagram's twin), the plant's friction 0.5, 0.7 (nominal) and 0.9,
    against the floor's a_true = mu g f_w = 3.92, 5.49, 7.06 m/s^2.

    A read |a| / sin(C atan(B sigma)) is right at the true slip, but the square's slides are spins and
    locks, and their slip is read from the mixed v_t, which leads the body by 0.06-0.1 m/s after the
    wheels hand v_t to the accelerometers (C1): the read slip is about half the true one, so the read
    runs high, by at most 1 / sin(C atan(B 0.4 sigma_peak)) = 1.149 where a sample first weighs in
    (tyre_peak_evidence_slip), and never low but for the force's noise (5 %). From the nominal 5.49 one
    lap gives a few such slides, and which run lands where in that band is the path's lottery. So: the
    mean over four runs and each other floor within [0.95, 1.149] a_true, and every run at least half-way
    from the nominal to the floor.

    At friction 0.5 the curve at the identified peak sets S(17)'s side slip: over the four runs the RMS
    of the lateral velocity error is below 0.85 of the nominal curve's. The position error is not the
    curve's to set: on this floor it comes from the spins and locks, where C1 hands v_t from the wheels to
    the accelerometers with 0.1-0.4 m/s of error."""
    square = load_scenario("square")
    p = square.navigation.mixing
    high = 1.0 / curve_share(p.tyre_peak_evidence_slip * peak_slip(p), p)  # 1.149
    steps = 4700  # 9.4 s: the lap and its final braking
    slippery = with_keys(square, {"plant.robot_overrides.tyre_friction": 0.5})
    identifying = {seed: run_scenario_plain_loop(slippery, seed, steps) for seed in (0, 1, 2, 3)}
    peaks = [identifying[seed]["nav_est_tyre_peak"][-1] for seed in (0, 1, 2, 3)]
    true_peak = 0.5 * 9.81 * 0.8
    assert 0.95 * true_peak <= np.mean(peaks) <= high * true_peak, peaks
    for peak in peaks:  # identified: at least half-way from the nominal to the floor
        assert abs(peak - true_peak) <= 0.5 * abs(p.tyre_peak_acceleration - true_peak), peaks
    for friction in (0.7, 0.9):
        floor = with_keys(square, {"plant.robot_overrides.tyre_friction": friction})
        peak = run_scenario_plain_loop(floor, 1, steps)["nav_est_tyre_peak"][-1]
        assert 0.95 * friction * 9.81 * 0.8 <= peak <= high * friction * 9.81 * 0.8, (friction, peak)
    nominal_curve = with_keys(slippery, {"navigation.mixing.tyre_peak_identification": False})
    identified = fixed = 0.0
    for seed in (0, 1, 2, 3):
        identified += lateral_velocity_rms(identifying[seed])
        fixed += lateral_velocity_rms(run_scenario_plain_loop(nominal_curve, seed, steps))
    assert identified < 0.85 * fixed, (identified, fixed)


def lateral_velocity_rms(a) -> float:
    """RMS of the navigation's lateral velocity error ^v_n - v_n over a run (m/s)."""
    return float(np.sqrt(np.mean((a["nav_est_v_n"] - a["true_v_n"]) ** 2)))


def test_mix_checked_learns_only_from_checked_samples_of_rolling_wheels():
    """mix_checked's tyre peak (the state's last three) moves on a sliding sample, and not while a sensor
    check excludes an inertial channel or an encoder, nor with both wheels at rest; a two-element check
    state keeps the nominal curve without identification."""
    from slipnav.systems.navigation.mixing.mixer import mix_checked

    p = MixingParameters()
    sigma = peak_slip(p)
    odo = [2.0, 0.5, 2.0, 2.0]
    inertial = [2.0, -sigma * 2.0, 0.5, 0.0, -3.0]  # the EKF's v_n slides at sigma_peak; 3 m/s^2 across
    previous = np.array(inertial)
    state = (-sigma * 2.0, -0.01, 5.49, 0.0, 0.0)  # F: the slide; S: the curve's own
    learnt = mix_checked(odo, inertial, 1.0, 0.0, 0.0, previous, p, state, T_N)[2]
    assert learnt[2] < 5.49 and learnt[3] > 0.0  # a read of about 3 m/s^2 pulls the peak down
    for faults in ((True, False), (False, True)):
        kept = mix_checked(odo, inertial, 1.0, 0.0, 0.0, previous, p, state, T_N, *faults)[2]
        assert kept[2:] == state[2:], faults
    at_rest = mix_checked([0.0, 0.0, 0.0, 0.0], inertial, 0.0, 0.0, 0.0, previous, p, state, T_N)[2]
    assert at_rest[2:] == state[2:]
    assert len(mix_checked(odo, inertial, 1.0, 0.0, 0.0, previous, p, state[:2], T_N)[2]) == 2
