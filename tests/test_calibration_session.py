"""slipnav calibrate SESSION.yaml: a real robot's logs and hand measurements, read as a session
(studies/calibration_session.py); the simulated session round-trips to the same identification."""

import dataclasses as dc
import math
import os
import re
import stat

import numpy as np
import pytest
from slipnav.scenarios.config import Scenario, ScenarioError
from slipnav.scenarios.model import RobotModel, load_model
from slipnav.scenarios.sensor_log import SensorLog, write_sensor_log
from slipnav.studies.calibration import calibrate, compare
from slipnav.studies.calibration_session import read_session, write_session
from slipnav.studies.cli import main

from tests.shared import calibration_manoeuvres


@pytest.fixture(scope="module")
def simulated(tmp_path_factory):
    """Kurt3D's calibration manoeuvres for seed 5 (simulated once: tests/shared.py), in memory and
    written as a session."""
    manoeuvres, truth = calibration_manoeuvres(Scenario(robot="kurt3d", trajectory=None), 5)
    folder = tmp_path_factory.mktemp("lab") / "kurt3d-day1.calibration"
    session = write_session(manoeuvres, folder, "kurt3d", "simulated lab day")
    return manoeuvres, truth, session


def test_session_round_trip_identifies_exactly_what_the_memory_does(simulated, tmp_path, capsys):
    manoeuvres, truth, session = simulated
    direct = calibrate(manoeuvres, "kurt3d", RobotModel(robot="kurt3d"))
    assert main(["calibrate", str(session), "--out", str(tmp_path)]) == 0
    printed = capsys.readouterr().out.strip().splitlines()
    path = tmp_path / "kurt3d-day1.calibrated.model.yaml"
    assert printed[-1] == f"calibration model={path}"
    model = load_model(path)
    robot = model.robot_parameters()
    assert robot.radius_R == direct.values["wheel_radius_R"]  # bit for bit: logs round-trip exactly
    assert robot.track_width == direct.values["track_width"]
    assert model.calibration.gyro_scale_error == direct.values["gyro_scale_error"]
    assert "simulated lab day" in model.description
    # And what was identified is Kurt3D's drawn robot (radii 0.1 %, track 0.3 %).
    for key, (_, _, relative, _) in compare(direct, truth).items():
        if key in ("wheel_radius_R", "wheel_radius_L"):
            assert abs(relative) < 1e-3, key
        if key == "track_width":
            assert abs(relative) < 3e-3


def _tiny_session(tmp_path, text: str, log_rows=None):
    t = np.arange(5) * 0.002 if log_rows is None else log_rows
    columns = {"t": t, "gyro": np.zeros(5), "enc_R": np.zeros(5), "enc_L": np.zeros(5)}
    columns.update({c: np.zeros(5) for c in ("acc1_t", "acc1_n", "acc2_t", "acc2_n")})
    write_sensor_log(SensorLog(columns=columns), tmp_path / "a.sensors.csv")
    path = tmp_path / "session.yaml"
    path.write_text(text)
    return path


@pytest.mark.parametrize(
    "text, message",
    [
        ("robot: tinyphoon\nmanoeuvres: []\n", r"manoeuvres is empty"),
        ("robot: tinyphoon\nmanoeuvers: []\n", r"manoeuvers is an unknown key"),
        ("robot: r2d2\nmanoeuvres: [{kind: standstill, log: a.sensors.csv}]\n", r"robot='r2d2' is unknown"),
        ("manoeuvres: [{kind: wobble, log: a.sensors.csv}]\n", r"manoeuvres\[0\].kind='wobble' is unknown"),
        ("manoeuvres: [{kind: square, log: a.sensors.csv}]\n", r"manoeuvres\[0\].measured_pose is missing"),
        (
            "manoeuvres: [{kind: square, log: a.sensors.csv, measured_pose: [0, 0]}]\n",
            r"measured_pose=\[0.0, 0.0\]: allowed three finite numbers",
        ),
        (
            "manoeuvres: [{kind: standstill, log: a.sensors.csv, pose_std: [0.001, 0]}]\n",
            r"manoeuvres\[0\].pose_std=.*allowed two numbers > 0",
        ),
        (
            "manoeuvres: [{kind: standstill, log: b.sensors.csv}]\n",
            r"manoeuvres\[0\].log='b.sensors.csv': no such",
        ),
        (
            "manoeuvres: [{kind: standstill, log: a.sensors.csv, speed: x}]\n",
            r"manoeuvres\[0\].speed: expected float",
        ),
    ],
)
def test_malformed_session_is_a_clear_error(tmp_path, text, message):
    with pytest.raises(ScenarioError, match=message):
        read_session(_tiny_session(tmp_path, text))


def test_a_malformed_log_names_the_manoeuvre_column_and_row_and_nothing_is_written(tmp_path, capsys):
    t = np.array([0.0, 0.002, 0.004, 0.003, 0.008])
    path = _tiny_session(tmp_path, "manoeuvres: [{kind: standstill, log: a.sensors.csv}]\n", t)
    out = tmp_path / "out"
    out.mkdir()
    assert main(["calibrate", str(path), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "manoeuvres[0].log" in err and "column 't'" in err and "row 4" in err
    assert list(out.iterdir()) == []


def test_an_incomplete_session_writes_no_model(tmp_path, simulated, capsys):
    _, _, session = simulated
    text = session.read_text()
    only_still = text.split("- kind: spot_turn")[0]  # the standstill alone
    (session.parent / "still.yaml").write_text(only_still)
    out = tmp_path / "out"
    out.mkdir()
    assert main(["calibrate", str(session.parent / "still.yaml"), "--out", str(out)]) == 2
    assert "calibration needs the manoeuvres" in capsys.readouterr().err
    assert list(out.iterdir()) == []


def test_calibrate_needs_a_session_or_simulate(capsys):
    assert main(["calibrate"]) == 2
    assert "give a calibration session SESSION.yaml or --simulate ROBOT" in capsys.readouterr().err


def test_write_session_refuses_an_existing_folder(tmp_path, simulated):
    manoeuvres, _, _ = simulated
    (tmp_path / "day").mkdir()
    with pytest.raises(ScenarioError, match=r"folder .*day.* exists"):
        write_session([dc.replace(manoeuvres[0])], tmp_path / "day", "kurt3d")


def _edited_session(session, tmp_path, edit):
    """A copy of the session file beside its logs, its text changed by ``edit``."""
    path = session.parent / f"edited-{tmp_path.name}.yaml"
    path.write_text(edit(session.read_text()))
    return path


def test_a_heading_measured_modulo_a_turn_is_a_clear_error(tmp_path, simulated, capsys):
    """A spot turn's three revolutions written as the protractor's remainder would identify radii tens of
    per cent off: the session is refused, naming the manoeuvre's measured heading and its unwrapped value."""
    manoeuvres, _, session = simulated
    index = next(i for i, m in enumerate(manoeuvres) if m.kind == "spot_turn")
    heading = manoeuvres[index].measured_pose[2]
    wrapped = math.remainder(heading, 2.0 * math.pi)
    path = _edited_session(session, tmp_path, lambda text: text.replace(repr(heading), repr(wrapped), 1))
    out = tmp_path / "out"
    assert main(["calibrate", str(path), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("slipnav: error: ") and err.count("\n") == 1, err
    assert f"manoeuvres[{index}].measured_pose[2]={wrapped!r}" in err and "whole revolutions" in err
    assert not out.exists() or list(out.iterdir()) == []


def test_logs_that_contradict_the_session_are_a_clear_error(tmp_path, simulated, capsys):
    """The standstill's log swapped for a spiral's: what the logs identify is out of range (a gyro bias of
    a turning robot), reported as the session's contradiction, with no model written."""
    _, _, session = simulated
    text = session.read_text()
    standstill = re.search(r"log: (\S*standstill\S*)", text).group(1)
    spiral = re.search(r"log: (\S*spiral\S*)", text).group(1)
    path = _edited_session(session, tmp_path, lambda t: t.replace(f"log: {standstill}", f"log: {spiral}", 1))
    out = tmp_path / "out"
    assert main(["calibrate", str(path), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("slipnav: error: ") and err.count("\n") == 1, err
    assert "contradict each other" in err and "is out of range" in err
    assert list(out.iterdir()) == []


def test_seed_options_with_a_session_are_a_clear_error(simulated, capsys):
    _, _, session = simulated
    assert main(["calibrate", str(session), "--seeds", "3"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("slipnav: error: --seeds with a calibration session") and err.count("\n") == 1


def test_a_written_session_is_as_readable_as_the_umask_says(tmp_path, simulated):
    manoeuvres, _, _ = simulated
    previous = os.umask(0o002)
    try:
        session = write_session([dc.replace(manoeuvres[0])], tmp_path / "day", "kurt3d")
    finally:
        os.umask(previous)
    assert stat.S_IMODE(session.parent.stat().st_mode) == 0o775
    for path in session.parent.iterdir():
        assert stat.S_IMODE(path.stat().st_mode) == 0o664, path
