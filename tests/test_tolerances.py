"""Truth and belief (scenarios/tolerances.py): the plant is the world, navigation and control read the
nominal robot; tolerances are drawn reproducibly; impossible tolerances are clear errors."""

import math

import numpy as np
import pytest
from slipnav.diagrams.closed_loop import build_closed_loop_diagram
from slipnav.diagrams.records import Belief, Truth
from slipnav.scenarios.config import BUILTIN_DIR, ScenarioError, load_scenario, scenario_from_yaml
from slipnav.scenarios.run_plan import closed_loop_settings
from slipnav.scenarios.runner import run_scenario
from slipnav.scenarios.tolerances import TOLERANCE_PRESET
from slipnav.systems.robot.sensors import SensorParameters, accelerometer_truth, sensor_frame


def corner_with(extra: str):
    return scenario_from_yaml((BUILTIN_DIR / "corner.yaml").read_text() + "\n" + extra, name="corner")


def test_navigation_and_control_read_the_nominal_robot():
    """A plant whose radii, track, mass and friction all differ: the diagram's plant carries the true values,
    the odometry, calibration, sensor checks, perturbation monitor, path follower and saturator the
    nominal ones."""
    scenario = corner_with(
        "plant: {robot_overrides: {tyre_friction: 0.5},"
        " deviations: {wheel_radius_R: 0.01, wheel_radius_L: -0.01, track_width: 0.03, mass: 0.25}}"
    )
    nominal = scenario.robot_parameters()
    plant, sensors, _ = scenario.plant_parameters()
    control, speed, _ = closed_loop_settings(scenario, True, "bounded")
    truth = Truth(sensors=sensors, seed=0, plant=plant, initial_speed=speed)
    belief = Belief(robot=nominal, rates=scenario.rates(), navigation=scenario.navigation)
    built = build_closed_loop_diagram(truth, belief, control, log=False)
    assert built.robot.plant.params == plant
    assert plant.radius_R == pytest.approx(1.01 * nominal.wheel_radius)
    assert plant.radius_L == pytest.approx(0.99 * nominal.wheel_radius)
    assert plant.track_width == pytest.approx(1.03 * nominal.track_width) and plant.tyre_friction == 0.5
    assert plant.wheel_radius == nominal.wheel_radius  # the motor firmware converts with the nominal radius
    nav = built.diagram.GetSubsystemByName("navigation")
    odometry = nav.GetSubsystemByName("Odometry")
    assert (odometry._r, odometry._b) == (nominal.wheel_radius, nominal.track_width)
    assert nav.GetSubsystemByName("Gyro and odometry calibration")._b == nominal.track_width
    # the force balances (sensor checks, perturbation monitor) weigh the nominal robot, not the heavier plant
    assert plant.mass == pytest.approx(1.25 * nominal.mass)
    checks = nav.GetSubsystemByName("Sensor checks")._g
    assert checks.mass == nominal.mass
    # the gyro's replacement (yaw dynamics) reads the nominal inertia and tyre, not the slipperier plant's
    assert (checks.yaw_inertia, checks.tyre_friction) == (nominal.yaw_inertia, nominal.tyre_friction)
    assert checks.tyre_peak_acceleration == pytest.approx(nominal.traction_limit_acceleration)
    assert plant.traction_limit_acceleration < 0.75 * checks.tyre_peak_acceleration
    monitor = built.diagram.GetSubsystemByName("Perturbation monitor")
    assert (monitor._robot.mass, monitor._robot.yaw_inertia) == (nominal.mass, nominal.yaw_inertia)
    control_diagram = built.diagram.GetSubsystemByName("control")
    saturator = control_diagram.GetSubsystemByName("Wheel-speed saturator")
    follower = control_diagram.GetSubsystemByName("Lyapunov path follower")
    assert saturator._half == pytest.approx(0.5 * nominal.track_width)
    assert saturator._V_m == nominal.wheel_speed_limit
    assert follower._half == pytest.approx(0.5 * nominal.track_width)


def test_tolerance_draws_are_deterministic_per_seed_and_within_bounds():
    scenario = load_scenario("square")
    first = scenario.plant_parameters(seed=4, tolerances=True)[2]
    again = scenario.plant_parameters(seed=4, tolerances=True)[2]
    other = scenario.plant_parameters(seed=5, tolerances=True)[2]
    assert first == again and first != other
    for key, value in first.items():
        assert abs(value) <= getattr(TOLERANCE_PRESET, key)
    assert all(v == 0.0 for v in scenario.plant_parameters(seed=4)[2].values())
    # the draw has its own stream: the sensor noise of a seed is unchanged by tolerances
    a = run_scenario(scenario, seed=4, duration=0.2).arrays
    b = run_scenario(scenario, seed=4, duration=0.2, tolerances=True).arrays
    np.testing.assert_array_equal(a["meas_enc_R"][:5], b["meas_enc_R"][:5])
    assert float(b["plant_track_width"]) == pytest.approx(
        scenario.robot_parameters().track_width * (1 + first["track_width"])
    )
    assert float(b["track_width"]) == scenario.robot_parameters().track_width  # the nominal, as believed


@pytest.mark.parametrize(
    "yaml_text, key",
    [
        ("plant: {deviations: {wheel_radius_R: -1.0}}", "plant.deviations.wheel_radius_R"),
        (
            "plant: {tolerances: {wheel_radius_L: 0.5}, deviations: {wheel_radius_L: 0.6}}",
            "plant.tolerances.wheel_radius_L",
        ),
        ("plant: {deviations: {accel1_misalignment_deg: 90}}", "plant.deviations.accel1_misalignment_deg"),
        ("plant: {tolerances: {accel2_misalignment_deg: -1}}", "plant.tolerances.accel2_misalignment_deg"),
        ("plant: {robot_overrides: {tyre_friction: 0.0}}", "plant.robot_overrides.tyre_friction"),
        ("plant: {robot_overrides: {rolling_radius_R: -0.01}}", "plant.robot_overrides.rolling_radius_R"),
        ("plant: {sensor_overrides: {gyro_scale_error: -1.0}}", "plant.sensor_overrides.gyro_scale_error"),
        ("plant: {deviations: {gyro_scal: 0.01}}", "plant.deviations.gyro_scal"),
    ],
)
def test_impossible_tolerances_name_the_key(yaml_text, key):
    with pytest.raises(ScenarioError, match=key.replace(".", r"\.")):
        corner_with(yaml_text)


def test_accelerometer_scale_and_misalignment_by_hand():
    g = math.radians(1.0)
    p = SensorParameters(accel1_scale_error=0.02, accel2_misalignment=g)
    truth = accelerometer_truth([1.0, 2.0, 0.0], 0.0, p.accelerometer_position)
    t1, n1, t2, n2 = sensor_frame(truth, p)
    assert (t1, n1) == pytest.approx((1.02, 2.04))
    assert t2 == pytest.approx(math.cos(g) + 2 * math.sin(g)) and n2 == pytest.approx(
        2 * math.cos(g) - math.sin(g)
    )


def test_unequal_wheels_turn_the_robot_as_kinematics_say(open_loop):
    """Equal wheel-speed commands, right rolling radius +1 %: the firmware holds equal wheel rates, so the
    robot turns left at omega = (r_R - r_L) w / b (within 5 %), and the encoders see no turn."""
    robot = load_scenario("corner").robot_parameters().replace(rolling_radius_R=0.01515)
    a = open_loop(robot, [[0.6, 0.6]] * 100, 1.5)
    late = a["t"] > 1.0
    w = a["true_wheel_L"][late] / robot.radius_L
    expected = (robot.radius_R - robot.radius_L) * w / robot.track_width
    assert np.mean(a["true_omega"][late]) == pytest.approx(np.mean(expected), rel=0.05)
    assert abs(a["meas_enc_R"][-1] - a["meas_enc_L"][-1]) < 0.01 * abs(a["meas_enc_L"][-1])
