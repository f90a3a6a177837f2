"""Robustness of the navigation to a real robot that is not its data sheet: ``slipnav robustness
[SCENARIO ...] [--seeds N] [--workers N]`` (benchmark).

Every case changes only the simulated robot (the scenario's ``plant`` section); navigation and control
keep the nominal model. Cases: the matched robot, every single tolerance at its bound (each wheel radius
+-1 %, both +1 %, track +-3 %, gyro scale +-1 %, accelerometer misalignment 1 deg, accelerometer scale
+-2 %, mass +25 %, friction 0.5 and 0.9) and random draws of the tolerance preset. For each case and
seed: the final position error (% of the path) of the fused estimate, odometry-only and Gyrodometry, the
final heading errors, the side-slip RMS (where |alpha| > 1 deg) and, beside the issue's final errors,
each estimate's RMS position error over the run against the same row's truth (``run_rms_pct``;
metrics.rms_position_error: an error made along the way counts even where a later one cancels it at the
end) and its RMS and maximum along the run against the truth of the instant each pose describes
(``rms_pct``, ``max_pct``; metrics.position_errors). Prints a table (the matched row first), writes a
figure, and ends with ``robustness worst_fused_pct=<f> worst_fused_over_best_baseline=<f>
worst_alpha_rms_deg=<f> worst_fused_max_pct=<f>``.
"""

import dataclasses as dc
import functools
import hashlib
import math
import sys
import time
from pathlib import Path as FilePath

import numpy as np
from slipnav.scenarios.config import load_scenario
from slipnav.scenarios.metrics import (
    ESTIMATES,
    final_position_error,
    position_errors_in_percent,
    rms_position_error,
    side_slip_rms_error,
)
from slipnav.scenarios.model import RobotModel, SensorCalibration, write_model
from slipnav.scenarios.plots import save_figure_atomically
from slipnav.scenarios.runner import run_scenario
from slipnav.scenarios.tolerances import RobotDeviations
from slipnav.studies import calibration as procedure
from slipnav.studies import calibration_identify, calibration_manoeuvres, calibration_signals
from slipnav.studies.engine import run_jobs

CALIBRATION_PROCEDURE = (procedure, calibration_manoeuvres, calibration_signals, calibration_identify)
"""The modules of the calibration procedure, whose sources key a calibrated model kept for reuse."""
CASES = {
    "matched": ({}, {}),
    "right radius +1 %": ({"wheel_radius_R": 0.01}, {}),
    "right radius -1 %": ({"wheel_radius_R": -0.01}, {}),
    "left radius +1 %": ({"wheel_radius_L": 0.01}, {}),
    "left radius -1 %": ({"wheel_radius_L": -0.01}, {}),
    "both radii +1 %": ({"wheel_radius_R": 0.01, "wheel_radius_L": 0.01}, {}),
    "track +3 %": ({"track_width": 0.03}, {}),
    "track -3 %": ({"track_width": -0.03}, {}),
    "gyro scale +1 %": ({"gyro_scale": 0.01}, {}),
    "gyro scale -1 %": ({"gyro_scale": -0.01}, {}),
    "accel misalignment 1 deg": ({"accel1_misalignment_deg": 1.0, "accel2_misalignment_deg": 1.0}, {}),
    "accel scale +2 %": ({"accel1_scale": 0.02, "accel2_scale": 0.02}, {}),
    "accel scale -2 %": ({"accel1_scale": -0.02, "accel2_scale": -0.02}, {}),
    "mass +25 %": ({"mass": 0.25, "yaw_inertia": 0.25}, {}),
    "friction 0.5": ({}, {"tyre_friction": 0.5}),
    "friction 0.9": ({}, {"tyre_friction": 0.9}),
    "tolerance preset draws": None,
}
"""Case label -> (plant.deviations, plant.robot_overrides); None: random draws of TOLERANCE_PRESET."""


RESULT_COLUMNS = (
    "scenario case seed".split()
    + [
        f"{label}_{figure}"
        for label, _ in ESTIMATES
        for figure in ("pct", "heading_deg", "run_rms_pct", "rms_pct", "max_pct")
    ]
    + ["alpha_rms_deg"]
)
"""The columns of run_case's row (a resumed robustness.csv must have them all)."""


def run_case(name: str, case: str, seed: int, open_loop=None) -> dict:
    """One run of ``case``; returns its figures."""
    scenario = load_scenario(name)
    spec = CASES[case]
    if spec is not None:
        deviations, overrides = spec
        scenario.plant = dc.replace(
            scenario.plant,
            deviations=RobotDeviations(**deviations),
            robot_overrides={**scenario.plant.robot_overrides, **overrides},
        )
    a = run_scenario(scenario, seed=seed, open_loop=open_loop, tolerances=spec is None).arrays
    length = float(a["path_length"])
    out = {"scenario": name, "case": case, "seed": seed}
    for label, prefix in ESTIMATES:
        out[f"{label}_pct"] = 100.0 * final_position_error(a, prefix) / length
        heading = a[f"{prefix}_phi"][-1] - a["true_phi"][-1]
        out[f"{label}_heading_deg"] = math.degrees(math.remainder(heading, 2.0 * math.pi))
        out[f"{label}_run_rms_pct"] = 100.0 * rms_position_error(a, prefix) / length
        along = position_errors_in_percent(a, prefix)
        out[f"{label}_rms_pct"], out[f"{label}_max_pct"] = along["rms"], along["max"]
    out["alpha_rms_deg"] = math.degrees(side_slip_rms_error(a))
    return out


def _run(job, open_loop=None):
    return run_case(job["scenario"], job["case"], job["seed"], open_loop)


def robustness(
    names,
    seeds: int,
    workers=None,
    out_dir="runs",
    open_loop=None,
    stream=None,
    *,
    scheduler=None,
    resume=False,
) -> list:
    """Run every case of every scenario over seeds 0..seeds-1 on the sweep engine (studies/engine.py:
    ``workers`` processes, default one per core, or ``scheduler``; results in ``out_dir``/robustness.csv,
    ``resume``); print the table and the last line, write ``out_dir/robustness.png``; returns the
    per-run figures."""
    stream = stream or sys.stdout
    jobs = [
        {"scenario": name, "case": case, "seed": seed}
        for name in names
        for case in CASES
        for seed in range(seeds)
    ]
    start = time.perf_counter()
    results = FilePath(out_dir) / "robustness.csv"
    run = functools.partial(_run, open_loop=open_loop)
    rows = run_jobs(
        run,
        jobs,
        workers=workers,
        scheduler=scheduler,
        results=results,
        resume=resume,
        label="robustness",
        columns=RESULT_COLUMNS,
    )
    summary = summarise(rows, stream)
    print(f"{len(jobs)} runs in {time.perf_counter() - start:.0f} s", file=stream)
    figure = plot_robustness(rows, FilePath(out_dir) / "robustness.png")
    print(f"figure: {figure}", file=stream)
    pct, ratio, alpha, largest = summary
    print(
        f"robustness worst_fused_pct={pct:.3f} worst_fused_over_best_baseline={ratio:.3f} "
        f"worst_alpha_rms_deg={alpha:.3f} worst_fused_max_pct={largest:.3f}",
        file=stream,
    )
    return rows


def summarise(rows: list, stream) -> tuple:
    """Print per scenario and case: mean (worst) of each error, the mean ratio of fused to the better
    baseline, the seeds on which fused exceeded either baseline, and the largest error along the run.
    Returns the last line's figures (the worst fused final error, ratio, side-slip RMS and fused maximum
    along the run)."""
    worst_pct, worst_ratio, worst_alpha, worst_max = 0.0, 0.0, 0.0, 0.0
    for name in dict.fromkeys(r["scenario"] for r in rows):
        print(f"\n{name}", file=stream)
        print(
            f"{'case':<26}{'fused %':>14}{'odometry %':>14}{'Gyrodom. %':>14}{'fused/best':>11}"
            f"{'above a baseline':>17}{'heading fused/odo/gyro deg':>30}{'alpha RMS deg':>15}"
            f"{'run RMS fused/odo/gyro %':>27}{'above':>7}{'max fused/odo/gyro %':>23}",
            file=stream,
        )
        for case in CASES:
            sel = [r for r in rows if r["scenario"] == name and r["case"] == case]
            if not sel:
                continue
            col = {k: np.array([r[k] for r in sel], float) for k in sel[0] if k not in ("scenario", "case")}
            best = np.minimum(col["odometry_pct"], col["gyrodometry_pct"])
            ratio = col["fused_pct"].mean() / best.mean()
            above = int(
                np.sum((col["fused_pct"] > col["odometry_pct"]) | (col["fused_pct"] > col["gyrodometry_pct"]))
            )
            alpha = col["alpha_rms_deg"]
            alpha_text = (
                f"{np.nanmean(alpha):.2f} ({np.nanmax(alpha):.2f})" if np.isfinite(alpha).any() else "-"
            )
            worst_pct = max(worst_pct, col["fused_pct"].max())
            worst_ratio = max(worst_ratio, ratio)
            if np.isfinite(alpha).any():
                worst_alpha = max(worst_alpha, float(np.nanmean(alpha)))

            def mw(k, col=col):
                return f"{col[k].mean():.2f} ({col[k].max():.2f})"

            labels = [label for label, _ in ESTIMATES]
            heading = "/".join(f"{np.abs(col[f'{p}_heading_deg']).mean():.2f}" for p in labels)
            rms = {p: col[f"{p}_run_rms_pct"] for p in labels}
            run_rms = "/".join(f"{rms[p].mean():.2f}" for p in labels)
            beyond = (rms["fused"] > rms["odometry"]) | (rms["fused"] > rms["gyrodometry"])
            run_above = f"{int(np.sum(beyond))}/{len(sel)}"
            largest = "/".join(f"{col[f'{p}_max_pct'].mean():.2f}" for p in labels)
            worst_max = max(worst_max, col["fused_max_pct"].max())
            print(
                f"{case:<26}{mw('fused_pct'):>14}{mw('odometry_pct'):>14}{mw('gyrodometry_pct'):>14}{ratio:>11.2f}"
                f"{f'{above}/{len(sel)}':>17}{heading:>30}{alpha_text:>15}{run_rms:>27}{run_above:>7}"
                f"{largest:>23}",
                file=stream,
            )
    print(
        "\nfigures: mean (worst) over seeds; fused/best = mean fused / mean of the better baseline per seed; "
        "alpha RMS where |alpha| > 1 deg (its mean enters the last line); run RMS = the position error's RMS "
        "over the run against the same row's truth, mean over seeds, and the seeds on which the fused one is "
        "above either baseline's; max = the largest position error along the run (each pose against the "
        "truth of the instant it describes), mean over seeds",
        file=stream,
    )
    return worst_pct, worst_ratio, worst_alpha, worst_max


def plot_robustness(rows: list, path: FilePath) -> FilePath:
    """Grouped bars: per case the mean final error of fused, odometry-only and Gyrodometry (% of the
    path), one panel per scenario, worst seeds as error-bar tops."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = list(dict.fromkeys(r["scenario"] for r in rows))
    fig, axes = plt.subplots(len(names), 1, figsize=(12, 3.6 * len(names)), squeeze=False)
    cases = list(CASES)
    x = np.arange(len(cases))
    for ax, name in zip(axes[:, 0], names, strict=True):
        for j, (label, key) in enumerate(
            (("fused", "fused_pct"), ("odometry-only", "odometry_pct"), ("Gyrodometry", "gyrodometry_pct"))
        ):
            means, worsts = [], []
            for case in cases:
                values = [r[key] for r in rows if r["scenario"] == name and r["case"] == case]
                means.append(np.mean(values) if values else np.nan)
                worsts.append(np.max(values) if values else np.nan)
            means, worsts = np.array(means), np.array(worsts)
            ax.bar(
                x + (j - 1) * 0.27,
                means,
                0.27,
                label=label,
                yerr=[np.zeros_like(means), worsts - means],
                capsize=2,
            )
        ax.set_yscale("log")
        ax.set_ylabel("final position error (% of path)")
        ax.set_title(f"{name}: nominal navigation on a toleranced robot (bars: mean, whiskers: worst seed)")
        ax.set_xticks(x, cases, rotation=30, ha="right", fontsize=8)
        ax.axhline(1.0, color="k", lw=0.8, ls="--")
        ax.legend(fontsize=8)
    fig.tight_layout()
    return save_figure_atomically(fig, path)


# ---------------------------------------------------------------------------------------------------
# slipnav robustness --calibrated: nominal, calibrated and matched models on the same toleranced robots

CALIBRATED_TARGET = 1.3
"""Issue target: the fused error with the calibrated model <= 1.3 x the matched model's (mean)."""


def true_model(scenario, plant, sensors):
    """The matched model (an oracle, for judging only): the nominal robot with every RobotParameters field
    the plant changed, the sensors' true gains and misalignments, and the tyres' true peak acceleration
    mu g f_w (S(15), S(17))."""
    nominal = scenario.robot_parameters()
    overrides = {
        f.name: float(getattr(plant, f.name))
        for f in dc.fields(plant)
        if f.name != "name"
        and getattr(plant, f.name) is not None
        and isinstance(getattr(plant, f.name), (int, float))
        and getattr(plant, f.name) != getattr(nominal, f.name)
    }
    calibration = SensorCalibration(
        **{
            key: getattr(sensors, key)
            for key in (
                "gyro_scale_error",
                "accel1_scale_error",
                "accel2_scale_error",
                "accel1_misalignment",
                "accel2_misalignment",
            )
        }
    )
    navigation = scenario.navigation
    navigation = dc.replace(
        navigation,
        mixing=dc.replace(navigation.mixing, tyre_peak_acceleration=plant.traction_limit_acceleration),
    )
    return RobotModel(
        robot=scenario.robot,
        description="the true robot (slipnav robustness --calibrated: the matched model, an oracle)",
        robot_overrides=overrides,
        calibration=calibration,
        T_N=scenario.T_N,
        T_C=scenario.T_C,
        navigation=navigation,
    )


def calibrated_model_path(scenario, seed: int, model_dir) -> FilePath:
    """Calibrate the scenario's robot drawn from the preset by ``seed`` (studies/calibration.py: its
    manoeuvres on that robot, identified from their logs), once per robot and draw: the model file is
    kept in ``model_dir`` and reused (corner and square share Tinyphoon's) while the robot, its draw and
    the calibration procedure (the sources of CALIBRATION_PROCEDURE) are unchanged."""
    world = repr((scenario.robot, scenario.robot_overrides, scenario.sensor_overrides, scenario.plant))
    source = b"".join(FilePath(module.__file__).read_bytes() for module in CALIBRATION_PROCEDURE)
    key = hashlib.sha1(world.encode() + source).hexdigest()[:8]
    path = FilePath(model_dir) / f"{scenario.robot}-{key}-seed{seed}.calibrated.model.yaml"
    if not path.is_file():
        manoeuvres, _ = procedure.simulate_manoeuvres(scenario, seed)
        base = RobotModel(robot=scenario.robot, T_N=scenario.T_N, T_C=scenario.T_C)
        write_model(procedure.calibrate(manoeuvres, scenario.robot, base).model, path)
    return path


def run_calibrated(name: str, seed: int, model_dir, open_loop=None) -> dict:
    """The preset draw of ``seed`` on scenario ``name`` with the nominal, the calibrated and the matched
    model: each one's fused, odometry and Gyrodometry final errors, their RMS and maximum along the run
    (% of the path; ``_pct``, ``_rms_pct``, ``_max_pct``) and headings (``open_loop``: as run_scenario's;
    True drives the same commands with every model)."""
    model_dir = FilePath(model_dir)
    model_dir.mkdir(parents=True, exist_ok=True)
    scenario = load_scenario(name)
    plant, sensors, _ = scenario.plant_parameters(seed, tolerances=True)
    models = {
        "nominal": None,
        "calibrated": calibrated_model_path(scenario, seed, model_dir),
        "matched": write_model(
            true_model(scenario, plant, sensors), model_dir / f"{name}-seed{seed}.true.model.yaml"
        ),
    }
    out = {"scenario": name, "seed": seed}
    for label, path in models.items():
        run = scenario if path is None else dc.replace(scenario, model=str(path)).validate()
        a = run_scenario(run, seed=seed, tolerances=True, open_loop=open_loop).arrays
        length = float(a["path_length"])
        for estimate, prefix in ESTIMATES:
            out[f"{label}_{estimate}_pct"] = 100.0 * final_position_error(a, prefix) / length
            along = position_errors_in_percent(a, prefix)
            for figure in ("rms", "max"):
                out[f"{label}_{estimate}_{figure}_pct"] = along[figure]
            heading = math.remainder(a[f"{prefix}_phi"][-1] - a["true_phi"][-1], 2.0 * math.pi)
            out[f"{label}_{estimate}_heading_deg"] = math.degrees(heading)
        out[f"{label}_alpha_rms_deg"] = math.degrees(side_slip_rms_error(a))
    return out


def _run_calibrated(job, model_dir):
    return run_calibrated(job["scenario"], job["seed"], model_dir)


def robustness_calibrated(
    names, seeds: int, workers=None, out_dir="runs", stream=None, *, scheduler=None, resume=False
) -> list:
    """``slipnav robustness --calibrated``: per scenario and preset draw (seeds 0..seeds-1) the nominal,
    calibrated and matched models on the same robot (run_calibrated), on the sweep engine (results in
    ``out_dir``/robustness-calibrated.csv, models in ``out_dir``/robustness-models/); prints the table
    and ``robustness calibrated worst_calibrated_over_matched=<f> worst_calibrated_fused_pct=<f>
    calibrated_above_a_baseline=<n>/<m>``, writes ``out_dir``/robustness-calibrated.png."""
    stream = stream or sys.stdout
    # Scenario-major order: the two workers calibrate different seeds, and square finds corner's models.
    jobs = [{"scenario": name, "seed": seed} for name in names for seed in range(seeds)]
    start = time.perf_counter()
    out = FilePath(out_dir)
    run = functools.partial(_run_calibrated, model_dir=str(out / "robustness-models"))
    rows = run_jobs(
        run,
        jobs,
        workers=workers,
        scheduler=scheduler,
        results=out / "robustness-calibrated.csv",
        resume=resume,
        label="robustness --calibrated",
    )
    worst_ratio, worst_pct, above = summarise_calibrated(rows, stream)
    print(
        f"{len(jobs)} robots (3 runs and a calibration each) in {time.perf_counter() - start:.0f} s",
        file=stream,
    )
    figure = plot_calibrated(rows, out / "robustness-calibrated.png")
    print(f"figure: {figure}", file=stream)
    print(
        f"robustness calibrated worst_calibrated_over_matched={worst_ratio:.3f} "
        f"worst_calibrated_fused_pct={worst_pct:.3f} calibrated_above_a_baseline={above}/{len(rows)}",
        file=stream,
    )
    return rows


def summarise_calibrated(rows: list, stream) -> tuple:
    """Per scenario: mean (worst) fused error of each model, the calibrated over matched ratio of the
    means (target <= CALIBRATED_TARGET), the baselines with the calibrated model, and the seeds where the
    calibrated fused estimate exceeds either of them. Returns (worst ratio, worst calibrated fused %,
    seeds above a baseline)."""
    worst_ratio, worst_pct, above_total = 0.0, 0.0, 0
    print(
        f"\n{'scenario':<12}{'nominal %':>14}{'calibrated %':>14}{'matched %':>14}{'cal/matched':>12}"
        f"{'cal. odometry %':>17}{'cal. Gyrodom. %':>17}{'above a baseline':>18}"
        f"{'RMS / max nominal %':>21}{'calibrated %':>14}{'matched %':>12}",
        file=stream,
    )
    for name in dict.fromkeys(r["scenario"] for r in rows):
        sel = [r for r in rows if r["scenario"] == name]
        col = {k: np.array([r[k] for r in sel], float) for k in sel[0] if k not in ("scenario", "seed")}
        ratio = col["calibrated_fused_pct"].mean() / col["matched_fused_pct"].mean()
        above = int(
            np.sum(
                (col["calibrated_fused_pct"] > col["calibrated_odometry_pct"])
                | (col["calibrated_fused_pct"] > col["calibrated_gyrodometry_pct"])
            )
        )
        worst_ratio = max(worst_ratio, ratio)
        worst_pct = max(worst_pct, float(col["calibrated_fused_pct"].max()))
        above_total += above

        def mw(k, col=col):
            return f"{col[k].mean():.2f} ({col[k].max():.2f})"

        print(
            f"{name:<12}{mw('nominal_fused_pct'):>14}{mw('calibrated_fused_pct'):>14}"
            f"{mw('matched_fused_pct'):>14}{ratio:>12.2f}{mw('calibrated_odometry_pct'):>17}"
            f"{mw('calibrated_gyrodometry_pct'):>17}{f'{above}/{len(sel)}':>18}"
            + "".join(
                f"{col[f'{model}_fused_rms_pct'].mean():.2f} / {col[f'{model}_fused_max_pct'].mean():.2f}"
                .rjust(width)
                for model, width in (("nominal", 21), ("calibrated", 14), ("matched", 12))
            ),
            file=stream,
        )
    print(
        f"\nfigures: final position error, % of the path, mean (worst) over the preset draws; cal/matched = "
        f"mean calibrated / mean matched (target <= {CALIBRATED_TARGET}); matched = the true robot as the "
        "model (an oracle); RMS / max = the fused position error's RMS and maximum along the run, mean over "
        "the draws",
        file=stream,
    )
    return worst_ratio, worst_pct, above_total


def plot_calibrated(rows: list, path: FilePath) -> FilePath:
    """Per scenario and seed: fused final error with the nominal, calibrated and matched model."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = list(dict.fromkeys(r["scenario"] for r in rows))
    fig, axes = plt.subplots(1, len(names), figsize=(4.5 * len(names), 3.8), squeeze=False)
    for ax, name in zip(axes[0], names, strict=True):
        sel = sorted((r for r in rows if r["scenario"] == name), key=lambda r: r["seed"])
        seeds = np.array([r["seed"] for r in sel])
        for j, label in enumerate(("nominal", "calibrated", "matched")):
            ax.bar(seeds + (j - 1) * 0.27, [r[f"{label}_fused_pct"] for r in sel], 0.27, label=label)
        ax.set_yscale("log")
        ax.set_xlabel("seed (tolerance preset draw)")
        ax.set_ylabel("fused final error (% of path)")
        ax.set_title(f"{name}: model of the navigation")
        ax.legend(fontsize=8)
    fig.tight_layout()
    return save_figure_atomically(fig, path)
