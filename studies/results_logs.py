"""Sections of ``slipnav results`` on real robots' recordings (docs/robot-logs.md): the TurtleBot trials
evaluated with the data sheet's model, the TurtleBot calibrated on one trial and evaluated on the others,
and the Warthog's doughnuts (on demand). Each imports the recording as ``slipnav import`` does
(scenarios/import_turtlebot.py, import_warthog.py), replays and evaluates it as ``slipnav evaluate`` does
(scenarios/evaluate.py) and calibrates as ``slipnav calibrate LOG --truth TRUTH`` does
(studies/truth_calibration.py). Without the dataset a section is skipped, saying where it is looked for."""

from __future__ import annotations

import math
import tempfile
from pathlib import Path as FilePath

import numpy as np
from slipnav.scenarios import import_turtlebot, import_warthog
from slipnav.scenarios.evaluate import evaluate_arrays, load_estimates, read_truth
from slipnav.scenarios.importers import write_import
from slipnav.studies.engine import run_jobs
from slipnav.studies.results_text import Section, SectionSkipped, number, paragraph, table
from slipnav.studies.truth_calibration import calibrate_truth_command

TURTLEBOT = "phil-turtlebot2-vicon"
TRIALS = tuple(f"trial_{i}" for i in range(4))
WARTHOG = "norlab-warthog-doughnut"
ESTIMATES = (("fused", "fused"), ("odometry", "odometry-only"), ("gyrodometry", "Gyrodometry"))


def _dataset(context, name: str, parts=("",)) -> FilePath:
    """The dataset folder ``name`` in the context's datasets, or SectionSkipped saying where it is looked
    for."""
    folder = FilePath(context.datasets) / name
    if not all((folder / part).is_dir() for part in parts):
        raise SectionSkipped(
            f"the dataset {name} is not in the datasets folder {FilePath(context.datasets).name}/ (the "
            "default: shared/datasets beside the repository; `--datasets DIR` names another; "
            "docs/robot-logs.md says where to obtain it)."
        )
    return folder


def imported(adapter, folder, out) -> tuple[str, str]:
    """(sensor log, truth file) of the recording ``folder`` imported into ``out`` (``slipnav import``)."""
    log, _, truth, _ = write_import(adapter.import_trial(folder), out)
    return str(log), str(truth)


def evaluation(job: dict) -> dict:
    """``slipnav evaluate LOG --truth TRUTH [--model MODEL]`` (job: log, truth, model or None) as flat
    figures: per estimate the final error (m), ATE (m), final heading error (deg) and the windowed ATE's
    median, 90th percentile and per-window list; the health shares."""
    with tempfile.TemporaryDirectory() as out:
        _, a, _ = load_estimates(job["log"], job["truth"], job["model"], out)
    result = evaluate_arrays(a, read_truth(job["truth"]))
    row = {}
    for label, _ in ESTIMATES:
        m = result["estimates"][label] or {}
        windowed = m.get("windowed_ate") or {}
        row |= {
            f"{label}_final_m": m.get("final_error_m", math.nan),
            f"{label}_ate_m": m.get("ate_m", math.nan),
            f"{label}_heading_deg": m.get("final_heading_error_deg", math.nan),
            f"{label}_window_median_m": windowed.get("median_m", math.nan),
            f"{label}_window_p90_m": windowed.get("p90_m", math.nan),
            f"{label}_windows": " ".join(f"{v!r}" for v in windowed.get("per_window_m", [])),
        }
    health = result["health"]
    row["flagged_share"] = (
        health["any_health_channel"] if health["any_health_channel"] is not None else math.nan
    )
    row["c1_share"] = health.get("C1_below_0.75", math.nan)
    row["samples"] = len(a["t"])
    return row


def _triple(row: dict, label: str) -> str:
    return (
        f"{number(row[f'{label}_final_m'], 3)}, {number(row[f'{label}_ate_m'], 3)}, "
        f"{number(row[f'{label}_heading_deg'], 1)}°"
    )


def turtlebot_section(context) -> str:
    """The four TurtleBot trials with the data sheet's model."""
    folder = _dataset(context, TURTLEBOT, TRIALS)
    with tempfile.TemporaryDirectory() as out:
        files = [imported(import_turtlebot, folder / trial, out) for trial in TRIALS]
        jobs = [{"log": log, "truth": truth, "model": None} for log, truth in files]
        rows = run_jobs(evaluation, jobs, workers=context.workers, label="turtlebot")
    lines = [[name, *(_triple(r, label) for r in rows)] for label, name in ESTIMATES]
    lines.append(["samples flagged by a sensor check", *(f"{100 * r['flagged_share']:.1f} %" for r in rows)])
    lines.append(["samples with C1 < 0.75", *(f"{100 * r['c1_share']:.1f} %" for r in rows)])
    lines.append(["samples", *(str(r["samples"]) for r in rows)])
    intro = paragraph(
        "The TurtleBot 2 trials (navX gyro and accelerometers, Kobuki encoders, Vicon truth) imported with "
        "the data sheet's model (`slipnav import phil-turtlebot`) and evaluated against the Vicon (`slipnav "
        "evaluate`): per estimate the final position error (m), the ATE (m) and the final heading error, "
        "each estimate aligned on its start pose; the shares of samples a sensor check flagged and of "
        "samples the slip detector reads as slip (C1 < 0.75)."
    )
    return intro + "\n\n" + table(("", *(t.replace("_", " ") for t in TRIALS)), lines)


def turtlebot_calibration_section(context) -> str:
    """The TurtleBot calibrated on each trial against its truth, evaluated on the other trials."""
    folder = _dataset(context, TURTLEBOT, TRIALS)
    with tempfile.TemporaryDirectory() as out:
        files = [imported(import_turtlebot, folder / trial, out) for trial in TRIALS]
        fits, models = [], []
        for log, truth in files:
            fits.append(calibrate_truth_command(log, truth, None, out, context.report))
            models.append(
                str(
                    FilePath(out) / f"{FilePath(log).name.removesuffix('.sensors.csv')}.calibrated.model.yaml"
                )
            )
        pairs = [(i, j) for j in range(len(TRIALS)) for i in range(len(TRIALS)) if i != j]
        jobs = [{"log": files[i][0], "truth": files[i][1], "model": models[j]} for i, j in pairs]
        rows = run_jobs(evaluation, jobs, workers=context.workers, label="turtlebot calibration")
    fit_lines = [
        [
            trial.replace("_", " "),
            *(
                f"{1000 * getattr(f, key):.2f} ± {1000 * f.standard_errors[key]:.2f}"
                for key in ("rolling_radius_R", "rolling_radius_L", "track_width")
            ),
            f"{100 * f.gyro_scale_error:+.2f} ± {100 * f.standard_errors['gyro_scale_error']:.2f}",
            f"{math.degrees(f.gyro_bias):+.3f}",
        ]
        for trial, f in zip(TRIALS, fits, strict=True)
    ]
    cells = {pair: _triple(row, "fused") for pair, row in zip(pairs, rows, strict=True)}
    cross = [
        [f"calibrated on {TRIALS[j].replace('_', ' ')}", *(cells.get((i, j), "") for i in range(len(TRIALS)))]
        for j in range(len(TRIALS))
    ]
    intro = paragraph(
        "The TurtleBot calibrated on each trial against its Vicon truth (`slipnav calibrate LOG --truth "
        "TRUTH`: the rolling radii, the effective track, the gyro's scale and bias) and each calibrated "
        "model evaluated on the other trials. The fits (mm, %, °/s; the data sheet: r = 35 mm, b = 230 mm):"
    )
    second = paragraph(
        "The fused estimate with each calibrated model: final position error (m), ATE (m), final heading "
        "error; the data sheet's and the baselines' figures are in the section above."
    )
    fit_header = (
        "trial",
        "r_R (mm)",
        "r_L (mm)",
        "effective track (mm)",
        "gyro scale error (%)",
        "gyro bias (°/s)",
    )
    cross_header = ("model", *(t.replace("_", " ") for t in TRIALS))
    return "\n\n".join([intro, table(fit_header, fit_lines), second, table(cross_header, cross)])


def warthog_section(context) -> str:
    """The Warthog's doughnuts (no accelerometers; RTK truth): the windowed ATE."""
    folder = _dataset(context, WARTHOG)
    with tempfile.TemporaryDirectory() as out:
        log, truth = imported(import_warthog, folder, out)
        (row,) = run_jobs(
            evaluation, [{"log": log, "truth": truth, "model": None}], workers=0, label="warthog"
        )
    windows = {label: np.array(row[f"{label}_windows"].split(), float) for label, _ in ESTIMATES}
    better = int(np.sum(windows["fused"] <= windows["gyrodometry"]))
    lines = [
        [
            name,
            number(row[f"{label}_window_median_m"]),
            number(row[f"{label}_window_p90_m"]),
            number(row[f"{label}_final_m"], 1),
        ]
        for label, name in ESTIMATES
    ]
    intro = paragraph(
        f"The Clearpath Warthog's doughnuts on grass (a four-wheel skid steer; no accelerometers, wheel "
        f"readings at 5 Hz, RTK GNSS truth; {row['samples']} samples) imported with the data sheet's model "
        f"(`slipnav import norlab-warthog`) and evaluated (`slipnav evaluate`): the ATE over windows of 30 "
        f"s, each estimate aligned afresh at the window's start. The fused estimate is at most Gyrodometry's "
        f"in {better} of the {len(windows['fused'])} windows; a sensor check flags "
        f"{100 * row['flagged_share']:.1f} % of the samples."
    )
    return intro + "\n\n" + table(("estimate", "median (m)", "90th percentile (m)", "final error (m)"), lines)


SECTIONS = (
    Section(
        "turtlebot",
        "Real logs: the TurtleBot trials",
        "robot-logs.md",
        turtlebot_section,
        study=("slipnav import phil-turtlebot TRIAL_DIR", "slipnav evaluate LOG --truth TRUTH"),
        fixed="recorded logs",
    ),
    Section(
        "turtlebot-calibration",
        "Real logs: the TurtleBot calibrated on one trial, evaluated on the others",
        "robot-logs.md",
        turtlebot_calibration_section,
        study=("slipnav calibrate LOG --truth TRUTH", "slipnav evaluate LOG --truth TRUTH --model MODEL"),
        fixed="recorded logs",
    ),
    Section(
        "warthog",
        "Real logs: the Warthog's doughnuts",
        "robot-logs.md",
        warthog_section,
        study=("slipnav import norlab-warthog DIR", "slipnav evaluate LOG --truth TRUTH"),
        on_demand=True,
        fixed="recorded log",
    ),
)
