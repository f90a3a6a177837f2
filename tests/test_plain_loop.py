"""The whole closed-loop diagram equals the plain sequential loop over the same pure functions."""

import dataclasses as dc

import numpy as np
import pytest
from slipnav.diagrams.records import Belief, Truth
from slipnav.scenarios.config import load_scenario
from slipnav.scenarios.plain_loop import (
    PLAIN_LOOP_KEYS,
    run_plain_loop,
    run_scenario_plain_loop,
)
from slipnav.scenarios.run_plan import closed_loop_settings
from slipnav.scenarios.runner import run_scenario
from slipnav.systems.robot.faults import FaultEvent

FAULT_EVENTS = [
    FaultEvent("dropout", "gyro", 1.4, 0.1),
    FaultEvent("spike", "encoder_L", 1.5, 0.5, 1000.0),
    FaultEvent("scale", "encoder_R", 1.6, 0.1, 1.0),
    FaultEvent("bias", "accel2_n", 1.7, 0.2, 5.0),
    FaultEvent("nan", "accel1_t", 1.8, 0.05),
    FaultEvent("wheel_held", "wheel_R", 1.9, 0.1),
    FaultEvent("wheel_pushed", "wheel_L", 1.95, 0.1, 0.001),
    FaultEvent("body_push", "body_n", 2.0, 0.1, 1.0),
    FaultEvent("wheel_lifted", "wheel_L", 2.1, 0.05),
]


_SQUARE = load_scenario("square").navigation
SLIDE_ONSET_ON = dc.replace(_SQUARE, mixing=dc.replace(_SQUARE.mixing, slide_onset_jump=0.05))


@pytest.mark.parametrize(
    "name, duration, overrides, changes",
    [
        ("corner", 3.0, {}, {}),  # 1 s standstill; trajectory mode, slip control acting (delta < 1)
        ("square", 2.0, {"slip_control": False}, {}),
        ("circle", 2.0, {"speed_law": "bounded"}, {}),  # Kurt3D, max_speed mode, I(24)
        ("corner", 2.2, {}, {"faults": FAULT_EVENTS}),  # injected, flagged, replaced; the held and
        # lifted wheels spin the robot beyond the gyro's range (saturated, flagged)
        # a sideways push beyond the tyres' grip: the monitor's flag feeds the mixer (external_force)
        ("square", 2.3, {}, {"faults": [FaultEvent("body_push", "body_n", 2.0, 0.5, 2.0)]}),
        ("square", 2.0, {}, {"localisation": "odometry"}),  # the follower on odometry-only
        ("circle", 2.0, {}, {"localisation": "gyrodometry"}),
        ("corner", 2.0, {}, {"localisation": "truth"}),  # on the plant's state
        ("corner", 2.0, {}, {"paper": True}),  # paper mode: S(11) printed, delta_K at once
        # the checks off (paper mode): a NaN encoder reaches the odometry, which holds, and S(11) skips it
        ("corner", 2.0, {}, {"paper": True, "faults": [FaultEvent("nan", "encoder_L", 1.5, 0.1)]}),
        ("circle", 1.0, {}, {"paper": True}),  # max_speed mode in paper mode: I(24) on V1 of the instant
        # the per-sample slide-onset test on (C1 = 0 in S(15) from a lock's first sample; off by default)
        ("square", 2.5, {}, {"navigation": SLIDE_ONSET_ON}),
    ],
)
def test_closed_loop_diagram_equals_plain_loop(name, duration, overrides, changes):
    """Every signal, every sample: plant, sensors, navigation and control (<= 1e-12). This proves the
    multi-rate wiring of the whole loop (no stray delay at any port) and the plant's discrete timing."""
    assert_diagram_equals_plain_loop(dc.replace(load_scenario(name), **changes), duration, overrides, changes)


def test_diagram_equals_plain_loop_with_a_calibrated_model(tmp_path):
    """A model with radii, track, gyro scale and accelerometer gains and misalignments (the
    SensorCorrection block and its twin in NavigationLoop) on a robot that differs from the nominal."""
    from slipnav.scenarios.model import RobotModel, SensorCalibration, write_model

    model = RobotModel(
        robot="tinyphoon",
        robot_overrides={"rolling_radius_R": 0.01515, "rolling_radius_L": 0.0149, "track_width": 0.0695},
        calibration=SensorCalibration(
            gyro_scale_error=0.01,
            accel1_scale_error=-0.02,
            accel2_scale_error=0.015,
            accel1_misalignment=0.017,
            accel2_misalignment=-0.01,
        ),
    )
    path = write_model(model, tmp_path / "robot.model.yaml")
    scenario = dc.replace(load_scenario("corner"), model=str(path)).validate()
    deviations = {"wheel_radius_R": 0.01, "gyro_scale": 0.01, "accel1_misalignment_deg": 1.0}
    truth = dc.replace(scenario.plant, deviations=dc.replace(scenario.plant.deviations, **deviations))
    a = assert_diagram_equals_plain_loop(dc.replace(scenario, plant=truth), 2.0, {}, {"model": True})
    assert a["plant_gyro_scale_error"] == pytest.approx(0.01)  # the plant is not the model


def test_diagram_equals_plain_loop_with_faults_on_unequal_wheels():
    """The sensor checks read the online calibration's [b_g, D] (the YawRateCalibration's state in the
    diagram, NavigationLoop's before its step): on a right wheel 1 % larger than the nominal, D is
    learned before the gyro's dropout at 1.4 s, and its replacement and the encoders' read it."""
    scenario = load_scenario("corner")
    deviations = dc.replace(scenario.plant.deviations, wheel_radius_R=0.01)
    truth = dc.replace(scenario.plant, deviations=deviations)
    a = assert_diagram_equals_plain_loop(
        dc.replace(scenario, plant=truth, faults=FAULT_EVENTS),
        2.2,
        {},
        {"faults": FAULT_EVENTS, "plant": True},
    )
    dropout = np.searchsorted(a["t"], 1.4)
    assert 0.007 < a["est_radius_difference"][dropout] < 0.013
    assert np.any(a["health_gyro"][dropout : dropout + 60] > 0)


def test_diagram_equals_plain_loop_where_the_tyre_model_check_opens():
    """A floor with less grip than the navigation's tyre curve (friction 0.5): the VelocityMixer's
    state (the free integral and the curve's own side slip) opens the check in the turn."""
    from slipnav.scenarios.config import with_keys

    scenario = with_keys(load_scenario("corner"), {"plant.robot_overrides.tyre_friction": 0.5})
    a = assert_diagram_equals_plain_loop(scenario, 2.6, {}, {"plant": True}, seed=1)
    assert np.max(a["tyre_model_weight"]) > 0.5
    assert a["est_tyre_peak"][0] == 5.49 and a["est_tyre_peak"][-1] < 4.5  # identified in the slide


def assert_diagram_equals_plain_loop(scenario, duration, overrides, changes, seed=7):
    """The run's artifact arrays after comparing every plain-loop signal with the diagram's."""
    name = scenario.name
    result = run_scenario(scenario, seed=seed, duration=duration, **overrides)
    a = result.arrays
    n = len(a["t"])
    plain = run_scenario_plain_loop(scenario, seed, n, **overrides)  # the seed's noise, as the diagram's
    compared = 0
    for key in PLAIN_LOOP_KEYS:
        artifact_key = key.removeprefix("nav_")
        if key in ("true_w_R", "true_w_L"):
            world = scenario.plant_parameters(seed)[0]  # the plant's rolling radius of each wheel
            artifact = a[f"true_wheel_{key[-1]}"] / getattr(world, f"radius_{key[-1]}")
        elif artifact_key in a:
            artifact = a[artifact_key]
        else:
            continue
        if scenario.mode == "max_speed" and key in ("step_size", "progress"):
            continue
        finite = np.isfinite(artifact) & np.isfinite(plain[key])
        np.testing.assert_array_equal(np.isfinite(artifact), np.isfinite(plain[key]), err_msg=key)
        np.testing.assert_allclose(plain[key][finite], artifact[finite], rtol=0, atol=1e-12, err_msg=key)
        compared += 1
    assert compared >= 40
    if name == "corner" and (not changes or "paper" in changes):
        assert np.min(a["step_size"]) < 1.0  # the slip-control branch was exercised
    assert np.ptp(a["true_x"]) > 0.5  # and the robot really drove
    if changes.get("faults") is FAULT_EVENTS and "plant" not in changes:
        flagged = {
            key: set(np.unique(a[key])) for key in ("health_gyro", "health_encoder_L", "health_accel2_n")
        }
        assert flagged == {
            "health_gyro": {0, 2, 3, 6},
            "health_encoder_L": {0, 4, 6},
            "health_accel2_n": {0, 5},
        }
    pushes = [e for e in changes.get("faults", ()) if e.kind == "body_push" and e.channel == "body_n"]
    if pushes and pushes == list(changes["faults"]):  # the lone push beyond the grip: taken (F alone, w = 1)
        during = (a["t"] >= pushes[0].start) & (a["t"] < pushes[0].start + pushes[0].duration)
        taken = (a["tyre_model_weight"] == 1.0) & (a["est_v_n"] == a["free_v_n"])
        assert np.count_nonzero(taken[during]) > 0.5 * np.count_nonzero(during)  # 134 of 150
        assert not taken[~during].any()
    return a


def test_plain_loop_rejects_bad_inputs():
    scenario = load_scenario("corner")
    control, v0, _ = closed_loop_settings(scenario, True, "bounded")
    truth = Truth(sensors=scenario.sensor_parameters(), seed=0)
    belief = Belief(robot=scenario.robot_parameters(), rates=scenario.rates(), navigation=scenario.navigation)
    with pytest.raises(ValueError, match="truth.plant_time_step"):
        run_plain_loop(dc.replace(truth, plant_time_step=0.0), belief, control, 10)
    with pytest.raises(ValueError, match="time_step=0.0003 must divide T_N"):
        run_plain_loop(dc.replace(truth, plant_time_step=0.0003), belief, control, 10)
    with pytest.raises(ValueError, match="noise must have shape"):
        run_plain_loop(truth, belief, control, 10, noise=np.zeros((3, 14)))
