"""Physics of the slipping robot plant (systems/robot/plant.py)."""

import dataclasses
import math

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator
from scipy.integrate import solve_ivp
from slipnav.systems.navigation.mixing.tyre_curve import (
    lateral_velocity_model,
    longitudinal_slip_speed,
    side_slip_from_accelerations,
)
from slipnav.systems.rates import SampleRates
from slipnav.systems.robot.contact import contact_forces, tyre_force
from slipnav.systems.robot.dynamics import PlantState, kinetic_energy, plant_advance, plant_derivatives
from slipnav.systems.robot.motors import motor_current, motor_currents, speed_loop_update
from slipnav.systems.robot.parameters import GRAVITY, RobotParameters, kurt3d, robot_parameters, tinyphoon
from slipnav.systems.robot.plant import DEFAULT_TIME_STEP, DifferentialDrivePlant

T_C = 0.02


def ramp(v_end, t_ramp, t_total, omega_frac=0.0, track_width=0.068):
    """Wheel-speed table at T_C: linear ramp of v to v_end, optional yaw rate omega = omega_frac*v."""
    t = np.arange(int(t_total / T_C) + 1) * T_C
    v = v_end * np.clip(t / t_ramp, 0.0, 1.0)
    w = omega_frac * v
    return np.column_stack([v + 0.5 * track_width * w, v - 0.5 * track_width * w])


@pytest.mark.parametrize("shoes, tolerance", [(False, 0.01), (True, 0.025)])
def test_gentle_commands_roll_without_slip_and_follow_S1(open_loop, shoes, tolerance):
    """In the no-slip regime the true pose equals S(1) integrated from the wheel speeds (v_n = 0).

    S(1) integrated with the plant's own (v_t, v_n, omega) reproduces its pose (kinematic consistency).
    The no-slip unicycle driven by the wheel speeds alone misses only the small linear-tyre side slip of
    the turn (~0.6 %) and, with Tinyphoon's felt shoes, the ~1 % creep that pushes against their drag.
    """
    p = tinyphoon()
    if not shoes:
        p = p.replace(wheel_load_fraction=1.0, shoe_friction=0.0, shoe_viscous_drag=0.0)
    # 0.8 m/s reached in 1 s (0.8 m/s^2 << mu*g), then a 1 m radius turn: a_n = 0.64 m/s^2.
    table = ramp(0.8, 1.0, 3.0, omega_frac=1.0, track_width=p.track_width)
    a = open_loop(p, table, 3.0)
    rolling = a["t"] > 0.1
    slip_speed = 0.5 * (a["true_wheel_R"] + a["true_wheel_L"]) - a["true_v_t"]
    assert np.max(np.abs(slip_speed[rolling])) < 0.02  # r*theta_dot ~ v_t within 2 cm/s
    assert np.max(np.abs(a["true_v_n"])) < 0.01 * 0.8  # v_n ~ 0: under 1 % of the speed
    # Steady turn: the small slip angle is the linear-tyre one, alpha = m*a_n / (2*mu*N*B*C).
    v_end, w_end = a["true_v_t"][-1], a["true_omega"][-1]
    cornering_stiffness = p.tyre_friction * p.wheel_normal_load * 15.0 * 1.3
    expected_alpha = -p.mass * v_end * w_end / (2 * cornering_stiffness)
    assert a["true_alpha"][-1] == pytest.approx(expected_alpha, rel=0.1)

    t = a["t"]

    def s1(tau, q):
        v_t, v_n, w = (np.interp(tau, t, a[k]) for k in ("true_v_t", "true_v_n", "true_omega"))
        c, s = math.cos(q[2]), math.sin(q[2])
        return [v_t * c - v_n * s, v_t * s + v_n * c, w]

    sol = solve_ivp(s1, (0.0, t[-1]), [0.0, 0.0, 0.0], rtol=1e-9, atol=1e-12, max_step=0.002)
    np.testing.assert_allclose(sol.y[:, -1], [a["true_x"][-1], a["true_y"][-1], a["true_phi"][-1]], atol=2e-4)

    # Independent integration of the no-slip unicycle from the wheel speeds (S(10) into S(1), v_n = 0).

    def rhs(tau, q):
        v_R = np.interp(tau, t, a["true_wheel_R"])
        v_L = np.interp(tau, t, a["true_wheel_L"])
        v, w = 0.5 * (v_R + v_L), (v_R - v_L) / p.track_width
        return [v * math.cos(q[2]), v * math.sin(q[2]), w]

    sol = solve_ivp(rhs, (0.0, t[-1]), [0.0, 0.0, 0.0], rtol=1e-9, atol=1e-12, max_step=0.002)
    x, y, phi = sol.y[:, -1]
    distance = np.sum(np.hypot(np.diff(a["true_x"]), np.diff(a["true_y"])))
    assert distance > 1.5
    position_error = math.hypot(x - a["true_x"][-1], y - a["true_y"][-1])
    assert position_error < tolerance * distance
    assert abs(phi - a["true_phi"][-1]) < tolerance * abs(a["true_phi"][-1])


def test_tangential_slip_onset_near_mu_g(open_loop):
    """Commanded accelerations below the traction limit roll; above it the wheels spin."""
    p = tinyphoon()
    a_lim = p.traction_limit_acceleration  # mu * g * wheel_load_fraction = 5.49 m/s^2
    gentle = open_loop(p, ramp(0.6 * a_lim * 0.4, 0.4, 0.6), 0.6)
    hard = open_loop(p, ramp(1.6 * a_lim * 0.4, 0.4, 0.6), 0.6)
    gentle_slip = 0.5 * (gentle["true_wheel_R"] + gentle["true_wheel_L"]) - gentle["true_v_t"]
    hard_slip = 0.5 * (hard["true_wheel_R"] + hard["true_wheel_L"]) - hard["true_v_t"]
    # Gentle: the body follows the commanded ramp; only the T_C staircase leaves transient slip.
    assert np.max(np.abs(gentle_slip)) < 0.15
    assert np.mean(np.abs(gentle_slip)) < 0.03
    assert gentle["true_v_t"][-1] == pytest.approx(0.6 * a_lim * 0.4, rel=0.03)
    assert np.max(hard_slip) > 0.5  # the wheels run away from the body
    assert np.max(hard["true_slip_R"]) > 0.3
    # While spinning, the body accelerates at about mu*g (sliding friction mu*sin(C*pi/2) of the peak,
    # less the felt shoes' drag).
    window = (hard["t"] > 0.1) & (hard["t"] < 0.35)
    achieved = np.polyfit(hard["t"][window], hard["true_v_t"][window], 1)[0]
    assert 0.75 * a_lim < achieved < 1.0 * a_lim


@pytest.mark.parametrize("factor, slides", [(0.5, False), (1.3, True)])
def test_cornering_slides_above_mu_g(open_loop, factor, slides):
    """Lateral acceleration v^2/R below the traction limit holds the line; above it the robot slides."""
    p = tinyphoon()
    v = 1.2
    radius = v**2 / (factor * p.traction_limit_acceleration)
    n = int(1.5 / T_C) + 1
    w = v / radius
    table = np.tile([v + 0.5 * p.track_width * w, v - 0.5 * p.track_width * w], (n, 1))
    a = open_loop(p, table, 1.5, initial_speed=v)
    alpha = np.degrees(np.abs(a["true_alpha"][a["t"] > 0.3]))
    # Linear-tyre slip angle needed for the lateral force m*v^2/R: m*a_n / (2*mu*N*B*C).
    linear = np.degrees(p.mass * v**2 / radius / (2 * p.tyre_friction * p.wheel_normal_load * 15 * 1.3))
    if slides:  # the tyres saturate: several degrees, far beyond the linear-tyre angle
        assert np.max(alpha) > 3.0
        assert np.max(alpha) > 2.5 * linear
    else:  # holds the line at the small linear-tyre angle, steady
        assert np.max(alpha) == pytest.approx(linear, rel=0.15)
        assert np.ptp(alpha) < 0.1


def test_energy_is_dissipated_with_motors_off():
    """With zero motor current, tyres, shoes and bearings only remove kinetic energy (dE/dt <= 0)."""
    rng = np.random.default_rng(1)
    for p in (tinyphoon(), kurt3d()):
        for _ in range(2000):
            state = np.zeros(10)
            state[3:6] = rng.normal(0.0, [2.0, 0.5, 5.0])
            state[8:10] = rng.normal(state[3], 1.0, 2) / p.wheel_radius
            xdot, _ = plant_derivatives(state, (0.0, 0.0), p)
            s, d = PlantState(state), PlantState(np.array(xdot))
            power = (
                p.mass * (s.v_t * d.v_t + s.v_n * d.v_n)
                + p.yaw_inertia * s.omega * d.omega
                + p.wheel_inertia * (s.w_R * d.w_R + s.w_L * d.w_L)
            )
            assert power <= 1e-9 * (1.0 + abs(kinetic_energy(state, p)))

    # A coasting slide integrated with scipy: energy decreases monotonically to rest.
    p = tinyphoon()
    x0 = np.array([0, 0, 0, 2.0, 0.5, 3.0, 0, 0, 0.0, 3.0 / p.wheel_radius])
    sol = solve_ivp(
        lambda t, x: plant_derivatives(x, (0.0, 0.0), p)[0],
        (0, 2.5),
        x0,
        method="LSODA",
        max_step=1e-3,
        rtol=1e-8,
        atol=1e-10,
    )
    energy = np.array([kinetic_energy(x, p) for x in sol.y.T])
    assert np.all(np.diff(energy) <= 1e-9)
    assert energy[-1] < 0.01 * energy[0]  # shoes' drag (~1.2 m/s^2) stops it within ~1.7 s


def test_tyre_force_saturates_on_the_friction_circle():
    p = tinyphoon()
    n = 1.5
    for kappa, tan_a in [(0.05, 0.0), (1.0, 0.0), (0.0, 0.3), (0.4, -0.4), (3.0, 2.0)]:
        v_x = 1.0
        f_x, f_y, k, ta = tyre_force(v_x, tan_a * v_x, v_x * (1 + kappa), n, p)
        assert k == pytest.approx(kappa / (1 + kappa) if kappa > 0 else kappa)
        magnitude = math.hypot(f_x, f_y)
        sigma = math.hypot(k, ta)
        expected = p.tyre_friction * n * math.sin(1.3 * math.atan(15.0 * sigma))
        assert magnitude == pytest.approx(expected)
        assert magnitude <= p.tyre_friction * n + 1e-12
        # Force anti-parallel to the contact slip velocity (r*w - v_x, -v_y) direction.
        if sigma > 0:
            assert f_x * k >= 0 and f_y * ta <= 0


def test_speed_loop_tracks_and_saturates():
    p = tinyphoon()
    state = [0.0, 0.0, 0.0, 0.0]
    out = speed_loop_update(state, (1.0, -1.0), (0.0, 0.0), p)
    assert out[2] == p.supply_voltage and out[3] == -p.supply_voltage  # saturated
    assert out[0] == 0.0  # integral frozen while saturated (anti-windup)
    small = speed_loop_update(state, (0.01, 0.0), (0.0, 0.0), p)
    e = 0.01 / p.wheel_radius
    assert small[2] == pytest.approx(p.speed_loop_kp * e + p.speed_loop_ki * e * p.speed_loop_period)


def test_reference_robots_match_design_figures():
    t = tinyphoon()
    assert t.track_width == 0.068 and t.wheel_radius == 0.015 and t.mass == 0.4
    assert 2 * t.supply_voltage**2 / (4 * t.motor_resistance) / t.mass == pytest.approx(22.5)
    assert 3.9 < t.no_load_speed < 4.5
    assert t.traction_limit_acceleration == pytest.approx(0.7 * 0.8 * GRAVITY)
    k = kurt3d()
    assert k.track_width == 0.4 and k.wheel_speed_limit == 4.1 and k.speed_loop_period == 0.01


@pytest.mark.parametrize(
    "field, value",
    [
        ("mass", -1.0),
        ("track_width", 0.0),
        ("tyre_friction", float("nan")),
        ("wheel_load_fraction", 1.5),
        ("tyre_shape_factor", 2.5),
        ("speed_loop_period", 0.0),
    ],
)
def test_parameter_validation_names_the_parameter(field, value):
    with pytest.raises(ValueError, match=rf"{field}=.*allowed"):
        tinyphoon().replace(**{field: value})


def test_wheel_speed_limit_above_motor_capability_is_rejected():
    with pytest.raises(ValueError, match="wheel_speed_limit.*no-load"):
        tinyphoon().replace(wheel_speed_limit=6.0)


def test_unknown_robot_and_bad_rates_are_rejected():
    with pytest.raises(ValueError, match="robot='hal'.*allowed"):
        robot_parameters("hal")
    with pytest.raises(ValueError, match="T_C=0.021.*integer multiple of T_N"):
        SampleRates(T_N=0.002, T_C=0.021)
    with pytest.raises(ValueError, match="T_N=-0.002.*allowed"):
        SampleRates(T_N=-0.002)
    with pytest.raises(ValueError, match="T_C=0.001"):
        SampleRates(T_N=0.002, T_C=0.001)
    assert SampleRates(T_N=0.002, T_C=0.02).batch_length == 10


def test_parameters_are_frozen():
    with pytest.raises(dataclasses.FrozenInstanceError):
        tinyphoon().mass = 1.0  # type: ignore[misc]
    assert isinstance(tinyphoon(), RobotParameters)


def continuous_reference(p, table, duration, x0):
    """The continuous model (DOP853, rtol 1e-9) with the PI loop sampled every speed_loop_period."""
    Ts = p.speed_loop_period
    x, loop, out, acc = np.array(x0, float), [0.0] * 4, [np.array(x0, float)], []
    for j in range(int(round(duration / Ts))):
        command = table[min(int(j * Ts / T_C + 1e-9), len(table) - 1)]
        loop = speed_loop_update(loop, command, (x[8], x[9]), p)
        volts = loop[2:4]

        def rhs(t, s, volts=volts):
            currents = (motor_current(volts[0], s[8], p), motor_current(volts[1], s[9], p))
            return plant_derivatives(s, currents, p)[0]

        x = solve_ivp(rhs, (0.0, Ts), x, method="DOP853", rtol=1e-9, atol=1e-12).y[:, -1]
        out.append(x)
        currents = (motor_current(volts[0], x[8], p), motor_current(volts[1], x[9], p))
        acc.append(plant_derivatives(x, currents, p)[1])
    return np.array(out), np.array(acc)


def discrete_run(p, table, duration, x0, h):
    per = int(round(p.speed_loop_period / h))
    x, loop, out, acc = list(x0), [0.0] * 4, [np.array(x0, float)], []
    for j in range(int(round(duration / p.speed_loop_period))):
        command = table[min(int(j * p.speed_loop_period / T_C + 1e-9), len(table) - 1)]
        x, loop, a = plant_advance(x, loop, command, j * per, per, h, p)
        out.append(np.array(x))
        acc.append(a)
    return np.array(out), np.array(acc)


def test_discrete_plant_converges_to_the_continuous_model():
    """The semi-implicit step (plant_substep) is first order and stable on the stiff wheel mode: the error
    against the continuous model halves with the step; at the default 0.5 ms it stays below 1 mm and
    2 cm/s through a slipping launch (1.6x the traction limit) into a turn, and the body acceleration the
    accelerometers see stays within their white noise (0.062 m/s^2 rms)."""
    p = tinyphoon()
    duration = 1.0
    table = ramp(1.6 * p.traction_limit_acceleration * 0.4, 0.4, duration, omega_frac=2.0)
    x0 = [0.0] * 10
    truth, truth_acc = continuous_reference(p, table, duration, x0)
    assert np.max(truth[:, 8] * p.wheel_radius - truth[:, 3]) > 0.5  # the wheels really spin
    errors = {}
    for h in (1e-3, 5e-4, 2.5e-4):
        d, acc = discrete_run(p, table, duration, x0, h)
        errors[h] = (
            np.max(np.hypot(d[:, 0] - truth[:, 0], d[:, 1] - truth[:, 1])),
            np.max(np.abs(d[:, 3:5] - truth[:, 3:5])),
            np.sqrt(np.mean((acc[:, 0:2] - truth_acc[:, 0:2]) ** 2)),
        )
    for coarse, fine in ((1e-3, 5e-4), (5e-4, 2.5e-4)):
        for i in range(2):
            assert 1.6 < errors[coarse][i] / errors[fine][i] < 2.5  # first order
    position, velocity, acceleration = errors[DEFAULT_TIME_STEP]
    assert position < 2.5e-3
    assert velocity < 2e-2  # v_t, v_n (m/s), in a launch that spins the wheels at 0.5 m/s
    assert acceleration < 0.062


def test_discrete_and_continuous_plant_diagrams_agree(open_loop):
    """The same open-loop command through the Drake diagram with either time model. (Their difference is
    of the order of the error-controlled RK3's own error at its 1e-2 target accuracy.)"""
    p = tinyphoon()
    table = ramp(0.8, 0.5, 1.5, omega_frac=1.5, track_width=p.track_width)
    discrete = open_loop(p, table, 1.5)
    continuous = open_loop(p, table, 1.5, plant_time_step=0.0)
    np.testing.assert_allclose(discrete["true_x"], continuous["true_x"], atol=1e-3)
    np.testing.assert_allclose(discrete["true_y"], continuous["true_y"], atol=1e-3)
    np.testing.assert_allclose(discrete["true_v_t"], continuous["true_v_t"], atol=5e-3)
    np.testing.assert_allclose(discrete["true_omega"], continuous["true_omega"], atol=2e-2)


@pytest.mark.parametrize(
    "time_step, update_period, message",
    [
        (3e-4, 0.002, "time_step=0.0003 must divide speed_loop_period"),
        (1e-3, 0.0015, "time_step=0.001 must divide update_period"),
        (-1e-3, 0.002, "allowed 0 \\(continuous\\) or \\(0, 0.01\\]"),
        (float("nan"), 0.002, "plant time_step=nan"),
        (5e-4, None, "update_period is required"),
    ],
)
def test_discrete_plant_rejects_inconsistent_steps(time_step, update_period, message):
    with pytest.raises(ValueError, match=message):
        DifferentialDrivePlant(tinyphoon(), time_step=time_step, update_period=update_period)


@pytest.mark.parametrize(
    "robot, speed, omega_frac",
    [
        (tinyphoon, 1.0, 1.0),
        (tinyphoon, 1.0, 1.5),
        (tinyphoon, 1.5, 1.33),
        (tinyphoon, 2.0, 1.0),
        (tinyphoon, 2.0, 1.25),
        (kurt3d, 1.0, 1.0),
        (kurt3d, 1.0, 1.5),
    ],
)
def test_steady_turn_side_slip_follows_the_navigations_tyre_model(robot, speed, omega_frac, navigation_tyres):
    """In a steady turn the plant's v_n is the navigation's tyre model (the inverse magic formula at
    a_n = v_t omega with the robot's a_peak = mu g f_w, B, C) to 10 %, from the linear range up to 0.9 of
    the friction limit (Tinyphoon; Kurt3D's wide track only while |omega| track/2 << v_t)."""
    p = robot()
    table = ramp(speed, 0.5, 3.0, omega_frac=omega_frac, track_width=p.track_width)
    states, acc = discrete_run(p, table, 3.0, [0.0] * 10, DEFAULT_TIME_STEP)
    x, a_n = states[-1], acc[-1][1]
    assert a_n == pytest.approx(speed**2 * omega_frac, rel=0.05)  # steady: a_n = v_t omega
    assert x[4] < -0.005  # a real side slip, to the outside of the turn
    assert a_n == pytest.approx(x[3] * x[5], rel=1e-3)
    tyres = navigation_tyres(p)
    assert lateral_velocity_model(x[3], x[5], tyres) == pytest.approx(x[4], rel=0.1)


@pytest.mark.parametrize(
    "speed, omega_frac, deceleration", [(1.5, 1.33, 3.0), (1.5, 1.6, 5.0), (1.2, 2.5, 4.0)]
)
def test_side_slip_braking_in_a_turn_follows_the_tyre_force(
    speed, omega_frac, deceleration, navigation_tyres
):
    """Braking at 3-5 m/s^2 out of a steady turn at 3-3.6 m/s^2 (yaw-rate command held): the friction
    circle takes grip from the turn and the body keeps sliding outwards. The plant's v_n follows the
    slip of the tyres that carry the force it accelerates with (side_slip_from_accelerations at the true
    v_t, a_t, a_n, with Tinyphoon's tyres and shoes) to 5 % (+ 1 mm/s) up to 0.96 of the friction limit,
    while the steady-turn model at v_t omega misses it by up to half."""
    p = tinyphoon()
    tyres = navigation_tyres(p)
    t = np.arange(int(3.0 / T_C) + 1) * T_C
    v = np.where(t > 2.0, np.maximum(speed - deceleration * (t - 2.0), 0.2), speed * np.clip(t, 0.0, 1.0))
    omega = omega_frac * speed * np.clip(t, 0.0, 1.0)
    table = np.column_stack([v + 0.5 * p.track_width * omega, v - 0.5 * p.track_width * omega])
    states, acc = discrete_run(p, table, 2.3, [0.0] * 10, DEFAULT_TIME_STEP)
    steady_miss = 0.0
    for time in (2.05, 2.1, 2.15, 2.2):
        k = int(round(time / p.speed_loop_period))
        x, a = states[k], acc[k - 1]  # the acceleration of the step that ends in x
        assert a[0] < -1.0 and x[4] < -0.005  # braking, sliding outwards
        wheel_speed = 0.5 * (x[8] + x[9]) * p.wheel_radius
        target, utilisation = side_slip_from_accelerations(x[3], wheel_speed, a[0], a[1], tyres)
        assert 0.4 < utilisation < 0.97
        assert target == pytest.approx(x[4], rel=0.05, abs=1e-3), (time, x[4], target)
        steady_miss = max(steady_miss, abs(lateral_velocity_model(x[3], x[5], tyres) / x[4] - 1.0))
    assert steady_miss > 0.1


@pytest.mark.parametrize("shoes", [True, False])
@pytest.mark.parametrize("acceleration", [0.0, 1.0, 2.0, 3.5])
def test_launch_slip_follows_the_navigations_tyre_model(shoes, acceleration, navigation_tyres):
    """Launched straight at a constant acceleration (or rolling at constant speed, pushing against the
    felt shoes' drag only), the plant's tyres creep ahead of the body by the navigation's
    longitudinal_slip_speed (the combined-slip magic formula with the robot's a_peak, B, C and the shoes'
    drag mu_s (1 - f_w) g + 2 c_v v / m) to 10 % (+ 1 mm/s), at 0.6, 1.2 and 1.8 m/s, from the creep of the
    drag alone up to 0.64 of the friction limit."""
    p = tinyphoon()
    if not shoes:
        p = p.replace(wheel_load_fraction=1.0, shoe_friction=0.0, shoe_viscous_drag=0.0)
    tyres = navigation_tyres(p)
    for speed in (0.6, 1.2, 1.8):
        if acceleration:  # sampled at `speed`, two thirds into a ramp to 1.5 speed
            table, duration = ramp(1.5 * speed, 1.5 * speed / acceleration, 3.0), speed / acceleration
        else:  # 1 s to settle after a 0.5 s ramp
            table, duration = ramp(speed, 0.5, 3.0), 1.5
        states, acc = discrete_run(p, table, duration, [0.0] * 10, 5e-4)
        x, a = states[-1], acc[-1]
        slip = x[8] * p.wheel_radius - x[3]
        last_T_C = (states[-1, 3] - states[-1 - int(round(T_C / p.speed_loop_period)), 3]) / T_C
        assert last_T_C == pytest.approx(acceleration, rel=0.1, abs=0.02)  # at the set rate, or steady
        model = longitudinal_slip_speed(x[8] * p.wheel_radius, a[0], a[1], tyres)
        assert slip > 0.001 or not (shoes or acceleration)  # a real creep
        assert model == pytest.approx(slip, rel=0.1, abs=1e-3), (speed, slip, model)


def _coast(p, enable, plant_time_step=DEFAULT_TIME_STEP, duration=2.0):
    """Open loop: 1 m/s reached in 0.5 s, held, the table's enable rows (None: the input unconnected)."""
    from slipnav.diagrams.open_loop import build_open_loop_diagram
    from slipnav.diagrams.records import Belief, Truth
    from slipnav.diagrams.robot import make_simulator
    from slipnav.scenarios.artifact_arrays import collect_arrays
    from slipnav.systems.robot.sensors import SensorParameters

    rates = SampleRates()
    table = ramp(1.0, 0.5, duration)
    truth = Truth(sensors=SensorParameters(), seed=4, plant_time_step=plant_time_step)
    built = build_open_loop_diagram(
        truth,
        Belief(robot=p, rates=rates),
        table,
        np.zeros((len(table), 3)),
        motor_enable=None if enable is None else enable(len(table)),
    )
    simulator = make_simulator(built.diagram, 4, p.speed_loop_period)
    simulator.AdvanceTo(duration)
    return collect_arrays(built.loggers, simulator.get_context(), p)


def _off_from(k_off):
    def rows(n):
        enable = np.ones((n, 2))
        enable[k_off:] = 0.0
        return enable

    return rows


def _check_coast(robot, m_eff, viscous, plant_time_step, rtol):
    """The motors switched off at row 50 (1 s): the deceleration against the hand formula."""
    k_off = 50
    a = _coast(robot, _off_from(k_off), plant_time_step)
    t, v = a["t"], a["true_v_t"]
    window = (t > k_off * T_C + 0.05) & (v > 0.1)
    assert window.sum() > 200  # rolls on for > 0.4 s
    deceleration = -np.gradient(v, t)[window]
    coulomb = robot.shoe_friction * (1.0 - robot.wheel_load_fraction) * robot.mass * GRAVITY
    expected = (coulomb + viscous * v[window]) / m_eff
    np.testing.assert_allclose(deceleration, expected, rtol=rtol)


def test_coasting_robot_decelerates_at_its_shoes_and_bearings_drag_per_mass():
    """Motors switched off at 1 s (motor_enable 0): no current, the wheels free-wheel, and the robot on its
    felt shoes decelerates by hand at (mu_s N_shoes + 2 c v + 2 b_w v / r^2) / (m + 2 J / r^2): the shoes'
    Coulomb friction and viscous drag, the bearings' drag and the wheels' inertia seen at the ground. The
    continuous plant meets it within 0.5 %; the semi-implicit 0.5 ms step coasts 3-8 % slower (more at
    low speed; its exponential-Euler step lags the free wheel's stiff slip mode, J / (r^2 dF/dv) ~ 0.7 ms:
    the tyres push ~7 mN too much, a slip of ~a h whatever J; first order; studies/calibration.py coasts on
    the continuous plant). A wheel rolling without slip carries no tyre force: the body then decelerates
    at the shoes' (mu_s N_shoes + 2 c v) / m exactly. With the motors driven all along the same table
    holds 1 m/s."""
    p = tinyphoon()
    r, J, b_w = p.wheel_radius, p.wheel_inertia, p.bearing_drag
    m_eff, viscous = p.mass + 2.0 * J / r**2, 2.0 * p.shoe_viscous_drag + 2.0 * b_w / r**2
    _check_coast(p, m_eff, viscous, 0.0, 0.005)
    _check_coast(p, m_eff, viscous, DEFAULT_TIME_STEP, 0.08)
    coulomb = p.shoe_friction * (1.0 - p.wheel_load_fraction) * p.mass * GRAVITY
    for v in (0.2, 0.6, 1.0):
        (a_t, a_n, omega_dot), _, _ = contact_forces([0, 0, 0, v, 0, 0, 0, 0, v / r, v / r], p)
        assert a_t == pytest.approx(-(coulomb + 2.0 * p.shoe_viscous_drag * v) / p.mass, rel=1e-9)
        assert a_n == 0.0 and omega_dot == 0.0
    on = _coast(p, None)
    assert on["true_v_t"][on["t"] > 1.2].min() > 0.97  # driven: the speed holds


def test_motor_enable_all_on_is_bit_identical_to_the_unconnected_input():
    p = tinyphoon()
    unconnected = _coast(p, None, duration=1.0)
    ones = _coast(p, lambda n: np.ones((n, 2)), duration=1.0)
    for key in ("true_v_t", "true_x", "true_phi", "meas_enc_R"):
        np.testing.assert_array_equal(unconnected[key], ones[key])


@pytest.mark.parametrize(
    "enable, phrase",
    [
        (lambda n: np.ones((n - 1, 2)), "motor_enable has"),
        (lambda n: np.full((n, 2), 0.5), "motor_enable holds"),
    ],
)
def test_motor_enable_table_is_checked(enable, phrase):
    with pytest.raises(ValueError, match=phrase):
        _coast(tinyphoon(), enable, duration=0.1)


@pytest.mark.parametrize("time_step", [0.0, 0.0005])
def test_motor_currents_output_is_the_armature_current_at_the_state(time_step):
    """The motor_currents port (the drivers' current sense reads it) holds (V - k w) / R at the state
    output, clipped at the driver's limit, with the PI loop's held voltages: a launch from rest sits at
    the limit, and the output matches motor_currents(loop, state) of the plant's own state."""
    p = tinyphoon()
    plant = DifferentialDrivePlant(p, time_step=time_step, update_period=0.002)
    simulator = Simulator(plant)
    context = simulator.get_mutable_context()
    plant.GetInputPort("wheel_speed_command").FixValue(context, [2.0, 1.0])
    simulator.AdvanceTo(0.01)
    currents = plant.GetOutputPort("motor_currents").Eval(context)
    np.testing.assert_allclose(currents, [p.motor_current_limit] * 2)  # launching: current-limited
    simulator.AdvanceTo(0.5)
    x = plant.GetOutputPort("state").Eval(context)
    loop = context.get_discrete_state(1 if time_step else 0).value()  # SpeedLoopState
    np.testing.assert_allclose(
        plant.GetOutputPort("motor_currents").Eval(context), motor_currents(loop, x, p), rtol=1e-12
    )
    assert 0.0 < plant.GetOutputPort("motor_currents").Eval(context)[1] < p.motor_current_limit
