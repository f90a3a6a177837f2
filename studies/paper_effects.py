"""What each deviation from the printed equations does: ``python -m slipnav.studies.paper_effects
[SCENARIO ...] [--seeds N] [--workers N]``.

For each scenario (default corner, square), closed and open loop, and seeds 0..N-1, runs the default,
paper mode (scenarios/paper.py) and the default with one deviation at a time set to the print
(scenarios.paper.DEVIATIONS), and prints, per variant, the mean (worst) fused final position error in %
of the path and the mean side-slip RMS error where |alpha| > 1 deg (scenarios.metrics; NaN where no seed
has enough samples), as the rows of README's Paper mode table. The control deviations act in the closed
loop only. A benchmark, not a test.
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
    """Figures of one run (job: scenario, variant, seed, open_loop)."""
    scenario = scenario_of(job["scenario"], job["variant"])
    a = run_scenario(scenario, seed=job["seed"], open_loop=job["open_loop"]).arrays
    f = navigation_figures(a)
    enough = f["alpha_updates"] >= MIN_SIDE_SLIP_UPDATES
    return {"pct": f["fused_error_pct"], "alpha_deg": f["alpha_rms_deg"] if enough else math.nan}


def paper_effects(names, seeds: int, workers=None, stream=None) -> dict:
    """Run every variant and print its mean (worst) figures; returns {(scenario, open_loop, variant):
    (pct array, alpha array)}."""
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
    out = {}
    for job, row in zip(jobs, rows, strict=True):
        key = (job["scenario"], job["open_loop"], job["variant"])
        pct, alpha = out.setdefault(key, ([], []))
        pct.append(row["pct"])
        alpha.append(row["alpha_deg"])
    print(f"{len(jobs)} runs in {time.perf_counter() - start:.0f} s, {seeds} seeds", file=stream)
    for (name, open_loop, variant), (pct, alpha) in out.items():
        pct, alpha = np.array(pct), np.array(alpha)
        side = f"{np.nanmean(alpha):.2f} deg" if np.isfinite(alpha).any() else "-"
        loop = "open" if open_loop else "closed"
        print(
            f"{name:<8} {loop:<6} {variant:<22} {pct.mean():5.2f} % ({pct.max():4.2f})  alpha {side}",
            file=stream,
        )
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
