"""Navigation accuracy benchmark over seeds: ``slipnav accuracy [SCENARIO ...] [--seeds N]``.

Prints, per scenario, the mean and worst figures of scenarios.metrics.navigation_figures against the
navigation targets (fused error <= 1 % of path length and <= 0.3 x odometry-only, side-slip RMS <= 0.5 deg
where |alpha| > 1 deg, tangential slip detected, C1 < 0.75, within 2 T_C). Goals, not tests. The position
goals are stated on the final error; the RMS and the maximum of the position error along the run
(metrics.position_errors) are printed against them too, since a closed path's end cancels errors made on
the way.

The side-slip figure is judged only on seeds where |alpha| > 1 deg lasted at least
scenarios.metrics.MIN_SIDE_SLIP_UPDATES T_C updates, and always printed with the number of samples it
rests on; a scenario with no such seed (the square) gets "not enough samples" and no verdict.
"""

import math
import sys
import time

import numpy as np
from slipnav.scenarios.config import load_scenario
from slipnav.scenarios.metrics import (
    DETECTION_C1_LEVEL,
    ESTIMATES,
    MIN_SIDE_SLIP_UPDATES,
    navigation_figures,
)
from slipnav.scenarios.paper import paper_mode
from slipnav.scenarios.runner import run_scenario
from slipnav.studies.engine import session


def summarise(name: str, figures: list, wall: float, stream=None) -> None:
    """Print the mean and worst figures of one scenario against the goals (to ``stream``, default
    stdout)."""
    stream = stream or sys.stdout

    def col(key):
        return np.array([f[key] for f in figures], dtype=float)

    pct, ratio, alpha = col("fused_error_pct"), col("fused_over_odometry"), col("alpha_rms_deg")
    episodes, detected = col("slip_episodes").sum(), col("slip_detected").sum()
    latency = col("max_latency_T_C")
    lines = [
        f"{name}: {len(figures)} seeds in {wall:.1f} s",
        f"  fused final error      mean {pct.mean():.2f} %  worst {pct.max():.2f} % of path length"
        " (goal <= 1 %)",
        f"  fused / odometry-only  mean {ratio.mean():.2f}  worst {ratio.max():.2f} (goal <= 0.3)",
        f"  final errors (m)       fused {col('fused_error_m').mean():.4f}  odometry "
        f"{col('odometry_error_m').mean():.4f}  Gyrodometry {col('gyrodometry_error_m').mean():.4f}",
    ]
    lines += along_run_lines(col)
    lines += side_slip_lines(
        alpha, col("alpha_rms_at_updates_deg"), col("alpha_samples"), col("alpha_updates")
    )
    if episodes:
        lines.append(
            f"  tangential slip        {int(detected)}/{int(episodes)} episodes detected (C1 < "
            f"{DETECTION_C1_LEVEL}), worst latency {_worst(latency):.1f} T_C (goal <= 2 T_C)"
        )
        lines.append(
            f"{'':25}{int(col('slip_detected_c1_half').sum())}/{int(episodes)} with C1 < 0.5 (two "
            f"batches), worst latency {_worst(col('max_latency_c1_half_T_C')):.1f} T_C"
        )
    print("\n".join(lines), file=stream)


def along_run_lines(col) -> list[str]:
    """The position error's RMS and maximum along the run (``col(key)``: a figure over the seeds) against
    the goals stated on the final error (<= 1 % of the path, <= 0.3 x odometry-only), and each estimate's
    RMS and maximum in metres (means over the seeds)."""
    lines = []
    for figure, name in (("rms", "RMS"), ("max", "max")):
        pct, ratio = col(f"fused_{figure}_error_pct"), col(f"fused_over_odometry_{figure}")
        lines += [
            f"  fused {name + ' error':<17}mean {pct.mean():.2f} %  worst {pct.max():.2f} % of path length "
            "along the run (goal <= 1 %, stated on the final error)",
            f"{'':25}over odometry-only's: mean {ratio.mean():.2f}  worst {ratio.max():.2f} (goal <= 0.3, "
            "stated on the final error)",
        ]
    for figure, name in (("rms", "RMS"), ("max", "max")):
        fused, odometry, gyrodometry = (col(f"{label}_{figure}_error_m").mean() for label, _ in ESTIMATES)
        lines.append(
            f"  {name + ' errors (m)':<23}fused {fused:.4f}  odometry {odometry:.4f}  Gyrodometry "
            f"{gyrodometry:.4f}"
        )
    return lines


def side_slip_lines(alpha, at_updates, samples, updates) -> list[str]:
    """The side-slip RMS lines: mean and worst over the seeds whose |alpha| > 1 deg lasted at least
    MIN_SIDE_SLIP_UPDATES T_C updates, with the samples they rest on; "not enough samples" and no verdict
    when no seed has that many (the square, peaking at ~1 deg)."""
    if not np.isfinite(alpha).any():
        return ["  side-slip RMS error    no sample with |alpha| > 1 deg on any seed: nothing to judge"]
    rests = (
        f"rests on {_span(samples)} T_N samples ({_span(updates)} T_C updates) with |alpha| > 1 deg per seed"
    )
    enough = updates >= MIN_SIDE_SLIP_UPDATES
    if not enough.any():
        return [
            f"  side-slip RMS error    not enough samples, no verdict on the goal (<= 0.5 deg): fewer than "
            f"{MIN_SIDE_SLIP_UPDATES} T_C updates with |alpha| > 1 deg on every seed",
            f"{'':25}{rests}; what there is: mean {np.nanmean(alpha):.2f} deg (at the T_C updates "
            f"{_nanmean(at_updates):.2f} deg)",
        ]
    seeds = f"{int(enough.sum())}/{len(enough)} seeds with >= {MIN_SIDE_SLIP_UPDATES} updates"
    alpha, at_updates = alpha[enough], at_updates[enough]
    return [
        f"  side-slip RMS error    mean {np.nanmean(alpha):.2f} deg  worst {np.nanmax(alpha):.2f} deg"
        " (goal <= 0.5 deg where |alpha| > 1 deg)",
        f"{'':25}at the T_C updates (no hold): mean {_nanmean(at_updates):.2f} deg  worst "
        f"{_worst(at_updates):.2f} deg",
        f"{'':25}{rests}; {seeds}",
    ]


def _span(values) -> str:
    lo, hi = int(np.min(values)), int(np.max(values))
    return f"{lo}" if lo == hi else f"{lo}-{hi}"


def _nanmean(values) -> float:
    return float(np.nanmean(values)) if np.isfinite(values).any() else math.nan


def _worst(values) -> float:
    return float(np.nanmax(values)) if np.isfinite(values).any() else math.nan


def run_seed(job: dict) -> dict:
    """The figures of one run (job: scenario, seed, duration, open_loop, and paper if true)."""
    scenario = load_scenario(job["scenario"])
    if job.get("paper"):
        scenario = paper_mode(scenario)
    return navigation_figures(
        run_scenario(scenario, seed=job["seed"], duration=job["duration"], open_loop=job["open_loop"]).arrays
    )


def accuracy(
    names,
    seeds: int,
    duration=None,
    stream=None,
    open_loop=None,
    *,
    paper=False,
    workers=None,
    scheduler=None,
    out_dir=None,
    resume=False,
) -> dict:
    """Run each scenario for seeds 0..seeds-1 on the sweep engine (studies/engine.py: ``workers``,
    ``scheduler``, results in ``out_dir``/accuracy.csv, ``resume``); print and return the per-scenario
    rows (the figures with their job). ``paper``: in paper mode (scenarios/paper.py)."""
    results = {}
    with session("accuracy", workers, scheduler, out_dir, resume) as (engine, file):
        for name in names:
            start = time.perf_counter()
            jobs = [
                {"scenario": name, "seed": seed, "duration": duration, "open_loop": open_loop}
                | ({"paper": True} if paper else {})
                for seed in range(seeds)
            ]
            results[name] = figures = engine.map(run_seed, jobs, file, label=name)
            label = f"{name} (paper mode)" if paper else name
            summarise(label, figures, time.perf_counter() - start, stream)
    return results
