"""The sections of ``slipnav results`` that simulate (studies/results_page.py writes the page): each
measure calls a study's own functions (studies/accuracy.py, paper_effects.py, error_budget.py,
robustness.py, random_faults.py, faults.py, bench.py, reproduce.py) and returns markdown
(studies/results_text.py). The registry of every section, SECTIONS, is at the end."""

from __future__ import annotations

import math
import os
import tempfile

import numpy as np
from slipnav.scenarios.metrics import DETECTION_C1_LEVEL, MIN_SIDE_SLIP_UPDATES
from slipnav.studies import results_logs, results_runs
from slipnav.studies.accuracy import accuracy
from slipnav.studies.bench import bench
from slipnav.studies.error_budget import VARIANTS, error_budget
from slipnav.studies.paper_effects import paper_effects, variants
from slipnav.studies.random_faults import random_faults
from slipnav.studies.reproduce import reproduce
from slipnav.studies.results_text import Section, mean_worst, number, paragraph, table
from slipnav.studies.robustness import CASES, robustness
from slipnav.systems.compiled import ENABLED as COMPILED

SCENARIOS = ("corner", "square")
"""Seyr's two scenarios on the simulated Tinyphoon: the navigation's benchmarks."""
LOOPS = ((False, "closed"), (True, "open"))


def _column(rows, key) -> np.ndarray:
    return np.array([r[key] for r in rows], float)


def _side_slip(rows) -> str:
    """Side-slip RMS where |alpha| > 1 deg over the seeds with at least MIN_SIDE_SLIP_UPDATES T_C updates of
    it, mean (worst); "—" where no seed has that many."""
    enough = _column(rows, "alpha_updates") >= MIN_SIDE_SLIP_UPDATES
    return mean_worst(_column(rows, "alpha_rms_deg")[enough], unit="°") if enough.any() else "—"


def _slips(rows) -> str:
    """Tangential slip episodes detected (C1 < 0.75) of all, and the worst latency in T_C."""
    episodes = int(_column(rows, "slip_episodes").sum())
    if not episodes:
        return "—"
    latency = _column(rows, "max_latency_T_C")
    worst = number(np.nanmax(latency) if np.isfinite(latency).any() else math.nan, 1)
    return f"{int(_column(rows, 'slip_detected').sum())}/{episodes}, {worst} T_C"


def accuracy_section(context) -> str:
    """Navigation accuracy: studies/accuracy.py over the seeds, closed and open loop, default and paper."""
    lines = []
    for paper in (False, True):
        for open_loop, loop in LOOPS:
            results = accuracy(
                SCENARIOS,
                context.seeds,
                open_loop=open_loop or None,
                paper=paper,
                workers=context.workers,
                stream=context.report,
            )
            for name, rows in results.items():
                fused, odometry, gyro = (
                    _column(rows, f"{k}_error_m") for k in ("fused", "odometry", "gyrodometry")
                )
                better = int(np.sum(fused <= np.minimum(odometry, gyro)))
                lines.append(
                    [
                        f"{name} {loop}, {'paper' if paper else 'default'}",
                        mean_worst(_column(rows, "fused_error_pct")),
                        mean_worst(_column(rows, "fused_over_odometry")),
                        " / ".join(f"{1000 * v.mean():.1f}" for v in (fused, odometry, gyro)),
                        mean_worst(_column(rows, "fused_rms_error_pct")),
                        f"{better}/{len(rows)}",
                        _side_slip(rows),
                        _slips(rows),
                    ]
                )
    header = (
        "run",
        "fused final, % of path",
        "fused / odometry",
        "final, mm: fused / odometry / Gyrodometry",
        "fused RMS, %",
        "fused ≤ baselines",
        "side-slip RMS",
        "slips detected",
    )
    intro = paragraph(
        "The fused estimate against odometry-only and Gyrodometry on Seyr's corner and square (the simulated "
        "Tinyphoon), closed loop and open loop (the trajectory's wheel speeds fed forward), in the default "
        "and in paper mode (the papers' equations as printed, [paper-mode.md](paper-mode.md)); mean (worst) "
        "over the seeds of the fused final error (% of the path), of its ratio to odometry-only's, of its "
        "RMS along the run (%) and of the side-slip RMS error where |α| > 1° (on the seeds with at least "
        f"{MIN_SIDE_SLIP_UPDATES} T_C updates of it, else —); the mean final errors in mm; the seeds on "
        "which the fused final error is at most both baselines'; the tangential slip episodes detected "
        f"(C1 < {DETECTION_C1_LEVEL}) of all and the worst latency. Goals: fused final error ≤ 1 % of the "
        "path and ≤ 0.3 × odometry-only's, side slip ≤ 0.5°, slips detected within 2 T_C."
    )
    return intro + "\n\n" + table(header, lines)


def paper_effects_section(context) -> str:
    """Each deviation from the print alone on top of the default (studies/paper_effects.py)."""
    out = paper_effects(SCENARIOS, context.seeds, context.workers, context.report)
    columns = [(name, open_loop, loop) for name in SCENARIOS for open_loop, loop in LOOPS]
    rows = []
    for variant in variants(False):
        cells = []
        for name, open_loop, _ in columns:
            figures = out.get((name, open_loop, variant))
            if figures is None:
                cells.append("—")
                continue
            alpha = figures["alpha_deg"]
            side = f", {np.nanmean(alpha):.2f}°" if np.isfinite(alpha).any() else ""
            cells.append(f"{figures['final_pct'].mean():.2f} / {figures['rms_pct'].mean():.2f}{side}")
        label = {"default": "none (the default)", "paper": "**all of them: paper mode**"}.get(
            variant, f"`{variant.removeprefix('only ')}`"
        )
        rows.append([label, *cells])
    intro = paragraph(
        "What each deviation from the printed equations does alone: the default with one switch set to the "
        "print (the switches and their keys: [paper-mode.md](paper-mode.md)), on the corner and the square, "
        "closed and open loop; mean over the seeds of the fused final error / its RMS along the run (% of "
        "the path) and the side-slip RMS where |α| > 1° (where the seeds have enough of it). The "
        "controller's switches act in the closed loop only (—)."
    )
    return (
        intro + "\n\n" + table(["switch set to the print", *(f"{n} {loop}" for n, _, loop in columns)], rows)
    )


def error_budget_section(context) -> str:
    """The error budget's oracle variants (studies/error_budget.py), closed and open loop."""
    budgets = {
        (name, loop): runs
        for open_loop, loop in LOOPS
        for name, runs in error_budget(
            SCENARIOS, context.seeds, open_loop or None, context.report, workers=context.workers
        ).items()
    }
    columns = [(name, loop) for name in SCENARIOS for _, loop in LOOPS]
    position, side = [], []
    for variant in VARIANTS:
        cells, alphas = [], []
        for key in columns:
            runs = budgets[key]
            final = [b[variant]["final_pct"] for b in runs]
            rms = np.array([b[variant]["rms_pct"] for b in runs], float)
            cells.append(
                f"{mean_worst(final)} / {number(np.nanmean(rms)) if np.isfinite(rms).any() else '—'}"
            )
            alphas.append(mean_worst([b[variant]["alpha_deg"] for b in runs], unit="°"))
        position.append([variant, *cells])
        side.append([variant, *alphas])
    header = [f"{name} {loop}" for name, loop in columns]
    intro = paragraph(
        "Where the fused estimate's error comes from: each run's sensor samples replayed through the plain "
        "navigation loop with one cause of error removed at a time by an oracle from the truth, or one "
        "extension set back to the paper's equation (the variants: studies/error_budget.py). Fused final "
        "error, mean (worst) over the seeds / its RMS along the run (mean), % of the path:"
    )
    second = paragraph("Side-slip RMS error where |α| > 1°, mean (worst) over the seeds:")
    return "\n\n".join(
        [intro, table(["variant", *header], position), second, table(["variant", *header], side)]
    )


def robustness_section(context) -> str:
    """Toleranced robots against the baselines (studies/robustness.py)."""
    names = ("corner", "square", "long_path")
    with tempfile.TemporaryDirectory() as out:
        rows = robustness(names, context.seeds, context.workers, out, stream=context.report)
    cases = []
    for case in CASES:
        cells = []
        for name in names:
            sel = [r for r in rows if r["scenario"] == name and r["case"] == case]
            fused, odo, gyro = (_column(sel, f"{k}_pct") for k in ("fused", "odometry", "gyrodometry"))
            above = int(np.sum((fused > odo) | (fused > gyro)))
            cells.append(f"{fused.mean():.2f} / {odo.mean():.2f} / {gyro.mean():.2f}, {above}/{len(sel)}")
        cases.append([case, *cells])
    totals = []
    for name in names:
        sel = [r for r in rows if r["scenario"] == name]
        fused, odo, gyro = (_column(sel, f"{k}_pct") for k in ("fused", "odometry", "gyrodometry"))
        rms = {k: _column(sel, f"{k}_run_rms_pct") for k in ("fused", "odometry", "gyrodometry")}
        above_rms = (rms["fused"] > rms["odometry"]) | (rms["fused"] > rms["gyrodometry"])
        totals.append(
            [
                name,
                str(len(sel)),
                str(int(np.sum((fused > odo) | (fused > gyro)))),
                str(int(np.sum(above_rms))),
                f"{fused.max():.2f} %",
                f"{_column(sel, 'fused_max_pct').max():.2f} %",
            ]
        )
    intro = paragraph(
        "The nominal navigation on robots that are not its data sheet: every single tolerance at its bound "
        "and draws of the tolerance preset (the plant changes, navigation and control keep the nominal "
        "model; [truth-and-belief.md](truth-and-belief.md)). Per case, the final error of fused / "
        "odometry-only / Gyrodometry in % of the path (mean over the seeds) and the seeds on which the fused "
        "one is above either baseline (fused / odometry / Gyrodometry, above):"
    )
    header = ["case", *names]
    summary_header = (
        "scenario",
        "runs",
        "fused final above a baseline",
        "fused run RMS above a baseline's",
        "worst fused final",
        "worst fused along the run",
    )
    return "\n\n".join([intro, table(header, cases), table(summary_header, totals)])


def random_faults_section(context) -> str:
    """One random sensor fault per seed and scenario (studies/random_faults.py)."""
    result = random_faults(SCENARIOS, context.seeds, context.report, workers=context.workers)
    summary = result["summary"]

    def ms(seconds):
        return number(1000 * seconds if seconds is not None else math.nan, 0)

    rows = [
        [
            name,
            str(g["runs"]),
            f"{g['significant_in_time']}/{g['significant']}",
            f"{g['detected']}/{g['runs']}",
            f"{ms(g['median_latency_s'])} / {ms(g['max_latency_s'])}",
            f"{g['isolated']}/{g['flagged']}",
            str(g["other_blamed"]),
            f"{g['fused_le_best_baseline']}/{g['runs']}",
            number(g["mean_error_ratio"]),
        ]
        for name, g in [*summary["classes"].items(), ("**all**", summary["overall"])]
    ]
    header = (
        "class",
        "runs",
        "significant, flagged within 0.2 s",
        "detected",
        "latency median / max, ms",
        "isolated / flagged",
        "another channel blamed",
        "fused ≤ better baseline",
        "mean error / fault-free",
    )
    verdicts = {True: "met", False: "not met", None: "nothing to judge"}
    targets = [[t["target"], t["measured"], verdicts[t["pass"]]] for t in summary["targets"]]
    intro = paragraph(
        "One sensor fault per seed, drawn at random (class, channel, onset, duration, magnitude: "
        "studies/random_faults.py), on the corner and the square beside each seed's fault-free run; "
        "detection from the fault's significant onset, isolation of the first flag, the fused final error "
        "against the better baseline's and against the fault-free run's. The false alarms are the fault-free "
        "runs' flags."
    )
    return "\n\n".join([intro, table(header, rows), table(("target", "measured", "verdict"), targets)])


def speed_section(context) -> str:
    """slipnav bench corner: the diagram against the plain loop (studies/bench.py)."""
    load = os.getloadavg()[0]
    f = bench("corner", 3, context.report)
    steps = f["samples"]
    parts = {part: 1e6 * seconds / steps for part, seconds in f["parts_s"].items()}
    rows = [
        ["Drake diagram", f"{1e6 * f['diagram_s'] / steps:.0f}", f"{f['realtime_factor']:.2f}"],
        ["plain loop", f"{1e6 * f['loop_s'] / steps:.0f}", f"{f['loop_realtime_factor']:.2f}"],
        *([f"… {part}", f"{us:.0f}", ""] for part, us in parts.items()),
    ]
    ratio = parts.get("navigation", math.nan) / parts.get("plant", math.nan)
    intro = paragraph(
        f"The corner's closed loop as the Drake diagram and as the plain loop over the same functions, best "
        f"of 3 (`slipnav bench corner`), compiled arithmetic {'on (numba)' if COMPILED else 'off'}, load "
        f"average {load:.1f} at the start. Navigation / plant per T_N in the plain loop: {ratio:.1f} (target "
        f"≤ 2); the diagram makes {f['python_callbacks_per_sample']:.1f} Python callbacks per T_N; its "
        f"framework overhead is {f['overhead_in_floors']:.1f} floors of "
        f"{1e6 * f['python_block_floor_s']:.1f} µs (one trivial Python block's update; target ≤ 40)."
    )
    return intro + "\n\n" + table(("loop", "µs per T_N sample", "real-time factor"), rows)


def claims_section(context) -> str:
    """The papers' claims as slipnav reproduce measures them (studies/reproduce.py)."""
    with tempfile.TemporaryDirectory() as out:
        result = reproduce(out, stream=context.report)
    items = []
    for row in result["claims"]:
        measured = "; ".join(f"{mode} mode: {text}" for mode, text in row["measured"].items())
        items.append(
            "- " + paragraph(f"**{row['claim']}.** {measured} (`{row['command']}`).").replace("\n", "\n  ")
        )
    intro = paragraph(
        "The papers' quantitative claims measured on the runs that `slipnav reproduce` recreates the papers' "
        "figures from (seed 0), in the default and in paper mode:"
    )
    return intro + "\n\n" + "\n".join(items)


SECTIONS = (
    Section(
        "accuracy",
        "Navigation accuracy",
        "navigation.md",
        accuracy_section,
        seeds=10,
        study=("slipnav accuracy corner square --seeds {seeds} [--open-loop] [--paper]",),
    ),
    Section(
        "paper-effects",
        "Paper mode, switch by switch",
        "paper-mode.md",
        paper_effects_section,
        seeds=2,
    ),
    Section(
        "claims",
        "The papers' claims",
        "paper-mode.md",
        claims_section,
        study=("slipnav reproduce",),
        fixed="seed 0",
    ),
    results_runs.CONTROL,
    Section(
        "error-budget",
        "Error budget",
        "navigation.md",
        error_budget_section,
        seeds=3,
        study=("slipnav error-budget corner square --seeds {seeds} [--open-loop]",),
    ),
    results_runs.REST,
    results_runs.LONG_RUN,
    Section(
        "robustness",
        "Truth and belief: toleranced robots against the baselines",
        "truth-and-belief.md",
        robustness_section,
        seeds=3,
        study=("slipnav robustness corner square long_path --seeds {seeds}",),
    ),
    Section(
        "random-faults",
        "Random sensor faults",
        "sensor-faults.md",
        random_faults_section,
        seeds=26,
        study=("slipnav faults corner square --random {seeds}",),
    ),
    results_runs.PERTURBATIONS,
    results_runs.CALIBRATION,
    Section(
        "speed",
        "Speed",
        "speed.md",
        speed_section,
        study=("slipnav bench corner --repeat 3",),
        fixed="seed 0",
    ),
    *results_logs.SECTIONS,
)
"""Every section of the page, in the page's order."""
