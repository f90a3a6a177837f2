"""Indiveri, Nüchter & Lingemann's Figs. 2 and 5-9 recreated from ``slipnav reproduce``'s runs
(studies/reproduce.py)."""

from __future__ import annotations

import math

import numpy as np
from slipnav.scenarios.plots import agg_pyplot
from slipnav.studies.reproduce_measures import (
    AT_V_M,
    HOLD,
    PUSH,
    Reproduced,
    Run,
    following_mask,
    following_time,
    saturation_fractions,
    speed_switches,
    time_axis,
)

FIG2_POINTS = {"A": (1.0, 0.0), "B": (0.0, 1.0), "C": (1.0, 1.0), "D": (0.0, 0.0)}
"""Indiveri Fig. 2's points as (v_l, v_r) over V_m: D u = 0, C u = V_m, BA the line u = V_m / 2."""


def indiveri_fig2(V_m: float, b: float, runs=(), mode: str = "default") -> Reproduced:
    """Indiveri Fig. 2: curvature I(5) and linear speed I(3) over the wheel speeds v_l, v_r in [0, V_m]
    (b: half the track, Indiveri's b), the line BA (u = V_m/2) and the I(24) speed's edge max(v_l, v_r) =
    V_m, and the paper's points: D (u = 0), C (u = V_m) and the ends A, B of the line BA (the paper
    does not say which end is which: here A at v_l = V_m, B at v_r = V_m); ``runs``: (label, Run) whose
    wheel commands are drawn on top."""
    v = np.linspace(0.0, V_m, 201)
    vl, vr = np.meshgrid(v, v)
    with np.errstate(invalid="ignore", divide="ignore"):
        kappa = (vr - vl) / (b * (vr + vl))
    u = 0.5 * (vr + vl)
    fig, axes = agg_pyplot().subplots(1, 2, figsize=(12, 5.2))
    c0 = axes[0].contourf(vl, vr, np.clip(kappa, -1 / b, 1 / b), levels=21, cmap="coolwarm")
    fig.colorbar(c0, ax=axes[0], label="curvature $\\kappa$ I(5) (1/m)")
    c1 = axes[1].contourf(vl, vr, u, levels=21, cmap="viridis")
    fig.colorbar(c1, ax=axes[1], label="linear speed u I(3) (m/s)")
    for ax in axes:
        ax.plot([0, V_m], [V_m, 0], "w--", lw=1.2, label="BA: u = $V_m$/2")
        for name, (x, y) in FIG2_POINTS.items():
            ax.annotate(name, (x * V_m, y * V_m), textcoords="offset points", xytext=(4, 4), fontsize=11)
        for (label, run), color in zip(runs, ("k", "m"), strict=False):
            a, following = run.arrays, following_mask(run)
            ax.plot(a["cmd_L"][following], a["cmd_R"][following], ".", color=color, ms=1.5, label=label)
        ax.set_xlabel("$v_l$ (m/s)")
        ax.set_ylabel("$v_r$ (m/s)")
        ax.set_xlim(0, V_m * 1.02)
        ax.set_ylim(0, V_m * 1.02)
        ax.set_aspect("equal")
        ax.legend(fontsize=7, loc="lower left")
    axes[0].set_title("curvature, bounded to [-1/b, 1/b] for $v_l, v_r \\geq 0$")
    axes[1].set_title("u; I(24) drives on the edge max($v_l, v_r$) = $V_m$")
    fig.suptitle(
        f"Indiveri Fig. 2 ({mode}): curvature and speed against the wheel speeds, $V_m$ = {V_m:g} m/s"
    )
    fig.tight_layout()
    numbers, measured = {}, []
    for label, run in runs:
        a, following = run.arrays, following_mask(run)
        peak = float(np.nanmax(np.maximum(a["cmd_R"], a["cmd_L"])[following]))
        one, _ = saturation_fractions(run)
        numbers[label] = {"peak_command": peak, "on_edge": one}
        measured.append(
            f"{label}: largest command {peak:.2f} m/s ({peak / V_m:.3f} V_m), a wheel at >= {AT_V_M:g} V_m "
            f"{100 * one:.0f} % of the time"
        )
    return Reproduced(
        "indiveri-fig2",
        "Indiveri Fig. 2",
        fig,
        "Differential drive curvature and total linear velocity as functions of the wheels speeds.",
        "The full curvature range [-1/b, 1/b] needs u <= V_m/2 (line BA); I(24) u = V_m/(1 + b|kappa_r|) "
        "reaches V_m on one wheel.",
        "; ".join(measured) or f"V_m = {V_m:g} m/s, b = {b:g} m (no run drawn).",
        "; ".join(run.command for _, run in runs) or "slipnav reproduce",
        numbers,
    )


def indiveri_fig5(run: Run, mode: str = "default") -> Reproduced:
    """Indiveri Fig. 5: the circle followed with both wheels in the air (no load), localised by odometry;
    (1) the right wheel stopped by hand, (2) the left one turned faster; top the path the encoders say was
    driven, bottom the wheel speeds (commands and wheels)."""
    a = run.arrays
    t = a["t"]
    fig, (ax, ax2) = agg_pyplot().subplots(2, 1, figsize=(9, 10), gridspec_kw={"height_ratios": [1.2, 1]})
    ax.plot(run.path.x, run.path.y, "k--", lw=1, label="path")
    ax.plot(a["odo_x"], a["odo_y"], "C2", lw=1.2, label="followed path (wheel encoders)")
    ax.plot(a["true_x"], a["true_y"], "C0o", ms=6, label="true position (in the air)")
    for (start, end), label in ((HOLD, "(1)"), (PUSH, "(2)")):
        k = (t >= start) & (t <= end)
        ax.plot(a["odo_x"][k], a["odo_y"][k], "C3", lw=3)
        ax.annotate(label, (a["odo_x"][k][0], a["odo_y"][k][0]), fontsize=12, color="C3")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.legend(fontsize=7)
    ax.grid(True, alpha=0.3)
    ax2.plot(t, a["cmd_R"], "C1", lw=0.8, label="command R")
    ax2.plot(t, a["cmd_L"], "C2", lw=0.8, label="command L")
    ax2.plot(t, a["true_wheel_R"], "C1:", lw=1.5, label="wheel R")
    ax2.plot(t, a["true_wheel_L"], "C2:", lw=1.5, label="wheel L")
    for (start, end), label in ((HOLD, "(1) R held"), (PUSH, "(2) L pushed")):
        ax2.axvspan(start, end, color="0.85", zorder=0)
        ax2.text(start, ax2.get_ylim()[1] * 0.95 if ax2.get_ylim()[1] > 0 else 1.0, label, fontsize=8)
    ax2.set_ylabel("wheel speed (m/s)")
    ax2.legend(fontsize=7, ncol=2)
    time_axis(ax2)
    fig.suptitle(f"Indiveri Fig. 5 ({mode}): circle, no load, (1) a wheel stopped, (2) a wheel accelerated")
    fig.tight_layout()
    before = (t >= HOLD[0] - 0.3) & (t < HOLD[0])
    held = (t >= HOLD[0] + 0.1) & (t < HOLD[1])
    pushed = (t >= PUSH[0] + 0.1) & (t < PUSH[1])
    before_push = (t >= PUSH[0] - 0.3) & (t < PUSH[0])
    n = {
        "other_before_hold": float(np.mean(a["cmd_L"][before])),
        "other_during_hold": float(np.min(a["cmd_L"][held])) if held.any() else math.nan,
        "held_wheel": float(np.max(np.abs(a["true_wheel_R"][held]))) if held.any() else math.nan,
        "other_before_push": float(np.mean(a["cmd_R"][before_push])) if before_push.any() else math.nan,
        "other_during_push": float(np.max(a["cmd_R"][pushed])) if pushed.any() else math.nan,
        "pushed_wheel": float(np.max(a["true_wheel_L"][pushed])) if pushed.any() else math.nan,
        "completed_path": bool(run.summary["controller_completion_time_s"] is not None),
    }
    return Reproduced(
        "indiveri-fig5",
        "Indiveri Fig. 5",
        fig,
        "Following a circular path in no load operation with applied perturbations: Top: Followed path: In "
        "(1) one wheel has been manually stopped, and in (2) one wheel was accelerated. Bottom: When one "
        "wheel is stopped, the second wheel stops instantly too, to keep the vehicle on the given path.",
        "When one wheel is stopped, the second wheel stops instantly too; the path following is stable.",
        f"(1) right wheel held (|v| <= {n['held_wheel']:.2f} m/s): the left command falls from "
        f"{n['other_before_hold']:.2f} to {n['other_during_hold']:.2f} m/s (slows, does not stop); "
        f"(2) left wheel pushed to {n['pushed_wheel']:.2f} m/s: the right command rises from "
        f"{n['other_before_push']:.2f} to {n['other_during_push']:.2f} m/s; the encoders' path rejoins the "
        f"circle (finished: {n['completed_path']}).",
        run.command,
        n,
    )


def indiveri_fig6(runs: dict, mode: str = "default") -> Reproduced:
    """Indiveri Fig. 6: the circle followed localised by odometry, Gyrodometry (Algorithm 1) and the fusion
    (ours in place of ICP/Gyrodometry), each compared with the true path (the paper's ICP reference), with
    the followed estimate's final, RMS and maximum position error.
    ``runs``: {"odometry": Run, "gyrodometry": Run, "fused": Run}."""
    fig, axes = agg_pyplot().subplots(1, 3, figsize=(15, 5.2))
    prefix = {"odometry": "odo", "gyrodometry": "gyro", "fused": "est"}
    numbers = {}
    for ax, (source, run) in zip(axes, runs.items(), strict=True):
        a = run.arrays
        ax.plot(run.path.x, run.path.y, "k--", lw=0.8, label="path")
        ax.plot(a["true_x"], a["true_y"], "C0", lw=3, alpha=0.5, label="true (the paper's ICP)")
        ax.plot(
            a[f"{prefix[source]}_x"],
            a[f"{prefix[source]}_y"],
            "C3",
            lw=1,
            label=f"{source} (what it followed)",
        )
        ax.set_aspect("equal", adjustable="datalim")
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")
        s = run.summary
        numbers[source] = {
            "end_distance_m": s["end_distance_m"],
            "path_error_rms_m": s["path_error_rms_m"],
            "path_error_max_m": s["path_error_max_m"],
        } | {  # the followed estimate's own position error (metrics.position_errors)
            f"position_error_{figure}_m": s[f"{figure}_position_error_m"][source]
            for figure in ("final", "rms", "max")
        }
        ax.set_title(f"localised by {source}: path error RMS {100 * s['path_error_rms_m']:.1f} cm")
        ax.legend(fontsize=7)
        ax.grid(True, alpha=0.3)
    fig.suptitle(f"Indiveri Fig. 6 ({mode}): circle, the follower localised by different methods")
    fig.tight_layout()
    measured = "; ".join(
        f"{src}: true path error RMS {100 * v['path_error_rms_m']:.1f} cm, ends "
        f"{100 * v['end_distance_m']:.1f} cm from the path's end; the {src} estimate's position error final "
        f"{100 * v['position_error_final_m']:.1f}, RMS {100 * v['position_error_rms_m']:.1f}, max "
        f"{100 * v['position_error_max_m']:.1f} cm"
        for src, v in numbers.items()
    )
    return Reproduced(
        "indiveri-fig6",
        "Indiveri Fig. 6",
        fig,
        "Following a circular path using different localization methods. Top: Odometry based path "
        "following. Bottom left: Gyrodometry based path following. Bottom right: Combined ICP/Gyrodometry "
        "path following. All paths are compared with ICP localization.",
        "No number: control quality depends crucially on the localisation.",
        measured,
        "; ".join(run.command for run in runs.values()),
        numbers,
    )


def indiveri_fig7(bounded: Run, constant: Run, mode: str = "default") -> Reproduced:
    """Indiveri Fig. 7: the long path with straights and turns of different radii, followed with the
    bounded speed law I(24) and with u = V_m/2."""
    fig, ax = agg_pyplot().subplots(figsize=(8, 7))
    ax.plot(bounded.path.x, bounded.path.y, "k--", lw=1, label="path")
    for run, label, color in ((constant, "u = $V_m$/2", "C2"), (bounded, "I(24) bounded", "C3")):
        a = run.arrays
        ax.plot(
            a["true_x"],
            a["true_y"],
            color,
            lw=1,
            label=f"{label}: RMS {100 * run.summary['path_error_rms_m']:.1f} cm",
        )
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.legend(fontsize=8)
    ax.grid(True, alpha=0.3)
    ax.set_title(f"Indiveri Fig. 7 ({mode}): long path, true paths")
    fig.tight_layout()
    sb, sc = bounded.summary, constant.summary
    return Reproduced(
        "indiveri-fig7",
        "Indiveri Fig. 7",
        fig,
        "Following a path with long straight parts and curves with different curvatures.",
        "No number in the figure (its speeds: Fig. 9).",
        f"true path error RMS / max: bounded {100 * sb['path_error_rms_m']:.1f} / "
        f"{100 * sb['path_error_max_m']:.1f} cm, "
        f"constant {100 * sc['path_error_rms_m']:.1f} / {100 * sc['path_error_max_m']:.1f} cm.",
        f"{bounded.command}; {constant.command}",
        {
            "rms_bounded": sb["path_error_rms_m"],
            "rms_constant": sc["path_error_rms_m"],
            "max_bounded": sb["path_error_max_m"],
            "max_constant": sc["path_error_max_m"],
        },
    )


def _wheel_speed_panels(key, title, bounded: Run, constant: Run, mode: str, caption, claim):
    """Indiveri Figs. 8-9: wheel commands against V_m, low speed (u = V_m/2, top) and high speed (I(24),
    bottom), each on its own time axis."""
    fig, axes = agg_pyplot().subplots(2, 1, figsize=(10, 8))
    numbers = {}
    for ax, run, label in (
        (axes[0], constant, "low speed, u = $V_m$/2"),
        (axes[1], bounded, "high speed, I(24)"),
    ):
        a = run.arrays
        t, following = a["t"], following_mask(run)
        ax.plot(t[following], a["cmd_R"][following], "C1", lw=0.8, label="command R")
        ax.plot(t[following], a["cmd_L"][following], "C2", lw=0.8, label="command L")
        ax.axhline(float(a["V_m"]), color="k", ls="--", lw=0.8, label="$V_m$")
        one, both = saturation_fractions(run)
        tag = "bounded" if run is bounded else "constant"
        numbers[f"one_{tag}"], numbers[f"both_{tag}"] = one, both
        numbers[f"time_{tag}"] = following_time(run)
        ax.set_title(
            f"{label}: {following_time(run):.1f} s; a wheel $\\geq$ {AT_V_M:g} $V_m$ {100 * one:.0f} %, "
            f"both {100 * both:.0f} %"
        )
        ax.set_ylabel("wheel speed command (m/s)")
        ax.legend(fontsize=7, ncol=3)
        time_axis(ax)
    numbers["time_ratio"] = numbers["time_bounded"] / numbers["time_constant"]
    numbers["switches"] = speed_switches(bounded)
    fig.suptitle(f"{title} ({mode}): wheel speeds, low speed (top) vs high speed (bottom)")
    fig.tight_layout()
    measured = (
        f"time {numbers['time_bounded']:.1f} s bounded vs {numbers['time_constant']:.1f} s constant "
        f"({100 * numbers['time_ratio']:.0f} %); a wheel at >= {AT_V_M:g} V_m "
        f"{100 * numbers['one_bounded']:.0f} % of the time (constant {100 * numbers['one_constant']:.0f} %), "
        f"both {100 * numbers['both_bounded']:.0f} %; I(24) switched between V_m/2 and "
        f"V_m/(1 + b|kappa_r|) {numbers['switches']} times."
    )
    return Reproduced(
        key, title, fig, caption, claim, measured, f"{bounded.command}; {constant.command}", numbers
    )


def indiveri_fig8(bounded: Run, constant: Run, mode: str = "default") -> Reproduced:
    """Indiveri Fig. 8: the circle's wheel speeds at u = V_m/2 (top) and with I(24) (bottom)."""
    return _wheel_speed_panels(
        "indiveri-fig8",
        "Indiveri Fig. 8",
        bounded,
        constant,
        mode,
        "Comparison of low speed behavior (top) and high speed behavior (bottom), while following a circular "
        "line. Note: The x-axis (time) is scaled differently.",
        "In the high speed case one wheel is always assigned the maximal control input (circular path); in "
        "the original law saturation is nearly avoided.",
    )


def indiveri_fig9(bounded: Run, constant: Run, mode: str = "default") -> Reproduced:
    """Indiveri Fig. 9: the long path's wheel speeds at u = V_m/2 (top) and with I(24) (bottom); the
    paper's claim: the path driven in about 50 % of the time."""
    return _wheel_speed_panels(
        "indiveri-fig9",
        "Indiveri Fig. 9",
        bounded,
        constant,
        mode,
        "Comparison of low speed behavior (top) and high speed behavior (bottom) [the paper's caption "
        "repeats Fig. 8's; the text: the velocities of Fig. 7's path]. Note: The x-axis (time) is scaled "
        "differently.",
        "The whole path is driven in about 50 % of the time. One wheel is always saturated, on the straight "
        "parts quite often both motors.",
    )
