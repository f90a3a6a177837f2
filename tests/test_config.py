"""Scenario YAML loading: strict schema, errors that name the key."""

import math

import pytest
from slipnav.scenarios.config import ScenarioError, builtin_scenarios, load_scenario, scenario_from_yaml

GOOD = """
trajectory:
  segments:
    - !Straight {length: 1.0, v_end: 1.0}
    - !Arc {radius: 0.5, angle_deg: 90}
"""


def test_builtins_load(navigation_tyres):
    assert set(builtin_scenarios()) >= {"corner", "square", "circle", "long_path"}
    for name in builtin_scenarios():
        scenario = load_scenario(name)
        assert scenario.name == name
        # The navigation's tyre curve (S(15)'s creep, S(17)'s side slip) is its robot's, as identified.
        mixing, robots = scenario.navigation.mixing, navigation_tyres(scenario.robot_parameters())
        assert mixing.tyre_peak_acceleration == pytest.approx(robots.tyre_peak_acceleration, rel=0.01)
        assert mixing.tyre_stiffness_factor == robots.tyre_stiffness_factor, name
        assert mixing.tyre_shape_factor == robots.tyre_shape_factor, name
        # The drag the tyres push against (S(15)'s creep compensation) is its felt shoes'.
        assert mixing.drag_acceleration == pytest.approx(robots.drag_acceleration, abs=0.005), name
        assert mixing.drag_per_speed == pytest.approx(robots.drag_per_speed), name


def test_no_tyre_side_slip_is_the_papers_S17():
    scenario = scenario_from_yaml(
        GOOD + "navigation: {mixing: {tyre_peak_acceleration: .inf, q2_inertial: 1.0}}\n"
    )
    assert scenario.navigation.mixing.tyre_peak_acceleration == math.inf


def test_good_yaml_and_overrides():
    scenario = scenario_from_yaml(
        GOOD + "robot_overrides: {tyre_friction: 0.5}\nnavigation: {mixing: {b1: 0.06}}\n", name="mine"
    )
    assert scenario.navigation.mixing.b1 == 0.06 and scenario.navigation.mixing.a1 == 150.0
    assert scenario.name == "mine"
    assert scenario.robot_parameters().tyre_friction == 0.5
    assert scenario.rates().batch_length == 10


@pytest.mark.parametrize(
    "extra, message",
    [
        ("colour: red\n", r"colour is an unknown key"),
        ("T_N: fast\n", r"T_N: expected float, got 'fast'"),
        ("seed: 1.5\n", r"seed: expected int"),
        ("T_C: 0.021\n", r"T_C=0.021 must be a positive integer multiple of T_N"),
        ("robot: hal\n", r"robot='hal' is unknown"),
        ("robot_overrides: {tyre_frict: 0.5}\n", r"robot_overrides.tyre_frict is unknown"),
        ("robot_overrides: {mass: -1}\n", r"mass=-1.* allowed"),
        ("sensor_overrides: {gyro_noise_std: -1}\n", r"gyro_noise_std=-1.*allowed"),
        ("mode: fastest\n", r"mode='fastest' is unknown"),
        ("settle_time: -1\n", r"settle_time=-1.*allowed"),
        ("plant_time_step: 0.02\n", r"plant_time_step=0.02 is out of range: allowed 0 \(continuous\)"),
        ("plant_time_step: 0.0003\n", r"time_step=0.0003 must divide T_N"),
        ("plant_time_step: 0.002\n", r"time_step=0.002 must divide speed_loop_period"),
        ("navigation: {mixing: {q2: 1.5}}\n", r"mixing.q2=1.5 is out of range"),
        ("navigation: {mixing: {b1: -0.1}}\n", r"mixing.b1=-0.1 is out of range"),
        ("navigation: {mixing: {tyre_peak_acceleration: 0}}\n", r"tyre_peak_acceleration=0.* \(0, inf\]"),
        ("navigation: {mixing: {tyre_shape_factor: 2.5}}\n", r"mixing.tyre_shape_factor=2.5.* \(1, 2\)"),
        ("navigation: {ekf: {R: [1.0, 1.0]}}\n", r"ekf.R must list 3"),
        ("navigation: {sideslip: {c_alpha: 2.0, d_alpha: 1.0}}\n", r"sideslip.d_alpha=1.0"),
        ("navigation: {gyrodometry: {drift_rate: 1.0}}\n", r"gyrodometry.drift_rate=1.0"),
        ("navigation: {mixing: {b4: 1.0}}\n", r"navigation.mixing.b4 is an unknown key"),
    ],
)
def test_errors_name_the_key(extra, message):
    with pytest.raises(ScenarioError, match=message):
        scenario_from_yaml(GOOD + extra)


@pytest.mark.parametrize(
    "text, message",
    [
        (
            "trajectory:\n  segments:\n    - !Straight {lenght: 1}\n",
            r"trajectory.segments\[0\].lenght is an unknown key",
        ),
        (
            "trajectory:\n  segments:\n    - !Straight {length: abc}\n",
            r"trajectory.segments\[0\].length: expected float, got 'abc'",
        ),
        (
            "trajectory:\n  segments:\n    - !Teleport {x: 1}\n",
            r"trajectory.segments\[0\]: type tag !Teleport is unknown",
        ),
        ("trajectory:\n  segments:\n    - {length: 1}\n", r"trajectory.segments\[0\]: needs a type tag"),
        ("trajectory: [1, 2\n", r"malformed YAML"),
        ("mode: max_speed\n", r"needs a 'path'"),
        ("trajectory:\n  segments: 3\n", r"trajectory.segments: expected a list"),
    ],
)
def test_structural_errors(text, message):
    with pytest.raises(ScenarioError, match=message):
        scenario_from_yaml(text)


def test_missing_file_and_unknown_name(tmp_path):
    with pytest.raises(ScenarioError, match="does not exist"):
        load_scenario(str(tmp_path / "nope.yaml"))
    with pytest.raises(ScenarioError, match="neither a built-in"):
        load_scenario("nope")


def test_docs_example_scenario_loads_and_builds():
    """The scenario example in docs/model.md (its first YAML block) is valid as written."""
    import re
    from pathlib import Path

    from slipnav.scenarios.run_plan import follower_path, reference_for

    text = (Path(__file__).resolve().parent.parent / "docs" / "model.md").read_text()
    blocks = re.findall(r"```yaml\n(.*?)```", text, re.S)
    example = next(b for b in blocks if "manoeuvres:" not in b)  # not a calibration session
    scenario = scenario_from_yaml(example, name="docs")
    assert scenario.follower.epsilon == 0.05 and scenario.slip_control.delta_min == 0.75
    reference, _ = reference_for(scenario)
    assert reference.length == pytest.approx(1.0 + 1.0 + 0.5 * math.pi / 4 + 1.0 + 0.5)
    assert follower_path(scenario).length == pytest.approx(reference.length)


def test_unknown_localisation_names_the_key_and_the_sources():
    base = "trajectory: {segments: [!Straight {length: 1.0, v_end: 1.0}]}\n"
    assert scenario_from_yaml(base + "localisation: gyrodometry\n").localisation == "gyrodometry"
    with pytest.raises(ScenarioError, match=r"localisation='gps' is unknown: allowed \['fused', 'odometry'"):
        scenario_from_yaml(base + "localisation: gps\n")
