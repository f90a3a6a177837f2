"""``slipnav sweep SCENARIO --seeds N [--set KEY=V1,V2 ...]`` on the sweep engine (studies/engine.py).

``slipnav sweep`` runs the cartesian product of the ``--set`` values (dotted scenario keys, checked as a
loaded scenario is before any run starts) times seeds 0..N-1, prints per combination the mean (worst)
final position error of the fused estimate, odometry-only and Gyrodometry (% of path length), writes
``DIR/sweep-<scenario>.csv`` and ``DIR/sweep-<scenario>.png`` (the distributions) and ends with
``sweep runs=<n> workers=<n> wall_s=<f> runs_per_s=<f> mean_fused_pct=<f> worst_fused_pct=<f>``.
"""

from __future__ import annotations

import functools
import itertools
import math
import sys
import time
from pathlib import Path as FilePath

import numpy as np
from slipnav.scenarios.config import ScenarioError, check_duration, check_seed_count, load_scenario, with_keys
from slipnav.scenarios.metrics import (
    ESTIMATES,
    final_position_error,
    position_errors_in_percent,
    side_slip_rms_error,
)
from slipnav.scenarios.plots import save_figure_atomically
from slipnav.scenarios.runner import run_scenario
from slipnav.scenarios.typed_yaml import parse_value
from slipnav.studies.engine import (
    Engine,
    check_engine_options,
    run_jobs,  # noqa: F401 (the Python API names slipnav.studies.sweep.run_jobs)
)
from slipnav.studies.results_file import ResultsFile, job_key, run_version

# ---------------------------------------------------------------------------------------------------
# slipnav sweep


def split_values(text: str) -> list[str]:
    """``v1,v2,[0, 0, 1]`` -> ['v1', 'v2', '[0, 0, 1]']: commas inside brackets or braces do not split."""
    values, depth, current = [], 0, ""
    for char in text:
        if char in "[{":
            depth += 1
        elif char in "]}":
            depth -= 1
        if char == "," and depth == 0:
            values.append(current.strip())
            current = ""
        else:
            current += char
    return values + [current.strip()]


def parse_set_options(options: list[str]) -> dict[str, list[str]]:
    """``["KEY=V1,V2", ...]`` -> {KEY: ['V1', 'V2']} (the values' text, in order)."""
    sets = {}
    for option in options:
        key, equals, text = option.partition("=")
        key = key.strip()
        if not equals or not key:
            raise ScenarioError(
                f"--set {option!r}: allowed KEY=VALUE[,VALUE ...], e.g. navigation.mixing.b1=0.03,0.05"
            )
        if key in sets:
            raise ScenarioError(f"--set {key} is given twice: allowed once per key, with all its values")
        values = split_values(text)
        if any(v == "" for v in values):
            raise ScenarioError(f"--set {option!r} has an empty value: allowed KEY=VALUE[,VALUE ...]")
        if len(set(values)) < len(values):
            raise ScenarioError(f"--set {option!r} repeats a value: allowed each value once")
        sets[key] = values
    return sets


def combinations(sets: dict[str, list[str]]) -> list[dict[str, str]]:
    """The cartesian product of the --set values, the first key varying slowest."""
    return [dict(zip(sets, values, strict=True)) for values in itertools.product(*sets.values())]


@functools.lru_cache(maxsize=32)
def _scenario(name: str, changes: tuple):
    """The scenario ``name`` with ``changes`` ((key, value text) pairs) set; cached per process."""
    scenario = load_scenario(name)
    for key, text in changes:
        try:
            scenario = with_keys(scenario, {key: parse_value(text)})
        except ScenarioError as e:
            raise ScenarioError(f"--set {key}={text}: {e}") from None
    return scenario


def check_sweep(name: str, sets: dict, seeds: int, duration=None) -> None:
    """Every combination's scenario loads and validates, seeds in 1 .. MAX_SEEDS, the duration fits: before
    any run."""
    check_seed_count(seeds)
    if "seed" in sets:
        raise ScenarioError("--set seed=...: the sweep runs seeds 0..N-1 of --seeds N; allowed any other key")
    for combination in combinations(sets):
        scenario = _scenario(name, tuple(combination.items()))
        if duration is not None:
            check_duration(scenario, duration)


def final_errors(a: dict) -> dict:
    """The final position error (% of path length), its RMS and maximum along the run (``_rms_pct``,
    ``_max_pct``; metrics.position_errors) and the final heading error (deg) of the fused estimate,
    odometry-only and Gyrodometry, and the side-slip RMS error (deg, where |alpha| > 1 deg) of a run's
    arrays."""
    length = float(a["path_length"])
    out = {}
    for label, prefix in ESTIMATES:
        out[f"{label}_pct"] = 100.0 * final_position_error(a, prefix) / length
        along = position_errors_in_percent(a, prefix)
        out[f"{label}_rms_pct"], out[f"{label}_max_pct"] = along["rms"], along["max"]
        heading = float(a[f"{prefix}_phi"][-1] - a["true_phi"][-1])
        out[f"{label}_heading_deg"] = math.degrees(math.remainder(heading, 2.0 * math.pi))
    out["alpha_rms_deg"] = math.degrees(side_slip_rms_error(a))
    return out


SET_PREFIX = "set:"
"""Job columns of the --set keys: ``set:navigation.mixing.b1``."""


def run_sweep_job(job: dict) -> dict:
    """One run of ``slipnav sweep``: the job's scenario with its ``set:`` keys, at its seed."""
    changes = tuple((k[len(SET_PREFIX) :], v) for k, v in job.items() if k.startswith(SET_PREFIX))
    scenario = _scenario(job["scenario"], changes)
    result = run_scenario(scenario, seed=job["seed"], duration=job["duration"], open_loop=job["open_loop"])
    return {**final_errors(result.arrays), "completed": bool(result.summary["completed"])}


def sweep_jobs(name: str, sets: dict, seeds: int, duration=None, open_loop=None) -> list[dict]:
    """Every combination of the --set values times seeds 0..seeds-1."""
    return [
        {
            "scenario": name,
            **{SET_PREFIX + key: value for key, value in combination.items()},
            "seed": seed,
            "duration": duration,
            "open_loop": open_loop,
        }
        for combination in combinations(sets)
        for seed in range(seeds)
    ]


def _groups(jobs: list, rows: list) -> dict:
    """{combination label: rows} in job order; the label is ``key=value key=value`` or ``as is``."""
    groups = {}
    for job, row in zip(jobs, rows, strict=True):
        label = " ".join(f"{k[len(SET_PREFIX) :]}={v}" for k, v in job.items() if k.startswith(SET_PREFIX))
        groups.setdefault(label or "as is", []).append(row)
    return groups


def summary_table(name: str, jobs: list, rows: list) -> tuple[list[str], dict]:
    """The summary's lines (per combination: runs, mean (worst) fused, odometry-only and Gyrodometry
    final error in % of path, the fused error's RMS and maximum along the run, mean (worst), mean fused
    over the mean better baseline, runs not completed) and the figures of the last line."""
    groups = _groups(jobs, rows)
    width = max(26, *(len(label) + 2 for label in groups))
    lines = [
        f"{name}: final position error, % of path length, mean (worst) over seeds; the fused one's RMS and "
        "maximum along the run",
        f"{'combination':<{width}}{'runs':>5}{'fused %':>16}{'odometry %':>16}{'Gyrodom. %':>16}"
        f"{'fused RMS %':>16}{'fused max %':>16}{'fused/best':>11}{'incomplete':>11}",
    ]
    for label, sel in groups.items():
        keys = ("fused_pct", "odometry_pct", "gyrodometry_pct", "fused_rms_pct", "fused_max_pct")
        col = {k: np.array([r.get(k, math.nan) for r in sel], float) for k in keys}
        best = np.minimum(col["odometry_pct"], col["gyrodometry_pct"])

        def mw(k, col=col):
            return f"{col[k].mean():.3f} ({col[k].max():.3f})"

        # a baseline that ended exactly on the truth (a run too short to move) gives no ratio
        ratio = f"{col['fused_pct'].mean() / best.mean():.3f}" if best.mean() > 0 else "-"
        lines.append(
            f"{label:<{width}}{len(sel):>5}{mw('fused_pct'):>16}{mw('odometry_pct'):>16}"
            f"{mw('gyrodometry_pct'):>16}{mw('fused_rms_pct'):>16}{mw('fused_max_pct'):>16}{ratio:>11}"
            f"{sum(not r['completed'] for r in sel):>11}"
        )
    fused = np.array([r["fused_pct"] for r in rows], float)
    return lines, {"mean_fused_pct": float(fused.mean()), "worst_fused_pct": float(fused.max())}


def plot_distributions(name: str, jobs: list, rows: list, path) -> FilePath:
    """Per combination, the distribution over seeds of the final error (% of path) of fused,
    odometry-only and Gyrodometry: boxes with every run as a dot. Written atomically."""
    import matplotlib
    import matplotlib.ticker

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    path = FilePath(path)
    groups = _groups(jobs, rows)
    estimators = (
        ("fused", "fused_pct"),
        ("odometry-only", "odometry_pct"),
        ("Gyrodometry", "gyrodometry_pct"),
    )
    fig, ax = plt.subplots(figsize=(max(6.0, 1.6 * len(groups) + 2.0), 4.5))
    x = np.arange(len(groups))
    for j, (label, key) in enumerate(estimators):
        data = [[r[key] for r in sel] for sel in groups.values()]
        positions = x + (j - 1) * 0.27
        color = f"C{j}"
        ax.boxplot(
            data,
            positions=positions,
            widths=0.22,
            showfliers=False,
            patch_artist=True,
            boxprops={"facecolor": color, "alpha": 0.35},
            medianprops={"color": color},
        )
        for p, values in zip(positions, data, strict=True):
            jitter = np.linspace(-0.06, 0.06, len(values)) if len(values) > 1 else [0.0]
            ax.plot(
                p + np.asarray(jitter),
                values,
                ".",
                color=color,
                ms=4,
                label=label if p == positions[0] else None,
            )
    ax.set_yscale("log")
    ax.set_xticks(x, [label.replace(" ", "\n") for label in groups], fontsize=8)
    ax.yaxis.set_major_formatter(matplotlib.ticker.ScalarFormatter())
    ax.yaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
    ax.set_ylabel("final position error (% of path)")
    ax.set_title(f"{name}: {len(rows)} runs, final position error per combination (box: quartiles)")
    ax.axhline(1.0, color="k", lw=0.8, ls="--")
    ax.legend(fontsize=8)
    fig.tight_layout()
    return save_figure_atomically(fig, path)


def sweep(
    name: str,
    seeds: int,
    sets: dict | None = None,
    *,
    duration=None,
    open_loop=None,
    workers: int | None = None,
    scheduler: str | None = None,
    out_dir="runs",
    resume: bool = False,
    stream=None,
) -> list:
    """``slipnav sweep``: run, print the summary and the last line, write the CSV and the figure;
    returns the rows in job order (combinations of ``sets`` {key: [value text]} x seeds)."""
    stream = stream or sys.stdout
    sets = sets or {}
    check_engine_options(workers, scheduler)
    check_sweep(name, sets, seeds, duration)
    jobs = sweep_jobs(name, sets, seeds, duration, open_loop)
    stem = f"sweep-{load_scenario(name).name}"
    results = FilePath(out_dir) / f"{stem}.csv"
    start = time.perf_counter()
    file = ResultsFile(results, resume)
    try:
        file.check_jobs(jobs)
        with Engine(workers, scheduler) as engine:
            resumed = sum(file.finished(job_key(job), run_version(job)) for job in jobs)
            rows = engine.map(run_sweep_job, jobs, file, label=f"sweep {name}")
            wall = time.perf_counter() - start
            used = engine.workers
            cluster_s = engine.start_s
    finally:
        file.close()
    lines, figures = summary_table(name, jobs, rows)
    ran = len(jobs) - resumed
    local = scheduler is None and used == 0
    where = "in this process" if local else f"on {used} workers, cluster start {cluster_s:.1f} s"
    lines += [
        f"{ran} runs in {wall:.1f} s {where} ({ran / wall:.2f} runs/s)"
        + (f"; {resumed} finished runs resumed from the results file" if resumed else ""),
        f"results: {results}",
        f"figure: {plot_distributions(name, jobs, rows, FilePath(out_dir) / f'{stem}.png')}",
        f"sweep runs={ran} workers={used} wall_s={wall:.3f} runs_per_s={ran / wall:.3f} "
        f"mean_fused_pct={figures['mean_fused_pct']:.4f} worst_fused_pct={figures['worst_fused_pct']:.4f}",
    ]
    print("\n".join(lines), file=stream)
    return rows
