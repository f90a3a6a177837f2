"""Model files as belief: the sensor correction, a scenario's ``model:`` key and ``slipnav run --model``."""

import dataclasses as dc
import json
import math

import numpy as np
import pytest
from slipnav.scenarios.config import ScenarioError, load_scenario, scenario_from_yaml
from slipnav.scenarios.model import RobotModel, SensorCalibration, write_model
from slipnav.scenarios.runner import run_scenario
from slipnav.studies.cli import main
from slipnav.systems.navigation.sensor_correction import (
    SensorCorrection,
    corrected_accelerometers,
    corrected_gyro,
)
from slipnav.systems.robot.sensors import SensorParameters, sensor_frame

CALIBRATION = SensorCalibration(
    gyro_scale_error=0.012,
    gyro_bias=0.003,
    accel1_scale_error=-0.02,
    accel2_scale_error=0.017,
    accel1_misalignment=math.radians(1.0),
    accel2_misalignment=math.radians(-0.7),
    accel_bias=[0.05, -0.04, 0.03, 0.02],
)


def test_correction_inverts_the_sensor_model():
    """sensors.sensor_frame turns and scales the true readings; the correction with the same gains and
    angles gives the truth back (the biases are the yaw calibration's, not removed)."""
    sensors = SensorParameters(
        gyro_scale_error=CALIBRATION.gyro_scale_error,
        accel1_scale_error=CALIBRATION.accel1_scale_error,
        accel2_scale_error=CALIBRATION.accel2_scale_error,
        accel1_misalignment=CALIBRATION.accel1_misalignment,
        accel2_misalignment=CALIBRATION.accel2_misalignment,
    )
    rng = np.random.default_rng(3)
    for truth in rng.normal(0.0, 8.0, (20, 4)):
        read = sensor_frame(list(truth), sensors)
        assert not np.allclose(read, truth, atol=1e-3)  # the sensor frame is really different
        np.testing.assert_allclose(corrected_accelerometers(CALIBRATION, read), truth, rtol=0, atol=1e-12)
    omega = 2.5
    assert corrected_gyro(CALIBRATION, (1 + 0.012) * omega) == pytest.approx(omega, abs=1e-15)
    # By hand: a 1 deg misalignment shows a pure tangential 10 m/s^2 as -0.1745 m/s^2 lateral, undone.
    one = SensorCalibration(accel1_misalignment=math.radians(1.0))
    read = [10 * math.cos(math.radians(1)), -10 * math.sin(math.radians(1)), 0.0, 0.0]
    np.testing.assert_allclose(corrected_accelerometers(one, read), [10, 0, 0, 0], atol=1e-12)


def test_sensor_correction_system_matches_the_pure_functions():
    system = SensorCorrection(CALIBRATION)
    context = system.CreateDefaultContext()
    acc = [1.0, -2.0, 3.0, 0.5]
    system.GetInputPort("accelerometers").FixValue(context, acc)
    system.GetInputPort("gyro").FixValue(context, [0.7])
    np.testing.assert_allclose(
        system.GetOutputPort("accelerometers").Eval(context), corrected_accelerometers(CALIBRATION, acc)
    )
    assert system.GetOutputPort("gyro").Eval(context)[0] == corrected_gyro(CALIBRATION, 0.7)
    assert SensorCalibration().is_identity() and not CALIBRATION.is_identity()
    assert SensorCalibration(gyro_bias=0.01).is_identity()  # a bias alone corrects nothing


def test_bad_calibration_is_a_clear_error():
    with pytest.raises(ValueError, match=r"calibration.accel2_misalignment=0.6 .*allowed \(-0.5, 0.5\) rad"):
        SensorCorrection(SensorCalibration(accel2_misalignment=0.6))


def _model_file(tmp_path, **changes):
    model = RobotModel(
        robot="tinyphoon",
        robot_overrides={"rolling_radius_R": 0.01515, "track_width": 0.0699},
        calibration=CALIBRATION,
        **changes,
    )
    return write_model(model, tmp_path / "robot.model.yaml")


def test_scenario_model_is_belief_only(tmp_path):
    """The model refines what navigation and control read; the plant stays the scenario's."""
    path = _model_file(tmp_path)
    scenario = dc.replace(load_scenario("corner"), model=str(path)).validate()
    belief = scenario.belief()
    assert belief.robot.radius_R == 0.01515 and belief.robot.track_width == 0.0699
    assert belief.robot.radius_L == scenario.robot_parameters().radius_L  # not in the model: nominal
    assert belief.calibration == CALIBRATION
    plant, sensors, _ = scenario.plant_parameters()
    nominal = load_scenario("corner")
    assert plant == nominal.plant_parameters()[0]  # the world did not change
    assert sensors.gyro_scale_error == 0.0
    assert nominal.belief().calibration.is_identity()


def test_model_key_is_read_from_the_scenario_files_folder(tmp_path):
    _model_file(tmp_path)
    text = (
        "trajectory: {segments: [!Straight {length: 0.5, v_peak: 0.5}]}\n"
        "robot: tinyphoon\nmodel: robot.model.yaml\n"
    )
    (tmp_path / "s.yaml").write_text(text)
    scenario = load_scenario(str(tmp_path / "s.yaml"))
    assert scenario.belief().robot.track_width == 0.0699


@pytest.mark.parametrize(
    "yaml_changes, message",
    [
        (
            {"robot": "kurt3d"},
            r"model: the model file .* describes robot 'tinyphoon', the scenario robot 'kurt3d'",
        ),
        ({"T_N": 0.001}, r"model: the model file's T_N=0.002 differs from the scenario's T_N=0.001"),
    ],
)
def test_model_that_does_not_fit_the_scenario_is_a_clear_error(tmp_path, yaml_changes, message):
    path = _model_file(tmp_path)
    trajectory = "trajectory: {segments: [!Straight {length: 0.5, v_peak: 0.5}]}\n"
    keys = "".join(f"{k}: {v}\n" for k, v in yaml_changes.items())
    with pytest.raises(ScenarioError, match=message):
        scenario_from_yaml(trajectory + keys + f"model: {path}\n")


def test_missing_or_malformed_model_file_names_the_key(tmp_path):
    trajectory = "trajectory: {segments: [!Straight {length: 0.5, v_peak: 0.5}]}\n"
    with pytest.raises(ScenarioError, match=r"model: model file .*nowhere.yaml.* cannot be read"):
        scenario_from_yaml(trajectory + f"model: {tmp_path / 'nowhere.yaml'}\n")
    bad = tmp_path / "bad.model.yaml"
    bad.write_text("robot: tinyphoon\ncalibration: {gyro_scale_error: 0.9}\n")
    with pytest.raises(ScenarioError, match=r"model: .*calibration.gyro_scale_error=0.9 is out of range"):
        scenario_from_yaml(trajectory + f"model: {bad}\n")


def test_a_model_of_the_true_robot_removes_its_systematic_errors(tmp_path):
    """Corner on a robot whose gyro reads 1 % high and whose right wheel rolls 1 % larger: with the true
    values as the model (radii and gyro scale) the Gyrodometry baseline and the fused estimate lose the
    systematic heading error (the Gyrodometry's heading by more than half)."""
    scenario = load_scenario("corner")
    truth = dc.replace(
        scenario.plant,
        deviations=dc.replace(scenario.plant.deviations, wheel_radius_R=0.01, gyro_scale=0.01),
    )
    scenario = dc.replace(scenario, plant=truth)
    plant = scenario.plant_parameters()[0]
    model = RobotModel(
        robot="tinyphoon",
        robot_overrides={"rolling_radius_R": plant.radius_R},
        calibration=SensorCalibration(gyro_scale_error=0.01),
    )
    path = write_model(model, tmp_path / "true.model.yaml")
    nominal = run_scenario(scenario, seed=2).arrays
    matched = run_scenario(dc.replace(scenario, model=str(path)).validate(), seed=2).arrays

    def heading_error(a, key):
        return abs(math.remainder(a[f"{key}_phi"][-1] - a["true_phi"][-1], 2 * math.pi))

    assert heading_error(matched, "gyro") < 0.5 * heading_error(nominal, "gyro")
    assert heading_error(matched, "est") < heading_error(nominal, "est")


def test_run_model_option_writes_its_own_artifact(tmp_path, capsys):
    path = _model_file(tmp_path)
    out = tmp_path / "runs"
    assert (
        main(["run", "corner", "--duration", "1.5", "--no-figures", "--out", str(out), "--model", str(path)])
        == 0
    )
    stem = "corner-seed0-model-robot"
    summary = json.loads((out / f"{stem}.summary.json").read_text())
    assert summary["model"] == str(path)
    written = (out / f"{stem}.model.yaml").read_text()
    assert "rolling_radius_R: 0.01515" in written and "gyro_scale_error: 0.012" in written
    assert main(["run", "corner", "--out", str(out), "--model", str(tmp_path / "none.yaml")]) == 2
    assert "model: model file" in capsys.readouterr().err
