"""The slipnav command line and the run artifact contract (docs/artifacts.md)."""

import json

import numpy as np
import pytest
from slipnav.scenarios.artifact_arrays import SCALAR_KEYS, SERIES_KEYS
from slipnav.scenarios.config import builtin_scenarios
from slipnav.studies import cli
from slipnav.studies.cli import COMMANDS, main
from slipnav.studies.cli_parser import build_parser

from tests.shared import shared_runs

SUMMARY_KEYS = {
    "scenario",
    "seed",
    "path_length_m",
    "duration_s",
    "completion_time_s",
    "final_position_error_m",
    "rms_position_error_m",
    "max_position_error_m",
    "max_position_error_time_s",
    "wall_time_s",
    "realtime_factor",
}


def test_every_subcommand_has_a_handler_and_every_handler_a_subcommand():
    subcommands = next(a for a in build_parser("")._actions if a.dest == "command").choices
    assert set(COMMANDS) == set(subcommands)


def test_list(capsys):
    assert main(["list"]) == 0
    assert capsys.readouterr().out.split() == builtin_scenarios()


@pytest.mark.parametrize("name", ["corner", "square", "circle", "long_path"])
def test_every_scenario_runs_and_honours_the_artifact_contract(name, tmp_path, capsys):
    assert main(["run", name, "--out", str(tmp_path), "--seed", "3", "--duration", "1.2"]) == 0
    data = np.load(tmp_path / f"{name}-seed3.npz")
    n = len(data["t"])
    assert n == 601  # 1.2 s on the 2 ms grid, both ends included (1 s standstill, then driving)
    np.testing.assert_allclose(np.diff(data["t"]), 0.002, atol=1e-12)
    for key in SERIES_KEYS:
        assert data[key].shape == (n,) and data[key].dtype == float, key
    for key in SCALAR_KEYS:
        assert data[key].shape == (), key
    assert float(data["T_N"]) == 0.002 and float(data["T_C"]) == 0.02
    trajectory_mode = name in ("corner", "square")
    for key in ("step_size", "progress"):  # slip control exists in trajectory mode only
        assert np.all(np.isfinite(data[key]) == trajectory_mode), key
    for key in (
        "true_x",
        "cmd_R",
        "est_x",
        "est_alpha",
        "odo_x",
        "gyro_phi",
        "C1",
        "C2",
        "C3",
        "delta_v",
        "ref_x",
        "ref_phi",
    ):
        assert np.all(np.isfinite(data[key])), key
    assert float(data["start_time"]) == 1.0
    before = data["t"] <= 1.0  # +inf until the follower's first update, at the standstill's end
    assert np.all(data["V1"][before] == np.inf) and np.all(np.isfinite(data["V1"][~before]))
    assert np.all(data["cmd_R"][before] == 0.0) and np.max(np.abs(data["true_x"][before])) < 1e-9
    summary = json.loads((tmp_path / f"{name}-seed3.summary.json").read_text())
    assert SUMMARY_KEYS <= set(summary)
    assert summary["seed"] == 3 and summary["scenario"] == name
    for key in ("final_position_error_m", "rms_position_error_m", "max_position_error_m"):
        assert all(v is not None and v >= 0.0 for v in summary[key].values()), key
    for fig in ("path", "error", "speeds", "slip", "navigation", "control"):
        assert (tmp_path / f"{name}-seed3.{fig}.png").stat().st_size > 10_000


def test_corner_slides_sideways_and_square_spins_wheels_open_loop(tmp_path):
    """Issue 2's done-criterion: visible side-slip in the corner, tangential slip in the square."""
    with shared_runs(cli):  # the open corner, shared (tests/shared.py)
        assert main(["run", "corner", "--out", str(tmp_path), "--no-figures", "--open-loop"]) == 0
    corner = json.loads((tmp_path / "corner-seed0-open-loop.summary.json").read_text())
    assert corner["peak_abs_true_alpha_deg"] > 5.0
    assert corner["completion_time_s"] is not None
    assert (
        main(["run", "square", "--out", str(tmp_path), "--no-figures", "--duration", "2.0", "--open-loop"])
        == 0
    )
    square = np.load(tmp_path / "square-seed0-open-loop.npz")
    slip_speed = square["true_wheel_R"] - square["true_v_t"]
    assert np.max(np.abs(slip_speed)) > 0.4  # wheels run 0.4 m/s ahead of / behind the body
    assert np.max(np.abs(np.degrees(square["true_alpha"][square["true_v_t"] > 0.2]))) < 1.0
    assert np.all(np.isnan(square["V1"]))  # no controller in the open loop


def test_control_flags(tmp_path):
    assert (
        main(
            [
                "run",
                "corner",
                "--out",
                str(tmp_path),
                "--no-figures",
                "--duration",
                "0.5",
                "--no-slip-control",
            ]
        )
        == 0
    )
    data = np.load(tmp_path / "corner-seed0-no-slip-control.npz")
    assert np.all(data["step_size"] == 1.0)
    summary = json.loads((tmp_path / "corner-seed0-no-slip-control.summary.json").read_text())
    assert summary["slip_control"] is False
    assert (
        main(
            [
                "run",
                "circle",
                "--out",
                str(tmp_path),
                "--no-figures",
                "--duration",
                "1.0",
                "--speed-law",
                "constant",
            ]
        )
        == 0
    )
    data = np.load(tmp_path / "circle-seed0-speed-law-constant.npz")
    assert np.max(data["cmd_R"]) <= 0.5 * float(data["V_m"]) * 1.3  # u = V_m/2 plus steering


@pytest.mark.parametrize(
    "argv, message",
    [
        (["run", "nosuch"], "neither a built-in"),
        (["run", "corner", "--seed", "-1"], "seed=-1"),
        (["run", "corner", "--duration", "0"], "--duration=0.0"),
    ],
)
def test_user_errors_exit_2_without_traceback(argv, message, capsys, tmp_path):
    assert main(argv + ["--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err


def test_yaml_file_scenario(tmp_path, capsys):
    f = tmp_path / "mine.yaml"
    f.write_text("trajectory:\n  segments:\n    - !Straight {length: 0.2, v_end: 0.5}\nsettle_time: 0.1\n")
    assert main(["run", str(f), "--out", str(tmp_path), "--no-figures"]) == 0
    summary = json.loads((tmp_path / "mine-seed0.summary.json").read_text())
    assert summary["path_length_m"] == pytest.approx(0.2)
    bad = tmp_path / "bad.yaml"
    bad.write_text("trajectory:\n  segmnts: []\n")
    assert main(["run", str(bad), "--out", str(tmp_path)]) == 2
    assert "trajectory.segmnts is an unknown key" in capsys.readouterr().err


def test_a_robot_that_did_not_move_reports_no_path_error(tmp_path, capsys):
    """Tyres without grip: the robot stays at its start, whose distance from the path is nanometres; the
    summary says it did not move and gives no path error (null), the command warns."""
    f = tmp_path / "no-grip.yaml"
    f.write_text(
        "mode: max_speed\npath:\n  segments:\n    - !Arc {radius: 0.5, angle_deg: 90}\n"
        "plant: {robot_overrides: {tyre_friction: 0.001}}\nduration: 2\n"
    )
    assert main(["run", str(f), "--out", str(tmp_path), "--no-figures"]) == 0
    summary = json.loads((tmp_path / "no-grip-seed0.summary.json").read_text())
    assert summary["moved"] is False and summary["travelled_m"] < 0.01
    assert summary["path_error_rms_m"] is None and summary["path_error_max_m"] is None
    err = capsys.readouterr().err
    assert "slipnav: warning: no-grip did not move: the robot travelled " in err and "(moved: false)" in err
    assert main(["run", "corner", "--out", str(tmp_path), "--no-figures", "--duration", "1.5"]) == 0
    assert json.loads((tmp_path / "corner-seed0.summary.json").read_text())["moved"] is True


def test_bad_choice_exits_2(capsys):
    with pytest.raises(SystemExit) as e:
        main(["run", "corner", "--speed-law", "fast"])
    assert e.value.code == 2
    assert "invalid choice: 'fast'" in capsys.readouterr().err


def test_bench_prints_the_contract_line(capsys):
    """``slipnav bench``: the diagram and the plain loop compute the same samples; the last line is the
    DESIGN.md contract. (A benchmark: the speeds are printed, not asserted.)"""
    assert main(["bench", "corner", "--repeat", "1"]) == 0
    lines = capsys.readouterr().out.strip().splitlines()
    assert "same samples: max position difference 0.0e+00 m" in "\n".join(lines)
    last = dict(item.split("=") for item in lines[-1].split())
    assert list(last) == ["realtime_factor", "diagram_over_loop", "overhead_in_floors"]
    assert float(last["realtime_factor"]) > 0.0 and float(last["diagram_over_loop"]) > 0.0
    float(last["overhead_in_floors"])  # a number (negative only if the diagram beat the plain loop)
    # The Python callbacks per sample: 20 per T_N sample (13 updates, 7 outputs the same sample reads) and
    # the T_C blocks' about 9 every T_C (corner: T_C = 10 T_N).
    callbacks = next(line for line in lines if "Python callbacks per T_N" in line)
    count = float(callbacks.split("Python callbacks per T_N")[0].split(";")[-1])
    assert 20.5 < count < 21.5, callbacks  # the exact figure moves with the run's events (20.9)


@pytest.mark.parametrize(
    "argv, message",
    [
        (["bench", "nowhere"], "nowhere"),
        (["bench", "corner", "--repeat", "0"], "--repeat=0 is out of range"),
    ],
)
def test_bench_user_errors_exit_2(argv, message, capsys):
    assert main(argv) == 2
    assert message in capsys.readouterr().err
