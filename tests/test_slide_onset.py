"""The per-sample slide-onset test (systems/navigation/mixing/slide_onset.py: slide_onset_step, in the
VelocityMixer) that hands S(15)'s v_t to the inertial estimate while the wheels have left the body."""

import dataclasses as dc
import math

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator
from slipnav.scenarios.config import load_scenario, with_keys
from slipnav.scenarios.plain_loop import run_scenario_plain_loop
from slipnav.systems.navigation.mixing.mixer import VelocityMixer
from slipnav.systems.navigation.mixing.parameters import MixingParameters
from slipnav.systems.navigation.mixing.slide_onset import (
    SLIDE_ONSET_INITIAL,
    accelerometer_pair_disagreement,
    slide_onset_step,
)
from slipnav.systems.navigation.parameters import NavigationParameters, check_slide_onset, health_geometry
from slipnav.systems.robot.sensors import default_sensor_parameters

from tests.shared import scenario_run

T_N = 0.002
P = MixingParameters(slide_onset_jump=0.05)  # Tinyphoon's (the default is off)
ARMED = (0, 0, 1.0)  # released, armed, previous odometric v_t 1 m/s


def run(state, samples, p=P):
    """samples: (odo_v_t, inertial_v_t, inertial_a_t, disagreement) per sample; returns the flags."""
    flags = []
    for sample in samples:
        state, onset = slide_onset_step(state, *sample, p, T_N)
        flags.append(onset)
    return state, flags


def test_a_wheel_speed_drop_beyond_the_bodys_deceleration_sets_the_test():
    # 1.0 -> 0.9 m/s in 2 ms while the accelerometers say -5 m/s^2 (-0.01 m/s): 0.09 beyond, > 0.05.
    _, flags = run(ARMED, [(0.9, 0.99, -5.0, 0.0)])
    assert flags == [True]
    # The same drop explained by the deceleration (-45 m/s^2: -0.09 m/s) is no slide, nor is 0.04 beyond.
    assert run(ARMED, [(0.9, 0.91, -45.0, 0.0)])[1] == [False]
    assert run(ARMED, [(0.95, 0.99, -5.0, 0.0)])[1] == [False]
    # A spinning wheel (a jump up) sets it too.
    assert run(ARMED, [(1.1, 1.0, 0.0, 0.0)])[1] == [True]


def test_the_test_holds_while_the_speeds_disagree_and_releases_after_five_agreeing_samples():
    state, flags = run(ARMED, [(0.8, 1.0, -5.0, 0.0)] + [(0.8, 0.95, -5.0, 0.0)] * 20)
    assert all(flags) and state[0] == 1 and state[1] == 21  # 0.15 m/s apart: held
    state, flags = run(state, [(0.8, 0.8, 0.0, 0.0)] * 6)
    assert flags == [True, True, True, True, False, False]  # agreement counted 2..5, then released
    assert state[0] == 0 and state[1] == 0
    # A disagreeing sample restarts the count.
    state, flags = run(ARMED, [(0.8, 1.0, 0.0, 0.0), (0.8, 0.8, 0.0, 0.0), (0.8, 0.9, 0.0, 0.0)])
    assert state[0] == 1 and all(flags)


def test_the_test_releases_after_its_longest_time_whatever_the_speeds():
    n = round(P.slide_onset_max_time / T_N)
    _, flags = run(ARMED, [(0.0, 1.0, 0.0, 0.0)] * (n + 2))
    assert all(flags[:n]) and not flags[n]  # 250 samples: 0.5 s


def test_disagreeing_accelerometers_release_and_block_the_test():
    state, flags = run(ARMED, [(0.8, 1.0, 0.0, 0.0), (0.8, 1.0, 0.0, 1.5)])
    assert flags == [True, False] and state == (0, 0, 0.8)
    assert run(ARMED, [(0.8, 1.0, 0.0, math.nan)])[1] == [False]  # a non-finite reading
    assert run(ARMED, [(0.8, 1.0, 0.0, 1.49)])[1] == [True]


def test_the_test_arms_after_ten_samples_and_is_off_at_an_infinite_threshold():
    # The odometry's first speeds span an unknown previous angle (a start at speed reads 0, then 1.5).
    _, flags = run(SLIDE_ONSET_INITIAL, [(0.0, 0.0, 0.0, 0.0)] * 2 + [(1.5, 0.0, 0.0, 0.0)] * 8)
    assert not any(flags)
    _, flags = run(SLIDE_ONSET_INITIAL, [(1.0, 1.0, 0.0, 0.0)] * 9 + [(0.5, 1.0, 0.0, 0.0)])
    assert not any(flags)  # a jump at the tenth sample: still arming
    state, flags = run(SLIDE_ONSET_INITIAL, [(1.0, 1.0, 0.0, 0.0)] * 10 + [(0.5, 1.0, 0.0, 0.0)])
    assert flags[-1] and not any(flags[:-1])
    off = MixingParameters()  # the default
    assert not any(run(ARMED, [(0.0, 1.0, 0.0, 0.0), (5.0, 1.0, 0.0, 0.0)], off)[1])


def test_a_non_finite_odometric_speed_neither_sets_nor_releases():
    state, flags = run(ARMED, [(math.nan, 1.0, 0.0, 0.0), (0.5, 1.0, 0.0, 0.0)])
    assert flags == [False, False]  # the finite speed after the gap is not tested against the old one
    state, _ = run(ARMED, [(0.8, 1.0, 0.0, 0.0)])
    state, flags = run(state, [(math.nan, 1.0, 0.0, 0.0)] * 3)
    assert all(flags) and state[0] == 1 and state[1] == 4  # held, ageing
    n = round(P.slide_onset_max_time / T_N)
    assert not run(state, [(math.nan, 1.0, 0.0, 0.0)] * n)[1][-1]  # the longest time bounds it still


def test_pair_disagreement_removes_the_centripetal_difference_of_S3():
    """S(3): accelerometers at +-(x, y) read a_t -/+ (omega_dot y + omega^2 x)."""
    x, omega, a_t = 0.02, 4.0, -3.0
    acc = [a_t - omega**2 * x, 0.0, a_t + omega**2 * x, 0.0]
    assert accelerometer_pair_disagreement(acc, omega, (x, 0.015)) == pytest.approx(0.0, abs=1e-15)
    acc[0] += 0.7
    assert accelerometer_pair_disagreement(acc, omega, (x, 0.015)) == pytest.approx(0.7)
    assert math.isnan(accelerometer_pair_disagreement([math.nan, 0.0, 0.0, 0.0], omega, (x, 0.015)))


def test_velocity_mixer_runs_the_test_and_takes_v_t_from_the_ekf_while_it_holds():
    from slipnav.systems.navigation.mixing.mixer import MIXER_START

    onset_at = MIXER_START["slide_onset"]
    mixer = VelocityMixer(P, T_N, 0.0, (0.02, 0.015))
    context = mixer.CreateDefaultContext()
    inertial = [0.99, 0.0, 0.5, -5.0, 0.0]
    odo = [0.9, 0.5, 0.0, 0.0]
    acc = [-5.0 - 0.25 * 0.02, 0.0, -5.0 + 0.25 * 0.02, 0.0]  # omega = 0.5: the pair agrees
    for port, value in (
        ("odometry", odo),
        ("inertial_estimate", inertial),
        ("C1", [1.0]),
        ("C2_C3", [1.0, 1.0]),
        ("previous_estimate", [1.0, 0.0, 0.5, -5.0, 0.0]),
        ("inertial_fault", [0.0]),
        ("accelerometers", acc),
        ("encoder_fault", [0.0]),
    ):
        mixer.GetInputPort(port).FixValue(context, value)
    initial = context.get_discrete_state(1).get_value()
    assert initial[0] == 0 and initial[1] == -10 and math.isnan(initial[2])  # SLIDE_ONSET_INITIAL
    context.get_mutable_discrete_state(1).set_value([0.0, 0.0, 1.0])  # armed, previous odometric v_t 1 m/s
    mixing = mixer.GetOutputPort("mixing").Eval(context)
    state, onset = slide_onset_step(ARMED, 0.9, 0.99, -5.0, 0.0, P, T_N)
    assert onset
    np.testing.assert_array_equal(mixing[onset_at : onset_at + 4], [1.0, *state])
    assert mixing[0] == 0.99  # v_t: the inertial estimate's, not the odometry's 0.9
    assert mixing[8] == 0.0  # mixing_gain's C1: the weight actually used
    simulator = Simulator(mixer, context)
    simulator.AdvanceTo(0.5 * T_N)  # one update: the test's state is stored
    np.testing.assert_array_equal(context.get_discrete_state(1).get_value(), state)
    context.get_mutable_discrete_state(1).set_value([0.0, 0.0, 0.9])  # no jump: C1 = 1
    mixing = mixer.GetOutputPort("mixing").Eval(context)
    assert mixing[onset_at] == 0.0 and mixing[8] == 1.0 and mixing[0] != 0.99
    mixer.GetInputPort("accelerometers").FixValue(context, [math.nan, 0.0, 0.0, 0.0])
    context.get_mutable_discrete_state(1).set_value([0.0, 0.0, 1.0])  # a jump, but the pair is not usable
    assert mixer.GetOutputPort("mixing").Eval(context)[onset_at] == 0.0


def test_closed_loop_square_braking_slides_keep_the_bodys_speed():
    """Square, seed 0, plain closed loop (the diagram's twin): its four braking slides lock the wheels;
    S(11)'s batch sees a lock only at the batch's end and C1 falls over 60 ms, while the per-sample test
    hands v_t to the inertial estimate within a sample (it also holds through the launches' wheel spin:
    21 % of the run). Measured: v_t RMS error 62 -> 11 mm/s (3 seeds, matched), the along-track integral
    of the v_t error 88 -> 8 mm by the fourth corner."""
    square = load_scenario("square")  # the default: off
    assert math.isinf(square.navigation.mixing.slide_onset_jump)
    with_test = run_scenario_plain_loop(
        with_keys(square, {"navigation.mixing.slide_onset_jump": 0.05}), 0, 4850
    )
    without = run_scenario_plain_loop(square, 0, 4850)

    def vt_rms(a):
        return float(np.sqrt(np.mean((a["nav_est_v_t"] - a["true_v_t"]) ** 2)))

    assert vt_rms(with_test) < 0.02 and vt_rms(without) > 0.04, (vt_rms(with_test), vt_rms(without))
    onset = with_test["nav_slide_onset"]
    assert 0.0 < np.mean(onset) < 0.3 and not np.any(without["nav_slide_onset"])
    # Each of the four braking slides (the sides end at ~2.2, 4.0, 5.8, 7.6 s) sets it.
    t = np.arange(len(onset)) * T_N
    for end in (2.2, 4.0, 5.8, 7.6):
        assert np.any(onset[(t > end - 0.3) & (t < end + 0.3)] > 0), end
    # In those slides the follower steers the sliding wheels apart while the body does not turn: the
    # perturbation monitor's yaw test pauses while the test holds (it flagged 45 samples before).
    for channel in ("wheel_R", "wheel_L", "yaw", "body"):
        assert not np.any(with_test[f"perturbation_{channel}"]), channel


def test_the_diagram_runs_the_test_when_it_is_on():
    """The closed-loop diagram (run_scenario) with the test on: it holds in the square's first braking
    (test_closed_loop_diagram_equals_plain_loop shows the diagram equals the plain loop there)."""
    from slipnav.scenarios.runner import run_scenario

    square = with_keys(load_scenario("square"), {"navigation.mixing.slide_onset_jump": 0.05})
    a = run_scenario(square, duration=2.5).arrays
    assert 50 < np.sum(a["slide_onset"]) < 0.5 * len(a["slide_onset"])
    assert not np.any(scenario_run("square", duration=2.5).arrays["slide_onset"])  # shared: tests/shared.py


def test_slide_onset_parameters_are_checked_at_construction():
    for bad in (0.0, -0.05, math.nan):
        with pytest.raises(ValueError, match=r"mixing.slide_onset_jump=.*allowed \(0, inf\] m/s"):
            MixingParameters(slide_onset_jump=bad)
    MixingParameters(slide_onset_jump=math.inf)
    for name in ("slide_onset_release", "slide_onset_max_time", "slide_onset_pair_tolerance"):
        with pytest.raises(ValueError, match=rf"mixing.{name}=.*allowed \(0, inf\)"):
            MixingParameters(**{name: math.inf})
    for bad in (0, 2.5, True, 10**4):
        with pytest.raises(
            ValueError, match=r"slide_onset_release_samples=.*allowed an integer in \[1, 1000\]"
        ):
            MixingParameters(slide_onset_release_samples=bad)
    # Kurt3D's encoders: one count is 0.061 m/s in a 2 ms sample, above Tinyphoon's 0.05 threshold.
    kurt = default_sensor_parameters("kurt3d")
    geometry = health_geometry(NavigationParameters(), 0.08, 0.4, T_N, kurt)
    with pytest.raises(ValueError, match=r"mixing.slide_onset_jump=0.05 is out of range .* allowed \[0.18"):
        check_slide_onset(P, geometry)
    check_slide_onset(dc.replace(P, slide_onset_jump=math.inf), geometry)
    check_slide_onset(P, health_geometry(NavigationParameters(), 0.015, 0.068, T_N))
