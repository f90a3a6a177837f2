"""Random sensor-fault benchmark: ``slipnav faults [SCENARIO ...] --random N``.

Per scenario and seed 0..N-1: the fault-free reference run, then one run with the fault the seed draws
(``draw_fault``; the same draw on every scenario, placed in each reference run's driving part), both on
studies/faults.py's run machinery (run_job) and the sweep engine (--workers). Every figure is read from
the runs' npz arrays (docs/artifacts.md): the truth, the fused pose ``est_*``, the baselines ``odo_*``
(odometry-only) and ``gyro_*`` (Gyrodometry), ``fault`` and every ``health_<channel>`` code present, so
the benchmark judges whatever health layer the navigation has.

The draw: the class from CLASS_KINDS, balanced (seeds 13 b .. 13 b + 12 draw every class once, in an
order shuffled per block b); a channel uniformly among the classes' valid ones (DRAWN_CHANNELS); the
onset uniform over the reference run's driving part (driving_part); duration and magnitude from the
constants below, magnitudes in the channel's white-noise sigma of the data sheet (systems/robot/sensors.py:
accelerometers 0.062 m/s^2, gyro 0.014 rad/s), an encoder's in counts. Current-sense faults are not drawn:
systems/robot/faults.py's schema has no current channel.

Per run: whether the fault is significant (it moves the reading by more than SIGNIFICANT_SIGMAS noise
sigmas on consecutive samples for SIGNIFICANT_TIME or longer, the fault applied to the reference run's
readings as studies/faults.fault_onset does; an encoder's reading is its angle, its sigma the
quantisation's 1/sqrt(12) count, so a one-sample spike never is); detection (the faulted channel's health
code or ``fault`` nonzero from the fault's start on) and its latency from the significant onset (the
first sample of the first such stretch; negative: flagged before it); isolation (the channels flagged
first from the start on are the faulted one alone) and, beside it, how long another channel is flagged;
the fused, odometry-only and Gyrodometry final position errors, whether the fused one is <= the better
baseline's, the fused final error over the reference run's, and the fused RMS and largest position error
along the run against the truth POSE_DELAY_SAMPLES back. False alarms: the flag onsets (a code turning
nonzero) on every health channel of the reference runs from the controller's start to the end, per hour
of that time. The issue's targets (TARGETS) are printed PASS/FAIL beside the figures; the exit status
does not change.

Output (studies/random_faults_report.py): the per-run and per-class tables, the targets, a last line
``random faults runs=...``; with ``--out DIR``: DIR/random-faults-reference.csv and DIR/random-faults.csv
(the engine's incremental files, --resume), DIR/random-faults.json (rows, references, summary,
distributions) and DIR/random-faults.png.
"""

import math
import sys
import time
from pathlib import Path as FilePath

import numpy as np
from slipnav.scenarios.config import load_scenario
from slipnav.scenarios.metrics import position_error_columns
from slipnav.studies.engine import Engine
from slipnav.studies.fault_cases import MEASURED_KEYS
from slipnav.studies.faults import run_job
from slipnav.studies.random_faults_report import TARGETS, print_rows, print_summary, write_outputs
from slipnav.studies.results_file import ResultsFile
from slipnav.systems.robot.faults import (
    ENCODER_CHANNELS,
    MAX_FAULT_TIME,
    SENSOR_CHANNELS,
    FaultEvent,
    apply_sensor_faults,
)

DRAW_STREAM = 45
"""First entropy word of the draw's generators ([DRAW_STREAM, ...]), apart from the noise streams."""
CLASS_KINDS = {
    "nan": ("nan", "nan"),
    "inf": ("inf", "inf"),
    "dropout": ("dropout", None),
    "stuck": (None, "stuck"),
    "bias": ("bias", "bias"),
    "ramp": ("ramp", None),
    "scale": ("scale", "scale"),
    "spike": ("spike", "spike"),
    "saturation": ("saturation", None),
    "bias_step": ("bias", "bias"),
    "sign_flip": ("scale", "scale"),
    "frozen": ("dropout", "stuck"),
    "dead": ("dropout", "stuck"),
}
"""Fault class -> its schema kind (systems/robot/faults.py) on an analog channel and on an encoder
(None: none)."""
CLASSES = tuple(CLASS_KINDS)
DRAWN_CHANNELS = tuple(c for c in SENSOR_CHANNELS if c in MEASURED_KEYS)
"""Channels a fault may be drawn on: the schema's (no current sense)."""
SHORT_DURATION = (0.05, 1.0)
"""s, log-uniform: nan, inf, dropout, stuck, bias, saturation."""
LONG_DURATION = (1.0, 20.0)
"""s, log-uniform: ramp, scale, bias_step, sign_flip, frozen (the run's end may cut them)."""
LONG_CLASSES = ("ramp", "scale", "bias_step", "sign_flip", "frozen")
BIAS_SIGMA = (3.0, 50.0)
"""bias, bias_step on an analog channel: |value| log-uniform in noise sigmas, either sign."""
ENCODER_BIAS_COUNTS = (10.0, 1000.0)
"""bias, bias_step on an encoder: |value| log-uniform in counts, either sign."""
RAMP_SIGMA_PER_S = (2.0, 50.0)
"""ramp (drift): |rate| log-uniform in noise sigmas per second, either sign."""
SPIKE_SIGMA = (10.0, 300.0)
"""spike (one sample) on an analog channel: |value| log-uniform in noise sigmas, either sign."""
ENCODER_SPIKE_COUNTS = (10.0, 1000.0)
"""spike on an encoder: |value| log-uniform in counts, either sign."""
SCALE_CHANGE = (0.1, 0.9)
"""scale: |value| log-uniform, either sign: the reading (an encoder's increments) x (1 +- |value|)."""
SIGN_FLIP = -2.0
"""sign_flip: a scale of -2, the reading x -1 (an encoder counting backwards)."""
SATURATION_FRACTION = (0.2, 0.9)
"""saturation: uniform, the clip level over the channel's largest |reading| in the driving part."""
SIGNIFICANT_SIGMAS = 5.0
SIGNIFICANT_TIME = 0.1
"""A fault is significant when it moves the reading by > 5 noise sigmas for >= 0.1 s."""


def _log_uniform(rng, bounds) -> float:
    return float(math.exp(rng.uniform(math.log(bounds[0]), math.log(bounds[1]))))


def _magnitude(fault_class: str, encoder: bool, rng) -> tuple[float, str]:
    """(|magnitude|, unit) of a class on an analog channel or an encoder ((0, "none"): no magnitude)."""
    if fault_class == "saturation":
        return float(rng.uniform(*SATURATION_FRACTION)), "peak fraction"
    if fault_class == "sign_flip":
        return abs(SIGN_FLIP), "relative"
    bias, spike = (ENCODER_BIAS_COUNTS, ENCODER_SPIKE_COUNTS) if encoder else (BIAS_SIGMA, SPIKE_SIGMA)
    laws = {"bias": bias, "bias_step": bias, "spike": spike, "ramp": RAMP_SIGMA_PER_S, "scale": SCALE_CHANGE}
    if fault_class not in laws:
        return 0.0, "none"
    units = {"ramp": "sigma/s", "scale": "relative"}
    return _log_uniform(rng, laws[fault_class]), units.get(fault_class, "counts" if encoder else "sigma")


def draw_fault(seed: int) -> dict:
    """The fault of ``seed`` (module docstring): fault_class, kind, channel, onset_fraction (of the driving
    part), duration (s; inf: to the run's end; 0: a spike's one sample), magnitude (>= 0, in unit), sign."""
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ValueError(f"seed={seed!r} is out of range: allowed integers >= 0")
    seed = int(seed)
    order = np.random.default_rng([DRAW_STREAM, seed // len(CLASSES)]).permutation(len(CLASSES))
    fault_class = CLASSES[int(order[seed % len(CLASSES)])]
    rng = np.random.default_rng([DRAW_STREAM, seed, 1])
    analog, encoder = CLASS_KINDS[fault_class]
    channels = [c for c in DRAWN_CHANNELS if (encoder if c in ENCODER_CHANNELS else analog)]
    channel = channels[int(rng.integers(len(channels)))]
    on_encoder = channel in ENCODER_CHANNELS
    onset_fraction = float(rng.uniform())
    if fault_class == "dead":
        duration = math.inf
    elif fault_class == "spike":
        duration = 0.0
    else:
        duration = _log_uniform(rng, LONG_DURATION if fault_class in LONG_CLASSES else SHORT_DURATION)
    magnitude, unit = _magnitude(fault_class, on_encoder, rng)
    signed = fault_class in ("bias", "bias_step", "ramp", "spike", "scale")
    sign = (1.0 if rng.uniform() < 0.5 else -1.0) if signed else 1.0
    return {
        "fault_class": fault_class,
        "kind": encoder if on_encoder else analog,
        "channel": channel,
        "onset_fraction": onset_fraction,
        "duration": duration,
        "magnitude": magnitude,
        "unit": unit,
        "sign": sign,
    }


def noise_sigma(channel: str, sensors) -> float:
    """The channel's white-noise sigma in its reading's unit (an encoder: the quantisation's, rad)."""
    if channel in ENCODER_CHANNELS:
        return sensors.encoder_step / math.sqrt(12.0)
    return sensors.gyro_noise_std if channel == "gyro" else sensors.accel_noise_std


def driving_part(a: dict) -> tuple[float, float]:
    """(the controller's start, the last sample with a nonzero wheel command; the run's end without)."""
    t = np.asarray(a["t"])
    t0 = float(a["start_time"]) if "start_time" in a else float(t[0])
    command = np.abs(np.asarray(a["cmd_R"])) + np.abs(np.asarray(a["cmd_L"]))
    driving = np.flatnonzero((command > 0.0) & (t >= t0))
    return t0, float(t[driving[-1]]) if len(driving) else float(t[-1])


def place_fault(draw: dict, clean: dict, sensors) -> FaultEvent:
    """``draw`` (draw_fault) as the FaultEvent of the reference run ``clean``: the start on the T_N grid
    of its driving part, the value in the channel's units."""
    T_N = float(clean["T_N"])
    t0, t1 = driving_part(clean)
    start = round(round((t0 + draw["onset_fraction"] * (t1 - t0)) / T_N) * T_N, 9)
    duration = draw["duration"]
    duration = MAX_FAULT_TIME if math.isinf(duration) else duration if duration > 0.0 else T_N
    signed = draw["sign"] * draw["magnitude"]
    unit = draw["unit"]
    if unit in ("sigma", "sigma/s"):
        value = signed * noise_sigma(draw["channel"], sensors)
    elif unit == "peak fraction":
        t = np.asarray(clean["t"])
        reading = np.asarray(clean[MEASURED_KEYS[draw["channel"]]])[(t >= t0) & (t <= t1)]
        value = draw["magnitude"] * float(np.max(np.abs(reading)))
    elif draw["fault_class"] == "sign_flip":
        value = SIGN_FLIP
    else:
        value = signed
    return FaultEvent(draw["kind"], draw["channel"], start, duration, value)


def significance(clean: dict, event: FaultEvent, sigma: float, encoder_step: float) -> tuple:
    """(significant, its onset (s; NaN if not), the largest deviation in sigmas) of ``event`` applied to
    the reference run's readings ``clean``: significant when the reading moves by more than
    SIGNIFICANT_SIGMAS sigma on SIGNIFICANT_TIME / T_N consecutive samples (NaN, inf: any amount)."""
    t = np.asarray(clean["t"])
    T_N = float(clean["T_N"])
    rows = np.column_stack([clean[MEASURED_KEYS[c]] for c in SENSOR_CHANNELS])
    k0 = int(np.searchsorted(t, event.start - 1e-9))
    end = event.start + (T_N if event.kind == "spike" else event.duration)
    k1 = int(np.searchsorted(t, end - 1e-9))
    held = previous = rows[max(k0 - 1, 0)].tolist()
    deviation = np.zeros(max(k1 - k0, 0))
    for j, k in enumerate(range(k0, k1)):
        read = apply_sensor_faults(float(t[k]), rows[k], held, previous, [event], T_N, encoder_step)
        change = abs(read[event.index] - rows[k][event.index])
        deviation[j] = change / sigma if math.isfinite(change) else math.inf
        held, previous = read, rows[k].tolist()
    need = max(1, math.ceil(SIGNIFICANT_TIME / T_N - 1e-9))
    run = 0
    for j, above in enumerate(deviation > SIGNIFICANT_SIGMAS):
        run = run + 1 if above else 0
        if run == need:
            return True, float(t[k0 + j - need + 1]), float(np.max(deviation))
    return False, math.nan, float(np.max(deviation, initial=0.0))


def health_channels(a: dict) -> list[str]:
    """The channels the run's health layer reports (its ``health_<channel>`` keys)."""
    return sorted(k[len("health_") :] for k in a if k.startswith("health_"))


def flag_onsets(codes) -> int:
    """How often a health code turns nonzero (a flag at the first sample counts)."""
    flagged = np.asarray(codes) > 0
    return int(flagged[:1].sum() + np.sum(flagged[1:] & ~flagged[:-1]))


def false_alarms(a: dict) -> tuple[int, float]:
    """(flag onsets on every health channel, seconds) of fault-free run ``a`` from the controller's start."""
    t = np.asarray(a["t"])
    after = t >= float(a["start_time"]) - 1e-9
    return sum(flag_onsets(np.asarray(a[f"health_{c}"])[after]) for c in health_channels(a)), float(
        t[-1] - t[after][0]
    )


def detection_time(a: dict, channel: str, start: float) -> float:
    """First time from ``start`` on the faulted channel's health code or ``fault`` is nonzero (NaN: never)."""
    t = np.asarray(a["t"])
    flagged = np.zeros(len(t), bool)
    for key in (f"health_{channel}", "fault"):
        if key in a:
            flagged |= np.asarray(a[key]) > 0
    k = np.flatnonzero(flagged & (t >= start - 1e-9))
    return float(t[k[0]]) if len(k) else math.nan


def first_flagged(a: dict, start: float) -> tuple[float, tuple]:
    """(time, channels) of the first health flag from ``start`` on, on any channel ((NaN, ()): none)."""
    t = np.asarray(a["t"])
    firsts = {}
    for c in health_channels(a):
        k = np.flatnonzero((np.asarray(a[f"health_{c}"]) > 0) & (t >= start - 1e-9))
        if len(k):
            firsts[c] = int(k[0])
    if not firsts:
        return math.nan, ()
    k = min(firsts.values())
    return float(t[k]), tuple(c for c, i in firsts.items() if i == k)


def other_flag_time(a: dict, channel: str, start: float) -> float:
    """Seconds from ``start`` on during which a channel other than the faulted one is flagged (a healthy
    channel blamed, however the first flag fell)."""
    t = np.asarray(a["t"])
    others = [np.asarray(a[f"health_{c}"]) > 0 for c in health_channels(a) if c != channel]
    flagged = np.logical_or.reduce(others) if others else np.zeros(len(t), bool)
    return float(np.sum(flagged & (t >= start - 1e-9)) * (t[1] - t[0])) if len(t) > 1 else 0.0


def position_figures(a: dict) -> dict:
    """Final errors of the fused pose and both baselines, each one's RMS and largest error along the run
    (metrics.position_error_columns: against the truth POSE_DELAY_SAMPLES back), and the fused RMS and
    largest as ``rms_m``, ``max_m`` (m)."""
    columns = position_error_columns(a)
    return {**columns, "rms_m": columns["fused_rms_error_m"], "max_m": columns["fused_max_error_m"]}


def fault_figures(a: dict, job: dict) -> dict:
    """The faulted run's figures (module docstring); ``job``: the fault and the reference's figures."""
    detected_at = detection_time(a, job["channel"], job["start"])
    _, first = first_flagged(a, job["start"])
    figures = position_figures(a)
    fused, best = figures["fused_error_m"], min(figures["odometry_error_m"], figures["gyrodometry_error_m"])
    clean, clean_rms = job["clean_fused_error_m"], job["clean_rms_m"]
    return {
        "detected": bool(math.isfinite(detected_at)),
        "latency_s": detected_at - job["effect_onset_s"] if job["significant"] else math.nan,
        "latency_from_start_s": detected_at - job["start"],
        "first_flagged": "+".join(first) or "none",
        "isolated": (first == (job["channel"],)) if first else None,
        "other_flag_s": other_flag_time(a, job["channel"], job["start"]),
        **figures,
        "fused_le_best_baseline": bool(fused <= best),
        "error_ratio": fused / clean if clean > 0 else math.inf,
        "rms_ratio": figures["rms_m"] / clean_rms if clean_rms > 0 else math.inf,
    }


def run_reference(job: dict) -> dict:
    """The fault-free run of the job's scenario and seed: its figures and alarms, and the seed's fault
    placed in it with its significance."""
    a = run_job(job, None).arrays
    sensors = load_scenario(job["scenario"]).sensor_parameters()
    draw = draw_fault(job["seed"])
    event = place_fault(draw, a, sensors)
    sigma = noise_sigma(event.channel, sensors)
    significant, onset, peak = significance(a, event, sigma, sensors.encoder_step)
    alarms, seconds = false_alarms(a)
    return {
        **{k: draw[k] for k in ("fault_class", "magnitude", "unit")},
        **{k: getattr(event, k) for k in ("kind", "channel", "start", "duration", "value")},
        "significant": significant,
        "effect_onset_s": onset,
        "peak_deviation_sigma": peak,
        **position_figures(a),
        "false_alarms": alarms,
        "driving_s": seconds,
    }


FAULT_JOB_KEYS = (
    *("scenario", "seed", "open_loop", "tolerances"),
    *("fault_class", "kind", "channel", "start", "duration", "value", "magnitude", "unit"),
    *("significant", "effect_onset_s", "peak_deviation_sigma"),
)
"""What a faulted run's job carries over from its reference row (the run's identity and the fault)."""


def fault_job(reference: dict) -> dict:
    """The faulted run's job from its reference row (run_reference)."""
    job = {k: reference[k] for k in FAULT_JOB_KEYS if k in reference}
    return {**job, "clean_fused_error_m": reference["fused_error_m"], "clean_rms_m": reference["rms_m"]}


def run_random_fault(job: dict) -> dict:
    """One faulted run (fault_job) and its figures."""
    event = FaultEvent(job["kind"], job["channel"], job["start"], job["duration"], job["value"])
    return fault_figures(run_job(job, event).arrays, job)


def _finite(values) -> list:
    return [float(v) for v in values if v is not None and math.isfinite(v)]


def group_figures(rows: list) -> dict:
    """Counts, shares and means of a group of faulted runs (a class, or all)."""
    significant = [r for r in rows if r["significant"]]
    latencies = _finite(r["latency_s"] for r in significant)
    flagged = [r for r in rows if r["isolated"] is not None]
    ratios, rms = _finite(r["error_ratio"] for r in rows), _finite(r["rms_ratio"] for r in rows)
    return {
        "runs": len(rows),
        "significant": len(significant),
        "detected": sum(bool(r["detected"]) for r in rows),
        "significant_detected": len(latencies),
        "significant_in_time": sum(v <= TARGETS["detection_s"] + 1e-9 for v in latencies),
        "median_latency_s": float(np.median(latencies)) if latencies else math.nan,
        "max_latency_s": max(latencies, default=math.nan),
        "flagged": len(flagged),
        "isolated": sum(bool(r["isolated"]) for r in flagged),
        "other_blamed": sum(r["other_flag_s"] > 0 for r in rows),
        "fused_le_best_baseline": sum(bool(r["fused_le_best_baseline"]) for r in rows),
        "mean_error_ratio": float(np.mean(ratios)) if ratios else math.nan,
        "max_error_ratio": max(ratios, default=math.nan),
        "mean_rms_ratio": float(np.mean(rms)) if rms else math.nan,
    }


def _share(n: int, m: int) -> float:
    return n / m if m else math.nan


def _verdict(ok: bool, judged) -> bool | None:
    return bool(ok) if judged else None


def target_lines(overall: dict, classes: dict) -> list[dict]:
    """The issue's targets against the figures: target, measured, pass (None: nothing to judge)."""
    o = overall
    sig, in_time, flagged, runs = o["significant"], o["significant_in_time"], o["flagged"], o["runs"]
    isolation, baseline = _share(o["isolated"], flagged), _share(o["fused_le_best_baseline"], runs)
    rate = o["false_alarms_per_h"]
    ratios = {c: g["mean_error_ratio"] for c, g in classes.items() if math.isfinite(g["mean_error_ratio"])}
    worst = max(ratios, key=ratios.get, default="-")
    ratio = ratios.get(worst, math.nan)
    lines = [
        ("significant faults detected within 0.2 s: all", f"{in_time}/{sig}", _verdict(in_time == sig, sig)),
        (
            "isolation >= 95 %",
            f"{100 * isolation:.1f} % ({o['isolated']}/{flagged})",
            _verdict(isolation >= TARGETS["isolation"], flagged),
        ),
        (
            "false alarms <= 1 per hour",
            f"{rate:.1f} /h ({o['false_alarms']} in {o['fault_free_h']:.4f} h)",
            _verdict(rate <= TARGETS["false_alarms_per_h"], math.isfinite(rate)),
        ),
        (
            "fused <= better baseline in >= 95 % of runs",
            f"{100 * baseline:.1f} % ({o['fused_le_best_baseline']}/{runs})",
            _verdict(baseline >= TARGETS["better_baseline"], runs),
        ),
        (
            "per class mean error ratio <= 3",
            f"worst {ratio:.2f} ({worst})",
            _verdict(ratio <= TARGETS["class_ratio"], ratios),
        ),
    ]
    return [{"target": t, "measured": m, "pass": p} for t, m, p in lines]


def summarise(rows: list, references: list) -> dict:
    """Per class and overall figures, the false alarms of the reference runs, the targets."""
    classes = {c: group_figures([r for r in rows if r["fault_class"] == c]) for c in CLASSES}
    classes = {c: v for c, v in classes.items() if v["runs"]}
    overall = group_figures(rows)
    alarms = sum(int(r["false_alarms"]) for r in references)
    hours = sum(float(r["driving_s"]) for r in references) / 3600.0
    overall.update(false_alarms=alarms, fault_free_h=hours, false_alarms_per_h=_share(alarms, hours))
    return {"overall": overall, "classes": classes, "targets": target_lines(overall, classes)}


STATED = (
    *("CLASS_KINDS", "DRAWN_CHANNELS", "SHORT_DURATION", "LONG_DURATION", "LONG_CLASSES", "BIAS_SIGMA"),
    *("ENCODER_BIAS_COUNTS", "RAMP_SIGMA_PER_S", "SPIKE_SIGMA", "ENCODER_SPIKE_COUNTS", "SCALE_CHANGE"),
    *("SIGN_FLIP", "SATURATION_FRACTION", "SIGNIFICANT_SIGMAS", "SIGNIFICANT_TIME", "TARGETS"),
)
"""The module constants that state the draw, the significance rule and the targets."""


def distributions() -> dict:
    """The STATED constants by lower-case name, for the JSON file."""
    return {name.lower(): globals()[name] for name in STATED}


def random_faults(names, runs: int, stream=None, *, out_dir=None, resume=False, **options) -> dict:
    """Run the benchmark (module docstring) over seeds 0..runs-1 of the scenarios ``names``; print the
    report, write the files into ``out_dir`` (None: none); return {rows, references, summary}.
    ``options``: open_loop, tolerances (as ``slipnav faults``), workers, scheduler (the sweep engine)."""
    stream = stream or sys.stdout
    start = time.perf_counter()
    flags = {k: True for k in ("open_loop", "tolerances") if options.get(k)}
    jobs = [{"scenario": n, "seed": s, **flags} for n in names for s in range(runs)]
    files = [None, None]
    if out_dir is not None:
        files = [ResultsFile(FilePath(out_dir) / f"random-faults{s}.csv", resume) for s in ("-reference", "")]
    try:
        with Engine(options.get("workers"), options.get("scheduler")) as engine:
            references = engine.map(run_reference, jobs, files[0], label="random faults: fault-free")
            jobs = [fault_job(r) for r in references]
            rows = engine.map(run_random_fault, jobs, files[1], label="random faults")
    finally:
        for file in files:
            if file is not None:
                file.close()
    result = {"rows": rows, "references": references, "summary": summarise(rows, references)}
    wall = time.perf_counter() - start
    print_rows(rows, stream)
    if out_dir is not None:
        write_outputs(out_dir, {"wall_s": wall, "distributions": distributions(), **result}, stream)
    print_summary(result["summary"], wall, stream)
    return result
