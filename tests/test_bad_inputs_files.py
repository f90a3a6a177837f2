"""User mistakes in what the command line reads and writes besides the scenario: --out paths, a scheduler
address, a results file resumed, sensor logs and model files. Each gives exit status 2 and one line on
stderr naming the flag or key and what is allowed, before any simulation starts (the fixture below makes
starting one fail the test). Servers in these tests listen on the loopback address only."""

import socket
import threading

import numpy as np
import pytest
from slipnav.scenarios import progress, runner
from slipnav.scenarios.sensor_log import SensorLog, read_sensor_log, write_sensor_log
from slipnav.studies import engine, sweep
from slipnav.studies.cli import main


@pytest.fixture(autouse=True)
def no_simulation(monkeypatch):
    """Every mistake must be reported before a simulator exists."""

    def refuse(*args, **kwargs):
        raise AssertionError("a simulation was started for a bad input")

    monkeypatch.setattr(runner, "make_simulator", refuse)


def _one_line_error(capsys, argv) -> str:
    """main(argv)'s stderr, after checking the exit status 2 and the one line."""
    assert main(argv) == 2, argv
    err = capsys.readouterr().err
    assert err.startswith("slipnav: error: ") and err.count("\n") == 1, err
    assert "Traceback" not in err
    return err


# --- slipnav diagram --out


def test_diagram_out_is_a_directory(tmp_path, capsys):
    (tmp_path / "x.dot").mkdir()
    err = _one_line_error(capsys, ["diagram", "closed_loop", "--out", str(tmp_path / "x.dot")])
    assert "--out=" in err and "is a directory" in err and "allowed a FILE.dot" in err


def test_diagram_out_below_a_file(tmp_path, capsys):
    (tmp_path / "a_file").write_text("x")
    err = _one_line_error(capsys, ["diagram", "navigation", "--out", str(tmp_path / "a_file" / "x.dot")])
    assert "--out=" in err and "a folder of it is a file" in err


@pytest.mark.parametrize("out", ["/proc/slipnav-test/x.dot", "/proc/x.dot"])
def test_diagram_out_that_cannot_be_written(out, capsys):
    """Folders no one can create a file in (as a read-only file system): the OSError as one line."""
    err = _one_line_error(capsys, ["diagram", "navigation", "--out", out])
    assert f"--out={out!r} cannot be written" in err and "allowed a FILE.dot" in err


# --- --scheduler: an address that is no dask scheduler


@pytest.fixture
def short_scheduler_timeout(monkeypatch):
    monkeypatch.setattr(engine, "SCHEDULER_TIMEOUT", 1.0)


def _accuracy_on(address, tmp_path):
    return ["accuracy", "corner", "--seeds", "1", "--scheduler", address, "--out", str(tmp_path / "out")]


def test_scheduler_that_never_answers_times_out(tmp_path, capsys, short_scheduler_timeout):
    """A port that accepts connections and stays silent (the kernel accepts into the backlog)."""
    with socket.create_server(("127.0.0.1", 0)) as server:
        address = f"tcp://127.0.0.1:{server.getsockname()[1]}"
        err = _one_line_error(capsys, _accuracy_on(address, tmp_path))
    assert f"--scheduler={address!r} did not answer as a dask scheduler within 1 s" in err


def test_scheduler_that_answers_something_else(tmp_path, capsys, short_scheduler_timeout):
    """A web server's reply is no dask message."""
    server = socket.create_server(("127.0.0.1", 0))

    def answer():
        with server:
            connection, _ = server.accept()
            with connection:
                connection.sendall(b"HTTP/1.1 400 Bad Request\r\nContent-Length: 0\r\n\r\n" * 4)

    thread = threading.Thread(target=answer, daemon=True)
    thread.start()
    address = f"tcp://127.0.0.1:{server.getsockname()[1]}"
    err = _one_line_error(capsys, _accuracy_on(address, tmp_path))
    thread.join(5)
    assert f"--scheduler={address!r} did not answer as a dask scheduler" in err


def test_scheduler_port_refused(tmp_path, capsys):
    with socket.create_server(("127.0.0.1", 0)) as server:
        port = server.getsockname()[1]  # closed at once: nothing listens there
    err = _one_line_error(capsys, _accuracy_on(f"tcp://127.0.0.1:{port}", tmp_path))
    assert "cannot be reached" in err and "allowed the address of a running dask scheduler" in err


# --- --resume: a results file that is not one


def _accuracy_resumed(tmp_path, seeds=1):
    return ["accuracy", "corner", "--seeds", str(seeds), "--workers", "0", "--out", str(tmp_path), "--resume"]


@pytest.mark.parametrize("resume", [True, False])
def test_results_file_is_a_directory(tmp_path, capsys, resume):
    (tmp_path / "accuracy.csv").mkdir()
    argv = _accuracy_resumed(tmp_path)[: None if resume else -1]
    err = _one_line_error(capsys, argv)
    assert "accuracy.csv' is a directory: allowed a file (or none) there" in err


def test_results_file_with_a_huge_field(tmp_path, capsys):
    huge = "x" * 200000
    (tmp_path / "accuracy.csv").write_text(f"key,code_version,scenario,seed\nk,{huge},corner,0\n")
    err = _one_line_error(capsys, _accuracy_resumed(tmp_path))
    assert "--resume: " in err and "line 2 is not a results line (field larger than field limit" in err


@pytest.mark.parametrize("text", ["not a results file", "x,y"])
def test_results_file_of_one_line_without_its_newline(tmp_path, capsys, text):
    """A file with no complete line: a sweep writes its header whole, so a first line that is no start of
    one is another file, not a header being written."""
    (tmp_path / "accuracy.csv").write_text(text)
    err = _one_line_error(capsys, _accuracy_resumed(tmp_path))
    assert "is not a sweep results file (its first column is not 'key')" in err
    assert (tmp_path / "accuracy.csv").read_text() == text  # left as it was


def test_results_file_with_a_word_where_a_number_was(tmp_path, capsys):
    """A resumed line of this code version whose number cell was overwritten with a word: refused before
    the study's table reads it (every run resumed: no simulation)."""
    jobs = [{"scenario": "corner", "seed": seed, "duration": None, "open_loop": None} for seed in range(2)]
    lines = ["key,code_version,scenario,seed,duration,open_loop,fused_error_m"]
    for job, value in zip(jobs, ("abc", "0.0016"), strict=True):
        key = sweep.job_key(job)
        lines.append(f"{key},{sweep.run_version(job)},corner,{job['seed']},,,{value}")
    (tmp_path / "accuracy.csv").write_text("\n".join(lines) + "\n")
    err = _one_line_error(capsys, _accuracy_resumed(tmp_path, seeds=2))
    key = sweep.job_key(jobs[0])
    assert f"the line of {key!r} holds fused_error_m='abc'" in err
    assert "allowed a file as a sweep wrote it, or no --resume" in err


# --- model files and sensor log metadata: what a run refuses, replay refuses alike


def _log(tmp_path, metadata=None, rows=5, last_truth=0.0, sensors=0.0):
    """A short sensor log at rest with truth columns; ``last_truth``: the last row's true_x."""
    t = np.arange(rows) * 0.002
    columns = {"t": t, "enc_R": np.zeros(rows), "enc_L": np.zeros(rows)}
    columns.update({c: np.full(rows, sensors) for c in ("gyro", "acc1_t", "acc1_n", "acc2_t", "acc2_n")})
    if sensors != sensors:  # nan: every sensor column without a sample
        columns["enc_R"] = columns["enc_L"] = np.full(rows, np.nan)
    columns.update({c: np.zeros(rows) for c in ("true_x", "true_y", "true_phi")})
    columns["true_x"][-1] = last_truth
    log = SensorLog(columns=columns, metadata={"robot": "tinyphoon", "T_N": 0.002, **(metadata or {})})
    return write_sensor_log(log, tmp_path / "lab.sensors.csv")


MODEL = "robot: tinyphoon\nT_N: 0.002\nT_C: 0.02\n"


@pytest.mark.parametrize(
    "model, message",
    [
        (MODEL + "robot_overrides: {track_width: 1.0e-9}\n", "robot_overrides.track_width=1e-09 is out of"),
        (MODEL + "robot_overrides: {mass: 1.0e+6}\n", "robot_overrides.mass=1000000.0 is out of range"),
        ("robot: tinyphoon\nT_N: 0.002\nT_C: 0.021\n", "T_C=0.021 must be a positive integer multiple"),
    ],
)
@pytest.mark.parametrize("command", ["run", "replay"])
def test_a_model_run_refuses_replay_refuses_alike(model, message, command, tmp_path, capsys):
    """One validation path (RobotModel.validate, the robot's physics included) for run and replay."""
    (tmp_path / "m.yaml").write_text(model)
    source = "corner" if command == "run" else str(_log(tmp_path))
    argv = [command, source, "--model", str(tmp_path / "m.yaml"), "--out", str(tmp_path / "out")]
    err = _one_line_error(capsys, [*argv, "--no-figures"])
    assert f"model file {str(tmp_path / 'm.yaml')!r}: {message}" in err


@pytest.mark.parametrize(
    "metadata, message",
    [
        ({"initial_speed": 1e9}, "metadata initial_speed=1000000000.0 is out of range: allowed finite"),
        ({"T_C": 0.021}, "metadata T_C=0.021 must be a positive integer multiple of T_N=0.002"),
        ({"T_C": 0.04}, "metadata T_C=0.04 s differs from the model's T_C=0.02 s"),
    ],
)
def test_log_metadata_a_run_would_refuse(metadata, message, tmp_path, capsys):
    log = _log(tmp_path, metadata)
    err = _one_line_error(capsys, ["replay", str(log), "--out", str(tmp_path / "out"), "--no-figures"])
    assert message in err


def test_a_log_whose_last_truth_is_missing_replays_without_a_final_error(tmp_path, capsys):
    log = _log(tmp_path, last_truth=np.nan)
    assert main(["replay", str(log), "--out", str(tmp_path / "out"), "--no-figures"]) == 0
    captured = capsys.readouterr()
    assert "(the last row's truth is missing: no final error)" in captured.out
    assert captured.err == ""


def test_a_log_without_any_sensor_sample_is_replayed_with_a_warning(tmp_path, capsys):
    log = _log(tmp_path, sensors=np.nan)
    assert main(["replay", str(log), "--out", str(tmp_path / "out"), "--no-figures"]) == 0
    err = capsys.readouterr().err
    assert err.startswith("slipnav: warning: sensor log ") and err.count("\n") == 1
    assert "the columns gyro, acc1_t, acc1_n, acc2_t, acc2_n, enc_R, enc_L hold no valid sample" in err


# --- progress of long tasks


def test_reading_a_long_log_reports_progress_in_plain_lines(tmp_path, capsys, monkeypatch):
    """Not a terminal (capsys): plain lines, no bar's carriage returns; DELAY 0 stands for a long read."""
    monkeypatch.setattr(progress, "DELAY", 0.0)
    read_sensor_log(_log(tmp_path, rows=50))
    lines = capsys.readouterr().err.splitlines()
    assert lines and lines[-1].startswith("slipnav: reading lab.sensors.csv: 100 % (")
    assert lines[-1].endswith(" s") and " MB), " in lines[-1] and "\r" not in "".join(lines)


def test_a_short_task_reports_nothing(capsys):
    with progress.TaskProgress(10, "slipnav: counting", "things") as task:
        for done in range(11):
            task.update(done)
    assert capsys.readouterr().err == ""
