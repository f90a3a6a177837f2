"""Accuracy metrics (scenarios/metrics.py) on hand-made signals, and the accuracy command."""

import math

import numpy as np
import pytest
from slipnav.scenarios.metrics import (
    POSE_DELAY_SAMPLES,
    along_run_figures,
    detection_latencies,
    final_position_error,
    position_error_along_run,
    position_errors,
    position_errors_in_percent,
    rms_position_error,
    side_slip_rms_error,
    side_slip_rms_error_at_updates,
    side_slip_sample_counts,
    slip_episodes,
)
from slipnav.studies.accuracy import along_run_lines, side_slip_lines
from slipnav.studies.cli import main
from slipnav.studies.long_run import position_error_lines

from tests.shared import scenario_run


def synthetic(n=1000, T_N=0.002):
    t = np.arange(n) * T_N
    a = {
        "t": t,
        "T_N": np.array(T_N),
        "T_C": np.array(0.02),
        "true_v_t": np.full(n, 1.0),
        "true_v_n": np.zeros(n),
    }
    a["true_wheel_R"] = a["true_wheel_L"] = np.full(n, 1.0)
    a["C1"] = np.ones(n)
    return a


def test_slip_episodes_and_latency():
    a = synthetic()
    for start, stop in ((100, 150), (160, 170), (500, 600)):  # the second merges into the first
        a["true_wheel_R"][start:stop] += 0.4
        a["true_wheel_L"][start:stop] += 0.4
    onsets = slip_episodes(a)
    assert onsets == pytest.approx([0.2, 1.0])
    a["C1"][112:140] = 0.2  # detected 12 samples = 24 ms = 1.2 T_C after the first onset
    a["C1"][495:520] = 0.1  # drop 10 ms before the second onset counts as immediate
    latencies = detection_latencies(a, onsets)
    assert latencies[0] == pytest.approx(0.024) and latencies[1] == 0.0
    a["C1"][:] = 1.0
    assert detection_latencies(a, onsets) == [None, None]
    # One batch of a clear detection with p = 0.5: C1 = p * 1 + (1 - p) * logsig, just above 0.5, is
    # counted at the default level 0.75, not at 0.5 (which needs a second batch).
    a["C1"][110:120] = 0.5 + 0.5 * 1e-3
    assert detection_latencies(a, onsets)[0] == pytest.approx(0.02)
    assert detection_latencies(a, onsets, c1_level=0.5)[0] is None


def test_position_and_side_slip_errors():
    a = synthetic()
    a.update(true_x=np.zeros(3), true_y=np.zeros(3), est_x=np.array([0, 0, 3.0]), est_y=np.array([0, 0, 4.0]))
    assert final_position_error(a, "est") == 5.0
    # RMS over the run: errors 0, 0, 5 -> sqrt(25 / 3); a path that returns to the truth at the end has
    # no final error but keeps its RMS.
    assert rms_position_error(a, "est") == pytest.approx(math.sqrt(25 / 3))
    a.update(est_x=np.array([0, 3.0, 0]), est_y=np.array([0, 4.0, 0]))
    assert final_position_error(a, "est") == 0.0
    assert rms_position_error(a, "est") == pytest.approx(5 / math.sqrt(3))
    # A robot at 1 m/s sampled every 0.5 m whose estimate lags two rows: 1 m off in the same row, exact
    # against the truth two rows back (rows 2..4 against 0..2).
    lagging = {"true_x": np.arange(5) * 0.5, "true_y": np.zeros(5), "est_y": np.zeros(5)}
    lagging["est_x"] = np.r_[0.0, 0.0, np.arange(3) * 0.5]
    assert rms_position_error(lagging, "est", delay_samples=2) == 0.0
    assert rms_position_error(lagging, "est") == pytest.approx(math.sqrt((0 + 0.25 + 1 + 1 + 1) / 5))
    for bad in (-1, 1.5, True):
        with pytest.raises(ValueError, match="delay_samples"):
            rms_position_error(lagging, "est", delay_samples=bad)
    b = synthetic(4)
    b["true_alpha"] = np.radians([0.5, 2.0, -3.0, 4.0])
    b["est_alpha"] = np.radians([0.0, 1.0, -3.0, 4.0])
    assert math.degrees(side_slip_rms_error(b)) == pytest.approx(math.sqrt(1 / 3))


def known_error_profile() -> dict:
    """A robot at rest, driving 0.1 m a row, at rest again (true x 0, 0, 0.1, 0.2, 0.3, 0.3, 0.3, 0.3);
    each estimate describes the truth two rows back plus an error of 0, 5, 0, 3, 0, 1 m on rows 2..7:
    final 1 m, RMS sqrt(35 / 6) m, max 5 m on row 3 (t = 0.3 s), path 0.3 m."""
    true_x = np.array([0.0, 0.0, 0.1, 0.2, 0.3, 0.3, 0.3, 0.3])
    error_x = np.array([0.0, 0.0, 0.0, 3.0, 0.0, 3.0, 0.0, 0.0])
    error_y = np.array([0.0, 0.0, 0.0, 4.0, 0.0, 0.0, 0.0, 1.0])
    a = {"t": np.arange(8) * 0.1, "true_x": true_x, "true_y": np.zeros(8), "path_length": np.array(0.3)}
    for prefix in ("est", "odo", "gyro"):
        a[f"{prefix}_x"] = np.r_[0.0, 0.0, true_x[:-2]] + error_x
        a[f"{prefix}_y"] = error_y.copy()
    a["odo_x"] = a["odo_x"] * 2.0  # odometry: twice the error along x
    return a


def test_position_errors_final_rms_and_max_of_a_known_profile():
    """The three figures of every accuracy report on a hand-made run: the closed path's end (1 m) hides
    the 5 m mid-run; each pose is judged against the truth of the instant it describes."""
    a = known_error_profile()
    assert POSE_DELAY_SAMPLES == 2
    np.testing.assert_allclose(position_error_along_run(a, "est", 2), [0, 5, 0, 3, 0, 1], atol=1e-12)
    errors = position_errors(a, "est")
    assert errors["final"] == pytest.approx(1.0, abs=1e-12)
    assert errors["rms"] == pytest.approx(math.sqrt(35 / 6), rel=1e-12)
    assert errors["max"] == pytest.approx(5.0, rel=1e-12) and errors["max_time_s"] == pytest.approx(0.3)
    percent = position_errors_in_percent(a, "est")
    expected = {"final": 100 / 0.3, "rms": 100 * math.sqrt(35 / 6) / 0.3, "max": 500 / 0.3}
    assert percent == pytest.approx(expected, rel=1e-12)
    # the same row's truth adds the 0.1 m a row of the lag to every moving row (row 2: 0.1 m, not 0)
    assert position_error_along_run(a, "est")[2] == pytest.approx(0.1)
    assert rms_position_error(a, "est", POSE_DELAY_SAMPLES) == pytest.approx(errors["rms"], rel=1e-12)
    figures = along_run_figures(a)
    assert figures["fused_max_error_m"] == pytest.approx(5.0)
    assert figures["fused_max_error_time_s"] == pytest.approx(0.3)
    assert figures["fused_rms_error_pct"] == pytest.approx(100 * math.sqrt(35 / 6) / 0.3, rel=1e-12)
    # odometry: x doubled, row 3 is (6, 4) m off the truth of row 1
    odometry = position_errors(a, "odo")
    assert odometry["max"] == pytest.approx(math.hypot(6.0, 4.0), rel=1e-12)
    assert figures["fused_over_odometry_max"] == pytest.approx(5.0 / odometry["max"], rel=1e-12)


def test_position_errors_skip_rows_without_truth_and_fail_on_a_lost_estimate():
    """A row whose truth (two rows back) is missing is left out, the final figure is the last row's; an
    estimate that is not finite where there is truth gives no RMS nor max (NaN), never a smaller one."""
    a = known_error_profile()
    a["true_y"] = np.r_[0.0, np.nan, np.zeros(6)]  # row 3's truth: the 5 m error is not judged
    errors = position_errors(a, "est")
    assert errors["max"] == pytest.approx(3.0) and errors["rms"] == pytest.approx(math.sqrt(10 / 5))
    assert errors["final"] == pytest.approx(1.0)
    a = known_error_profile()
    a["est_x"][4] = np.nan
    errors = position_errors(a, "est")
    assert math.isnan(errors["rms"]) and math.isnan(errors["max"]) and errors["final"] == pytest.approx(1.0)


def test_accuracy_states_its_goals_against_the_rms_and_the_maximum_too():
    """The accuracy study's lines for the hand-made profile: the fused RMS (sqrt(35/6) m of a 0.3 m path,
    805 %) and maximum (5 m, 1667 %) in % and over odometry-only's, then each estimate's in metres."""
    figures = along_run_figures(known_error_profile())
    lines = along_run_lines(lambda key: np.array([figures[key], figures[key]]))
    rms_pct, ratio = 100 * math.sqrt(35 / 6) / 0.3, figures["fused_over_odometry_rms"]
    assert lines[0].startswith(f"  fused RMS error        mean {rms_pct:.2f} %  worst {rms_pct:.2f} %")
    assert "(goal <= 1 %, stated on the final error)" in lines[0]
    assert lines[1].strip().startswith(f"over odometry-only's: mean {ratio:.2f}") and "<= 0.3" in lines[1]
    assert lines[2].startswith(f"  fused max error        mean {500 / 0.3:.2f} %")
    assert lines[5].startswith("  max errors (m)         fused 5.0000  odometry 7.2111")


def test_the_long_run_prints_each_estimates_three_errors():
    """The long-run benchmark's lines from a run's summary, "-" where it has none (a replay without truth,
    an older summary)."""
    summary = {
        "final_position_error_m": {"fused": 0.0086, "odometry": 0.0713, "gyrodometry": None},
        "rms_position_error_m": {"fused": 0.0363, "odometry": 0.0770, "gyrodometry": None},
        "max_position_error_m": {"fused": 0.0594, "odometry": 0.1375, "gyrodometry": None},
        "max_position_error_time_s": {"fused": 5.626, "odometry": 5.626, "gyrodometry": None},
    }
    assert position_error_lines(summary) == [
        "  position error fused        final 0.0086 m, RMS 0.0363 m, max 0.0594 m at 5.6 s",
        "  position error odometry     final 0.0713 m, RMS 0.0770 m, max 0.1375 m at 5.6 s",
        "  position error gyrodometry  final - m, RMS - m, max - m at - s",
    ]
    assert position_error_lines({})[0] == "  position error fused        final - m, RMS - m, max - m at - s"


def test_the_closed_squares_summary_reports_the_error_it_ends_without():
    """The closed square (seed 0) ends near where its fused estimate puts it, but the estimate was off by
    several centimetres mid-run: the summary's maximum is far above its final error, and the figures are
    the arrays' own."""
    result = scenario_run("square")
    s, a = result.summary, result.arrays
    for label, prefix in (("fused", "est"), ("odometry", "odo"), ("gyrodometry", "gyro")):
        errors = position_errors(a, prefix)
        assert s["final_position_error_m"][label] == final_position_error(a, prefix)
        assert s["rms_position_error_m"][label] == errors["rms"]
        assert s["max_position_error_m"][label] == errors["max"]
        assert s["max_position_error_time_s"][label] == errors["max_time_s"]
        final, rms = s["final_position_error_m"][label], s["rms_position_error_m"][label]
        assert final <= rms < s["max_position_error_m"][label]
    fused = {key: s[f"{key}_position_error_m"]["fused"] for key in ("final", "rms", "max")}
    assert fused["max"] > 5.0 * fused["final"]  # measured 5.94 cm against 0.86 cm
    assert fused["max"] > 0.01 * s["path_length_m"]  # above 1 % of the path mid-run (1.12 %)
    assert s["standstill_s"] < s["max_position_error_time_s"]["fused"] < s["completion_time_s"]


def test_side_slip_error_at_the_updates_leaves_out_the_hold():
    """est_alpha as the T_C block logs it (alpha_K of sample K n on rows K n + 1 ... K n + n) of a true
    alpha ramping by s per sample: exact at the updates, while the per-sample figure counts the hold,
    errors s, 2 s, ..., 10 s: RMS s sqrt(38.5). A constant 0.5 deg offset is 0.5 deg either way."""
    a = synthetic(400)
    slope = math.radians(0.1)
    a["true_alpha"] = math.radians(2.0) + slope * np.arange(400)
    rows = np.arange(400)
    a["est_alpha"] = a["true_alpha"][np.maximum((rows - 1) // 10 * 10, 0)]
    assert side_slip_rms_error_at_updates(a) == pytest.approx(0.0, abs=1e-15)
    inner = slice(1, 391)  # whole holds only
    b = {k: (v[inner] if isinstance(v, np.ndarray) and v.ndim else v) for k, v in a.items()}
    assert side_slip_rms_error(b) == pytest.approx(slope * math.sqrt(38.5), rel=1e-12)
    a["est_alpha"] += math.radians(0.5)
    assert math.degrees(side_slip_rms_error_at_updates(a)) == pytest.approx(0.5, rel=1e-12)
    a["true_alpha"][:] = math.radians(0.5)  # below the 1 deg threshold everywhere
    assert math.isnan(side_slip_rms_error_at_updates(a))


def test_side_slip_figure_reports_the_samples_it_rests_on():
    """|alpha| > 1 deg on rows 95..124 (30 T_N samples) holds the updates at rows 100, 110, 120 (3 of
    T_C = 10 T_N); a slow row (0.1 m/s, below MOVING_SPEED) inside does not count."""
    a = synthetic(400)
    a["true_alpha"] = np.zeros(400)
    a["true_alpha"][95:125] = math.radians(2.0)
    a["true_v_t"][96] = 0.1
    assert side_slip_sample_counts(a) == (29, 3)
    assert side_slip_sample_counts(a, threshold_deg=3.0) == (0, 0)


def test_accuracy_says_not_enough_samples_below_the_minimum():
    """The square's case: 0-7 samples, 0-1 updates on every seed -> no verdict, the counts printed; one seed
    with 27 updates -> judged on that seed alone."""
    nan = math.nan
    alpha, at_updates = np.array([0.09, nan, 0.14]), np.array([nan, nan, 0.12])
    few = side_slip_lines(alpha, at_updates, np.array([3.0, 0.0, 7.0]), np.array([0.0, 0.0, 1.0]))
    text = "\n".join(few)
    assert "not enough samples" in text and "no verdict" in text
    assert "0-7 T_N samples (0-1 T_C updates)" in text and "fewer than 10 T_C updates" in text
    assert "mean 0.12 deg" in text  # (0.09 + 0.14) / 2, shown as what there is, not as a result
    enough = side_slip_lines(alpha, at_updates, np.array([3.0, 0.0, 270.0]), np.array([0.0, 0.0, 27.0]))
    assert "mean 0.14 deg  worst 0.14 deg" in enough[0] and "not enough" not in "\n".join(enough)
    assert "0-270 T_N samples (0-27 T_C updates)" in enough[2] and "1/3 seeds with >= 10 updates" in enough[2]
    none = side_slip_lines(np.full(2, nan), np.full(2, nan), np.zeros(2), np.zeros(2))
    assert none == ["  side-slip RMS error    no sample with |alpha| > 1 deg on any seed: nothing to judge"]


def test_accuracy_command_smoke(capsys, tmp_path):
    argv = ["accuracy", "square", "--seeds", "1", "--duration", "2.0", "--workers", "0"]
    assert main([*argv, "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "fused final error" in out and "tangential slip" in out
    assert "fused RMS error" in out and "fused max error" in out and "max errors (m)" in out
    assert "side-slip RMS error" in out  # square: peak |alpha| ~ 1 deg, never a bare "goal met"
    assert main(["accuracy", "--seeds", "0"]) == 2
    assert "--seeds=0" in capsys.readouterr().err
