"""Accuracy metrics (scenarios/metrics.py) on hand-made signals, and the accuracy command."""

import math

import numpy as np
import pytest
from slipnav.scenarios.cli import main
from slipnav.scenarios.metrics import (
    detection_latencies,
    final_position_error,
    rms_position_error,
    side_slip_rms_error,
    side_slip_rms_error_at_updates,
    side_slip_sample_counts,
    slip_episodes,
)
from slipnav.studies.accuracy import side_slip_lines


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
    assert "side-slip RMS error" in out  # square: peak |alpha| ~ 1 deg, never a bare "goal met"
    assert main(["accuracy", "--seeds", "0"]) == 2
    assert "--seeds=0" in capsys.readouterr().err
