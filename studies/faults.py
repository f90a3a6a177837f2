"""Sensor-fault benchmark: ``slipnav faults [SCENARIO ...] [--seeds N]``.

For each scenario and seed: one fault-free run (its flags are false flags), then one run per channel
and fault class with a single fault of ``FAULT_DURATION`` (systems/robot/faults.py), starting 0.1 s before
the channel's largest reading while the robot moves (so that a scale or saturation fault acts). Each
run reports

- the detection latency: from the first sample the fault changed (against the fault-free run, which
  is identical up to there) to the first flag of that channel (systems/health/);
- the fused final position error over the fault-free run's (error ratio);
- the gyro-bias estimate at the end against the true bias, in the estimate's standard deviations;
- beside the issue's final-error ratio, the ratio of the fused position error's RMS over the run to the
  fault-free run's (metrics.rms_position_error against the truth POSE_DELAY_SAMPLES back, the estimation
  error without the pipeline's lag, which would dilute both): a closed-loop fault also changes the path,
  and the final braking then meets another error (the square's fault-free final error varies by an
  order of magnitude between seeds), while an error the fault causes counts in the RMS from then on (a
  heading error as the distance it costs).

Null faults: per scenario and seed, the gyro and accel1_t get a bias step of NULL_FAULT_BIAS for
FAULT_DURATION at their usual start, far below any noise, so that their final-error ratio is what chance
alone gives the issue's ratio. Closed loop it is not 1: the path follows the estimate, and the square's
spinning and locking wheels turn a change in the last bit of a reading into millimetres of path; open
loop it is 1.

Targets (issue 18): every fault detected within 0.1 s; no false flags; error ratio <= 3; bias within
3 sigma. Last line: ``faults detected=<n>/<m> worst_error_ratio=<f>``. With ``--perturbations`` it also
runs the plant perturbations (PERTURBATIONS) and prints their final errors against both baselines, the
completion, the perturbation monitor's first flag after the onset and the flags they caused; the
sensor-fault runs count the perturbation flags they raised (a sensor fault taken for a perturbation)
and the runs whose fault flagged another sensor channel (an isolation that blamed the healthy one).
"""

import math
import sys
import time
from pathlib import Path as FilePath

import numpy as np
from slipnav.scenarios.config import load_scenario
from slipnav.scenarios.metrics import position_error_columns
from slipnav.scenarios.plots import save_figure_atomically
from slipnav.scenarios.runner import run_scenario
from slipnav.studies.engine import session
from slipnav.studies.fault_cases import (
    DETECTION_LIMIT,
    NULL_FAULT_BIAS,
    NULL_FAULT_CHANNELS,
    fault_cases,
    null_fault_cases,
    perturbation_cases,
    run_rms_error,
    select_cases,
)
from slipnav.systems.health.perturbation import PERTURBATION_CHANNELS
from slipnav.systems.robot.faults import SENSOR_CHANNELS, FaultEvent


def seed_mean_ratios(rows: list, clean_rows: list) -> list:
    """Per scenario, channel and fault class over two or more seeds: the faulted runs' mean fused final
    error over the fault-free runs' mean, as (ratio, scenario, channel, kind, seeds): a fault-free seed
    whose final error is far below the others' weighs as one of them, not as a ratio's denominator."""
    groups = {}
    for r in rows:
        groups.setdefault((r["scenario"], r["channel"], r["kind"]), []).append(r)
    out, clean = [], {}
    for (scenario, channel, kind), runs in groups.items():
        seeds = sorted({r["seed"] for r in runs})
        if len(seeds) < 2:
            continue
        if not clean:
            for r in clean_rows:
                clean.setdefault(r.get("scenario"), {})[r.get("seed")] = r.get("fused_error_m", math.nan)
        faulted = np.mean([r["fused_error_m"] for r in runs])
        free = np.mean([clean.get(scenario, {}).get(seed, math.nan) for seed in seeds])
        if math.isfinite(faulted) and math.isfinite(free) and free > 0.0:  # else no figure
            out.append((faulted / free, scenario, channel, kind, len(seeds)))
    return out


def perturbation_samples(a: dict) -> int:
    """Samples of run ``a`` with a perturbation flag, summed over the monitor's channels."""
    return sum(int(np.sum(a[f"perturbation_{c}"] > 0)) for c in PERTURBATION_CHANNELS)


def run_job(job: dict, event: FaultEvent | None):
    """The job's scenario and seed with ``event`` (None: fault-free), open loop when the job says so
    (--open-loop), on the toleranced robot when it says so (--tolerances)."""
    scenario = load_scenario(job["scenario"])
    return run_scenario(
        scenario,
        seed=job["seed"],
        faults=[] if event is None else [event],
        open_loop=job.get("open_loop") or None,
        tolerances=bool(job.get("tolerances")),
    )


def fault_figures(
    a: dict, event: FaultEvent, onset: float, clean_fused: float, clean_run_rms: float = math.nan
) -> dict:
    """Latency, flags, position errors (metrics.position_error_columns: final, RMS and maximum along the
    run of each estimate), error ratios and bias check of the faulty run ``a`` (``onset``: fault_onset;
    ``clean_fused``, ``clean_run_rms``: the fault-free run's fused final error and its RMS over the
    run, m)."""
    t = a["t"]
    codes = a[f"health_{event.channel}"]
    flagged = np.flatnonzero((codes > 0) & (t >= event.start - 1e-9))
    latency = float(t[flagged[0]]) - onset if len(flagged) and math.isfinite(onset) else math.nan
    others = sum(int(np.sum(a[f"health_{c}"] > 0)) for c in SENSOR_CHANNELS if c != event.channel)
    errors = position_error_columns(a)
    fused = errors["fused_error_m"]
    std = float(a["est_gyro_bias_std"][-1])
    bias_error = float(a["est_gyro_bias"][-1] - a["true_gyro_bias"][-1])
    return {
        "onset_s": onset,
        "latency_s": latency,
        "detected": bool(math.isfinite(latency) and latency <= DETECTION_LIMIT + 1e-9),
        "flagged_samples": int(np.sum(codes > 0)),
        "other_flags": others,
        "perturbation_samples": perturbation_samples(a),
        **errors,
        "error_ratio": fused / clean_fused if clean_fused > 0 else math.inf,
        "run_rms_ratio": run_rms_error(a) / clean_run_rms if clean_run_rms > 0 else math.nan,
        "bias_error_sigma": abs(bias_error) / std if std > 0 else math.inf,
    }


def run_fault(job: dict) -> dict:
    """One fault run; the job carries its onset and the fault-free run's error (fault_cases)."""
    event = FaultEvent(job["kind"], job["channel"], job["start"], job["duration"], job["value"])
    a = run_job(job, event).arrays
    return fault_figures(
        a, event, job["onset_s"], job["clean_fused_error_m"], job.get("clean_fused_run_rms_m", math.nan)
    )


def run_perturbation(job: dict) -> dict:
    """One perturbation run: the three estimates' final errors and their RMS and maximum along the run,
    completion and the flags it caused."""
    event = FaultEvent(job["kind"], job["channel"], job["start"], job["duration"], job["value"])
    result = run_job(job, event)
    a = result.arrays
    flags = result.summary["sensor_health"]
    caught = result.summary["perturbations"]
    first = min((v["first_s"] for v in caught.values() if v["first_s"] >= job["start"]), default=math.nan)
    return {
        "perturbation_latency_s": first - job["start"],
        "perturbation_flags": " ".join(
            f"{c}:{'+'.join(k for k in ('braked', 'driven') if v.get(k)) or 'flagged'}"
            for c, v in caught.items()
        )
        or "none",
        **position_error_columns(a),
        "completed": bool(result.summary["completed"]),
        "flags": " ".join(f"{c}:{'+'.join(v['classes'])}" for c, v in flags.items()) or "none",
    }


def faults(
    names,
    seeds: int = 1,
    stream=None,
    *,
    perturbations=False,
    open_loop=False,
    tolerances=False,
    channels=None,
    kinds=None,
    workers=None,
    scheduler=None,
    out_dir=None,
    resume=False,
):
    """Run the benchmark (module docstring); with ``perturbations`` also the plant perturbations
    (PERTURBATIONS; printed, not kept in faults.csv); ``open_loop``: every run feeds the trajectory's
    wheel speeds forward, so that a fault cannot change the path and the error ratio is the fault's
    effect on the estimate alone; ``tolerances``: every run of a seed on the robot drawn from the
    tolerance preset by that seed (scenarios/tolerances.py; the navigation knows the nominal one);
    ``channels``, ``kinds``: only these sensor faults (None: all; the null
    faults stay); print the tables and the last line; return the sensor-fault rows."""
    stream = stream or sys.stdout
    select_cases([], channels, kinds)  # unknown names before any run
    rows, clean_rows, perturbed, nulls = [], [], [], []
    start = time.perf_counter()
    with session("faults", workers, scheduler, out_dir, resume) as (engine, file):
        for name in names:
            scenario = load_scenario(name)
            jobs, plant_jobs, null_jobs = [], [], []
            for seed in range(seeds):
                clean = run_scenario(
                    scenario, seed=seed, faults=[], open_loop=open_loop or None, tolerances=tolerances
                ).arrays
                clean_rows.append({"scenario": name, "seed": seed, **clean_figures(clean)})
                common = {
                    "scenario": name,
                    "seed": seed,
                    **({"open_loop": True} if open_loop else {}),
                    **({"tolerances": True} if tolerances else {}),
                }
                cases = fault_cases(clean)
                jobs += [{**common, **case} for case in select_cases(cases, channels, kinds)]
                null_jobs += [{**common, **case} for case in null_fault_cases(cases)]
                plant_jobs += [{**common, **c} for c in perturbation_cases(scenario, clean)]
            rows += engine.map(run_fault, jobs, file, label=f"faults {name}")
            nulls += engine.map(run_fault, null_jobs, None, label=f"null faults {name}")
            if perturbations:
                perturbed += engine.map(run_perturbation, plant_jobs, None, label=f"perturbations {name}")
    if perturbed:
        print_perturbations(perturbed, stream)
    if out_dir is not None and rows:
        print(f"figure: {plot_faults(rows, FilePath(out_dir) / 'faults.png')}", file=stream)
    print_report(rows, clean_rows, time.perf_counter() - start, stream, nulls)
    return rows


def plot_faults(rows: list, path) -> FilePath:
    """Two panels over the channel x class cases (one column each): the detection latency of every run
    (ms; a miss drawn at the top, the 0.1 s target dashed) and its fused final error over the fault-free
    run's (log; filled: final error, hollow: RMS over the run; the 3 x target dashed), one colour per
    scenario."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    cases = list(dict.fromkeys((r["channel"], r["kind"]) for r in rows))
    column = {case: i for i, case in enumerate(cases)}
    names = list(dict.fromkeys(r["scenario"] for r in rows))
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(max(8.0, 0.28 * len(cases) + 2.0), 7.5), sharex=True)
    worst = max([1000.0 * r["latency_s"] for r in rows if math.isfinite(r["latency_s"])] + [100.0])
    ceiling = 1.2 * worst
    for n, name in enumerate(names):
        mine = [r for r in rows if r["scenario"] == name]
        x = np.array([column[(r["channel"], r["kind"])] for r in mine]) + 0.15 * (n - (len(names) - 1) / 2)
        latency = np.array([1000.0 * r["latency_s"] for r in mine])
        missed = ~np.isfinite(latency)
        colour = f"C{n}"
        top.scatter(x[~missed], latency[~missed], s=12, color=colour, label=name)
        if missed.any():
            top.scatter(x[missed], np.full(missed.sum(), ceiling), marker="x", color=colour)
        bottom.scatter(x, [r["error_ratio"] for r in mine], s=12, color=colour, label=f"{name}: final error")
        rms = [r.get("run_rms_ratio", math.nan) for r in mine]
        bottom.scatter(x, rms, s=16, facecolors="none", edgecolors=colour, label=f"{name}: RMS over the run")
    top.axhline(1000.0 * DETECTION_LIMIT, color="k", lw=0.8, ls="--")
    top.set_ylabel("detection latency (ms; x: missed)")
    top.set_title("sensor faults: detection and cost (slipnav faults)")
    top.legend(fontsize=8)
    bottom.axhline(3.0, color="k", lw=0.8, ls="--")
    bottom.set_yscale("log")
    bottom.set_ylabel("fused error / fault-free run's")
    bottom.set_xticks(range(len(cases)), [f"{c} {k}" for c, k in cases], rotation=90, fontsize=7)
    bottom.legend(fontsize=7, ncol=2)
    fig.tight_layout()
    return save_figure_atomically(fig, path)


def print_perturbations(rows: list, stream) -> None:
    """The perturbation table: final errors (fused, odometry-only, Gyrodometry), the fused RMS and maximum
    along the run, completion, the perturbation monitor's first flag after the onset (ms) and flags, the
    sensor flags; then a line ``perturbations detected=<n>/<m> within_0.1s=<k>``."""
    print(
        f"{'scenario':10} {'seed':>4} {'perturbation':13} {'on':7} {'fused m':>8} {'odo m':>7} "
        f"{'gyrodo m':>8} {'RMS m':>7} {'max m':>7} {'done':>5} {'flag ms':>7}  perturbation flags | "
        "sensor flags",
        file=stream,
    )
    for r in rows:
        latency = r["perturbation_latency_s"]
        shown = f"{1000 * latency:.0f}" if math.isfinite(latency) else "-"
        print(
            f"{r['scenario']:10} {r['seed']:>4} {r['kind']:13} {r['channel']:7} {r['fused_error_m']:8.4f} "
            f"{r['odometry_error_m']:7.4f} {r['gyrodometry_error_m']:8.4f} "
            f"{r.get('fused_rms_error_m', math.nan):7.4f} {r.get('fused_max_error_m', math.nan):7.4f} "
            f"{str(r['completed']):>5} "
            f"{shown:>7}  {r['perturbation_flags']} | {r['flags']}",
            file=stream,
        )
    latencies = [r["perturbation_latency_s"] for r in rows]
    detected = sum(math.isfinite(v) for v in latencies)
    quick = sum(math.isfinite(v) and v <= 0.1 for v in latencies)
    print(f"perturbations detected={detected}/{len(rows)} within_0.1s={quick}", file=stream)


def clean_figures(a: dict) -> dict:
    """A fault-free run's flags (all false) and position errors (fused, odometry-only, Gyrodometry: final,
    RMS and maximum along the run)."""
    return {
        "false_flags": sum(int(np.sum(a[f"health_{c}"] > 0)) for c in SENSOR_CHANNELS)
        + perturbation_samples(a),
        **position_error_columns(a),
    }


def baseline_line(rows: list, clean_rows: list) -> str:
    """How often the fused final error is below each baseline's on the same runs (fault runs and
    fault-free runs apart), and the fault-free runs where it is not below both (a tie counts as not
    below). Rows without finite figures are skipped."""

    def finite(r, key):
        return math.isfinite(r.get(key, math.nan)) and math.isfinite(r.get("fused_error_m", math.nan))

    def closer(runs, key):
        runs = [r for r in runs if finite(r, key)]
        return sum(r["fused_error_m"] < r[key] for r in runs), len(runs)

    parts = []
    for label, key in (("odometry-only", "odometry_error_m"), ("Gyrodometry", "gyrodometry_error_m")):
        (n, m), (k, c) = closer(rows, key), closer(clean_rows, key)
        parts.append(f"below {label}'s in {n}/{m} fault runs and {k}/{c} fault-free runs")
    beaten = [
        f"{r['scenario']} seed {r['seed']}"
        for r in clean_rows
        if any(
            finite(r, key) and not r["fused_error_m"] < r[key]
            for key in ("odometry_error_m", "gyrodometry_error_m")
        )
    ]
    return (
        "baselines on the same runs: the fused final error is "
        + "; ".join(parts)
        + (f" (fault-free runs where it is not below both: {', '.join(beaten)})" if beaten else "")
    )


def along_run_baseline_line(rows: list, clean_rows: list) -> str:
    """baseline_line's counts for the fused RMS and maximum along the run against the baselines' ('' when
    no run has them): "along the run: the fused RMS is below odometry-only's in n/m fault runs and k/c
    fault-free runs, below Gyrodometry's in ...; its maximum ..."."""

    def closer(runs, figure, baseline):
        keys = (f"fused_{figure}_error_m", f"{baseline}_{figure}_error_m")
        runs = [r for r in runs if all(math.isfinite(r.get(key, math.nan)) for key in keys)]
        return f"{sum(r[keys[0]] < r[keys[1]] for r in runs)}/{len(runs)}"

    if not any("fused_rms_error_m" in r for r in [*rows, *clean_rows]):
        return ""
    parts = [
        f"{'the fused RMS' if figure == 'rms' else 'its maximum'} is "
        + ", ".join(
            f"below {label}'s in {closer(rows, figure, key)} fault runs and "
            f"{closer(clean_rows, figure, key)} fault-free runs"
            for label, key in (("odometry-only", "odometry"), ("Gyrodometry", "gyrodometry"))
        )
        for figure in ("rms", "max")
    ]
    return "along the run: " + "; ".join(parts)


def print_null_faults(nulls: list, stream) -> None:
    """One line on the null faults (null_fault_cases): the final-error ratio chance alone gives."""
    ratios = [r["error_ratio"] for r in nulls]
    rms = [r.get("run_rms_ratio", math.nan) for r in nulls]
    flagged = sum(r["flagged_samples"] + r["other_flags"] + r["perturbation_samples"] > 0 for r in nulls)
    channels = ", ".join(NULL_FAULT_CHANNELS)
    print(
        f"null faults (a {NULL_FAULT_BIAS:g} bias step on {channels}): {len(nulls)} runs, "
        f"final-error ratio {min(ratios):.2f}-{max(ratios):.2f} ({sum(v > 3.0 for v in ratios)} above 3), "
        f"RMS ratio {np.nanmin(rms):.2f}-{np.nanmax(rms):.2f}, flagged {flagged}",
        file=stream,
    )


def print_report(rows: list, clean_rows: list, wall: float, stream, nulls: list = ()) -> None:
    print(
        f"{'scenario':10} {'seed':>4} {'channel':9} {'fault':10} {'latency ms':>10} {'ratio':>6} "
        f"{'bias/sigma':>10} {'fused m':>8} {'odo m':>7} {'gyrodo m':>8} {'RMS ratio':>9} {'RMS m':>7} "
        f"{'max m':>7}",
        file=stream,
    )
    for r in rows:
        latency = f"{1000 * r['latency_s']:.0f}" if math.isfinite(r["latency_s"]) else "missed"
        print(
            f"{r['scenario']:10} {r['seed']:>4} {r['channel']:9} {r['kind']:10} {latency:>10} "
            f"{r['error_ratio']:6.2f} {r['bias_error_sigma']:10.2f} {r['fused_error_m']:8.4f} "
            f"{r['odometry_error_m']:7.4f} {r['gyrodometry_error_m']:8.4f} "
            f"{r.get('run_rms_ratio', math.nan):9.2f} {r.get('fused_rms_error_m', math.nan):7.4f} "
            f"{r.get('fused_max_error_m', math.nan):7.4f}",
            file=stream,
        )
    run_rms = [(r.get("run_rms_ratio", math.nan), r) for r in rows]
    run_rms = [(v, r) for v, r in run_rms if math.isfinite(v)]
    if run_rms:
        worst, r = max(run_rms, key=lambda item: item[0])
        above = sum(v > 3.0 for v, _ in run_rms)
        print(
            f"fused RMS error over the run / the fault-free run's: worst {worst:.2f} ({r['scenario']} seed "
            f"{r['seed']} {r['channel']} {r['kind']}), {above} runs above 3 (final error: "
            f"{sum(x['error_ratio'] > 3.0 for x in rows)})",
            file=stream,
        )
    if nulls:
        print_null_faults(nulls, stream)
    means = seed_mean_ratios(rows, clean_rows)
    if means:
        worst = max(means)
        print(
            f"over seeds, the faulted runs' mean fused error / the fault-free runs' mean: worst "
            f"{worst[0]:.2f} ({worst[1]} {worst[2]} {worst[3]}, {worst[4]} seeds), "
            f"{sum(m[0] > 3.0 for m in means)} of {len(means)} above 3",
            file=stream,
        )
    print(baseline_line(rows, clean_rows), file=stream)
    along = along_run_baseline_line(rows, clean_rows)
    if along:
        print(along, file=stream)
    false_flags = sum(r["false_flags"] for r in clean_rows)
    detected = sum(bool(r["detected"]) for r in rows)
    worst_ratio = max((r["error_ratio"] for r in rows), default=math.nan)
    worst_bias = max((r["bias_error_sigma"] for r in rows), default=math.nan)
    print(
        f"{len(rows)} fault runs and {len(clean_rows)} fault-free runs in {wall:.0f} s; false flags in the "
        f"fault-free runs: {false_flags}; worst gyro-bias error after recovery {worst_bias:.2f} sigma "
        "(goals: none, <= 3)",
        file=stream,
    )
    for label, key in (
        ("that flagged another channel", "other_flags"),
        ("with a perturbation flag", "perturbation_samples"),
    ):
        runs = [f"{r['channel']} {r['kind']}" for r in rows if r.get(key, 0) > 0]
        print(
            f"sensor-fault runs {label}: {len(runs)}"
            + (f" ({', '.join(sorted(set(runs)))})" if runs else ""),
            file=stream,
        )
    print(f"faults detected={detected}/{len(rows)} worst_error_ratio={worst_ratio:.3f}", file=stream)
