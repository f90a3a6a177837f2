"""The papers' figures recreated on our robots: ``slipnav reproduce [--out DIR] [--quick]``.

Seyr & Jakubek Figs. 4-8 and Indiveri, Nüchter & Lingemann Figs. 2, 5-9, each in default mode and in
paper mode (scenarios/paper.py), from a handful of closed-loop runs of the built-in scenarios and two
variants built here (the circle with its wheels in the air, Indiveri Fig. 5). Every figure function
returns a ``Reproduced``: the matplotlib Figure, the paper's caption, its quantitative claim, what we
measured (computed from the runs) and the command that makes the underlying run. ``reproduce`` writes
``DIR/reproduce/index.html`` (the figures beside caption, claim and measurement, and the claims table),
the PNGs (``<key>-<mode>.png``), the animations of Seyr's corner and square and Indiveri's long path
(``<run>-<mode>.html``, scenarios/animation.py), ``reproduce.json`` (the same as data) and
``lifted_circle.yaml``.
"""

from __future__ import annotations

import dataclasses as dc
import html
import json
import math
import time
from pathlib import Path as FilePath

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from slipnav.scenarios.config import BUILTIN_DIR, load_scenario, scenario_from_yaml  # noqa: E402
from slipnav.scenarios.metrics import (  # noqa: E402
    DETECTION_C1_LEVEL,
    final_position_error,
    moving_alpha,
    side_slip_rms_error,
)
from slipnav.scenarios.paper import paper_mode  # noqa: E402
from slipnav.scenarios.plots import (  # noqa: E402
    plot_associated_points,
    retimed_reference,
    save_figure_atomically,
)
from slipnav.scenarios.run_plan import follower_path  # noqa: E402
from slipnav.scenarios.runner import run_scenario  # noqa: E402
from slipnav.systems.mixing import logsig  # noqa: E402

MODES = ("default", "paper")
ANIMATED = {"corner": "Seyr's corner", "square": "Seyr's square", "long_path": "Indiveri's long path"}
"""Runs of the set the page links as animations (``<run>-<mode>.html``), with their names on the page."""

LIFTED_EVENTS = """faults:
  - {kind: wheel_lifted, channel: wheel_R, start: 0.0, duration: 3600.0}
  - {kind: wheel_lifted, channel: wheel_L, start: 0.0, duration: 3600.0}
  - {kind: wheel_held, channel: wheel_R, start: 2.5, duration: 0.5}
  - {kind: wheel_pushed, channel: wheel_L, start: 5.0, duration: 0.5, value: 5.0}
"""
"""Indiveri Fig. 5: Kurt3D on the circle with both wheels in the air (no ground contact), the right wheel
stopped by hand (1) for 0.5 s, then the left one turned faster (2) with 5 N m for 0.5 s."""
HOLD, PUSH = (2.5, 3.0), (5.0, 5.5)

DIVERGENCE = 0.05
"""m/s: |fused v_t - true v_t| above which Seyr Fig. 7's light grey marks a divergence of the estimate."""
EXCESSIVE_SLIP = 0.15
"""Slip ratio above which a wheel slips excessively (the slip-episode threshold of scenarios/metrics)."""


@dc.dataclass
class Reproduced:
    """One recreated figure: the Figure, the paper's caption and claim, what we measured, the command."""

    key: str
    title: str
    figure: object
    caption: str
    claim: str
    measured: str
    command: str
    numbers: dict = dc.field(default_factory=dict)


@dc.dataclass
class Run:
    """A run of the set (RunResult's arrays, summary, reference) and the command that makes it."""

    arrays: dict
    summary: dict
    reference: object
    path: object
    command: str


def lifted_circle_yaml() -> str:
    """The circle scenario with LIFTED_EVENTS (Indiveri Fig. 5), as a scenario file."""
    text = (BUILTIN_DIR / "circle.yaml").read_text()
    return "name: lifted_circle\n" + text + LIFTED_EVENTS


# -- the runs ----------------------------------------------------------------------------------------


def run_specs(quick: bool = False) -> dict:
    """name -> (scenario name or 'lifted_circle', run options, command tail). ``quick``: shorter
    durations of the long runs (the test's reduced set)."""
    short = (lambda s: {"duration": s}) if quick else (lambda s: {})
    dur = (lambda s: f" --duration {s:g}") if quick else (lambda s: "")
    return {
        "corner": ("corner", {}, ""),
        "corner_no_sc": ("corner", {"slip_control": False}, " --no-slip-control"),
        "square": ("square", short(4.0), dur(4.0)),
        "square_no_sc": ("square", {"slip_control": False, **short(4.0)}, " --no-slip-control" + dur(4.0)),
        "circle": ("circle", short(4.0), dur(4.0)),
        "circle_constant": (
            "circle",
            {"speed_law": "constant", **short(4.0)},
            " --speed-law constant" + dur(4.0),
        ),
        "circle_odometry": (
            "circle",
            {"localisation": "odometry", **short(4.0)},
            " --localisation odometry" + dur(4.0),
        ),
        "circle_gyrodometry": (
            "circle",
            {"localisation": "gyrodometry", **short(4.0)},
            " --localisation gyrodometry" + dur(4.0),
        ),
        "lifted": (
            "lifted_circle",
            {"localisation": "odometry", "speed_law": "constant", **short(6.0)},
            " --localisation odometry --speed-law constant" + dur(6.0),
        ),
        "long_path": ("long_path", short(8.0), dur(8.0)),
        "long_path_constant": (
            "long_path",
            {"speed_law": "constant", **short(8.0)},
            " --speed-law constant" + dur(8.0),
        ),
    }


def make_runs(mode: str, quick: bool = False, yaml_dir=None, progress=None) -> dict:
    """Every run of ``run_specs`` in ``mode`` (default or paper), in this process. ``yaml_dir``: where
    lifted_circle.yaml is (its command names it)."""
    lifted_path = FilePath(yaml_dir or ".") / "lifted_circle.yaml"
    runs = {}
    for name, (scenario_name, options, tail) in run_specs(quick).items():
        if scenario_name == "lifted_circle":
            scenario = scenario_from_yaml(lifted_circle_yaml(), "lifted_circle")
            target = str(lifted_path)
        else:
            scenario, target = load_scenario(scenario_name), scenario_name
        if mode == "paper":
            scenario, tail = paper_mode(scenario), tail + " --paper"
        result = run_scenario(scenario, **options)
        runs[name] = Run(
            result.arrays,
            result.summary,
            result.reference,
            follower_path(scenario),
            f"slipnav run {target}{tail}",
        )
        if progress:
            progress(name, mode, result.summary)
    return runs


# -- helpers -----------------------------------------------------------------------------------------


def _pct(run: Run, prefix: str = "est") -> float:
    """Final position error of an estimate in % of the path."""
    return 100.0 * final_position_error(run.arrays, prefix) / float(run.arrays["path_length"])


def _moving(a) -> np.ndarray:
    """Samples after the controller started."""
    return a["t"] >= float(a["start_time"])


def _following(run: Run) -> np.ndarray:
    """Samples while the controller followed (start to controller completion)."""
    a, end = run.arrays, run.summary["controller_completion_time_s"]
    return _moving(a) & (a["t"] <= (end if end is not None else np.inf))


def _time_above(a, values, level) -> float:
    """Time (s) where |values| > level."""
    return float(np.sum(np.abs(np.nan_to_num(values)) > level) * float(a["T_N"]))


def _spans(t, mask):
    """(start, end) times of the runs of True in ``mask``."""
    edges = np.flatnonzero(np.diff(mask.astype(int))) + 1
    bounds = np.r_[0, edges, len(t)]
    return [(t[i], t[min(j, len(t) - 1)]) for i, j in zip(bounds[:-1], bounds[1:], strict=True) if mask[i]]


def detection_onsets(a, level: float = DETECTION_C1_LEVEL) -> np.ndarray:
    """Times at which C1 falls below ``level``: detected tangential slip (Seyr Fig. 7's black circles)."""
    low = a["C1"] < level
    return a["t"][np.flatnonzero(low[1:] & ~low[:-1]) + 1]


def divergence_mask(a, threshold: float = DIVERGENCE) -> np.ndarray:
    """Samples where the fused v_t diverges from the truth by more than ``threshold`` (Seyr Fig. 7's light
    grey areas)."""
    return np.abs(a["est_v_t"] - a["true_v_t"]) > threshold


def _time_axis(ax, last: bool = True):
    if last:
        ax.set_xlabel("t (s)")
    ax.grid(True, alpha=0.3)


AT_V_M = 0.95
"""A wheel command at or above this fraction of V_m counts as at the bound (Indiveri Figs. 8-9)."""


def saturation_fractions(run: Run) -> tuple[float, float]:
    """Fractions of the following time with one wheel command at V_m (>= AT_V_M V_m) and with both."""
    a = run.arrays
    V_m, following = float(a["V_m"]), _following(run)
    at = np.column_stack([a["cmd_R"], a["cmd_L"]])[following] >= AT_V_M * V_m
    return float(np.mean(at.any(axis=1))), float(np.mean(at.all(axis=1)))


def speed_switches(run: Run) -> int:
    """How often the larger wheel command crosses 3/4 V_m while following: I(24)'s switches between
    V_m/2 (V1 >= epsilon) and V_m/(1 + b|kappa_r|) (V1 < epsilon)."""
    a = run.arrays
    high = (np.maximum(a["cmd_R"], a["cmd_L"]) > 0.75 * float(a["V_m"]))[_following(run)]
    return int(np.sum(high[1:] != high[:-1]))


def following_time(run: Run) -> float:
    """Time from the controller's start to its completion (s; to the run's end if it did not finish)."""
    a, end = run.arrays, run.summary["controller_completion_time_s"]
    return float((end if end is not None else a["t"][-1]) - float(a["start_time"]))


# -- Seyr & Jakubek ----------------------------------------------------------------------------------


def seyr_fig4(mixing, mode: str = "default") -> Reproduced:
    """Seyr Fig. 4: the double-sided logsig of S(12)-(14), the switch between odometric (C = 1) and
    inertial (C = 0) navigation, for C1 (|dv_K|), C2 (|a_n|) and C3 (|^O omega - ^I omega|) with
    ``mixing`` (MixingParameters) of the mode."""
    fig, axes = plt.subplots(1, 3, figsize=(12, 3.6))
    for ax, (name, a_, b_, label, unit) in zip(
        axes,
        (
            ("C1", mixing.a1, mixing.b1, "$\\Delta v_K$ S(11)", "m/s"),
            ("C2", mixing.a2, mixing.b2, "$a_n$", "m/s$^2$"),
            ("C3", mixing.a3, mixing.b3, "$^O\\omega - ^I\\omega$", "rad/s"),
        ),
        strict=True,
    ):
        x = np.linspace(-3.0 * b_, 3.0 * b_, 401)
        ax.plot(x, [logsig(a_, abs(v), b_) for v in x], "C0")
        for side in (-b_, b_):
            ax.axvline(side, color="0.5", ls="--", lw=0.8)
        ax.text(0.0, 0.5, "Odo.", ha="center")
        ax.text(2.3 * b_, 0.5, "INS.", ha="center")
        ax.text(-2.3 * b_, 0.5, "INS.", ha="center")
        ax.set_xlabel(f"{label} ({unit})")
        ax.set_ylabel(f"{name} (1)")
        ax.set_title(f"{name}: a = {a_:g}, b = {b_:g}")
        ax.set_ylim(-0.05, 1.05)
        ax.grid(True, alpha=0.3)
    fig.suptitle(f"Seyr Fig. 4 ({mode}): double-sided logsig S(12)-(14)")
    fig.tight_layout()
    width = 2.0 * math.log(9.0) / mixing.a1  # 10 %-90 % transition of C1
    return Reproduced(
        "seyr-fig4",
        "Seyr Fig. 4",
        fig,
        "Double-sided logsig-function as switch between odometric (Odo.) and inertial (INS.) navigation.",
        "No number: a1 as steep as possible, b1 as small as possible but above the accelerometers' bias.",
        f"C1: threshold b1 = {mixing.b1:g} m/s, 10-90 % transition over {width:.3f} m/s of |dv|; "
        f"C3: b3 = {mixing.b3:g} rad/s (a3 = {mixing.a3:g}).",
        "slipnav reproduce (systems/mixing.py logsig, the mode's MixingParameters)",
        {"c1_transition_m_s": width, "b1": mixing.b1, "b3": mixing.b3},
    )


def seyr_fig5(run: Run, mode: str = "default") -> Reproduced:
    """Seyr Fig. 5: the step size delta_K S(22) reduced in the corner and the nominal trajectory point K
    linked to the interpolated point Pi_K S(24)-(25) (the paper's ovals)."""
    a, ref = run.arrays, run.reference
    fig, (ax, ax2) = plt.subplots(1, 2, figsize=(12, 5), gridspec_kw={"width_ratios": [1, 1.3]})
    ax.plot(ref.x, ref.y, "k--", lw=1, label="reference (pre-planned)")
    ax.plot(a["true_x"], a["true_y"], "C0", lw=3, alpha=0.4, label="true")
    plot_associated_points(a, ref, ax, every=0.1)
    ax.plot([], [], color="0.6", label="K linked to $\\Pi_K$")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.legend(fontsize=7)
    ax.grid(True, alpha=0.3)
    moving = _moving(a)
    t = a["t"]
    K = np.maximum(np.ceil((t - float(a["start_time"])) / float(a["T_C"]) - 1e-9), 0.0)
    ax2.plot(t[moving], a["step_size"][moving], "C0", label="step size $\\delta_K$ S(22)")
    ax2.axhline(1.0, color="k", lw=0.6, ls="--")
    ax2.set_ylabel("$\\delta_K$ (1)")
    ax3 = ax2.twinx()
    ax3.plot(t[moving], (a["progress"] - K)[moving], "C1", lw=0.8, label="$\\Pi_K - K$ S(24)")
    ax3.set_ylabel("$\\Pi_K - K$ (control samples)", color="C1")
    ax2.legend(loc="upper left", fontsize=7)
    ax3.legend(loc="lower left", fontsize=7)
    _time_axis(ax2)
    fig.suptitle(f"Seyr Fig. 5 ({mode}): step size in the corner, trajectory points K and $\\Pi_K$")
    fig.tight_layout()
    lag = float(np.nanmin((a["progress"] - K)[moving]))
    dmin = float(np.nanmin(a["step_size"][moving]))
    return Reproduced(
        "seyr-fig5",
        "Seyr Fig. 5",
        fig,
        "Example for the variation of the step size during detected side-slip or tangential slip and "
        "corresponding interpolation of the pre-planned trajectory.",
        "No number: the step size is reduced in the curve, then increased beyond 1 to catch up.",
        f"corner: delta_K down to {dmin:.2f}, largest lag Pi_K - K = {lag:.1f} control samples "
        f"({-lag * float(a['T_C']) * 1000:.0f} ms), caught up by the end: Pi_K - K = "
        f"{float((a['progress'] - K)[-1]):.1f}.",
        run.command,
        {"min_step_size": dmin, "max_lag_samples": -lag},
    )


def seyr_fig6(run: Run, mode: str = "default") -> Reproduced:
    """Seyr Fig. 6: v_t, v_n and the side-slip angle S(19) estimated against the truth and the reference
    velocities, and the step size S(22), on the corner."""
    a, ref = run.arrays, run.reference
    t, moving = a["t"], _moving(a)
    v_ref, _, _ = retimed_reference(a, ref)
    fig, axes = plt.subplots(4, 1, figsize=(9, 10), sharex=True)
    axes[0].plot(t, v_ref, "k--", lw=1, label="Ref. ($\\delta_K$ v at $\\Pi_K$)")
    axes[0].plot(t, a["true_v_t"], "C0", lw=1.5, label="true")
    axes[0].plot(t, a["est_v_t"], "C3", lw=0.8, label="estimate")
    axes[0].set_ylabel("$v_t$ (m/s)")
    axes[1].plot(t, a["true_v_n"], "C0", lw=1.5, label="true")
    axes[1].plot(t, a["est_v_n"], "C3", lw=0.8, label="estimate")
    axes[1].set_ylabel("$v_n$ (m/s)")
    axes[2].plot(t, np.degrees(moving_alpha(a)), "C0", lw=1.5, label="true")
    axes[2].plot(t, np.degrees(a["est_alpha"]), "C3", lw=0.8, label="estimate S(19)")
    axes[2].set_ylabel("$\\alpha$ (deg)")
    axes[3].plot(t, a["step_size"], "C0", label="$\\delta_K$")
    axes[3].axhline(1.0, color="k", lw=0.6, ls="--")
    axes[3].set_ylabel("step size $\\delta_K$ (1)")
    for ax in axes:
        ax.legend(loc="best", fontsize=7)
        _time_axis(ax, ax is axes[-1])
    axes[0].set_xlim(float(a["start_time"]) - 0.2, t[-1])
    axes[0].set_title(f"Seyr Fig. 6 ({mode}): corner, velocities, side slip, step size")
    fig.tight_layout()
    alpha_true = np.degrees(np.nanmax(np.abs(moving_alpha(a))))
    alpha_est = np.degrees(np.nanmax(np.abs(a["est_alpha"][moving])))
    rms = math.degrees(side_slip_rms_error(a))
    dmin = float(np.nanmin(a["step_size"][moving]))
    return Reproduced(
        "seyr-fig6",
        "Seyr Fig. 6",
        fig,
        "Tangential and lateral velocity and side slip angle estimate and slip control during tracking of a "
        "corner, Ref. indicates the velocities associated with the reference trajectory.",
        "No number: the side slip builds up, is estimated with high accuracy, the step size is reduced.",
        f"peak |alpha| true {alpha_true:.1f} deg, estimated {alpha_est:.1f} deg; RMS error where |alpha| > 1 "
        f"deg {rms:.2f} deg; delta_K down to {dmin:.2f}.",
        run.command,
        {"peak_alpha_true_deg": alpha_true, "peak_alpha_est_deg": alpha_est, "alpha_rms_deg": rms},
    )


def seyr_fig7(run: Run, mode: str = "default") -> Reproduced:
    """Seyr Fig. 7: v_t and omega estimated against truth and reference on the square, with the step size;
    black circles where tangential slip is detected (C1 falling below DETECTION_C1_LEVEL, S(12)), light
    grey where the fused v_t diverges from the truth by more than DIVERGENCE (the finite reaction time of
    the switch S(15))."""
    a, ref = run.arrays, run.reference
    t = a["t"]
    v_ref, w_ref, _ = retimed_reference(a, ref)
    diverging = divergence_mask(a)
    onsets = detection_onsets(a)
    fig, axes = plt.subplots(3, 1, figsize=(10, 9), sharex=True)
    axes[0].plot(t, v_ref, "k--", lw=1, label="Ref.")
    axes[0].plot(t, a["true_v_t"], "C0", lw=1.5, label="true")
    axes[0].plot(t, a["est_v_t"], "C3", lw=0.8, label="estimate")
    axes[0].set_ylabel("$v_t$ (m/s)")
    axes[1].plot(t, w_ref, "k--", lw=1, label="Ref.")
    axes[1].plot(t, a["true_omega"], "C0", lw=1.5, label="true")
    axes[1].plot(t, a["est_omega"], "C3", lw=0.8, label="estimate")
    axes[1].set_ylabel("$\\omega$ (rad/s)")
    axes[2].plot(t, a["step_size"], "C0", label="$\\delta_K$")
    axes[2].axhline(1.0, color="k", lw=0.6, ls="--")
    axes[2].set_ylabel("step size $\\delta_K$ (1)")
    for ax in axes:
        for start, end in _spans(t, diverging):
            ax.axvspan(start, end, color="0.85", zorder=0)
    for ax, key in ((axes[0], "est_v_t"), (axes[2], "step_size")):
        ax.plot(onsets, np.interp(onsets, t, a[key]), "o", mfc="none", mec="k", ms=8, label="slip detected")
    axes[0].plot([], [], color="0.85", lw=6, label=f"|v_t error| > {DIVERGENCE:g} m/s")
    for ax in axes:
        ax.legend(loc="best", fontsize=7, ncol=2)
        _time_axis(ax, ax is axes[-1])
    axes[0].set_xlim(float(a["start_time"]) - 0.2, t[-1])
    axes[0].set_title(f"Seyr Fig. 7 ({mode}): square, v_t and yaw rate, slip detection, step size")
    fig.tight_layout()
    T_C = float(a["T_C"])
    reduced = sum(bool(np.any(a["step_size"][(t >= o) & (t <= o + 3 * T_C)] < 1.0)) for o in onsets)
    div_time = float(np.sum(diverging) * float(a["T_N"]))
    near = sum(any(abs(s0 - o) < 0.1 for o in onsets) for s0, _ in _spans(t, diverging))
    spans = len(_spans(t, diverging))
    return Reproduced(
        "seyr-fig7",
        "Seyr Fig. 7",
        fig,
        "Tangential velocity and yaw rate estimation and slip control during tracking of a square, Ref. "
        "indicates the velocities associated with the reference trajectory.",
        "No number: where slip is detected (black circles) the step size is temporarily reduced; there the "
        "velocity estimate diverges for a while (light grey), the switch's finite reaction time.",
        f"{len(onsets)} detections (C1 < {DETECTION_C1_LEVEL}), {reduced} followed by delta_K < 1 within "
        f"3 T_C; v_t diverged by > {DIVERGENCE:g} m/s in {spans} areas, {div_time:.2f} s in all, {near} of "
        "them within 0.1 s of a detection.",
        run.command,
        {"detections": len(onsets), "reduced": reduced, "divergence_s": div_time, "divergence_areas": spans},
    )


def seyr_fig8(corner: Run, square: Run, mode: str = "default") -> Reproduced:
    """Seyr Fig. 8: posture estimates on the corner (left) and the square (right): true, fused S(21) and
    odometry-only paths; the final error in % of the path (Seyr §VII: about 2.5 %)."""
    fig, axes = plt.subplots(1, 2, figsize=(12, 5.5))
    numbers = {}
    for ax, run, name in ((axes[0], corner, "corner"), (axes[1], square, "square")):
        a = run.arrays
        ax.plot(run.reference.x, run.reference.y, "k--", lw=0.8, label="reference")
        ax.plot(a["true_x"], a["true_y"], "C0", lw=4, alpha=0.4, label="true")
        ax.plot(a["est_x"], a["est_y"], "C3", lw=1, label=f"fused ({_pct(run):.2f} % at the end)")
        ax.plot(a["odo_x"], a["odo_y"], "C2", lw=0.8, label=f"odometry only ({_pct(run, 'odo'):.2f} %)")
        ax.set_aspect("equal", adjustable="datalim")
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")
        ax.set_title(name)
        ax.legend(fontsize=7)
        ax.grid(True, alpha=0.3)
        numbers[f"{name}_fused_pct"] = _pct(run)
        numbers[f"{name}_odometry_pct"] = _pct(run, "odo")
    fig.suptitle(f"Seyr Fig. 8 ({mode}): posture estimates, corner (left) and square (right)")
    fig.tight_layout()
    return Reproduced(
        "seyr-fig8",
        "Seyr Fig. 8",
        fig,
        "Posture estimates during tracking of a corner (left) and a square (right).",
        "About 2.5 % position error with reference to absolute trajectory length (§VII).",
        f"fused final error {numbers['corner_fused_pct']:.2f} % (corner), "
        f"{numbers['square_fused_pct']:.2f} % (square); odometry only "
        f"{numbers['corner_odometry_pct']:.2f} %, {numbers['square_odometry_pct']:.2f} %.",
        f"{corner.command}; {square.command}",
        numbers,
    )


def slip_control_effect(with_sc: Run, without: Run) -> dict:
    """What slip control does on one scenario: peak |alpha| (deg), time with a wheel's |slip ratio| >
    EXCESSIVE_SLIP (s), fused final error (%), following time (s), with and without."""
    out = {}
    for tag, run in (("on", with_sc), ("off", without)):
        a = run.arrays
        slip = np.maximum(np.abs(a["true_slip_R"]), np.abs(a["true_slip_L"]))
        out[f"alpha_{tag}"] = float(np.degrees(np.nanmax(np.abs(moving_alpha(a)))))
        out[f"slip_time_{tag}"] = _time_above(a, np.where(_moving(a), slip, 0.0), EXCESSIVE_SLIP)
        out[f"pct_{tag}"] = _pct(run)
        out[f"time_{tag}"] = following_time(run)
    return out


# -- Indiveri, Nüchter & Lingemann -------------------------------------------------------------------


def indiveri_fig2(V_m: float, b: float, runs=(), mode: str = "default") -> Reproduced:
    """Indiveri Fig. 2: curvature I(5) and linear speed I(3) over the wheel speeds v_l, v_r in [0, V_m]
    (b: half the track, Indiveri's b), the line BA (u = V_m/2) and the I(24) speed's edge max(v_l, v_r) =
    V_m; ``runs``: (label, Run) whose wheel commands are drawn on top."""
    v = np.linspace(0.0, V_m, 201)
    vl, vr = np.meshgrid(v, v)
    with np.errstate(invalid="ignore", divide="ignore"):
        kappa = (vr - vl) / (b * (vr + vl))
    u = 0.5 * (vr + vl)
    fig, axes = plt.subplots(1, 2, figsize=(12, 5.2))
    c0 = axes[0].contourf(vl, vr, np.clip(kappa, -1 / b, 1 / b), levels=21, cmap="coolwarm")
    fig.colorbar(c0, ax=axes[0], label="curvature $\\kappa$ I(5) (1/m)")
    c1 = axes[1].contourf(vl, vr, u, levels=21, cmap="viridis")
    fig.colorbar(c1, ax=axes[1], label="linear speed u I(3) (m/s)")
    for ax in axes:
        ax.plot([0, V_m], [V_m, 0], "w--", lw=1.2, label="BA: u = $V_m$/2")
        for (label, run), color in zip(runs, ("k", "m"), strict=False):
            a, following = run.arrays, _following(run)
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
        a, following = run.arrays, _following(run)
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
    fig, (ax, ax2) = plt.subplots(2, 1, figsize=(9, 10), gridspec_kw={"height_ratios": [1.2, 1]})
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
    _time_axis(ax2)
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
    (ours in place of ICP/Gyrodometry), each compared with the true path (the paper's ICP reference).
    ``runs``: {"odometry": Run, "gyrodometry": Run, "fused": Run}."""
    fig, axes = plt.subplots(1, 3, figsize=(15, 5.2))
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
        }
        ax.set_title(f"localised by {source}: path error RMS {100 * s['path_error_rms_m']:.1f} cm")
        ax.legend(fontsize=7)
        ax.grid(True, alpha=0.3)
    fig.suptitle(f"Indiveri Fig. 6 ({mode}): circle, the follower localised by different methods")
    fig.tight_layout()
    measured = "; ".join(
        f"{src}: true path error RMS {100 * v['path_error_rms_m']:.1f} cm, ends "
        f"{100 * v['end_distance_m']:.1f} cm from the path's end"
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
    fig, ax = plt.subplots(figsize=(8, 7))
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
    fig, axes = plt.subplots(2, 1, figsize=(10, 8))
    numbers = {}
    for ax, run, label in (
        (axes[0], constant, "low speed, u = $V_m$/2"),
        (axes[1], bounded, "high speed, I(24)"),
    ):
        a = run.arrays
        t, following = a["t"], _following(run)
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
        _time_axis(ax)
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


# -- the page ----------------------------------------------------------------------------------------


def figures_for(runs: dict, mode: str, mixing) -> list[Reproduced]:
    """Every recreated figure of one mode from its runs (make_runs)."""
    a = runs["long_path"].arrays
    return [
        seyr_fig4(mixing, mode),
        seyr_fig5(runs["corner"], mode),
        seyr_fig6(runs["corner"], mode),
        seyr_fig7(runs["square"], mode),
        seyr_fig8(runs["corner"], runs["square"], mode),
        indiveri_fig2(
            float(a["V_m"]),
            0.5 * float(a["track_width"]),
            (("long path, I(24)", runs["long_path"]), ("circle, I(24)", runs["circle"])),
            mode,
        ),
        indiveri_fig5(runs["lifted"], mode),
        indiveri_fig6(
            {
                "odometry": runs["circle_odometry"],
                "gyrodometry": runs["circle_gyrodometry"],
                "fused": runs["circle"],
            },
            mode,
        ),
        indiveri_fig7(runs["long_path"], runs["long_path_constant"], mode),
        indiveri_fig8(runs["circle"], runs["circle_constant"], mode),
        indiveri_fig9(runs["long_path"], runs["long_path_constant"], mode),
    ]


def claims(runs_by_mode: dict) -> list[dict]:
    """The claims table: per claim the paper's statement, our measurement per mode, the figure and the
    command."""
    rows = []
    measured = {}
    for mode, runs in runs_by_mode.items():
        c, s = runs["corner"], runs["square"]
        measured.setdefault("position", {})[mode] = (
            f"fused {_pct(c):.2f} % corner, {_pct(s):.2f} % square (odometry only {_pct(c, 'odo'):.2f} %, "
            f"{_pct(s, 'odo'):.2f} %)"
        )
        ec = slip_control_effect(c, runs["corner_no_sc"])
        es = slip_control_effect(s, runs["square_no_sc"])
        measured.setdefault("slip_control", {})[mode] = (
            f"with vs without slip control: corner: peak |alpha| {ec['alpha_on']:.1f} vs "
            f"{ec['alpha_off']:.1f} deg, fused {ec['pct_on']:.2f} vs {ec['pct_off']:.2f} %, "
            f"{ec['time_on']:.2f} vs {ec['time_off']:.2f} s; square: slip ratio > {EXCESSIVE_SLIP} for "
            f"{es['slip_time_on']:.2f} vs {es['slip_time_off']:.2f} s, fused {es['pct_on']:.2f} vs "
            f"{es['pct_off']:.2f} %, {es['time_on']:.2f} vs {es['time_off']:.2f} s"
        )
        b, k = runs["long_path"], runs["long_path_constant"]
        measured.setdefault("speed_law", {})[mode] = (
            f"{following_time(b):.1f} s vs {following_time(k):.1f} s "
            f"({100 * following_time(b) / following_time(k):.0f} % of the time); true path error RMS "
            f"{100 * b.summary['path_error_rms_m']:.1f} vs {100 * k.summary['path_error_rms_m']:.1f} cm, max "
            f"{100 * b.summary['path_error_max_m']:.1f} vs {100 * k.summary['path_error_max_m']:.1f} cm"
        )
        one, _ = saturation_fractions(runs["circle"])
        measured.setdefault("saturation", {})[mode] = (
            f"a wheel at >= {AT_V_M:g} V_m {100 * one:.0f} % of the circle's following time, "
            f"{speed_switches(runs['circle'])} switches of I(24)"
        )
    some = next(iter(runs_by_mode.values()))
    rows.append(
        dict(
            claim="Seyr §VII: about 2.5 % position error w.r.t. the trajectory length",
            measured=measured["position"],
            figure="seyr-fig8",
            command=f"{some['corner'].command}; {some['square'].command}",
        )
    )
    rows.append(
        dict(
            claim="Seyr §VI-VII: slip control reduces the step size in slip and limits excessive slip to "
            "short intervals",
            measured=measured["slip_control"],
            figure="seyr-fig6",
            command=f"{some['corner'].command} [--no-slip-control]; "
            f"{some['square'].command} [--no-slip-control]",
        )
    )
    rows.append(
        dict(
            claim="Indiveri §IV-C: the bounded speed law I(24) drives the long path in about 50 % of the "
            "time (its cost: path error)",
            measured=measured["speed_law"],
            figure="indiveri-fig9",
            command=f"{some['long_path'].command} [--speed-law constant]",
        )
    )
    rows.append(
        dict(
            claim="Indiveri §IV-B: on the circle one wheel is always at the maximal input",
            measured=measured["saturation"],
            figure="indiveri-fig8",
            command=f"{some['circle'].command} [--speed-law constant]",
        )
    )
    return rows


def write_animations(runs: dict, mode: str, out: FilePath) -> dict:
    """The runs of ANIMATED in ``mode`` as animations ``out/<run>-<mode>.html`` (scenarios/animation.py);
    returns {run: file name}."""
    from slipnav.scenarios.animation import write_animation

    return {
        name: write_animation(runs[name].arrays, out / f"{name}-{mode}.html", f"{name} ({mode} mode)").name
        for name in ANIMATED
    }


def _cell(text) -> str:
    return html.escape(str(text))


def write_page(
    out: FilePath, figures: dict, table: list[dict], wall: float, quick: bool, animations=None
) -> FilePath:
    """index.html: the links to the animations ({mode: {run: file}}), the claims table, then per figure
    the PNGs of each mode beside caption, claim, measurement and command (written to a temporary file and
    renamed)."""
    modes = list(figures)
    parts = [
        "<!DOCTYPE html><html><head><meta charset='utf-8'><title>slipnav reproduce</title>",
        "<style>body{font-family:sans-serif;max-width:1500px;margin:auto}table{border-collapse:collapse}"
        "td,th{border:1px solid #bbb;padding:4px;vertical-align:top}img{max-width:100%}"
        ".cap{font-size:90%}</style></head><body>",
        "<h1>Seyr &amp; Jakubek and Indiveri et al. figures recreated on our robots</h1>",
        f"<p>Made by <code>slipnav reproduce{' --quick' if quick else ''}</code> in {wall:.0f} s. Modes: "
        f"{', '.join(modes)} (paper: the equations as printed, README Paper mode). Seed 0.</p>",
        _animation_links(animations or {}),
        "<h2>Claims</h2><table><tr><th>paper's claim</th>"
        + "".join(f"<th>measured, {m}</th>" for m in modes)
        + "<th>figure</th><th>command</th></tr>",
    ]
    for row in table:
        parts.append(
            f"<tr><td>{_cell(row['claim'])}</td>"
            + "".join(f"<td>{_cell(row['measured'].get(m, '-'))}</td>" for m in modes)
            + f"<td><a href='#{row['figure']}'>{row['figure']}</a></td>"
            + f"<td><code>{_cell(row['command'])}</code></td></tr>"
        )
    parts.append("</table>")
    first = figures[modes[0]]
    for i, fig in enumerate(first):
        parts.append(f"<h2 id='{fig.key}'>{_cell(fig.title)}</h2><table><tr>")
        for m in modes:
            f = figures[m][i]
            parts.append(f"<td><img src='{f.key}-{m}.png' alt='{f.key} {m}'><br>{m} mode</td>")
        parts.append(
            f"<td class='cap'><b>Paper's caption:</b> {_cell(fig.caption)}"
            f"<br><b>Claim:</b> {_cell(fig.claim)}"
        )
        for m in modes:
            f = figures[m][i]
            parts.append(
                f"<br><b>Measured ({m}):</b> {_cell(f.measured)}"
                f"<br><b>Command:</b> <code>{_cell(f.command)}</code>"
            )
        parts.append("</td></tr></table>")
    parts.append("</body></html>")
    path = out / "index.html"
    tmp = out / "index.html.tmp"
    tmp.write_text("\n".join(parts))
    tmp.replace(path)
    return path


def _animation_links(animations: dict) -> str:
    """One paragraph linking each animated run's pages, one per mode ('' without animations)."""
    if not animations:
        return ""
    runs = [
        f"{ANIMATED[name]}: "
        + ", ".join(f"<a href='{files[name]}'>{mode}</a>" for mode, files in animations.items())
        for name in ANIMATED
    ]
    return (
        "<p id='animations'>Animations (true and fused robot, wheel slip; one HTML file each): "
        + "; ".join(runs)
        + ".</p>"
    )


def reproduce(out_dir="runs", quick: bool = False, modes=MODES, stream=None) -> dict:
    """Make every run, figure, animation and the page: ``out_dir/reproduce/index.html``,
    ``<key>-<mode>.png``, ``<run>-<mode>.html`` (ANIMATED), ``lifted_circle.yaml``. Returns {"index": path,
    "figures": {mode: [Reproduced]}, "claims": rows,
    "wall_s": seconds}."""
    import sys

    stream = stream or sys.stdout
    start = time.perf_counter()
    out = FilePath(out_dir) / "reproduce"
    out.mkdir(parents=True, exist_ok=True)
    yaml_path = out / "lifted_circle.yaml"
    tmp = out / "lifted_circle.yaml.tmp"
    tmp.write_text(lifted_circle_yaml())
    tmp.replace(yaml_path)
    figures, runs_by_mode, animations = {}, {}, {}
    for mode in modes:
        runs = make_runs(
            mode,
            quick,
            out,
            progress=lambda name, m, s: print(
                f"reproduce: {m} {name} ({s['wall_time_s']:.1f} s)", file=stream
            ),
        )
        runs_by_mode[mode] = runs
        animations[mode] = write_animations(runs, mode, out)
        scenario = load_scenario("corner")
        mixing = (paper_mode(scenario) if mode == "paper" else scenario).navigation.mixing
        figures[mode] = figures_for(runs, mode, mixing)
        for f in figures[mode]:
            save_figure_atomically(f.figure, out / f"{f.key}-{mode}.png")
            f.figure = None
        runs_by_mode[mode] = runs
    table = claims(runs_by_mode)
    wall = time.perf_counter() - start
    index = write_page(out, figures, table, wall, quick, animations)
    record = {
        "quick": quick,
        "wall_s": wall,
        "figures": {
            m: {
                f.key: {
                    "png": f"{f.key}-{m}.png",
                    "caption": f.caption,
                    "claim": f.claim,
                    "measured": f.measured,
                    "command": f.command,
                    "numbers": f.numbers,
                }
                for f in figs
            }
            for m, figs in figures.items()
        },
        "claims": table,
        "animations": animations,
    }
    tmp = out / "reproduce.json.tmp"
    tmp.write_text(json.dumps(record, indent=1))
    tmp.replace(out / "reproduce.json")
    for row in table:
        print(f"claim: {row['claim']}", file=stream)
        for m, text in row["measured"].items():
            print(f"  {m}: {text}", file=stream)
    print(
        f"reproduce figures={sum(len(v) for v in figures.values())} wall_s={wall:.1f} index={index}",
        file=stream,
    )
    return {"index": index, "figures": figures, "claims": table, "wall_s": wall}
