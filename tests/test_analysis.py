"""Linear analysis of the navigation and slip-control recursions (issue 5): the EKF's error dynamics with
Drake's observability/detectability helpers, fixed points of C1 S(12) and of the step size S(22), and the
limit cycle the paper warns of for a large q_delta."""

import dataclasses as dc
import math

import numpy as np
import pytest
from pydrake.systems.primitives import IsDetectable, IsObservable, LinearSystem
from slipnav.scenarios.config import load_scenario
from slipnav.scenarios.metrics import tangential_slip_speed
from slipnav.scenarios.runner import run_scenario
from slipnav.systems.control.slip_control import StepSizeParameters, step_size
from slipnav.systems.navigation.ekf import (
    MEASUREMENT_MATRIX,
    EkfParameters,
    ekf_gain,
    ekf_jacobian,
    ekf_joseph,
)
from slipnav.systems.navigation.mixing.parameters import MixingParameters
from slipnav.systems.navigation.mixing.tyre_curve import side_slip_from_accelerations
from slipnav.systems.navigation.mixing.weights import logsig, mixing_c1

T_N = 0.002
OPERATING_POINT = np.array([1.5, 0.1, 3.0, 0.0, 0.0])  # v_t, v_n, omega, a_t, a_n: a steady turn


def discrete_pair(G, C):
    return LinearSystem(G, np.zeros((5, 1)), C, np.zeros((C.shape[0], 1)), T_N)


def steady_gain(G, Q, R, P0, iterations=5000):
    """Iterate S(6), S(7), S(9) at a fixed operating point until the gain settles."""
    P = P0
    for _ in range(iterations):
        P_prior = G @ P @ G.T + Q
        L = ekf_gain(P_prior, R)
        P = ekf_joseph(P_prior, L, R)
    return L


def test_measurements_observe_omega_and_accelerations_but_not_the_velocities():
    G = ekf_jacobian(OPERATING_POINT, T_N)
    C = MEASUREMENT_MATRIX
    assert not IsObservable(discrete_pair(G, C))
    # The velocity block is a forward-Euler rotation with |lambda| = sqrt(1 + (omega T_N)^2) > 1 and is
    # not seen by y = [omega, a_t, a_n]: not detectable, which is why Fig. 3 overwrites v_t, v_n.
    assert not IsDetectable(discrete_pair(G, C))
    velocity_block = np.linalg.eigvals(G[:2, :2])
    np.testing.assert_allclose(np.abs(velocity_block), math.hypot(1.0, 3.0 * T_N))
    # Observability matrix rank 3: exactly omega, a_t, a_n.
    O = np.vstack([C @ np.linalg.matrix_power(G, k) for k in range(5)])
    assert np.linalg.matrix_rank(O) == 3
    # With odometric v_t and a v_n pseudo-measurement (the mixer's relaxation) the pair is observable.
    C_mixed = np.vstack([C, np.eye(5)[0:2]])
    assert IsObservable(discrete_pair(G, C_mixed))


def test_ekf_error_dynamics_with_mixing_feedback_are_stable():
    """(I - L C) G at a steady operating point: the measured block is stable; with the mixed estimate
    fed back (C1 = 1: odometric v_t; C2 = 1: v_n relaxed by q2, C2 = 0: by the slope-weighted q_I of
    S(17) with the tyre model; C3 = 1: odometric omega) every mode is. The tyre model's own dependence on
    v_t and omega is neglected (second order: dm/dv_t ~ 2 alpha); its dependence on the measured a_t, a_n
    moves no eigenvalue (their errors evolve on their own: A[2:, :2] = 0, block triangular)."""
    Q, R, P0 = EkfParameters().matrices()
    G = ekf_jacobian(OPERATING_POINT, T_N)
    L = steady_gain(G, Q, R, P0)
    A = (np.eye(5) - L @ MEASUREMENT_MATRIX) @ G
    measured = np.linalg.eigvals(A[2:, 2:])
    assert np.all(A[2:, :2] == 0.0)
    assert np.all(np.abs(measured) < 1.0)
    p = MixingParameters()
    v_t, omega = OPERATING_POINT[0], OPERATING_POINT[2]
    # The tyres carry the turn's a_n = v_t omega and the shoes' drag: u = |a| / a_peak.
    utilisation = side_slip_from_accelerations(v_t, v_t, 0.0, v_t * omega, p)[1]
    assert utilisation == pytest.approx(math.hypot(0.49 + 0.25 * v_t, v_t * omega) / 5.49)
    q_inertial = 1.0 - (1.0 - p.q2_inertial) * math.sqrt(1.0 - utilisation**2)
    assert q_inertial < 1.0
    for c1, c2, c3 in [(1.0, 1.0, 1.0), (0.0, 0.0, 0.0), (0.5, 0.5, 0.5)]:
        # Error propagation of the mixed estimate: odometric parts carry no inertial error.
        M = np.diag([1.0 - c1, (1.0 - c2) * q_inertial + c2 * p.q2, 1.0 - c3, 1.0, 1.0])
        eig = np.abs(np.linalg.eigvals(M @ A))
        if c1 > 0 and c2 > 0:
            assert np.all(eig < 1.0), (c1, c2, c3, eig)
    # Purely inertial (C1 = C2 = 0) with the paper's S(17) (q_I = 1): the velocity error is not
    # contracted, it grows by sqrt(1 + (wT)^2). The tyre model's pull on v_n contracts both (v_t's error
    # only through the rotation into v_n, slowly).
    eig = np.abs(np.linalg.eigvals(np.diag([1.0, 1.0, 1.0, 1.0, 1.0]) @ A))
    assert np.max(eig) == pytest.approx(math.hypot(1.0, 3.0 * T_N), rel=1e-9)
    eig = np.abs(np.linalg.eigvals(np.diag([1.0, q_inertial, 1.0, 1.0, 1.0]) @ A))
    assert np.max(eig) < 1.0


def test_c1_pt1_fixed_point_and_pole():
    p = MixingParameters()
    for dv in (0.0, 0.03, 0.2):
        fixed = logsig(p.a1, dv, p.b1)
        c1 = 1.0 - fixed if fixed < 0.5 else 0.0
        errors = []
        for _ in range(30):
            c1 = mixing_c1(c1, dv, p)
            errors.append(c1 - fixed)
        assert abs(errors[-1]) < 1e-8
        ratios = np.array(errors[1:8]) / np.array(errors[:7])
        np.testing.assert_allclose(ratios, p.p, rtol=1e-9)  # the PT1 pole S(12)
    assert 0.0 <= p.p < 1.0


def test_step_size_recursion_fixed_points():
    """S(22) at constant C1 and alpha is delta_K = clip(g delta_K-1) with g = delta_min + s (q - delta_min):
    g > 1 drives delta to the S(23) bound (stable, saturation); g < 1 to delta_min."""
    p = StepSizeParameters()
    for c1, alpha, lag, expected in [
        (1.0, 0.0, 0.0, 1.0),
        (1.0, 0.0, 2.0, p.delta_max),
        (1.0, 0.0, -2.0, p.delta_rem),
        (0.0, 0.0, 0.0, p.delta_min),
        (1.0, math.radians(10), 0.0, p.delta_min),
    ]:
        for delta0 in (p.delta_min, 1.0, p.delta_max):
            delta = delta0
            for _ in range(200):
                delta = step_size(delta, c1, alpha, lag, p)
            assert delta == pytest.approx(expected), (c1, alpha, lag, delta0)
    # The neutral switch value s* where g = 1 separates the two basins.
    s_star = (1.0 - p.delta_min) / (p.q_delta - p.delta_min)
    assert 0.0 < s_star < 1.0


def step_sequence(a):
    """delta_K once per control sample."""
    return a["step_size"][:: int(round(float(a["T_C"]) / float(a["T_N"])))]


def slip_speed(a):
    """|wheel-centre speed - ground speed| per sample (m/s): the tangential slip speed."""
    return np.abs(tangential_slip_speed(a))


def slip_distance(a):
    """Wheel travel lost to tangential slip (m): the integral of the slip speed."""
    return np.trapezoid(slip_speed(a), a["t"])


def heavy_slip_episodes(a, threshold=0.3):
    """Number of onsets of slip faster than `threshold` m/s."""
    return int(np.sum(np.diff((slip_speed(a) > threshold).astype(int)) == 1))


def test_large_q_delta_produces_the_limit_cycle_the_paper_warns_of():
    """Square, closed loop, with the paper's S(12) (C1 from each batch's dv alone). Default q_delta: after
    a cut delta grows geometrically (<= 5 % per T_C) and settles. Large q_delta: delta saws between
    delta_min and delta_max, each jump re-accelerating the robot into new wheel spin (S(22) with q too
    large, §V). With the summed dv (mixing.dv_memory) the cycle recurs as well, but C1 catches each
    re-spin earlier: less wheel travel is lost (measured 0.46 m against 0.51 m since the online
    gyro/odometry calibration; 0.39 against 0.45 with the earlier gyro bias estimate, 0.30 against 0.53
    before the creep compensation of S(15))."""
    scenario = load_scenario("square")
    default_mixing = scenario.navigation.mixing
    scenario.navigation.mixing = dc.replace(default_mixing, dv_memory=0.0)
    default = run_scenario(scenario, duration=4.0).arrays
    scenario.slip_control = dc.replace(scenario.slip_control, q_delta=2.5, delta_max=2.5)
    large = run_scenario(scenario, duration=4.0).arrays
    up_default = np.diff(step_sequence(default))
    assert np.max(up_default) <= 0.06
    scenario.navigation = dc.replace(scenario.navigation, mixing=default_mixing)
    summed = run_scenario(scenario, duration=4.0).arrays
    for run in (large, summed):
        up_large = np.diff(step_sequence(run))
        assert np.sum(up_large > 0.2) >= 4  # repeated large jumps: the cycle recurs
        lows = step_sequence(run) <= scenario.slip_control.delta_min + 1e-9
        assert np.sum(np.diff(lows.astype(int)) == 1) >= 4  # and keeps falling back to delta_min
    # every jump re-spins the wheels: more heavy-slip episodes and more than twice the wheel travel lost
    assert heavy_slip_episodes(large) >= 2 * heavy_slip_episodes(default)
    assert slip_distance(large) >= 2.0 * slip_distance(default)
    assert slip_distance(summed) < 0.95 * slip_distance(large)


# --- path following: Drake's Linearize on the scalar-generic closed loop --------------------------------


def linearised_loop(params, kappa, u, T_C=0.02):
    from pydrake.systems.framework import InputPortSelection, OutputPortSelection
    from pydrake.systems.primitives import Linearize
    from slipnav.systems.control.frenet_loop import FrenetFollowingErrors

    system = FrenetFollowingErrors(params, kappa, u, T_C)
    context = system.CreateDefaultContext()  # zero error: an equilibrium for every kappa
    return system, Linearize(system, context, InputPortSelection.kNoInput, OutputPortSelection.kNoOutput)


@pytest.mark.parametrize("kappa", [0.0, 1.0 / 3.0, -0.5])
@pytest.mark.parametrize("u", [0.5, 2.05, 4.1])
def test_path_following_linearisation_is_stable_for_default_gains(kappa, u):
    from slipnav.systems.control.path_follower import PathFollowerParameters

    _, lin = linearised_loop(PathFollowerParameters(), kappa, u)
    assert lin.time_period() == 0.02
    assert np.max(np.abs(np.linalg.eigvals(lin.A()))) < 1.0


def test_unstable_gain_set_is_reported_unstable():
    """k2 T_C > 2: the sampled heading loop overshoots within one sample (|1 - k2 T_C| > 1)."""
    from slipnav.systems.control.path_follower import PathFollowerParameters

    gains = object.__new__(PathFollowerParameters)  # bypass the range checks on purpose
    gains.__dict__.update(dc.asdict(PathFollowerParameters()), k2=150.0)
    _, lin = linearised_loop(gains, 0.0, 2.0)
    eig = np.abs(np.linalg.eigvals(lin.A()))
    assert np.max(eig) > 1.0
    assert np.max(eig) == pytest.approx(abs(1.0 - 150.0 * 0.02), rel=0.2)


def test_linearised_and_nonlinear_responses_agree_for_small_perturbations():
    from pydrake.systems.analysis import Simulator
    from slipnav.systems.control.path_follower import PathFollowerParameters

    system, lin = linearised_loop(PathFollowerParameters(), 1.0 / 3.0, 2.0)
    for scale in (1e-3, 1e-2):
        x0 = scale * np.array([1.0, -1.0, 0.5])
        simulator = Simulator(system)
        simulator.get_mutable_context().SetDiscreteState(x0)
        x_lin = x0.copy()
        for k in range(1, 51):
            simulator.AdvanceTo(k * 0.02)
            x_lin = lin.A() @ x_lin
            x_nl = simulator.get_context().get_discrete_state_vector().CopyToVector()
            # The difference is second order in the perturbation.
            assert np.linalg.norm(x_nl - x_lin) < 5.0 * scale**2 + 1e-12, (scale, k)
        assert np.linalg.norm(x_nl) < 0.5 * np.linalg.norm(x0)  # and both decay


# --- Indiveri I(24): when the speed law's switch slides (issue 48) ------------------------------------


def straight_line_loop(follower, seconds: float, T_N=0.002, T_C=0.02, time_step=0.0005):
    """Indiveri's follower and I(24) every T_C on a 60 m straight path around Kurt3D's plant (plant_advance:
    its PI speed loop at 100 Hz, the motors' current and voltage limits, the tyres), from rest, localised
    by the plant's own pose and speed (no navigation), the command acting from the next T_N sample as in
    the closed loop. Per control instant: [t, u of I(24), robot speed v, V1, s1]."""
    from slipnav.scenarios.trajectories import PathConfig, Straight, build_path
    from slipnav.systems.control.path_follower import (
        bounded_speed,
        follower_step,
        saturate_wheel_speeds,
        speed_law,
    )
    from slipnav.systems.robot.dynamics import plant_advance
    from slipnav.systems.robot.parameters import kurt3d

    robot, path = kurt3d(), build_path(PathConfig(segments=[Straight(length=60.0)]))
    V_m, half = robot.wheel_speed_limit, 0.5 * robot.track_width
    n, sub = round(T_C / T_N), round(T_N / time_step)
    x, loop, command = [0.0] * 10, [0.0] * 4, (0.0, 0.0)
    state = [0.0, 0.0, 0.0, math.inf, 0.0, 0.0, 0.0]  # FollowerState
    rows = []
    for K in range(round(seconds / T_C)):
        if follower.delayed_speed_law:
            u = bounded_speed(state[3], 0.0, V_m, half, follower.epsilon)
        else:
            u = speed_law(x[0:3], state[0], path, follower, V_m, half)[0]
        state = follower_step(state[0], x[0:3], u, path, follower, half, T_C, x[3])
        rows.append((K * T_C, u, x[3], state[3], state[4]))
        for i in range(n):
            x, loop, _ = plant_advance(x, loop, command, (K * n + i) * sub, sub, time_step, robot)
            command = saturate_wheel_speeds(state[1], state[2], V_m)
    return np.array(rows)


def branch_switches(u, V_m=4.1) -> int:
    """How often I(24) changes branch (u = V_m/2 <-> V_m on a straight path)."""
    high = u > 0.75 * V_m
    return int(np.sum(high[1:] != high[:-1]))


def test_i16_map_fixed_point_decides_whether_the_i24_switch_slides():
    """The follower's T_C map on a straight path (kappa_r = 0, y1 = theta = 0, so V1 = s1^2/2), the robot
    moving at v over the sample: s1+ = (1 - k1 T_C) s1 - T_C (u16 - v) (I(11) with I(16)), u16 the speed
    I(16) reads. Fixed point s1* = -(u16 - v)/k1, multiplier 1 - k1 T_C = 0.96: stable.

    u16 = the robot's speed v: s1* = 0 whatever u and v; on the surface V1 = epsilon both branches of I(24)
    contract V1 (factor 0.96^2): the surface is crossed downwards only, I(24) switches once (I(17) in
    discrete time). u16 = the command u: s1* = -(u - v)/k1, and V1* = (u - v)^2 / (2 k1^2) >= epsilon
    once the robot lags the command by k1 sqrt(2 epsilon) = 0.632 m/s; on the surface (s1 = -sqrt(2
    epsilon), the target ahead) the V_m branch raises V1 while v < V_m - 0.632 = 3.47 m/s and the V_m/2
    branch lowers it while v > V_m/2 - 0.632 = 1.42 m/s: between, both point at the surface, a sliding
    mode, which the sampled switch runs as chattering at T_C."""
    from slipnav.scenarios.trajectories import PathConfig, Straight, build_path
    from slipnav.systems.control.path_follower import PathFollowerParameters, follower_step

    path, T_C, V_m = build_path(PathConfig(segments=[Straight(length=20.0)])), 0.02, 4.1
    robots_speed, command = PathFollowerParameters(), PathFollowerParameters(use_estimated_speed=False)
    eps, k1 = robots_speed.epsilon, robots_speed.k1
    s1_surface = -math.sqrt(2.0 * eps)

    def next_s1(p, s1, u, v, s=5.0):
        s_next = follower_step(s, (s + s1, 0.0, 0.0), u, path, p, 0.2, T_C, u_measured=v)[0]
        return s + s1 + v * T_C - s_next

    for v in np.linspace(0.5, 4.1, 10):
        for u in (0.5 * V_m, V_m):
            for p, u16 in ((robots_speed, v), (command, u)):
                expected = (1.0 - k1 * T_C) * s1_surface - T_C * (u16 - v)
                assert next_s1(p, s1_surface, u, v) == pytest.approx(expected, abs=1e-12)
            assert next_s1(robots_speed, s1_surface, u, v) ** 2 / 2 < 0.93 * eps  # 0.96^2 = 0.92
        rises = next_s1(command, s1_surface, V_m, v) ** 2 / 2 > eps
        falls = next_s1(command, s1_surface, 0.5 * V_m, v) ** 2 / 2 < eps
        band = 0.5 * V_m - k1 * math.sqrt(2 * eps) < v < V_m - k1 * math.sqrt(2 * eps)
        assert (rises and falls) == band, v
    s1 = 0.0  # the map's fixed point under the command: the robot at V_m/2, I(24) at V_m
    for _ in range(500):
        s1 = next_s1(command, s1, V_m, 0.5 * V_m)
    assert s1 == pytest.approx(-(0.5 * V_m) / k1, rel=1e-6)  # s1* = -1.025 m: V1* = 0.525 >> epsilon
    assert s1**2 / 2 == pytest.approx(0.5253125, rel=1e-5)


def test_commanded_speed_in_i16_slides_on_the_switching_surface_on_kurt3d():
    """The chattering of the single-u reading (I(16) on the command u) explained on Kurt3D's plant: from
    rest I(24) picks V_m at once (V1 = 0), the robot cannot follow (2 x 90 W: about 4 m/s^2 from rest,
    less with speed), the target runs ahead and V1 reaches epsilon within 0.12 s. Then the loop slides:
    s1 stays at -sqrt(2 epsilon) = -0.316 m, the mean u exceeds the robot's speed by the equivalent
    control's k1 sqrt(2 epsilon) = 0.632 m/s (the target's mean s_dot = u + k1 s1 equals v), and the
    branch changes almost every T_C. The speed loop brakes harder than the motors accelerate at the top of
    their range, so the robot holds near V_m/2 (measured 2.05 m/s, 173 switches in 6 s): the ~50 % time
    saving cannot come. (Indiveri's long path, closed loop, seed 0: 1267 switches, 99 % of the constant
    law's time.)"""
    from slipnav.systems.control.path_follower import PathFollowerParameters

    p = PathFollowerParameters(use_estimated_speed=False, delayed_speed_law=False)
    t, u, v, V1, s1 = straight_line_loop(p, 6.0).T
    assert V1[t <= 0.12].max() >= p.epsilon
    assert branch_switches(u) >= 150
    sliding = t >= 3.0
    assert np.mean(s1[sliding]) == pytest.approx(-math.sqrt(2 * p.epsilon), rel=0.05)
    assert np.mean(u[sliding] - v[sliding]) == pytest.approx(p.k1 * math.sqrt(2 * p.epsilon), rel=0.05)
    assert np.max(v) < 0.53 * 4.1


def test_paper_mode_speed_law_switches_once_on_kurt3d():
    """Paper mode's follower (I(15)-(16) on the robot's speed, I(24) on V1 of the same instant) on the
    same plant: V1 stays below 1 % of epsilon (the target never leads: s1* = 0), I(24) stays on V_m
    without a single switch, and Kurt3D reaches 0.95 V_m in 1.64 s, as fast as its motors allow. Fails
    on the single-u reading (test above)."""
    from slipnav.scenarios.paper import paper_mode

    p = paper_mode(load_scenario("long_path")).follower
    t, u, v, V1, _ = straight_line_loop(p, 6.0).T
    assert branch_switches(u) <= 1
    assert np.max(V1[1:]) < 0.01 * p.epsilon
    assert t[np.argmax(v >= 0.95 * 4.1)] < 1.7
    assert np.all(u[2:] == 4.1)
