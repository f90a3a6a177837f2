"""The perturbation monitor (systems/health/perturbation.py): each flag from scripted commands,
encoders and estimates by hand, the LeafSystem as the pure function, and on the closed loop a held
wheel flagged while the fault-free run stays clean."""

import math

import numpy as np
import pytest
from slipnav.scenarios.config import ScenarioError, load_scenario, scenario_from_yaml
from slipnav.scenarios.metrics import final_position_error
from slipnav.scenarios.runner import run_scenario
from slipnav.systems.health.perturbation import (
    HELD_DEMAND,
    SLIDE_VELOCITY,
    WHEEL_BRAKED,
    WHEEL_DRIVEN,
    YAW_RESIDUAL,
    PerturbationParameters,
    perturbation_initial_state,
    perturbation_step,
    sideways_push,
)
from slipnav.systems.health.perturbation_monitor import PerturbationMonitor
from slipnav.systems.robot.contact import NO_DISTURBANCE
from slipnav.systems.robot.dynamics import plant_advance
from slipnav.systems.robot.faults import FaultEvent
from slipnav.systems.robot.motors import motor_currents
from slipnav.systems.robot.parameters import tinyphoon

T_N, R, B = 0.002, 0.015, 0.068
P = PerturbationParameters()


def drive(n, command, speeds, estimate=(0.0, 0.0, 0.0, 0.0, 0.0), state=None, theta=(0.0, 0.0), params=P):
    """n samples with constant command and wheel speeds (m/s); returns (flag rows, state, angles)."""
    state = state or perturbation_initial_state()
    theta, rows = list(theta), []
    for _ in range(n):
        state = perturbation_step(state, command, theta, estimate, params, (R, R), B, T_N)
        rows.append(state[-4:])
        theta = [theta[w] + speeds[w] * T_N / R for w in range(2)]
    return np.array(rows), state, theta


def test_a_wheel_following_its_command_is_not_flagged():
    rows, _, _ = drive(500, (1.0, 1.0), (1.0, 1.0), (1.0, 0.0, 0.0, 0.0, 0.0))
    assert not rows.any()


def test_a_held_wheel_is_braked_within_the_pt1_and_confirm_time():
    """The residual's PT1 (20 ms) reaches the bound 0.25 + 0.15 * 1.0 = 0.4 m/s of a 1 m/s deficit after
    ln(0.6) / ln(exp(-0.1)) = 5.1 -> 6 samples, then 5 samples to confirm, the flag one sample later."""
    _, state, theta = drive(300, (1.0, 1.0), (1.0, 1.0))  # the reference has reached the command
    rows, _, _ = drive(30, (1.0, 1.0), (0.0, 1.0), state=state, theta=theta)
    first = int(np.argmax(rows[:, 0] > 0))
    assert rows[first, 0] == WHEEL_BRAKED and not rows[:, 1].any() and not rows[:, 2].any()
    expected = math.ceil(math.log(1 - 0.4 / 1.0) / (-T_N / P.time_constant)) + P.confirm_samples
    assert first in (expected - 1, expected, expected + 1)


def test_a_pushed_wheel_is_driven_and_a_wheel_moving_against_a_stop_command_too():
    _, state, theta = drive(300, (1.0, 1.0), (1.0, 1.0))  # the reference has reached the command
    rows, _, _ = drive(40, (1.0, 1.0), (1.0, 1.8), state=state, theta=theta)
    assert rows[-1, 1] == WHEEL_DRIVEN and not rows[:, 0].any()
    rows, _, _ = drive(40, (0.0, 0.0), (0.0, 0.5))
    assert rows[-1, 1] == WHEEL_DRIVEN


def test_a_current_limited_run_up_is_in_the_band():
    """A command step 0 -> 3 m/s followed at 2.5 m/s^2 (above reference_acceleration): never flagged;
    followed at 1 m/s^2 it falls behind the band's reference and is braked."""

    def run_up(acceleration):
        state, theta, flags = perturbation_initial_state(), [0.0, 0.0], []
        for k in range(1000):
            v = min(acceleration * k * T_N, 3.0)
            state = perturbation_step(state, (3.0, 3.0), theta, (v, 0, 0, 0, 0), P, (R, R), B, T_N)
            flags.append(state[-4:])
            theta = [t + v * T_N / R for t in theta]
        return np.array(flags)

    assert not np.any(run_up(2.5))
    assert run_up(1.0)[:, 0].max() == WHEEL_BRAKED


def test_yaw_flag_on_a_turn_the_wheels_do_not_make_but_not_on_a_turns_understeer():
    straight = (1.0, 1.0)
    rows, _, _ = drive(60, straight, straight, (1.0, 0.0, 2.0, 0.0, 0.0))  # 2 rad/s > 1.2
    assert rows[-1, 2] == 1 and not rows[:, :2].any()
    turning = (1.0 + 0.5 * B * 4.0, 1.0 - 0.5 * B * 4.0)  # the wheels say 4 rad/s
    rows, _, _ = drive(200, turning, turning, (1.0, 0.0, 3.4, 0.0, 3.4))  # 15 % understeer, a_n = v omega
    assert not rows.any()


def test_yaw_test_pauses_while_the_wheels_slide():
    """The square's braking slide: the wheels follow commands 1.5 rad/s apart, (0.19 - 0.086) / b,
    while the sliding body does not turn. With the slide-onset test holding no yaw flag and the
    residual's PT1 stays at 0; once the slide ends the flag needs the PT1's full build-up again (the
    same sample count as from a fresh start)."""
    command = (0.19, 0.086)
    estimate = (0.4, 0.0, 0.0, -5.8, 0.0)

    def run(n, sliding, state=None, theta=(0.0, 0.0)):
        state, theta, rows = state or perturbation_initial_state(), list(theta), []
        for _ in range(n):
            state = perturbation_step(state, command, theta, estimate, P, (R, R), B, T_N, sliding=sliding)
            rows.append(state[-4:])
            theta = [theta[w] + command[w] * T_N / R for w in range(2)]
        return np.array(rows), state, theta

    fresh, _, _ = run(100, False)
    first = int(np.argmax(fresh[:, 2] > 0))
    assert fresh[-1, 2] == 1 and not fresh[:, :2].any() and first > P.confirm_samples
    held, state, theta = run(100, True)
    assert not held.any() and state[YAW_RESIDUAL] == 0.0
    after, _, _ = run(100, False, state, theta)
    assert int(np.argmax(after[:, 2] > 0)) == first


def test_body_flag_on_a_lateral_acceleration_beyond_the_centripetal():
    """The lateral test alone (no slide test): beyond 1.5 + 0.5 * 1 m/s^2 flagged, 1.8 not."""
    lateral = PerturbationParameters(slide_threshold=math.inf)
    rows, _, _ = drive(60, (1.0, 1.0), (1.0, 1.0), (1.0, 0.0, 0.0, 0.0, 2.5), params=lateral)
    assert rows[-1, 3] == 1
    rows, _, _ = drive(200, (1.0, 1.0), (1.0, 1.0), (1.0, 0.0, 0.0, 0.0, 1.8), params=lateral)
    assert not rows.any()


@pytest.mark.parametrize("excess, fraction, flagged", [(2.4, 0.2, False), (2.8, 0.2, True), (2.4, 0.0, True)])
def test_the_lateral_bound_grows_with_the_turns_demand(excess, fraction, flagged):
    """In a 3 rad/s turn at 1 m/s (demand v_t omega = 3 m/s^2) the bound is 1.5 + 0.5 * 1 + 0.2 * 3 =
    2.6 m/s^2 of a_n - v_t omega: 2.4 passes, 2.8 is flagged; without the demand's share (0) 2.4 is."""
    lateral = PerturbationParameters(slide_threshold=math.inf, lateral_fraction=fraction)
    omega = 3.0
    wheels = (1.0 + 0.5 * B * omega, 1.0 - 0.5 * B * omega)
    estimate = (1.0, 0.0, omega, 0.0, 1.0 * omega + excess)
    rows, _, _ = drive(200, wheels, wheels, estimate, params=lateral)
    assert not rows[:, :3].any()  # the wheels follow their commands and the turn is theirs
    assert bool(rows[-1, 3]) == flagged


def test_body_flag_on_a_side_slip_no_tyre_explains():
    """The slide test by hand: on a straight (no lateral demand) at 1 m/s, a_n = 1.8 m/s^2 with the
    estimate's v_n at 0 (below the lateral bound 1.5 + 0.5 * 1) integrates to
    L_k = q (L_k-1 + T_N a_n), q = exp(-T_N / 0.1), from L_0 = 0: L passes the bound 0.025 + 0.015 * 1
    m/s at sample n, the flag 4 samples later (5 confirmed). The same a_n - v_t omega in a turn that
    asks 2 m/s^2 of the tyres (above slide_demand, 1 m/s^2) is the tyres' own side slip: no flag."""
    q, bound = math.exp(-T_N / P.slide_time_constant), P.slide_threshold + P.slide_per_speed * 1.0
    L, n = 0.0, 0
    while L <= bound:
        L, n = q * (L + T_N * 1.8), n + 1
    rows, state, _ = drive(n + 10, (1.0, 1.0), (1.0, 1.0), (1.0, 0.0, 0.0, 0.0, 1.8))
    first = int(np.argmax(rows[:, 3] > 0))
    assert first == n - 1 + P.confirm_samples and not rows[:, :3].any()
    L_end = q * (1 - q ** (n + 9)) / (1 - q) * T_N * 1.8  # the first sample starts L at the estimate
    np.testing.assert_allclose(state[SLIDE_VELOCITY], L_end, rtol=1e-12)
    turning = (1.0 + 0.5 * B * 2.0, 1.0 - 0.5 * B * 2.0)  # 2 rad/s at 1 m/s: v_t omega = 2 m/s^2
    rows, _, _ = drive(n + 10, turning, turning, (1.0, 0.0, 2.0, 0.0, 3.8))
    assert not rows.any()


def sideways_rows(n, command, speeds, estimate, params=P, state=None):
    """drive, with the monitor's sideways_push per sample beside the flag rows."""
    state, theta, rows, pushes = state or perturbation_initial_state(), [0.0, 0.0], [], []
    for _ in range(n):
        state = perturbation_step(state, command, theta, estimate, params, (R, R), B, T_N)
        rows.append(state[-4:])
        pushes.append(sideways_push(state))
        theta = [theta[w] + speeds[w] * T_N / R for w in range(2)]
    return np.array(rows), np.array(pushes), state


def test_the_navigation_takes_a_sideways_push_only_without_demand_and_without_a_wheel_flag():
    """sideways_push (the mixer's external_force): the body test's lateral and slide conditions,
    confirmed, in an episode that held once below push_demand (0.5 m/s^2 of held |v_t omega|) and raised
    no wheel or yaw flag. On a straight the slide test's push (a_n = 1.8 m/s^2, as above) is taken
    from the sample the body flag is; the same excess in a turn asking 0.8 m/s^2 (slide test at any
    demand) is flagged but not taken; nor with the right wheel held (braked: the pivot's trace);
    push_demand 0 takes none."""
    rows, pushes, _ = sideways_rows(60, (1.0, 1.0), (1.0, 1.0), (1.0, 0.0, 0.0, 0.0, 1.8))
    assert rows[:, 3].any() and np.array_equal(pushes, rows[:, 3] > 0)
    anywhere = PerturbationParameters(slide_demand=math.inf)
    turning = (1.0 + 0.5 * B * 0.8, 1.0 - 0.5 * B * 0.8)  # 0.8 rad/s at 1 m/s: v_t omega = 0.8 m/s^2
    rows, pushes, _ = sideways_rows(60, turning, turning, (1.0, 0.0, 0.8, 0.0, 2.6), anywhere)
    assert rows[:, 3].any() and not pushes.any()
    _, settled, _ = drive(300, (1.0, 1.0), (1.0, 1.0))  # the reference has reached the command
    rows, pushes, _ = sideways_rows(60, (1.0, 1.0), (0.0, 1.0), (1.0, 0.0, 0.0, 0.0, 1.8), P, settled)
    assert rows[:, 0].any() and rows[:, 3].any() and not pushes.any()
    never = PerturbationParameters(push_demand=0.0)
    rows, pushes, _ = sideways_rows(60, (1.0, 1.0), (1.0, 1.0), (1.0, 0.0, 0.0, 0.0, 1.8), never)
    assert rows[:, 3].any() and not pushes.any()
    for bad in (-0.1, math.nan):
        with pytest.raises(ValueError, match=r"push_demand=.*allowed \[0, inf\]"):
            PerturbationParameters(push_demand=bad)


def test_slide_test_keys_take_inf_and_reject_what_is_not_a_bound():
    """slide_threshold: .inf switches the slide test off, slide_demand: .inf runs it at any demand (from
    YAML too); zero, negative or NaN bounds name the key; a NaN estimate keeps the held demand."""
    for key in ("slide_threshold", "slide_demand"):
        scenario = scenario_from_yaml(
            "trajectory: {segments: [!Straight {length: 0.5, v_peak: 0.5}]}\n"
            f"perturbation_monitor: {{{key}: .inf}}\n"
        )
        assert getattr(scenario.perturbation_monitor, key) == math.inf
        for bad in (0.0, -1.0, math.nan):
            with pytest.raises(ValueError, match=rf"perturbation_monitor.{key}={bad!r} is out of range"):
                PerturbationParameters(**{key: bad})
    turning = (1.0 + 0.5 * B * 2.0, 1.0 - 0.5 * B * 2.0)
    _, state, theta = drive(10, turning, turning, (1.0, 0.0, 2.0, 0.0, 2.0))  # held demand 2 m/s^2
    held = state[HELD_DEMAND]
    state = perturbation_step(state, turning, theta, (1.0, 0.0, math.nan, 0.0, 2.0), P, (R, R), B, T_N)
    np.testing.assert_allclose(state[HELD_DEMAND], held * math.exp(-T_N / P.slide_demand_hold), rtol=1e-12)
    straight, pushed = (1.0, 1.0), (1.0, 0.0, 0.0, 0.0, 1.8)
    assert drive(60, straight, straight, pushed)[0][-1, 3] == 1
    off = PerturbationParameters(slide_threshold=math.inf)  # no slide test
    assert not drive(60, straight, straight, pushed, params=off)[0].any()


def test_missing_encoder_samples_hold_the_residual():
    _, state, theta = drive(300, (1.0, 1.0), (1.0, 1.0))  # the reference has reached the command
    for _ in range(50):
        state = perturbation_step(state, (1.0, 1.0), (math.nan, theta[1]), (1, 0, 0, 0, 0), P, (R, R), B, T_N)
        theta[1] += 1.0 * T_N / R
    assert state[-4:] == [0.0, 0.0, 0.0, 0.0]
    theta[0] += 50 * T_N / R  # the wheel turned meanwhile: its next increment spans the gap, not used
    rows, _, _ = drive(30, (1.0, 1.0), (1.0, 1.0), (1.0, 0, 0, 0, 0), state=state, theta=theta)
    assert not rows.any()


def test_system_matches_the_pure_function():
    system = PerturbationMonitor(P, (R, R), B, T_N)
    context = system.CreateDefaultContext()
    system.GetInputPort("wheel_speed_command").FixValue(context, [1.0, 1.0])
    system.GetInputPort("encoders").FixValue(context, [0.3, 0.2])
    system.GetInputPort("mixed_estimate").FixValue(context, [1.0, 0.0, 0.5, 0.0, 3.0])
    state = perturbation_initial_state()
    for _ in range(3):
        update = system.EvalUniquePeriodicDiscreteUpdate(context)
        context.SetDiscreteState(update)  # the state and the flags it outputs
        state = perturbation_step(state, [1.0, 1.0], [0.3, 0.2], [1.0, 0.0, 0.5, 0.0, 3.0], P, (R, R), B, T_N)
    np.testing.assert_array_equal(context.get_discrete_state(0).value(), state)
    np.testing.assert_array_equal(system.GetOutputPort("perturbation").Eval(context), state[-4:])


def test_bad_thresholds_name_the_key():
    with pytest.raises(ValueError, match=r"perturbation_monitor.yaw_threshold=0.0 is out of range"):
        PerturbationParameters(yaw_threshold=0.0)
    with pytest.raises(ValueError, match=r"perturbation_monitor.lateral_fraction=-0.1 is out of range"):
        PerturbationParameters(lateral_fraction=-0.1)
    with pytest.raises(ScenarioError, match=r"perturbation_monitor.confirm_samples=0 is out of range"):
        scenario_from_yaml(
            "trajectory: {segments: [!Straight {length: 0.5, v_peak: 0.5}]}\n"
            "perturbation_monitor: {confirm_samples: 0}\n"
        )


def test_closed_loop_held_wheel_flagged_and_fault_free_run_clean():
    """Corner, the right wheel held 0.5 s from 2 s (the benchmark's perturbation): braked within 0.1 s;
    the fault-free run raises no perturbation flag."""
    scenario = load_scenario("corner")
    clean = run_scenario(scenario, seed=1)
    assert clean.summary["perturbations"] == {}
    held = run_scenario(scenario, seed=1, faults=[FaultEvent("wheel_held", "wheel_R", 2.0, 0.5)])
    caught = held.summary["perturbations"]
    assert "wheel_R" in caught and caught["wheel_R"]["braked"] > 0
    assert 2.0 <= caught["wheel_R"]["first_s"] <= 2.1
    assert "wheel_L" not in caught


def force_run(p, disturbance, seconds=0.6, command=(1.0, 1.0)):
    """The discrete plant (plant_advance) at a constant command with ``disturbance`` held, read by the
    monitor's force test exactly (true angles, currents and accelerations, no quantisation): the
    per-side unexplained forces [e_R, e_L] of the last sample."""
    p_steps = round(T_N / 0.0005)
    x, loop = [0.0] * 10, [0.0] * 4
    state = perturbation_initial_state()
    params = PerturbationParameters(confirm_samples=100)
    for k in range(round(seconds / T_N)):
        x, loop, acc = plant_advance(x, loop, command, k * p_steps, p_steps, 0.0005, p, disturbance)
        estimate = (x[3], x[4], x[5], acc[0], acc[1])
        currents = motor_currents(loop, x, p)
        state = perturbation_step(
            state, command, x[6:8], estimate, params, (p.radius_R, p.radius_L), p.track_width, T_N,
            currents, p,
        )  # fmt: skip
    return np.array(state[-6:-4]), x


def test_force_balance_is_zero_for_the_nominal_robot_and_finds_a_hand_on_a_wheel_or_the_body():
    """Module docstring, 4.: with the plant's own model as the belief, the motors explain every force
    of a steady run (|e| < 0.01 m/s^2, shoe drag and bearing drag included); a torque tau on the right
    wheel shows on its side alone as tau / (r m); a push F along the heading on both sides as F / (2 m)
    (the plant's contact_forces and wheel equation, to 2 %)."""
    p = tinyphoon()
    clean, _ = force_run(p, NO_DISTURBANCE)
    np.testing.assert_allclose(clean, 0.0, atol=0.01)
    tau = 0.01
    pushed, x = force_run(p, (1.0, 1.0, 0.0, 0.0, tau, 0.0, 0.0, 0.0))
    assert x[3] > 0.8  # the speed loop still drives at about its command
    np.testing.assert_allclose(
        pushed, [tau / (p.radius_R * p.mass), 0.0], atol=0.02 * tau / (p.radius_R * p.mass)
    )
    force = -1.0
    pushed, _ = force_run(p, (1.0, 1.0, 0.0, 0.0, 0.0, 0.0, force, 0.0))
    np.testing.assert_allclose(pushed, [force / (2 * p.mass)] * 2, rtol=0.02)


def test_force_test_classifies_sides_and_needs_currents():
    """A right-wheel force along its motion is driven, against it braked; both sides alike is a push on
    the body; NaN currents (a replayed log) or implausible ones (beyond 1.5 x the driver's limit) leave
    every force flag off."""
    p = tinyphoon()
    params = PerturbationParameters(confirm_samples=1)

    def flags(disturbance, command=(1.0, 1.0), read=None):
        p_steps = round(T_N / 0.0005)
        x, loop, state = [0.0] * 10, [0.0] * 4, perturbation_initial_state()
        for k in range(300):
            x, loop, acc = plant_advance(x, loop, command, k * p_steps, p_steps, 0.0005, p, disturbance)
            currents = read if read is not None else motor_currents(loop, x, p)
            state = perturbation_step(
                state, command, x[6:8], (x[3], x[4], x[5], acc[0], acc[1]), params,
                (p.radius_R, p.radius_L), p.track_width, T_N, currents, p,
            )  # fmt: skip
        return state[-4:]

    assert flags((1.0, 1.0, 0.0, 0.0, 0.02, 0.0, 0.0, 0.0))[0:2] == [WHEEL_DRIVEN, 0]
    assert flags((1.0, 1.0, 0.0, 0.0, -0.02, 0.0, 0.0, 0.0))[0:2] == [WHEEL_BRAKED, 0]
    assert flags((1.0, 1.0, 0.0, 0.0, 0.0, 0.0, -2.0, 0.0)) == [0, 0, 0, 1]
    assert flags((1.0, 1.0, 0.0, 0.0, 0.02, 0.0, 0.0, 0.0), read=(math.nan, math.nan)) == [0, 0, 0, 0]
    assert flags(NO_DISTURBANCE, read=(1.6 * p.motor_current_limit, 0.0)) == [0, 0, 0, 0]
    assert flags(NO_DISTURBANCE, read=(1.4 * p.motor_current_limit, 0.0))[0] == WHEEL_BRAKED  # held back?
    assert flags(NO_DISTURBANCE) == [0, 0, 0, 0]


def test_closed_loop_push_on_a_wheel_and_on_the_body_flagged_within_100_ms():
    """Corner: the right wheel pushed with 0.6 x the motor's stall torque (the speed loop absorbs it: no
    speed band is left) and the body pushed backwards at 5 m/s^2 x its mass, each from 2 s: the force
    balance flags wheel_R driven, and body, within 0.1 s; pushed to either side, the slide test flags
    body within 0.1 s."""
    scenario = load_scenario("corner")
    robot = scenario.robot_parameters()
    tau = 0.6 * robot.motor_constant * robot.motor_current_limit
    wheel = run_scenario(scenario, seed=1, faults=[FaultEvent("wheel_pushed", "wheel_R", 2.0, 0.5, tau)])
    caught = wheel.summary["perturbations"]
    assert caught["wheel_R"]["driven"] > 0 and caught["wheel_R"]["braked"] == 0
    assert 2.0 <= caught["wheel_R"]["first_s"] <= 2.1 and "wheel_L" not in caught
    body = run_scenario(
        scenario, seed=1, faults=[FaultEvent("body_push", "body_t", 2.0, 0.5, -5.0 * robot.mass)]
    )
    caught = body.summary["perturbations"]
    assert 2.0 <= caught["body"]["first_s"] <= 2.1
    assert "wheel_R" not in caught and "wheel_L" not in caught
    for side in (1.0, -1.0):  # sideways, a push the tyres hold: the slide test (28-36 ms)
        event = FaultEvent("body_push", "body_n", 2.0, 0.5, side * 5.0 * robot.mass)
        caught = run_scenario(scenario, seed=1, faults=[event]).summary["perturbations"]
        assert set(caught) == {"body"} and 2.0 <= caught["body"]["first_s"] <= 2.1


@pytest.mark.parametrize("seed, tolerances", [(0, False), (1, True)])
def test_a_sideways_push_is_integrated_not_taken_for_tyre_force(seed, tolerances):
    """Square, closed loop, the body pushed to the left at 5 m/s^2 x its mass for 0.5 s from 2 s (slipnav
    faults' body_push body_n): beyond the tyres' grip, the robot slides sideways at up to 0.48 m/s. The
    monitor's sideways flag (the slide and lateral tests) tells the mixer the tyre curve does not hold,
    and v_n follows the lateral kinematics: its RMS error over 2.05-2.5 s is 0.005-0.03 m/s (0.30-0.32
    when the mixer read the push as tyre force and anchored the integral where the tyres held it, the
    fused pose then no better than Gyrodometry's, which ignores side slip). The fused final position
    error is below both baselines'."""
    scenario = load_scenario("square")
    event = FaultEvent("body_push", "body_n", 2.0, 0.5, 5.0 * scenario.robot_parameters().mass)
    a = run_scenario(scenario, seed=seed, tolerances=tolerances, faults=[event]).arrays
    t, lag = a["t"], 2  # the estimate describes the truth two samples back (docs/artifacts.md)
    push = (t[:-lag] >= 2.05) & (t[:-lag] <= 2.5)
    assert np.max(a["true_v_n"][:-lag][push]) > 0.4
    error = a["est_v_n"][lag:][push] - a["true_v_n"][:-lag][push]
    assert np.sqrt(np.mean(error**2)) < 0.05
    fused, odometry, gyrodometry = (final_position_error(a, k) for k in ("est", "odo", "gyro"))
    assert fused < 0.7 * min(odometry, gyrodometry)


def test_a_stuck_encoder_raises_no_wheel_flag_on_the_closed_loop():
    """The monitor reads the navigation's checked encoders: a stuck right encoder on the corner (0.5 s)
    is excluded and replaced by the other wheel and the gyro, so no wheel reads as held (reading the raw
    counts, 301 samples of wheel_R flags)."""
    scenario = load_scenario("corner")
    stuck = run_scenario(scenario, seed=0, faults=[FaultEvent("stuck", "encoder_R", 2.11, 0.5)])
    assert stuck.summary["sensor_health"]["encoder_R"]["first_s"] <= 2.21
    assert stuck.summary["perturbations"] == {}


def test_a_stuck_encoder_at_the_current_limit_is_not_a_held_wheel():
    """Kurt3D's circle, encoder_R stuck for 0.5 s from 2.446 s (0.1 s before its largest reading, as
    slipnav faults injects it): the motors run at their current limit in that turn, so the current
    cannot tell the speed loop from a hand. The monitor reads the sensor checks' angles, the replaced
    one for the excluded encoder, and flags nothing (reading the raw counts it flagged wheel_R braked
    for 270 ms; with the former rule that took an excluded encoder's wheel as commanded below 0.9 of the
    current limit, a 3-sample body flag)."""
    from slipnav.systems.robot.faults import FaultEvent

    scenario = load_scenario("circle")
    a = run_scenario(
        scenario, seed=0, duration=3.2, faults=[FaultEvent("stuck", "encoder_R", 2.446, 0.5)]
    ).arrays
    t = a["t"]
    during = (t >= 2.446) & (t < 2.946)
    assert np.any(a["health_encoder_R"][during] > 0)
    limit = scenario.robot_parameters().motor_current_limit
    assert np.max(np.abs(a["meas_current_R"][during])) > 0.9 * limit
    for channel in ("wheel_R", "wheel_L", "yaw", "body"):
        assert not np.any(a[f"perturbation_{channel}"]), channel
