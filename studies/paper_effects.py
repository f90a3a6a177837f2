"""What each deviation from the printed equations does: ``python -m slipnav.studies.paper_effects
[SCENARIO ...] [--seeds N] [--workers N]``.

For each scenario (default corner, square), closed and open loop, and seeds 0..N-1, runs the default,
paper mode (scenarios/paper.py) and the default with one deviation at a time set to the print
(scenarios.paper.DEVIATIONS), and prints, per variant, the mean (worst) of the fused position error's
final value, RMS and maximum along the run in % of the path (scenarios.metrics.navigation_figures) and
the mean side-slip RMS error where |alpha| > 1 deg (NaN where no seed has enough samples), the figures of
the Paper mode table in docs/results.md. The final error alone flatters a closed path (the square ends
near its start); the RMS and the maximum count the errors made along the way. The control deviations act
in the closed loop only. A benchmark, not a test.
"""

import argparse
import math
import sys
import time

import numpy as np
from slipnav.scenarios.config import load_scenario
from slipnav.scenarios.metrics import MIN_SIDE_SLIP_UPDATES, navigation_figures
from slipnav.scenarios.paper import DEVIATIONS, one_deviation, paper_mode
from slipnav.scenarios.runner import run_scenario
from slipnav.studies.engine import run_jobs

CONTROL_DEVIATIONS = ("step_size_delay", "s22_inputs", "speed_law_delay")
"""Deviations of the controller: no effect open loop."""

FIGURES = {
    "final_pct": "fused_error_pct",
    "rms_pct": "fused_rms_error_pct",
    "max_pct": "fused_max_error_pct",
    "alpha_deg": "alpha_rms_deg",
}
"""A run's figures: the fused position error's final value, RMS and maximum (% of path length) and the
side-slip RMS error (deg), by the navigation_figures key each one is."""


def variants(open_loop: bool) -> list[str]:
    """``default``, ``paper`` and one ``only <name>`` per deviation (the control ones closed loop only)."""
    names = [d.name for d in DEVIATIONS if not (open_loop and d.name in CONTROL_DEVIATIONS)]
    return ["default", "paper"] + [f"only {name}" for name in names]


def scenario_of(name: str, variant: str):
    """The scenario ``name`` as ``variant`` runs it."""
    scenario = load_scenario(name)
    if variant == "paper":
        return paper_mode(scenario)
    if variant.startswith("only "):
        return one_deviation(scenario, variant.removeprefix("only "))
    return scenario


def run_one(job: dict) -> dict:
    """FIGURES of one run (job: scenario, variant, seed, open_loop); ``alpha_deg`` NaN on fewer than
    MIN_SIDE_SLIP_UPDATES side-slip updates."""
    scenario = scenario_of(job["scenario"], job["variant"])
    a = run_scenario(scenario, seed=job["seed"], open_loop=job["open_loop"]).arrays
    f = navigation_figures(a)
    row = {figure: f[key] for figure, key in FIGURES.items()}
    if f["alpha_updates"] < MIN_SIDE_SLIP_UPDATES:
        row["alpha_deg"] = math.nan
    return row


def paper_effects(names, seeds: int, workers=None, stream=None) -> dict:
    """Run every variant and print its mean (worst) figures; returns {(scenario, open_loop, variant):
    {figure: array over the seeds}} for each of FIGURES."""
    stream = stream or sys.stdout
    jobs = [
        {"scenario": name, "variant": variant, "seed": seed, "open_loop": open_loop}
        for open_loop in (False, True)
        for name in names
        for variant in variants(open_loop)
        for seed in range(seeds)
    ]
    start = time.perf_counter()
    rows = run_jobs(run_one, jobs, workers=workers, label="paper-effects")
    lists = {}
    for job, row in zip(jobs, rows, strict=True):
        key = (job["scenario"], job["open_loop"], job["variant"])
        for figure, values in lists.setdefault(key, {f: [] for f in FIGURES}).items():
            values.append(row[figure])
    out = {key: {f: np.array(values) for f, values in figures.items()} for key, figures in lists.items()}
    print(f"{len(jobs)} runs in {time.perf_counter() - start:.0f} s, {seeds} seeds", file=stream)
    print(f"{'':45}fused position error, % of path: mean (worst)", file=stream)
    for (name, open_loop, variant), figures in out.items():
        alpha = figures["alpha_deg"]
        side = f"{np.nanmean(alpha):.2f} deg" if np.isfinite(alpha).any() else "-"
        loop = "open" if open_loop else "closed"
        position = "  ".join(
            f"{title} {figures[f].mean():5.2f} ({figures[f].max():4.2f})"
            for title, f in (("final", "final_pct"), ("RMS", "rms_pct"), ("max", "max_pct"))
        )
        print(f"{name:<8} {loop:<6} {variant:<28} {position}  alpha {side}", file=stream)
    return out


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m slipnav.studies.paper_effects", description=__doc__)
    parser.add_argument("scenarios", nargs="*", default=["corner", "square"])
    parser.add_argument("--seeds", type=int, default=10)
    parser.add_argument("--workers", type=int, default=None)
    args = parser.parse_args(argv)
    paper_effects(args.scenarios, args.seeds, args.workers)
    return 0


if __name__ == "__main__":
    sys.exit(main())
