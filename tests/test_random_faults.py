"""The random sensor-fault benchmark (studies/random_faults.py, ``slipnav faults --random N``): the draw
per seed and its stated distributions, the significance, flag, isolation, false-alarm and error metrics on
hand-made npz-like dicts, the summary's targets, and one tiny real run through the command line."""

import json
import math

import numpy as np
import pytest
from slipnav.studies.cli import main
from slipnav.studies.fault_cases import MEASURED_KEYS
from slipnav.studies.random_faults import (
    BIAS_SIGMA,
    CLASS_KINDS,
    CLASSES,
    DRAWN_CHANNELS,
    ENCODER_BIAS_COUNTS,
    ENCODER_SPIKE_COUNTS,
    LONG_CLASSES,
    LONG_DURATION,
    RAMP_SIGMA_PER_S,
    SATURATION_FRACTION,
    SCALE_CHANGE,
    SHORT_DURATION,
    SPIKE_SIGMA,
    detection_time,
    draw_fault,
    driving_part,
    false_alarms,
    fault_figures,
    first_flagged,
    flag_onsets,
    noise_sigma,
    place_fault,
    significance,
    summarise,
)
from slipnav.systems.robot.faults import ENCODER_CHANNELS, MAX_FAULT_TIME, FaultEvent
from slipnav.systems.robot.sensors import SensorParameters

SENSORS = SensorParameters()
GYRO_SIGMA, ACCEL_SIGMA = 0.014, 0.062
ENCODER_SIGMA = SENSORS.encoder_step / math.sqrt(12.0)
SEEDS = range(13 * 100)
DRAWS = [draw_fault(seed) for seed in SEEDS]


def test_the_draw_is_deterministic_per_seed_and_differs_between_seeds():
    assert [draw_fault(seed) for seed in SEEDS] == DRAWS
    first = DRAWS[0]  # pinned: the streams [45, 0] and [45, 0, 1] of numpy's PCG64
    assert (first["fault_class"], first["kind"], first["channel"], first["unit"]) == (
        "bias_step",
        "bias",
        "gyro",
        "sigma",
    )
    assert first["magnitude"] == pytest.approx(3.2443222383406343, rel=1e-12)
    assert first["sign"] == -1.0
    onsets = [d["onset_fraction"] for d in DRAWS]
    assert len(set(onsets)) == len(onsets)
    with pytest.raises(ValueError, match="seed=-1"):
        draw_fault(-1)
    with pytest.raises(ValueError, match="seed=True"):
        draw_fault(True)


def test_every_class_is_drawn_once_per_block_of_13_seeds_on_every_valid_channel():
    assert len(CLASSES) == 13
    for block in range(len(SEEDS) // 13):
        assert sorted(d["fault_class"] for d in DRAWS[13 * block : 13 * block + 13]) == sorted(CLASSES)
    valid = {
        (c, ch)
        for c, (analog, encoder) in CLASS_KINDS.items()
        for ch in DRAWN_CHANNELS
        if (encoder if ch in ENCODER_CHANNELS else analog)
    }
    assert len(valid) == 80  # 9 classes on the 7 channels, 3 on the 5 analog ones, 1 on the 2 encoders
    assert {(d["fault_class"], d["channel"]) for d in DRAWS} == valid
    for d in DRAWS:
        analog, encoder = CLASS_KINDS[d["fault_class"]]
        assert d["kind"] == (encoder if d["channel"] in ENCODER_CHANNELS else analog)
    assert "current_R" not in DRAWN_CHANNELS and len(DRAWN_CHANNELS) == 7


def _within(value, bounds):
    return bounds[0] <= value <= bounds[1]


def test_durations_magnitudes_and_onsets_lie_within_their_stated_distributions():
    for d in DRAWS:
        c, encoder = d["fault_class"], d["channel"] in ENCODER_CHANNELS
        assert 0.0 <= d["onset_fraction"] < 1.0
        if c == "dead":
            assert d["duration"] == math.inf
        elif c == "spike":
            assert d["duration"] == 0.0
        else:
            assert _within(d["duration"], LONG_DURATION if c in LONG_CLASSES else SHORT_DURATION)
        law = {
            "bias": ENCODER_BIAS_COUNTS if encoder else BIAS_SIGMA,
            "bias_step": ENCODER_BIAS_COUNTS if encoder else BIAS_SIGMA,
            "spike": ENCODER_SPIKE_COUNTS if encoder else SPIKE_SIGMA,
            "ramp": RAMP_SIGMA_PER_S,
            "scale": SCALE_CHANGE,
            "saturation": SATURATION_FRACTION,
        }.get(c)
        if law is not None:
            assert _within(d["magnitude"], law)
        elif c == "sign_flip":
            assert (d["magnitude"], d["sign"], d["unit"]) == (2.0, 1.0, "relative")
        else:
            assert (d["magnitude"], d["unit"]) == (0.0, "none")
        assert d["sign"] in (1.0, -1.0)
    # log-uniform: log|bias| uniform on [ln 3, ln 50]: mean and spread within 4 standard errors
    logs = np.log([d["magnitude"] for d in DRAWS if d["unit"] == "sigma" and "bias" in d["fault_class"]])
    low, high = np.log(BIAS_SIGMA)
    assert len(logs) > 100
    assert abs(logs.mean() - (low + high) / 2) < 4 * (high - low) / math.sqrt(12 * len(logs))
    assert logs.std() == pytest.approx((high - low) / math.sqrt(12), rel=0.15)
    onsets = np.array([d["onset_fraction"] for d in DRAWS])
    assert abs(onsets.mean() - 0.5) < 4 * math.sqrt(1 / 12 / len(onsets))
    signs = [d["sign"] for d in DRAWS if d["fault_class"] in ("bias", "bias_step", "ramp", "spike", "scale")]
    assert 0.4 < signs.count(1.0) / len(signs) < 0.6


def clean_run(T_N=0.002, end=4.0, start_time=1.0, driving=(1.0, 3.0)):
    """A fault-free run's arrays: every reading 0, the wheels commanded over ``driving``."""
    t = np.round(np.arange(0.0, end + T_N / 2, T_N), 9)
    a = {"t": t, "T_N": np.array(T_N), "start_time": np.array(start_time)}
    a.update({key: np.zeros_like(t) for key in MEASURED_KEYS.values()})
    on = (t >= driving[0]) & (t <= driving[1] + 1e-9)
    a["cmd_R"], a["cmd_L"] = np.where(on, 1.0, 0.0), np.zeros_like(t)
    return a


def _draw(**fields):
    d = {"fault_class": "bias", "kind": "bias", "channel": "gyro", "onset_fraction": 0.25, "duration": 0.5}
    return {**d, "magnitude": 10.0, "unit": "sigma", "sign": -1.0, **fields}


def test_a_draw_is_placed_on_the_grid_of_the_driving_part_in_the_channels_units():
    a = clean_run()
    assert driving_part(a) == (1.0, 3.0)
    a["meas_a_n1"][(a["t"] > 1.9) & (a["t"] < 2.1)] = -4.0
    a["meas_a_n1"][a["t"] > 3.5] = 9.0  # after the driving part: not the peak
    assert noise_sigma("gyro", SENSORS) == GYRO_SIGMA and noise_sigma("accel2_t", SENSORS) == ACCEL_SIGMA
    assert noise_sigma("encoder_L", SENSORS) == pytest.approx(2 * math.pi / 6144 / math.sqrt(12))
    cases = [
        (_draw(), FaultEvent("bias", "gyro", 1.5, 0.5, -0.14)),
        (_draw(onset_fraction=0.3337), FaultEvent("bias", "gyro", 1.668, 0.5, -0.14)),
        (_draw(channel="encoder_R", unit="counts"), FaultEvent("bias", "encoder_R", 1.5, 0.5, -10.0)),
        (_draw(fault_class="ramp", kind="ramp", unit="sigma/s"), FaultEvent("ramp", "gyro", 1.5, 0.5, -0.14)),
        (
            _draw(
                fault_class="saturation",
                kind="saturation",
                channel="accel1_n",
                magnitude=0.5,
                unit="peak fraction",
            ),
            FaultEvent("saturation", "accel1_n", 1.5, 0.5, 2.0),
        ),
        (
            _draw(fault_class="sign_flip", kind="scale", magnitude=2.0, unit="relative", sign=1.0),
            FaultEvent("scale", "gyro", 1.5, 0.5, -2.0),
        ),
        (
            _draw(
                fault_class="dead",
                kind="stuck",
                channel="encoder_L",
                duration=math.inf,
                magnitude=0.0,
                unit="none",
            ),
            FaultEvent("stuck", "encoder_L", 1.5, MAX_FAULT_TIME, 0.0),
        ),
        (
            _draw(fault_class="spike", kind="spike", duration=0.0, sign=1.0),
            FaultEvent("spike", "gyro", 1.5, 0.002, 0.14),
        ),
    ]
    for draw, expected in cases:
        event = place_fault(draw, a, SENSORS)
        assert event.kind == expected.kind and event.channel == expected.channel
        assert event.start == pytest.approx(expected.start, abs=1e-12)
        assert event.duration == pytest.approx(expected.duration) and event.value == pytest.approx(
            expected.value
        )


def _gyro_event(kind, start, duration, value=0.0, channel="gyro"):
    return FaultEvent(kind, channel, start, duration, value)


def _significance(a, event):
    """(significant, onset or None, peak sigmas)."""
    significant, onset, peak = significance(
        a, event, noise_sigma(event.channel, SENSORS), SENSORS.encoder_step
    )
    assert significant == math.isfinite(onset)
    return significant, onset if significant else None, peak


def test_significance_by_hand():
    a = clean_run()
    s = GYRO_SIGMA
    assert _significance(a, _gyro_event("bias", 2.0, 0.2, 6 * s)) == (True, 2.0, pytest.approx(6.0))
    assert _significance(a, _gyro_event("bias", 2.0, 1.0, 4 * s)) == (False, None, pytest.approx(4.0))
    assert _significance(a, _gyro_event("bias", 2.0, 0.1, 10 * s))[:2] == (True, 2.0)  # 50 samples
    assert _significance(a, _gyro_event("bias", 2.0, 0.098, 10 * s))[:2] == (False, None)  # 49 samples
    assert _significance(a, _gyro_event("spike", 2.0, 0.5, 300 * s)) == (False, None, pytest.approx(300.0))
    # a drift of 9 sigma/s passes 5 sigma after 5/9 s: on the 278th sample (277 x 9 x 2 ms = 4.99 sigma)
    assert _significance(a, _gyro_event("ramp", 2.0, 1.0, 9 * s))[:2] == (True, pytest.approx(2.556))
    # a scale acts where the signal is: 1 rad/s from t = 2.5
    a["meas_gyro"][a["t"] >= 2.5 - 1e-9] = 1.0
    assert _significance(a, _gyro_event("scale", 2.0, 1.0, 0.5))[:2] == (True, pytest.approx(2.5))
    assert _significance(a, _gyro_event("scale", 2.0, 1.0, -0.05))[:2] == (False, None)  # 3.6 sigma
    sign_flip = _significance(a, _gyro_event("scale", 2.0, 1.0, -2.0))  # reads -1 rad/s: 2 rad/s off
    assert sign_flip == (True, pytest.approx(2.5), pytest.approx(2.0 / GYRO_SIGMA))
    assert _significance(a, _gyro_event("dropout", 2.6, 1.0)) == (False, None, 0.0)  # frozen at 1 rad/s
    assert _significance(a, _gyro_event("dropout", 2.4, 1.0))[:2] == (True, pytest.approx(2.5))
    assert _significance(a, _gyro_event("nan", 2.0, 0.1, channel="accel1_t")) == (True, 2.0, math.inf)
    assert _significance(a, _gyro_event("nan", 2.0, 0.098, channel="accel1_t"))[:2] == (False, None)


def test_an_encoders_significance_is_read_in_counts_of_its_angle():
    a = clean_run()
    a["meas_enc_R"] = 0.1 * a["t"]  # 0.2 mrad a sample; 5 sigma of the quantisation: 1.44 counts = 1.48 mrad
    stuck = _gyro_event("stuck", 2.0, 0.5, channel="encoder_R")
    # the frozen angle falls behind by (j + 1) x 0.2 mrad on the start's j-th sample: beyond 1.48 from j = 7
    assert _significance(a, stuck)[:2] == (True, pytest.approx(2.014))
    assert _significance(a, _gyro_event("bias", 2.0, 1.0, 1.0, channel="encoder_R"))[:2] == (False, None)
    two = _significance(a, _gyro_event("bias", 2.0, 1.0, 2.0, channel="encoder_R"))
    assert two == (True, 2.0, pytest.approx(2 * math.sqrt(12)))
    # a scale counts (1 + value) x the increments: the angle drifts by 0.5 x 0.2 mrad a sample
    assert _significance(a, _gyro_event("scale", 2.0, 1.0, 0.5, channel="encoder_R"))[:2] == (
        True,
        pytest.approx(2.028),
    )


def test_flag_onsets_and_false_alarms_by_hand():
    assert flag_onsets([0, 1, 1, 0, 6, 0, 0, 2, 2]) == 3
    assert flag_onsets([3, 0, 1]) == 2
    assert flag_onsets([0, 0]) == 0 and flag_onsets(np.array([np.nan, 1.0])) == 1
    t = np.arange(7) * 0.5
    a = {"t": t, "start_time": np.array(1.0), "fault": np.ones(7)}
    a["health_gyro"] = np.array([1, 0, 0, 1, 1, 0, 1])  # from t = 1: 0 1 1 0 1: two onsets
    a["health_accel1_t"] = np.array([0, 0, 1, 0, 0, 0, 0])  # one, at the window's first sample
    a["health_encoder_L"] = np.array([5, 5, 0, 0, 0, 0, 0])  # before the start only
    assert false_alarms(a) == (3, 2.0)


def flagged_run():
    t = np.round(np.arange(11) * 0.1, 9)
    a = {
        "t": t,
        "health_gyro": np.zeros(11),
        "health_accel1_t": np.zeros(11),
        "health_encoder_R": np.zeros(11),
    }
    a["health_gyro"][[1, 6, 7]] = [1, 4, 6]  # the flag at 0.1 s is before the fault's start
    a["health_accel1_t"][5] = 5
    a["fault"] = (a["health_gyro"] + a["health_accel1_t"] > 0).astype(float)
    return a


def test_detection_latency_and_isolation_by_hand():
    a = flagged_run()
    assert detection_time(a, "gyro", 0.3) == 0.5  # the fault flag, raised by accel1_t
    assert first_flagged(a, 0.3) == (0.5, ("accel1_t",))
    del a["fault"]
    assert detection_time(a, "gyro", 0.3) == 0.6
    assert math.isnan(detection_time(a, "encoder_R", 0.3))  # never
    assert detection_time(a, "gyro", 0.05) == pytest.approx(0.1)
    a["health_encoder_R"][5] = 2
    assert first_flagged(a, 0.3) == (0.5, ("accel1_t", "encoder_R"))
    assert first_flagged(a, 0.75)[1] == () and math.isnan(first_flagged(a, 0.75)[0])


def test_fault_figures_by_hand():
    a = flagged_run()
    x = np.array([0.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.8, 0.8])  # stops at 0.8 m
    a.update(true_x=x, true_y=np.zeros(11))
    a["est_x"] = np.concatenate([[0.0, 0.0], x[:-2]]) + 0.003  # two samples behind, 3 mm ahead ...
    a["est_y"] = np.full(11, 0.004)  # ... and 4 mm to the left: 5 mm off the truth it describes
    a["odo_x"], a["odo_y"] = x + 0.006, np.zeros(11)
    a["gyro_x"], a["gyro_y"] = x, np.full(11, -0.004)
    job = {"channel": "gyro", "start": 0.3, "significant": True, "effect_onset_s": 0.35}
    job.update(clean_fused_error_m=0.0025, clean_rms_m=0.002)
    f = fault_figures(a, job)
    assert (
        f["detected"]
        and f["latency_s"] == pytest.approx(0.15)
        and f["latency_from_start_s"] == pytest.approx(0.2)
    )
    assert (f["first_flagged"], f["isolated"], f["other_flag_s"]) == ("accel1_t", False, pytest.approx(0.1))
    assert f["fused_error_m"] == pytest.approx(0.005) and f["odometry_error_m"] == pytest.approx(0.006)
    assert f["gyrodometry_error_m"] == pytest.approx(0.004) and not f["fused_le_best_baseline"]
    assert f["rms_m"] == pytest.approx(0.005) and f["max_m"] == pytest.approx(0.005)
    assert f["error_ratio"] == pytest.approx(2.0) and f["rms_ratio"] == pytest.approx(2.5)
    a["health_accel1_t"][5], a["fault"][5] = 0, 0
    f = fault_figures(a, {**job, "significant": False})
    assert (f["first_flagged"], f["isolated"], f["latency_from_start_s"]) == (
        "gyro",
        True,
        pytest.approx(0.3),
    )
    assert math.isnan(f["latency_s"]) and f["other_flag_s"] == 0.0
    a["health_encoder_R"][[0, 2, 8, 9]] = 3  # before the start (0, 0.2 s) and 0.2 s after it
    assert fault_figures(a, job)["other_flag_s"] == pytest.approx(0.2)


def _row(fault_class, significant, latency, detected, isolated, below, ratio, rms, others=0.0):
    return dict(
        other_flag_s=others,
        fault_class=fault_class,
        significant=significant,
        latency_s=latency,
        detected=detected,
        isolated=isolated,
        fused_le_best_baseline=below,
        error_ratio=ratio,
        rms_ratio=rms,
    )


def test_summary_and_targets_by_hand():
    rows = [
        _row("bias", True, 0.1, True, True, True, 1.0, 1.0),
        _row("bias", True, 0.3, True, False, True, 5.0, 2.0, others=0.5),
        _row("nan", True, math.nan, False, None, False, 2.0, 1.5),
        _row("spike", False, math.nan, True, True, True, 1.0, 1.0),
    ]
    references = [{"false_alarms": 1, "driving_s": 1800.0}, {"false_alarms": 0, "driving_s": 1800.0}]
    s = summarise(rows, references)
    assert list(s["classes"]) == ["nan", "bias", "spike"]  # CLASSES' order
    bias, o = s["classes"]["bias"], s["overall"]
    assert (bias["significant_in_time"], bias["median_latency_s"], bias["max_latency_s"]) == (1, 0.2, 0.3)
    assert (bias["mean_error_ratio"], bias["mean_rms_ratio"], bias["isolated"], bias["flagged"]) == (
        3.0,
        1.5,
        1,
        2,
    )
    assert (o["runs"], o["significant"], o["significant_in_time"], o["detected"]) == (4, 3, 1, 3)
    assert (o["flagged"], o["isolated"], o["other_blamed"], o["fused_le_best_baseline"]) == (3, 2, 1, 3)
    assert (o["false_alarms"], o["fault_free_h"], o["false_alarms_per_h"]) == (1, 1.0, 1.0)
    verdicts = [(t["measured"], t["pass"]) for t in s["targets"]]
    assert verdicts == [
        ("1/3", False),
        ("66.7 % (2/3)", False),
        ("1.0 /h (1 in 1.0000 h)", True),
        ("75.0 % (3/4)", False),
        ("worst 3.00 (bias)", True),
    ]
    s = summarise([_row("spike", False, math.nan, False, None, True, 1.0, 1.0)], [])
    assert [t["pass"] for t in s["targets"]] == [None, None, None, True, True]


@pytest.mark.parametrize(
    "options",
    [
        ["--random", "0"],
        ["--random", "2", "--kinds", "nan"],
        ["--random", "2", "--seeds", "2"],
        ["--random", "1", "--perturbations"],
    ],
)
def test_random_with_a_fixed_list_option_is_a_clear_error(options, capsys, tmp_path):
    assert main(["faults", "corner", *options, "--out", str(tmp_path)]) == 2
    assert "--random" in capsys.readouterr().err
    assert not any(tmp_path.iterdir())


def test_one_random_fault_on_the_corner_end_to_end(capsys, tmp_path):
    assert main(["faults", "corner", "--random", "1", "--workers", "0", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    data = json.loads((tmp_path / "random-faults.json").read_text())
    (row,), (reference,) = data["rows"], data["references"]
    assert (row["fault_class"], row["channel"], row["kind"]) == ("bias_step", "gyro", "bias")
    assert 1.0 <= row["start"] <= 3.8 and row["value"] == pytest.approx(-3.2443222383406343 * GYRO_SIGMA)
    assert not row["significant"] and row["peak_deviation_sigma"] == pytest.approx(3.2443222, rel=1e-6)
    assert reference["false_alarms"] == 0 and 3.0 < reference["driving_s"] < 3.6  # slip control stretches it
    assert row["error_ratio"] == pytest.approx(row["fused_error_m"] / reference["fused_error_m"])
    best = min(row["odometry_error_m"], row["gyrodometry_error_m"])
    assert row["fused_le_best_baseline"] == (row["fused_error_m"] <= best)
    assert data["summary"]["overall"]["runs"] == 1 and data["distributions"]["bias_sigma"] == [3.0, 50.0]
    assert sum(line.startswith("target ") for line in out.splitlines()) == 5
    assert "random faults runs=1 significant=0" in out.splitlines()[-1]
    assert (tmp_path / "random-faults.png").stat().st_size > 10_000
    assert len((tmp_path / "random-faults.csv").read_text().splitlines()) == 2
