"""Sections of ``slipnav results`` made of single runs on the sweep engine (studies/engine.py): the
controller's figures, the navigation at rest, the plant perturbations, the simulated calibration. Each
run function is module-level (the engine's workers import it by name) and returns plain figures."""

from __future__ import annotations

import math
import tempfile
from pathlib import Path as FilePath

import numpy as np
from slipnav.scenarios.config import load_scenario, scenario_from_yaml
from slipnav.scenarios.runner import run_scenario
from slipnav.studies.calibration import COMPARED, compare, simulated_calibration
from slipnav.studies.engine import run_jobs
from slipnav.studies.fault_cases import PERTURBATIONS as PERTURBATION_CASES
from slipnav.studies.fault_cases import perturbation_cases
from slipnav.studies.faults import run_perturbation
from slipnav.studies.long_run import SPIN_RATE, run_child, spin
from slipnav.studies.results_text import Section, mean_worst, number, paragraph, table

ESTIMATE_KEYS = ("fused", "odometry", "gyrodometry")
CONTROL_RUNS = (
    ("corner", {}),
    ("corner", {"slip_control": False}),
    ("square", {}),
    ("square", {"slip_control": False}),
    ("long_path", {}),
    ("long_path", {"speed_law": "constant"}),
    ("circle", {}),
    ("circle", {"speed_law": "constant"}),
)
"""(scenario, run options) of the controller's table: slip control on and off (Seyr), the bounded speed
law I(24) and the constant one (Indiveri)."""
LOCALISATIONS = ("fused", "gyrodometry", "odometry", "truth")


def _mean(rows, key) -> float:
    """The mean of a figure over rows (a missing one, None, as NaN)."""
    return float(np.mean([math.nan if r[key] is None else r[key] for r in rows]))


def run_control(job: dict) -> dict:
    """One closed-loop run's summary figures (job: scenario, seed and slipnav run's options)."""
    options = {k: job[k] for k in ("slip_control", "speed_law", "localisation") if job.get(k) is not None}
    s = run_scenario(load_scenario(job["scenario"]), seed=job["seed"], **options).summary
    return {
        "completion_s": s["controller_completion_time_s"],
        "path_rms_m": s["path_error_rms_m"],
        "path_max_m": s["path_error_max_m"],
        "alpha_deg": s["peak_abs_true_alpha_deg"],
        "min_step_size": s["min_step_size"],
        "max_command_m_s": s["max_abs_wheel_command_m_s"],
        "end_distance_m": s["end_distance_m"],
        **{f"{k}_m": s["final_position_error_m"][k] for k in ESTIMATE_KEYS},
    }


def _option_text(options: dict) -> str:
    flags = {
        "slip_control": "--no-slip-control",
        "speed_law": "--speed-law",
        "localisation": "--localisation",
    }
    return " ".join(
        flags[k] if v is False else f"{flags[k]} {v}"
        for k, v in options.items()
        if k in flags and v is not None
    )


def _control_rows(jobs, rows) -> tuple[list, list]:
    """The controller's table's rows and the localisation table's, one per run, means over the seeds."""
    by_run = {}
    for job, row in zip(jobs, rows, strict=True):
        key = f"`{job['scenario']}{' ' if _option_text(job) else ''}{_option_text(job)}`"
        by_run.setdefault(key, []).append(row)
    control, localisation = [], []
    for key, sel in by_run.items():
        if "--localisation" in key:
            localisation.append(
                [
                    key,
                    number(100 * _mean(sel, "end_distance_m"), 1, " cm"),
                    number(100 * _mean(sel, "path_rms_m"), 1, " cm"),
                ]
            )
            continue
        control.append(
            [
                key,
                number(_mean(sel, "completion_s"), 2, " s"),
                f"{100 * _mean(sel, 'path_rms_m'):.1f} cm ({100 * _mean(sel, 'path_max_m'):.1f})",
                number(_mean(sel, "alpha_deg"), 1, "°"),
                number(_mean(sel, "min_step_size"), 2),
                number(_mean(sel, "max_command_m_s"), 2, " m/s"),
                " / ".join(f"{100 * _mean(sel, f'{k}_m'):.1f}" for k in ESTIMATE_KEYS),
            ]
        )
    return control, localisation


def control_section(context) -> str:
    """The controller's figures: slip control on and off, the two speed laws, the localisations."""
    runs = [(name, o) for name, o in CONTROL_RUNS] + [("square", {"localisation": k}) for k in LOCALISATIONS]
    jobs = [
        {
            "scenario": name,
            "seed": seed,
            **{k: options.get(k) for k in ("slip_control", "speed_law", "localisation")},
        }
        for name, options in runs
        for seed in range(context.seeds)
    ]
    rows = run_jobs(run_control, jobs, workers=context.workers, label="control")
    control, localisation = _control_rows(jobs, rows)
    intro = paragraph(
        "The closed loop's figures from each run's summary (docs/artifacts.md), mean over the seeds: the "
        "controller's completion time (`controller_completion_time_s`, the 1 s standstill included), the "
        "true path error, the peak side slip, the smallest step size δ of slip control, the largest wheel "
        "command and the final position errors."
    )
    header = (
        "run",
        "completion",
        "true path error RMS (max)",
        "peak \\|α\\|",
        "min δ",
        "max wheel command",
        "final error fused / odometry / Gyrodometry, cm",
    )
    second = paragraph(
        "Where the closed-loop square ends from its path's end (`end_distance_m`) by what the path follower "
        "localises by, and its true path error's RMS:"
    )
    return "\n\n".join(
        [
            intro,
            table(header, control),
            second,
            table(("run", "distance from the path's end", "true path error RMS"), localisation),
        ]
    )


CONTROL = Section(
    "control",
    "Control",
    "control.md",
    control_section,
    seeds=1,
    study=("slipnav run NAME --seed S [--no-slip-control] [--speed-law constant] [--localisation L]",),
)

REST_SECONDS = 30.0
REST_YAML = """description: "At rest: the robot stands still for {seconds:g} s"
robot: {robot}
mode: trajectory
controller: feedforward
trajectory:
  segments:
    - !Pause {{duration: {seconds:g}}}
navigation: {{standstill: {{enabled: {standstill}}}}}
"""
"""The rest scenario: a feed-forward trajectory of one pause, the zero-velocity update on or off."""


def run_rest(job: dict) -> dict:
    """Drift per minute of each estimate on the rest scenario (job: robot, standstill, seed): the final
    position error (mm/min) and heading error (deg/min) over the run's time."""
    text = REST_YAML.format(
        seconds=REST_SECONDS, robot=job["robot"], standstill=str(job["standstill"]).lower()
    )
    a = run_scenario(scenario_from_yaml(text, "rest"), seed=job["seed"]).arrays
    minutes = (float(a["t"][-1]) - float(a["t"][0])) / 60.0
    out = {}
    for label, prefix in zip(ESTIMATE_KEYS, ("est", "odo", "gyro"), strict=True):
        position = math.hypot(a[f"{prefix}_x"][-1] - a["true_x"][-1], a[f"{prefix}_y"][-1] - a["true_y"][-1])
        heading = math.remainder(float(a[f"{prefix}_phi"][-1] - a["true_phi"][-1]), 2.0 * math.pi)
        out[f"{label}_mm_per_min"] = 1000.0 * position / minutes
        out[f"{label}_deg_per_min"] = abs(math.degrees(heading)) / minutes
    return out


def rest_section(context) -> str:
    """Drift at rest, with and without the zero-velocity update."""
    jobs = [
        {"robot": robot, "standstill": standstill, "seed": seed}
        for robot in ("tinyphoon", "kurt3d")
        for standstill in (True, False)
        for seed in range(context.seeds)
    ]
    rows = run_jobs(run_rest, jobs, workers=context.workers, label="rest")
    lines = []
    for robot in ("tinyphoon", "kurt3d"):
        for standstill in (True, False):
            sel = [
                r
                for j, r in zip(jobs, rows, strict=True)
                if (j["robot"], j["standstill"]) == (robot, standstill)
            ]
            lines.append(
                [
                    f"{robot}, zero-velocity update {'on' if standstill else 'off'}",
                    *(
                        f"{mean_worst([r[f'{k}_mm_per_min'] for r in sel], 3)} / "
                        f"{mean_worst([r[f'{k}_deg_per_min'] for r in sel], 3)}"
                        for k in ESTIMATE_KEYS
                    ),
                ]
            )
    intro = paragraph(
        f"The robot standing still for {REST_SECONDS:g} s after its 1 s standstill (a feed-forward "
        "trajectory of one pause, the plant's sensor noise and bias drift), with the navigation's "
        "zero-velocity update (`navigation.standstill.enabled`) on and off: each estimate's drift per minute "
        "of the run, position (mm/min) / heading (°/min), mean (worst) over the seeds."
    )
    header = ("robot, zero-velocity update", "fused", "odometry-only", "Gyrodometry")
    return intro + "\n\n" + table(header, lines)


REST = Section(
    "rest",
    "Drift at rest",
    "navigation.md",
    rest_section,
    seeds=2,
)

PERTURBATION_NAMES = {
    ("wheel_lifted", "wheel_R"): "right wheel lifted",
    ("wheel_held", "wheel_R"): "right wheel held",
    ("wheel_pushed", "wheel_R"): "right wheel pushed",
    ("body_push", "body_n"): "body pushed to the left",
    ("body_push", "body_t"): "body pushed backwards",
}


def run_start(job: dict) -> dict:
    """The fault-free run's controller start (the perturbations start 1 s after it)."""
    return {
        "start_time": float(
            run_scenario(load_scenario(job["scenario"]), seed=job["seed"]).arrays["start_time"]
        )
    }


def perturbations_section(context) -> str:
    """The plant perturbations of studies/faults.py on the corner and the square."""
    names = ("corner", "square")
    clean = [{"scenario": n, "seed": s} for n in names for s in range(context.seeds)]
    starts = run_jobs(run_start, clean, workers=context.workers, label="perturbations: fault-free")
    jobs = [
        {**c, **case}
        for c, start in zip(clean, starts, strict=True)
        for case in perturbation_cases(load_scenario(c["scenario"]), start)
    ]
    rows = run_jobs(run_perturbation, jobs, workers=context.workers, label="perturbations")
    lines = []
    for kind, channel in PERTURBATION_CASES:
        cells = []
        for name in names:
            sel = [r for r in rows if (r["scenario"], r["kind"], r["channel"]) == (name, kind, channel)]
            latency = np.array([1000 * r["perturbation_latency_s"] for r in sel], float)
            flagged = latency[np.isfinite(latency)]
            span = f"{flagged.min():.0f}" + (f"–{flagged.max():.0f}" if np.ptp(flagged) >= 0.5 else "")
            flag = f"{span} ms" if len(flagged) else "not flagged"
            errors = " / ".join(f"{100 * _mean(sel, f'{k}_error_m'):.1f}" for k in ESTIMATE_KEYS)
            done = sum(bool(r["completed"]) for r in sel)
            cells.append(f"{errors} cm; {flag}; {done}/{len(sel)} completed")
        lines.append([PERTURBATION_NAMES[(kind, channel)], *cells])
    intro = paragraph(
        "The plant perturbed for 0.5 s from 1 s after the controller starts (a wheel lifted, held, pushed "
        "with 0.6 × the motor's stall torque; the body pushed at 5 m/s² × its mass): the final error of "
        "fused / odometry-only / Gyrodometry (mean over the seeds), the perturbation monitor's first flag "
        "after the onset (range over the seeds) and the runs that completed their path."
    )
    return intro + "\n\n" + table(("perturbation", *names), lines)


PERTURBATIONS = Section(
    "perturbations",
    "Perturbations",
    "sensor-faults.md",
    perturbations_section,
    seeds=2,
    study=("slipnav faults corner square --seeds {seeds} --perturbations",),
)

CALIBRATION_TARGETS = {
    "wheel_radius_R": 0.1,
    "wheel_radius_L": 0.1,
    "track_width": 0.3,
    "gyro_scale_error": 0.2,
    "tyre_peak_acceleration": 5.0,
}
"""Targets of the identification, |error| in %."""


def run_calibration(job: dict) -> dict:
    """One simulated calibration (job: robot, seed): each identified value's error (relative or absolute,
    1; a misalignment's in deg) and its error in standard errors."""
    calibration, truth = simulated_calibration(job["robot"], job["seed"])
    compared = compare(calibration, truth)
    return {
        **{f"{key}_error": error for key, (_, _, error, _) in compared.items()},
        **{f"{key}_z": z for key, (_, _, _, z) in compared.items()},
    }


def calibration_section(context) -> str:
    """slipnav calibrate --simulate on both robots: the identification's errors."""
    robots = ("tinyphoon", "kurt3d")
    jobs = [{"robot": robot, "seed": seed} for robot in robots for seed in range(context.seeds)]
    rows = run_jobs(run_calibration, jobs, workers=context.workers, label="calibration")
    lines = []
    for key, _, kind in COMPARED:
        cells = []
        for robot in robots:
            sel = [r for j, r in zip(jobs, rows, strict=True) if j["robot"] == robot]
            error = np.abs([r[f"{key}_error"] for r in sel]) * (1.0 if kind == "deg" else 100.0)
            z = np.abs([r[f"{key}_z"] for r in sel])
            cells.append(f"{error.max():.3f}{'°' if kind == 'deg' else ' %'}, {z.max():.1f}")
        target = CALIBRATION_TARGETS.get(key)
        lines.append([f"`{key}`", *cells, f"{target:g} %" if target else ""])
    intro = paragraph(
        "The calibration procedure (docs/calibration.md) on robots drawn from the tolerance preset by the "
        "seed: its manoeuvres driven on the simulated robot, the parameters identified from the logs and the "
        "hand measurements; the worst |error| over the seeds (a scale error absolute, a misalignment in "
        "degrees, the rest relative) and the worst error in the identification's own standard errors."
    )
    header = ("identified", *(f"{r}: worst \\|error\\|, in standard errors" for r in robots), "target")
    return intro + "\n\n" + table(header, lines)


CALIBRATION = Section(
    "calibration",
    "Calibration of the simulated robots",
    "calibration.md",
    calibration_section,
    seeds=2,
    study=(
        "slipnav calibrate --simulate tinyphoon --seeds {seeds}",
        "slipnav calibrate --simulate kurt3d --seeds {seeds}",
    ),
)

LONG_RUN_SECONDS = 3600.0
"""Simulated time of the long run's laps and of its spin: an hour of each (issue: a 1 h run of square laps
with standstills between them)."""


def long_run_section(context) -> str:
    """square_laps for LONG_RUN_SECONDS in a child process, and a spin on the spot as long."""
    with tempfile.TemporaryDirectory() as out:
        s = run_child("square_laps", LONG_RUN_SECONDS, FilePath(out))
    r = spin(LONG_RUN_SECONDS)
    if s.get("duration_s") is None:
        raise RuntimeError(f"slipnav run square_laps failed (exit status {s['exit_status']}): {s['stderr']}")
    rows = [
        [
            f"`square_laps`, {s['duration_s']:.0f} s closed loop",
            f"{s['peak_rss_MB']:.0f} MB, {s['total_wall_s']:.0f} s",
            f"{s['covariance_min_eigenvalue']:.2g} … {s['covariance_max_eigenvalue']:.2g}",
            f"{s['covariance_max_asymmetry']:.2g}",
            " / ".join(f"{100 * s['final_position_error_m'][k]:.1f}" for k in ESTIMATE_KEYS),
            _run_reports(s),
        ],
        [
            f"spin at {SPIN_RATE:g} rad/s, {r['duration_s']:.0f} s, plain loop",
            f"{r['wall_s']:.0f} s; finite: {'yes' if r['finite'] else 'no'}",
            f"{r['min_eigenvalue']:.2g} … {r['max_eigenvalue']:.2g}",
            f"{r['max_asymmetry']:.2g}",
            f"largest velocity variance {r['max_velocity_variance']:.2g} m²/s²",
            "—",
        ],
    ]
    intro = paragraph(
        f"{LONG_RUN_SECONDS / 60:g} minutes of Seyr's square laps with 5 s at rest between them (`slipnav "
        f"run square_laps --duration {LONG_RUN_SECONDS:g}` in a child process: its peak resident memory and "
        "wall time, the EKF covariance P's extreme eigenvalues and largest asymmetry over the run, checked "
        "every 0.1 s, and the final position errors of fused / odometry-only / Gyrodometry), and as long a "
        "spin on the spot through the plain navigation loop on synthetic sensors (P checked every 0.1 s). "
        "The reports: the channels the sensor checks flagged, the perturbations and the gyro bias changes "
        "the run's summary lists (none on a fault-free run)."
    )
    header = ("run", "memory, wall", "P's eigenvalues", "P's asymmetry", "final error, cm", "reports")
    return intro + "\n\n" + table(header, rows)


def _run_reports(summary: dict) -> str:
    """The fault-free run's reports from its summary: flagged channels, perturbations, bias changes."""
    flagged = sorted(summary.get("sensor_health") or {})
    perturbations = sorted(summary.get("perturbations") or {})
    changes = len(summary.get("gyro_bias_changes_s") or [])
    return (
        f"flagged: {', '.join(flagged) or 'none'}; perturbations: {', '.join(perturbations) or 'none'}; "
        f"bias changes: {changes}"
    )


LONG_RUN = Section(
    "long-run",
    "Long runs",
    "command-line.md",
    long_run_section,
    study=(
        f"python -m slipnav.studies.long_run --duration {LONG_RUN_SECONDS:g} --spin {LONG_RUN_SECONDS:g}",
    ),
    fixed="seed 0",
)
