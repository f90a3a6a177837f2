"""The replay engines (scenarios/replay_engines.py): the plain loop gives the diagram's arrays and summary
bit for bit, and it is what ``slipnav replay`` and ``slipnav evaluate`` run by default."""

import dataclasses as dc
import json

import numpy as np
import pytest
from slipnav.scenarios.config import load_scenario
from slipnav.scenarios.evaluate import EvaluationError, load_estimates
from slipnav.scenarios.replay import replay_log
from slipnav.scenarios.runner import run_scenario, write_artifacts
from slipnav.scenarios.sensor_log import COMMAND_COLUMNS, CURRENT_COLUMNS
from slipnav.studies.cli import main
from slipnav.systems.robot.faults import FaultEvent

TIMED = ("wall_time_s", "realtime_factor", "engine")
"""The summary keys that tell how the replay ran, not what it found."""


def assert_engines_agree(log, model) -> dict:
    """Both engines' replays of ``log``: the same keys in the same order, every array bit for bit, the same
    summary but its timing; returns the plain replay's arrays."""
    plain = replay_log(log, model, "log")
    diagram = replay_log(log, model, "log", engine="diagram")
    assert plain.summary["engine"] == "plain" and diagram.summary["engine"] == "diagram"
    assert list(plain.arrays) == list(diagram.arrays)
    for key, value in diagram.arrays.items():
        other = plain.arrays[key]
        assert other.dtype == value.dtype and other.shape == value.shape, key
        assert other.tobytes() == value.tobytes(), key
    drop = {key: None for key in TIMED}
    assert {**plain.summary, **drop} == {**diagram.summary, **drop}
    return plain.arrays


@pytest.fixture(scope="module")
def pushed_run():
    """A square with sensor faults and a sideways push beyond the tyres' grip: the checks exclude and
    replace, and the perturbation monitor's push reaches the mixer (v_n the free integral)."""
    faults = [
        FaultEvent("dropout", "gyro", 1.5, 0.1),
        FaultEvent("spike", "encoder_R", 1.6, 0.5, 1000.0),
        FaultEvent("nan", "accel2_t", 1.7, 0.02),
        FaultEvent("body_push", "body_n", 2.0, 0.5, 2.0),
    ]
    return run_scenario(dc.replace(load_scenario("square"), faults=faults), duration=2.6)


def test_the_plain_replay_of_a_run_with_faults_and_a_push_is_the_diagrams(pushed_run):
    a = assert_engines_agree(pushed_run.sensor_log, pushed_run.model)
    assert a["perturbation_body"].any() and (a["tyre_model_weight"] == 1.0).any()  # the push was taken
    assert a["health_gyro"].any() and a["health_encoder_R"].any() and a["fault"].any()
    np.testing.assert_array_equal(a["est_v_n"], pushed_run.arrays["est_v_n"])  # and the run's


def test_the_plain_replay_without_commands_and_currents_is_the_diagrams(pushed_run):
    """No commands: no monitor (no perturbation keys), no push; no currents: the odometry's force
    reference."""
    log = dc.replace(pushed_run.sensor_log, columns=dict(pushed_run.sensor_log.columns))
    for column in COMMAND_COLUMNS + CURRENT_COLUMNS:
        del log.columns[column]
    a = assert_engines_agree(log, pushed_run.model)
    assert "perturbation_body" not in a and "meas_current_R" not in a


@pytest.mark.parametrize("sets", [1, 0])
def test_the_plain_replay_of_a_log_with_fewer_accelerometer_sets_is_the_diagrams(sets):
    """A corner whose robot and model carry one accelerometer set or none (NaN columns in the log)."""
    scenario = load_scenario("corner")
    scenario = dc.replace(
        scenario, sensor_overrides={**scenario.sensor_overrides, "accelerometer_sets": sets}
    )
    run = run_scenario(scenario, duration=1.6)
    assert np.isnan(run.sensor_log.columns["acc2_t"]).all()
    a = assert_engines_agree(run.sensor_log, run.model)
    np.testing.assert_array_equal(a["est_x"], run.arrays["est_x"])


def test_replay_and_evaluate_run_the_plain_engine_by_default(pushed_run, tmp_path, capsys):
    write_artifacts(pushed_run, tmp_path, figures=False)
    log = tmp_path / "square-seed0.sensors.csv"
    summary = tmp_path / "square-seed0-replay.summary.json"
    assert main(["replay", str(log), "--out", str(tmp_path), "--no-figures"]) == 0
    assert json.loads(summary.read_text())["engine"] == "plain"
    assert main(["replay", str(log), "--out", str(tmp_path), "--no-figures", "--engine", "diagram"]) == 0
    assert json.loads(summary.read_text())["engine"] == "diagram"
    truth = tmp_path / "square.truth.csv"
    a = pushed_run.arrays
    rows = zip(a["t"], a["true_x"], a["true_y"], a["true_phi"], strict=True)
    truth.write_text("t,x,y,yaw,quality\n" + "".join(f"{t},{x},{y},{p},1\n" for t, x, y, p in rows))
    assert main(["evaluate", str(log), "--truth", str(truth), "--out", str(tmp_path)]) == 0
    assert json.loads(summary.read_text())["engine"] == "plain"
    with pytest.raises(SystemExit) as e:
        main(["evaluate", str(log), "--truth", str(truth), "--engine", "nope"])
    assert e.value.code == 2 and "invalid choice: 'nope'" in capsys.readouterr().err
    with pytest.raises(EvaluationError, match="--engine applies to a sensor log"):
        load_estimates(tmp_path / "square-seed0-replay.npz", truth, engine="diagram")
    with pytest.raises(ValueError, match="engine='nope' is unknown: allowed plain, diagram"):
        replay_log(pushed_run.sensor_log, pushed_run.model, engine="nope")
