"""slipnav evaluate: the metrics on hand-made trajectories with known answers, the files it writes (TUM,
JSON, figure), the health shares, the command line's mistakes."""

import json
import math

import numpy as np
import pytest
from slipnav.scenarios import evaluate as ev
from slipnav.studies.cli import main


def _straight(t):
    """The truth: along x at 1 m/s, heading 0."""
    return np.column_stack([t, np.zeros_like(t), np.zeros_like(t)])


def test_a_scale_error_has_known_ate_and_rpe():
    t = np.arange(0.0, 20.0 + 1e-9, 0.1)
    truth = _straight(t)
    estimate = truth * [1.1, 0.0, 0.0]  # 10 % too far: the error is 0.1 t
    m = ev.trajectory_metrics(t, estimate, truth)
    assert m["final_error_m"] == pytest.approx(2.0)
    assert m["ate_m"] == pytest.approx(0.1 * math.sqrt(np.mean(t**2)))
    assert m["rpe_per_m"]["translation_m"] == pytest.approx(0.1)  # 1.1 m driven per metre
    assert m["rpe_per_10s"]["translation_m"] == pytest.approx(1.0)
    assert m["rpe_per_m"]["rotation_deg"] == 0.0 and m["final_heading_error_deg"] == 0.0
    assert m["path_length_m"] == pytest.approx(20.0)


def test_a_steady_drift_has_a_known_windowed_ate():
    """An estimate drifting sideways at 0.01 m/s: aligned afresh at each 30 s window's start, its error
    grows from 0 to 0.3 m in every window, RMS near 0.3 / sqrt(3) m (960 samples per window); a 59 s
    log has one window: no windowed ATE."""
    t = np.arange(0.0, 90.0 + 1e-9, 1.0 / 32.0)  # exact in binary: the windows split at 30 s and 60 s
    truth = np.column_stack([t, np.zeros_like(t), np.zeros_like(t)])  # 1 m/s along x
    estimate = truth + np.column_stack([np.zeros_like(t), 0.01 * t, np.zeros_like(t)])
    windowed = ev.windowed_ate(t, estimate, truth)
    assert windowed["windows"] == 3 and windowed["window_s"] == 30.0
    expected = math.sqrt(np.mean((0.01 / 32.0 * np.arange(960)) ** 2))  # 0.1730 m
    np.testing.assert_allclose(windowed["per_window_m"], expected, rtol=1e-9)
    assert windowed["median_m"] == pytest.approx(expected) and windowed["p90_m"] == pytest.approx(expected)
    assert ev.windowed_ate(t[t < 59.0], estimate[t < 59.0], truth[t < 59.0]) is None
    assert ev.trajectory_metrics(t, estimate, truth)["windowed_ate"]["windows"] == 3


def test_a_heading_drift_has_known_rpe_rotation_and_the_start_pose_is_aligned():
    t = np.arange(0.0, 20.0 + 1e-9, 0.1)
    truth = _straight(t)
    drift = 0.01  # rad/s of heading error, positions right
    estimate = np.column_stack([t, np.zeros_like(t), drift * t])
    m = ev.trajectory_metrics(t, estimate, truth)
    assert m["final_heading_error_deg"] == pytest.approx(math.degrees(0.2))
    assert m["rms_heading_error_deg"] == pytest.approx(math.degrees(drift * math.sqrt(np.mean(t**2))))
    assert m["rpe_per_10s"]["rotation_deg"] == pytest.approx(math.degrees(0.1))
    # the relative motion over 1 m seen from the estimate's turned pose: 1 m at -drift t off the truth's
    i = np.arange(len(t) - 10)
    expected = np.sqrt(np.mean((2 * np.sin(drift * t[i] / 2)) ** 2 + 0.0 * i))
    assert m["rpe_per_m"]["translation_m"] == pytest.approx(expected, rel=1e-9)
    # A rigidly moved copy of the truth: aligned on its start pose, no error at all.
    c, s = math.cos(0.7), math.sin(0.7)
    moved = np.column_stack([3 + c * t, -2 + s * t, np.full_like(t, 0.7)])
    m = ev.trajectory_metrics(t, moved, truth)
    assert m["ate_m"] < 1e-12 and m["rpe_per_m"]["translation_m"] < 1e-12


def _write_truth(path, t, pose, quality=None):
    quality = np.ones(len(t)) if quality is None else quality
    rows = ["# a comment", "t,x,y,yaw,quality"]
    rows += [
        ",".join([*(repr(float(v)) for v in (a, b, c, d)), str(int(q))])
        for a, (b, c, d), q in zip(t, pose, quality, strict=True)
    ]
    path.write_text("\n".join(rows) + "\n")
    return path


def _arrays(t):
    truth = _straight(t)
    a = {"t": t, "C1": np.where(t < 5, 0.5, 1.0), "fault": (t > 18).astype(float)}
    for prefix, scale in (("est", 1.0), ("odo", 1.1), ("gyro", 1.05)):
        a[f"{prefix}_x"], a[f"{prefix}_y"], a[f"{prefix}_phi"] = (truth * [scale, 0, 0]).T
    a["health_gyro"] = np.where(t > 18, 2.0, 0.0)
    a["health_encoder_R"] = np.zeros_like(t)
    return a


def test_evaluate_writes_tum_json_and_figure_from_an_npz(tmp_path, capsys):
    t = np.arange(0.0, 20.0 + 1e-9, 0.002)
    np.savez(tmp_path / "run.npz", **_arrays(t))
    tt = np.arange(-0.5, 19.0, 0.01)  # the truth ends before the log: the rest is not judged
    quality = np.where((tt > 3) & (tt < 3.05), 0, 1)
    truth = _write_truth(tmp_path / "truth.csv", tt, _straight(tt), quality)
    out = tmp_path / "out"
    assert main(["evaluate", str(tmp_path / "run.npz"), "--truth", str(truth), "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "run odometry: final 1.899 m" in printed
    result = json.loads((out / "run.evaluation.json").read_text())
    fused, odo = result["estimates"]["fused"], result["estimates"]["odometry"]
    assert fused["ate_m"] == 0.0 and odo["final_error_m"] == pytest.approx(0.1 * 19.0, abs=0.001)
    assert result["truth"]["end_s"] == pytest.approx(19.0 - 0.01, abs=0.003)
    # the truth's 50 ms outage at 3 s (5 median rows) is left out, as is the time after its end
    assert result["truth"]["covered_share"] == pytest.approx((18.99 - 0.05) / 20.0, abs=0.001)
    h = result["health"]
    assert h["channels"] == {"encoder_R": 0.0, "gyro": pytest.approx(2.0 / 20.0, abs=1e-3)}
    assert h["any_health_channel"] == h["fault"] and h["C1_below_0.75"] == pytest.approx(0.25, abs=1e-3)
    for label in ("truth", "fused", "odometry", "gyrodometry"):
        rows = (out / f"run-{label}.tum").read_text().splitlines()
        assert rows[0].startswith("#") and all(len(r.split()) == 8 for r in rows[1:])
    assert len((out / "run-truth.tum").read_text().splitlines()) == 1 + int(quality.sum())
    assert (out / "run.evaluation.png").stat().st_size > 10_000


def test_tum_quaternion_is_the_rotation_about_z():
    line = ev.tum_text([1.5], [2.0], [3.0], [math.pi / 2]).splitlines()[1].split()
    assert [float(v) for v in line] == pytest.approx([1.5, 2, 3, 0, 0, 0, math.sqrt(0.5), math.sqrt(0.5)])


@pytest.mark.parametrize(
    "truth_text, log_name, phrase",
    [
        ("t,x,y,quality\n0,0,0,1\n", "run.npz", "column 'yaw' is missing"),
        ("t,x,y,yaw,quality\n0,0,0,a,1\n1,0,0,0,1\n", "run.npz", "line 2: 'a' is not a number"),
        ("t,x,y,yaw,quality\n1,0,0,0,1\n0,0,0,0,1\n", "run.npz", "column 't' must increase"),
        ("t,x,y,yaw,quality\n100,0,0,0,1\n101,0,0,0,1\n", "run.npz", "covers none of LOG's times"),
        ("t,x,y,yaw,quality\n0,0,0,0,1\n1,0,0,0,1\n", "run.txt", "allowed a sensor log (.csv) or"),
        ("t,x,y,yaw,quality\n0,0,0,0,1\n1,0,0,0,1\n", "missing.npz", "is not a file"),
    ],
)
def test_evaluate_mistakes_exit_2_with_one_line(truth_text, log_name, phrase, tmp_path, capsys):
    np.savez(tmp_path / "run.npz", **_arrays(np.arange(0.0, 2.0, 0.1)))
    (tmp_path / "run.txt").write_text("x")
    (tmp_path / "truth.csv").write_text(truth_text)
    argv = [
        "evaluate",
        str(tmp_path / log_name),
        "--truth",
        str(tmp_path / "truth.csv"),
        "--out",
        str(tmp_path),
    ]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith("slipnav: error: ") and phrase in err and err.count("\n") == 1


@pytest.fixture(scope="module")
def short_trial(tmp_path_factory):
    """Trial 2's first 5 s imported (log, model, truth files)."""
    from tests.test_import import TURTLEBOT

    if not (TURTLEBOT / "trial_2").is_dir():
        pytest.skip(f"the TurtleBot dataset is not at {TURTLEBOT} (../shared/datasets beside the repository)")
    from slipnav.scenarios.import_turtlebot import import_trial
    from slipnav.scenarios.importers import write_import

    result = import_trial(TURTLEBOT / "trial_2")
    result.log.columns = {k: v[:2500] for k, v in result.log.columns.items()}
    return write_import(result, tmp_path_factory.mktemp("import"))


def test_evaluate_replays_an_imported_log_and_judges_it(short_trial, tmp_path, capsys):
    log, _, truth, _ = short_trial
    assert main(["evaluate", str(log), "--truth", str(truth), "--out", str(tmp_path)]) == 0
    stem = "phil-turtlebot-trial_2-replay"
    assert (tmp_path / f"{stem}.npz").is_file() and (tmp_path / f"{stem}.summary.json").is_file()
    result = json.loads((tmp_path / f"{stem}.evaluation.json").read_text())
    assert result["truth"]["covered_share"] == 1.0
    for label in ("fused", "odometry", "gyrodometry"):
        m = result["estimates"][label]
        assert m["path_length_m"] > 0.5 and m["final_error_m"] < 0.1, label
    assert set(result["health"]) == {"any_health_channel", "channels", "fault", "C1_below_0.75"}
