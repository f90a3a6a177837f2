"""The random sensor-fault benchmark's report (studies/random_faults.py): the per-run and per-class
tables with the targets' verdicts, the figure and the JSON file."""

import json
import math
from pathlib import Path as FilePath

import numpy as np
from slipnav.scenarios.files import write_text_atomically
from slipnav.scenarios.plots import save_figure_atomically
from slipnav.systems.robot.faults import MAX_FAULT_TIME

TARGETS = {
    "detection_s": 0.2,  # every significant fault flagged within 0.2 s of its significant onset
    "isolation": 0.95,  # share of flagged runs whose first flagged channel is the faulted one alone
    "false_alarms_per_h": 1.0,  # flag onsets per hour of fault-free driving
    "better_baseline": 0.95,  # share of runs with fused final error <= the better baseline's
    "class_ratio": 3.0,  # per class, the mean fused final error / the reference run's
}
"""The issue's targets (printed PASS/FAIL; no exit status)."""


def _ms(seconds) -> str:
    return f"{1000 * seconds:.0f}" if seconds is not None and math.isfinite(seconds) else "-"


def print_rows(rows: list, stream) -> None:
    """One line per faulted run: the fault, its significance and latency, the channels flagged first and
    how long others were, the errors (final of each estimate; the fused RMS and maximum along the run)."""
    print(
        f"{'scenario':8} {'seed':>4} {'class':10} {'channel':9} {'start':>6} {'dur':>6} {'value':>9} "
        f"{'sig':>3} {'lat ms':>6} {'first flagged':17} {'others s':>8} {'fused m':>8} {'odo m':>7} "
        f"{'gyrodo m':>8} {'ratio':>6} {'rms':>5} {'RMS m':>7} {'max m':>7}",
        file=stream,
    )
    for r in rows:
        duration = "end" if r["duration"] >= MAX_FAULT_TIME else f"{r['duration']:.2f}"
        print(
            f"{r['scenario']:8} {r['seed']:>4} {r['fault_class']:10} {r['channel']:9} {r['start']:6.3f} "
            f"{duration:>6} {r['value']:9.3g} {'yes' if r['significant'] else 'no':>3} "
            f"{_ms(r['latency_s']):>6} {r['first_flagged']:17} {r['other_flag_s']:8.3f} "
            f"{r['fused_error_m']:8.4f} {r['odometry_error_m']:7.4f} {r['gyrodometry_error_m']:8.4f} "
            f"{r['error_ratio']:6.2f} {r['rms_ratio']:5.2f} {r.get('rms_m', math.nan):7.4f} "
            f"{r.get('max_m', math.nan):7.4f}",
            file=stream,
        )


def print_summary(summary: dict, wall: float, stream) -> None:
    """The per-class table, the targets and the last line."""
    print(
        f"{'class':10} {'runs':>4} {'sig':>3} {'in 0.2 s':>8} {'detected':>8} {'median ms':>9} "
        f"{'max ms':>6} {'isolated':>8} {'blamed':>6} {'<= base':>7} {'ratio':>6} {'max':>6} {'rms':>5}",
        file=stream,
    )
    for name, g in [*summary["classes"].items(), ("all", summary["overall"])]:
        print(
            f"{name:10} {g['runs']:>4} {g['significant']:>3} {g['significant_in_time']:>8} "
            f"{g['detected']:>8} {_ms(g['median_latency_s']):>9} {_ms(g['max_latency_s']):>6} "
            f"{g['isolated']:>3}/{g['flagged']:<4} {g['other_blamed']:>6} {g['fused_le_best_baseline']:>7} "
            f"{g['mean_error_ratio']:6.2f} {g['max_error_ratio']:6.2f} {g['mean_rms_ratio']:5.2f}",
            file=stream,
        )
    print("current-sense faults: not drawn (systems/robot/faults.py has no current channel)", file=stream)
    for t in summary["targets"]:
        verdict = {True: "PASS", False: "FAIL", None: "n/a"}[t["pass"]]
        print(f"target {t['target']}: {t['measured']} {verdict}", file=stream)
    o = summary["overall"]
    print(
        f"random faults runs={o['runs']} significant={o['significant']} detected_in_0.2s="
        f"{o['significant_in_time']}/{o['significant']} isolation={o['isolated']}/{o['flagged']} "
        f"false_alarms_per_h={o['false_alarms_per_h']:.2f} better_baseline={o['fused_le_best_baseline']}/"
        f"{o['runs']} wall_s={wall:.0f}",
        file=stream,
    )


def plot_summary(rows: list, summary: dict, path) -> FilePath:
    """Three panels over the classes: the shares detected (all runs) and flagged within 0.2 s (significant
    runs); every significant run's latency (0.2 s dashed, a miss as a cross at the top); every run's fused
    error over its fault-free run's (filled: final, hollow: RMS along the run; a bar: the class mean of
    the final; 3 x dashed); the scenarios side by side in each class's column."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names, groups = list(summary["classes"]), list(summary["classes"].values())
    x, column = np.arange(len(names)), {c: i for i, c in enumerate(names)}
    scenarios = list(dict.fromkeys(r["scenario"] for r in rows))

    def place(r) -> float:  # the class's column, the scenarios side by side
        return column[r["fault_class"]] + 0.15 * (scenarios.index(r["scenario"]) - (len(scenarios) - 1) / 2)

    fig, (rate, lat, err) = plt.subplots(3, 1, figsize=(max(7.0, 0.6 * len(names) + 2), 9), sharex=True)
    detected = [g["detected"] / g["runs"] for g in groups]
    in_time = [g["significant_in_time"] / g["significant"] if g["significant"] else np.nan for g in groups]
    rate.bar(x - 0.2, detected, 0.4, label="detected (all runs)")
    rate.bar(x + 0.2, in_time, 0.4, label="significant: flagged within 0.2 s")
    rate.set_ylabel("share of runs")
    rate.legend(fontsize=7)
    significant = [r for r in rows if r["significant"]]
    ms = np.array([1000 * r["latency_s"] for r in significant], float)
    xs = np.array([place(r) for r in significant], float)
    hit, target = np.isfinite(ms), 1000 * TARGETS["detection_s"]
    lat.scatter(xs[hit], ms[hit], s=14)
    lat.scatter(
        xs[~hit], np.full(np.sum(~hit), 1.2 * max(ms[hit].max(initial=0.0), target)), marker="x", c="C3"
    )
    lat.axhline(target, color="k", lw=0.8, ls="--")
    lat.set_ylabel("latency ms (x: missed)")
    xr = [place(r) for r in rows]
    err.scatter(xr, [r["error_ratio"] for r in rows], s=14, label="final error")
    err.scatter(xr, [r["rms_ratio"] for r in rows], s=18, facecolors="none", edgecolors="C1", label="RMS")
    err.scatter(x, [g["mean_error_ratio"] for g in groups], marker="_", s=300, c="k", label="class mean")
    err.axhline(TARGETS["class_ratio"], color="k", lw=0.8, ls="--")
    err.set_yscale("log")
    err.set_ylabel("fused error / fault-free run's")
    err.legend(fontsize=7)
    err.set_xticks(x, names, rotation=45, fontsize=8)
    rate.set_title("random sensor faults (slipnav faults --random)")
    fig.tight_layout()
    return save_figure_atomically(fig, path)


def _plain_json(value):
    """NaN and inf as null (strict JSON); containers recursively."""
    if isinstance(value, dict):
        return {str(k): _plain_json(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain_json(v) for v in value]
    return None if isinstance(value, float) and not math.isfinite(value) else value


def write_outputs(out_dir, data: dict, stream) -> None:
    """DIR/random-faults.png (plot_summary) and DIR/random-faults.json (``data``: rows, references,
    summary, distributions, wall time; NaN and inf as null)."""
    out = FilePath(out_dir)
    print(f"figure: {plot_summary(data['rows'], data['summary'], out / 'random-faults.png')}", file=stream)
    text = json.dumps(_plain_json(data), indent=1, allow_nan=False)
    print(f"rows: {write_text_atomically(out / 'random-faults.json', [text])}", file=stream)
