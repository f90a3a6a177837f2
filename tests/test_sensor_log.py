"""The sensor log (scenarios/sensor_log.py), slipnav replay and the model file (scenarios/model.py)."""

import dataclasses as dc
import json
import math

import numpy as np
import pytest
from slipnav.scenarios.config import load_scenario
from slipnav.scenarios.model import ModelError, load_model
from slipnav.scenarios.replay import replay_file
from slipnav.scenarios.runner import run_scenario
from slipnav.scenarios.sensor_log import (
    REQUIRED_COLUMNS,
    SensorLog,
    SensorLogError,
    read_sensor_log,
    sensor_log_text,
    write_sensor_log,
)
from slipnav.studies.cli import main
from slipnav.systems.health import INCONSISTENT
from slipnav.systems.robot.faults import FaultEvent

COMPARED = [
    "est_x est_y est_phi est_v_t est_v_n est_omega est_a_t est_a_n est_alpha est_track_speed",
    "odo_x odo_y odo_phi odo_v_t odo_omega gyro_x gyro_y gyro_phi C1 C2 C3 delta_v fault est_gyro_bias",
    "est_radius_difference est_radius_difference_std",
]
COMPARED = " ".join(COMPARED).split()


def _small_log(n=6):
    t = 0.002 * np.arange(n)
    columns = {c: np.linspace(-1.0, 1.0, n) + i for i, c in enumerate(REQUIRED_COLUMNS)}
    columns["t"] = t
    columns["enc_R"] = np.arange(n, dtype=float) * 3 - 2
    columns["enc_L"] = -np.arange(n, dtype=float)
    return SensorLog(columns=columns, metadata={"robot": "tinyphoon", "T_N": 0.002})


def _lines(tmp_path, log=None):
    return sensor_log_text(log or _small_log()).splitlines()


def _write(tmp_path, lines):
    path = tmp_path / "bad.sensors.csv"
    path.write_text("\n".join(lines) + "\n")
    return path


def test_floats_and_counts_round_trip_exactly(tmp_path):
    log = _small_log()
    log.columns["gyro"] = np.array([0.1 + 0.2, 1e-300, -2.0 / 3.0, math.pi, np.nan, np.inf])
    log.columns["enc_R"][4] = np.nan
    path = write_sensor_log(log, tmp_path / "x.sensors.csv")
    back = read_sensor_log(path)
    assert set(back.columns) == set(log.columns)
    for key, values in log.columns.items():
        np.testing.assert_array_equal(back.columns[key], values, err_msg=key)
    assert back.gyro[0] == 0.1 + 0.2 and back.gyro[2] == -2.0 / 3.0  # bit for bit, not approximately
    assert back.metadata["robot"] == "tinyphoon" and back.metadata["T_N"] == 0.002


def _header_index(lines):
    return next(i for i, line in enumerate(lines) if line.startswith("t,"))


@pytest.mark.parametrize(
    "edit, column, row, phrase",
    [
        (lambda h, rows: (h.replace("gyro", "gyr"), rows), "gyr", None, "is unknown"),
        (
            lambda h, rows: (h.replace(",enc_L", ""), [r.rsplit(",", 1)[0] for r in rows]),
            "enc_L",
            None,
            "missing",
        ),
        (lambda h, rows: (h + ",cmd_R", [r + ",0.5" for r in rows]), "cmd_L", None, "come together"),
        (lambda h, rows: (h, rows[:3] + [rows[1]] + rows[4:]), "t", 4, "must increase"),
        (lambda h, rows: (h, rows[:3] + rows[4:]), "t", 4, "off T_N"),
        (
            lambda h, rows: (h, [rows[0], rows[1].replace(rows[1].split(",")[1], "abc", 1), *rows[2:]]),
            "gyro",
            2,
            "not a number",
        ),
        (
            lambda h, rows: (h, [rows[0], rows[1], rows[2].rsplit(",", 1)[0] + ",7.5", *rows[3:]]),
            "enc_L",
            3,
            "whole number",
        ),
        (lambda h, rows: (h, [rows[0], rows[1] + ",1.0", *rows[2:]]), None, 2, "cells"),
        (lambda h, rows: (h, [rows[0].replace("0.0,", "nan,", 1), *rows[1:]]), "t", 1, "finite"),
    ],
)
def test_malformed_logs_name_the_column_and_row(tmp_path, capsys, edit, column, row, phrase):
    lines = _lines(tmp_path)
    i = _header_index(lines)
    header, rows = edit(lines[i], lines[i + 1 :])
    path = _write(tmp_path, [*lines[:i], header, *rows])
    with pytest.raises(SensorLogError) as info:
        read_sensor_log(path)
    message = str(info.value)
    assert phrase in message
    if column is not None:
        assert f"column {column!r}" in message
    if row is not None:
        assert f"row {row} (line {i + 1 + row})" in message
    out = tmp_path / "out"
    assert main(["replay", str(path), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("slipnav: error: ") and phrase in err and len(err.strip().splitlines()) == 1
    assert sorted(p.name for p in out.iterdir()) == []  # nothing written


def test_spacing_is_checked_against_the_navigation_period(tmp_path):
    log = _small_log()
    log.columns["t"] = 0.004 * np.arange(len(log))
    log.metadata = {}
    path = write_sensor_log(log, tmp_path / "slow.csv")
    with pytest.raises(
        SensorLogError, match=r"column 't', row 2 \(line \d+\): spacing 0.004 s .* off T_N = 0.002"
    ):
        read_sensor_log(path)
    assert len(read_sensor_log(path, T_N=0.004)) == len(log)
    log.metadata = {"T_N": 0.004}
    path = write_sensor_log(log, tmp_path / "slow.csv")
    with pytest.raises(SensorLogError, match="metadata T_N=0.004 s differs from the navigation's T_N=0.002"):
        read_sensor_log(path, T_N=0.002)


@pytest.fixture(scope="module")
def corner_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("runs")
    assert (
        main(["run", "corner", "--out", str(out), "--duration", "2.2", "--no-figures", "--tolerances"]) == 0
    )
    return out


def test_run_writes_its_sensor_log_and_model(corner_run):
    a = np.load(corner_run / "corner-seed0-tolerances.npz")
    log = read_sensor_log(corner_run / "corner-seed0-tolerances.sensors.csv")
    assert log.has_truth and log.has_commands and len(log) == len(a["t"])
    np.testing.assert_array_equal(log.t, a["t"])
    np.testing.assert_array_equal(log.gyro, a["meas_gyro"])
    np.testing.assert_array_equal(log.accelerometers[:, 3], a["meas_a_n2"])
    np.testing.assert_array_equal(
        log.encoder_angles(6144), np.column_stack([a["meas_enc_R"], a["meas_enc_L"]])
    )
    assert np.all(log.encoder_counts == np.round(log.encoder_counts))
    assert log.encoder_counts[-1, 0] > 1000  # the wheels turned: about 0.8 m / (2 pi 15 mm) * 6144
    model = load_model(corner_run / "corner-seed0-tolerances.model.yaml")
    assert model.robot == "tinyphoon" and model.robot_overrides == {}  # the belief, not the drawn plant
    summary = json.loads((corner_run / "corner-seed0-tolerances.summary.json").read_text())
    assert summary["plant"]["wheel_radius_R"] != 0.015  # the plant was drawn; the model did not see it


def test_replaying_a_runs_log_reproduces_its_navigation_bit_for_bit(corner_run, capsys):
    capsys.readouterr()
    log = corner_run / "corner-seed0-tolerances.sensors.csv"
    assert main(["replay", str(log), "--out", str(corner_run)]) == 0
    printed = capsys.readouterr().out
    assert "corner-seed0-tolerances-replay.npz" in printed and "model.yaml" in printed
    run = np.load(corner_run / "corner-seed0-tolerances.npz")
    replay = np.load(corner_run / "corner-seed0-tolerances-replay.npz")
    from slipnav.scenarios.artifact_arrays import SCALAR_KEYS, SERIES_KEYS

    assert set(SERIES_KEYS) | set(SCALAR_KEYS) <= set(replay.files)  # the same artifact keys
    assert np.isnan(replay["ref_x"]).all() and np.isnan(replay["true_slip_R"]).all()  # no plant, no reference
    keys = ["t", "meas_gyro", "meas_enc_L", "true_x", "cmd_R", "meas_current_R", "meas_current_L"]
    keys += ["perturbation_body", "perturbation_force_R"]  # the monitor, from the log's commands
    for key in COMPARED + keys:
        np.testing.assert_array_equal(replay[key], run[key], err_msg=key)  # currents: the log's cur_R/L
    assert np.isfinite(run["est_x"]).all() and np.ptp(run["est_x"]) > 0.5
    summary = json.loads((corner_run / "corner-seed0-tolerances-replay.summary.json").read_text())
    ran = json.loads((corner_run / "corner-seed0-tolerances.summary.json").read_text())
    assert summary["final_position_error_m"] == ran["final_position_error_m"]
    assert (corner_run / "corner-seed0-tolerances-replay.path.png").is_file()
    assert (corner_run / "corner-seed0-tolerances-replay.error.png").is_file()  # the log has the truth


def test_a_run_with_a_sideways_push_replays_bit_for_bit(tmp_path):
    """With the log's commands the replay runs the perturbation monitor as the run did: its flags, and
    the sideways push it feeds the mixer (v_n from the lateral kinematics), come out the same; without
    the commands the replay takes no push and its v_n parts from the run's."""
    push = FaultEvent("body_push", "body_n", 2.0, 0.5, 2.0)  # 5 m/s^2 x Tinyphoon's mass, to the left
    result = run_scenario(dc.replace(load_scenario("square"), faults=[push]), duration=2.6)
    from slipnav.scenarios.runner import write_artifacts
    from slipnav.scenarios.sensor_log import COMMAND_COLUMNS

    write_artifacts(result, tmp_path, figures=False)
    path = tmp_path / "square-seed0.sensors.csv"
    replayed = replay_file(path)
    assert result.arrays["perturbation_body"].any()
    for key in COMPARED + ["perturbation_body", "perturbation_yaw", "perturbation_force_L"]:
        np.testing.assert_array_equal(replayed.arrays[key], result.arrays[key], err_msg=key)
    assert replayed.summary["perturbations"] == result.summary["perturbations"]
    lines = path.read_text().splitlines()  # the same log without its command columns
    header = next(i for i, line in enumerate(lines) if not line.startswith("#"))
    names = lines[header].split(",")
    keep = [i for i, name in enumerate(names) if name not in COMMAND_COLUMNS]
    lines[header:] = [",".join(line.split(",")[i] for i in keep) for line in lines[header:]]
    path.write_text("\n".join(lines) + "\n")
    blind = replay_file(path)
    assert "perturbations" not in blind.summary
    np.testing.assert_array_equal(blind.arrays["est_v_n"][:1000], result.arrays["est_v_n"][:1000])
    assert np.max(np.abs(blind.arrays["est_v_n"] - result.arrays["est_v_n"])) > 0.05


def test_replay_of_a_kurt3d_run_with_its_own_navigation_tuning(tmp_path):
    """circle: Kurt3D with the scenario's navigation keys; the written model carries them."""
    result = run_scenario(load_scenario("circle"), seed=2, duration=2.5)
    from slipnav.scenarios.runner import write_artifacts

    write_artifacts(result, tmp_path, figures=False)
    replayed = replay_file(tmp_path / "circle-seed2.sensors.csv")
    for key in COMPARED:
        np.testing.assert_array_equal(replayed.arrays[key], result.arrays[key], err_msg=key)


def test_nan_cells_reach_the_sensor_check_and_no_truth_means_no_comparison(corner_run, tmp_path):
    log = read_sensor_log(corner_run / "corner-seed0-tolerances.sensors.csv")
    for key in ("true_x", "true_y", "true_phi", "true_v_t", "true_v_n", "true_omega", "cmd_R", "cmd_L"):
        del log.columns[key]
    log.columns["gyro"][200] = np.nan
    log.columns["acc2_n"][300] = np.nan
    log.columns["enc_R"][400] = np.nan
    path = write_sensor_log(log, tmp_path / "robot.sensors.csv")
    result = replay_file(path, corner_run / "corner-seed0-tolerances.model.yaml")
    a = result.arrays
    # 401: the first encoder increment after the NaN spans it and is not used (recovering); 402-411 are
    # the re-admission block (health.encoder_readmission_samples), 411 its last, re-admitted. The gyro's
    # NaN at 200 is followed by its own block (health.gyro_readmission_samples): 201-204 recovering.
    np.testing.assert_array_equal(np.flatnonzero(a["fault"]), [*range(200, 205), 300, *range(400, 411)])
    assert np.isfinite(a["est_x"]).all() and np.isnan(a["true_x"]).all()
    assert result.summary["has_truth"] is False
    assert result.summary["final_position_error_m"] == {"fused": None, "odometry": None, "gyrodometry": None}
    run = np.load(corner_run / "corner-seed0-tolerances.npz")
    np.testing.assert_array_equal(a["est_x"][:200], run["est_x"][:200])  # identical until the first fault
    assert abs(a["est_x"][-1] - run["est_x"][-1]) < 2e-3


def test_model_file_errors_name_the_key(tmp_path, capsys, corner_run):
    bad = tmp_path / "bad.model.yaml"
    bad.write_text("robot: tinyphoon\nrobot_overrides: {track_widht: 0.07}\n")
    with pytest.raises(ModelError, match=r"robot_overrides.track_widht is unknown"):
        load_model(bad)
    log = corner_run / "corner-seed0-tolerances.sensors.csv"
    assert main(["replay", str(log), "--model", str(bad), "--out", str(tmp_path / "o")]) == 2
    assert "track_widht" in capsys.readouterr().err
    bad.write_text("robot: tinyphoon\nsensor_overrides: {encoder_counts_per_revolution: 512}\n")
    assert main(["replay", str(log), "--model", str(bad), "--out", str(tmp_path / "o")]) == 2
    assert "encoder_counts_per_revolution" in capsys.readouterr().err


def test_a_runs_injected_faults_are_in_its_log_and_replay_the_same(tmp_path):
    """The log holds what the navigation read, faults included: the replay flags and excludes the same
    samples and reproduces the run's navigation bit for bit."""
    faults = [
        FaultEvent("dropout", "gyro", 1.5, 0.1),
        FaultEvent("spike", "encoder_R", 1.6, 0.5, 1000.0),
        FaultEvent("nan", "accel2_t", 1.7, 0.02),
        FaultEvent("bias", "accel1_t", 1.8, 0.1, 5.0),  # the pair's check, with the currents' reference
    ]
    result = run_scenario(dc.replace(load_scenario("corner"), faults=faults), duration=2.0)
    from slipnav.scenarios.runner import write_artifacts

    write_artifacts(result, tmp_path, figures=False)
    replayed = replay_file(tmp_path / "corner-seed0.sensors.csv")
    for key in COMPARED + ["health_gyro", "health_encoder_R", "health_accel2_t", "health_accel1_t"]:
        np.testing.assert_array_equal(replayed.arrays[key], result.arrays[key], err_msg=key)
    assert result.arrays["health_gyro"].any() and result.arrays["health_encoder_R"].any()
    assert (result.arrays["health_accel1_t"] == INCONSISTENT).any()
    assert replayed.summary["sensor_faults"] == result.summary["sensor_faults"] > 0
