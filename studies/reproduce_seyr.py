"""Seyr & Jakubek's Figs. 4-8 recreated from ``slipnav reproduce``'s runs (studies/reproduce.py), and the
slip control's effect its claims table reports."""

from __future__ import annotations

import math

import numpy as np
from slipnav.scenarios.metrics import (
    DETECTION_C1_LEVEL,
    moving_alpha,
    position_errors,
    side_slip_rms_error,
)
from slipnav.scenarios.plots import agg_pyplot, plot_associated_points, retimed_reference
from slipnav.studies.reproduce_measures import (
    DIVERGENCE,
    EXCESSIVE_SLIP,
    Reproduced,
    Run,
    detection_onsets,
    divergence_mask,
    following_time,
    moving_mask,
    percent_errors,
    percent_errors_text,
    percent_of_path,
    time_above,
    time_axis,
    true_spans,
)
from slipnav.systems.navigation.mixing.weights import logsig


def seyr_fig4(mixing, mode: str = "default") -> Reproduced:
    """Seyr Fig. 4: the double-sided logsig of S(12)-(14), the switch between odometric (C = 1) and
    inertial (C = 0) navigation, for C1 (|dv_K|), C2 (|a_n|) and C3 (|^O omega - ^I omega|) with
    ``mixing`` (MixingParameters) of the mode."""
    fig, axes = agg_pyplot().subplots(1, 3, figsize=(12, 3.6))
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
        "slipnav reproduce (systems/navigation/mixing/weights.py logsig, the mode's MixingParameters)",
        {"c1_transition_m_s": width, "b1": mixing.b1, "b3": mixing.b3},
    )


def seyr_fig5(run: Run, mode: str = "default") -> Reproduced:
    """Seyr Fig. 5: the step size delta_K S(22) reduced in the corner and the nominal trajectory point K
    linked to the interpolated point Pi_K S(24)-(25) (the paper's ovals)."""
    a, ref = run.arrays, run.reference
    fig, (ax, ax2) = agg_pyplot().subplots(1, 2, figsize=(12, 5), gridspec_kw={"width_ratios": [1, 1.3]})
    ax.plot(ref.x, ref.y, "k--", lw=1, label="reference (pre-planned)")
    ax.plot(a["true_x"], a["true_y"], "C0", lw=3, alpha=0.4, label="true")
    plot_associated_points(a, ref, ax, every=0.1)
    ax.plot([], [], color="0.6", label="K linked to $\\Pi_K$")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.legend(fontsize=7)
    ax.grid(True, alpha=0.3)
    moving = moving_mask(a)
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
    time_axis(ax2)
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
    t, moving = a["t"], moving_mask(a)
    v_ref, _, _ = retimed_reference(a, ref)
    fig, axes = agg_pyplot().subplots(4, 1, figsize=(9, 10), sharex=True)
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
        time_axis(ax, ax is axes[-1])
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
    fig, axes = agg_pyplot().subplots(3, 1, figsize=(10, 9), sharex=True)
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
        for start, end in true_spans(t, diverging):
            ax.axvspan(start, end, color="0.85", zorder=0)
    for ax, key in ((axes[0], "est_v_t"), (axes[2], "step_size")):
        ax.plot(onsets, np.interp(onsets, t, a[key]), "o", mfc="none", mec="k", ms=8, label="slip detected")
    axes[0].plot([], [], color="0.85", lw=6, label=f"|v_t error| > {DIVERGENCE:g} m/s")
    for ax in axes:
        ax.legend(loc="best", fontsize=7, ncol=2)
        time_axis(ax, ax is axes[-1])
    axes[0].set_xlim(float(a["start_time"]) - 0.2, t[-1])
    axes[0].set_title(f"Seyr Fig. 7 ({mode}): square, v_t and yaw rate, slip detection, step size")
    fig.tight_layout()
    T_C = float(a["T_C"])
    reduced = sum(bool(np.any(a["step_size"][(t >= o) & (t <= o + 3 * T_C)] < 1.0)) for o in onsets)
    div_time = float(np.sum(diverging) * float(a["T_N"]))
    near = sum(any(abs(s0 - o) < 0.1 for o in onsets) for s0, _ in true_spans(t, diverging))
    spans = len(true_spans(t, diverging))
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
    odometry-only paths; the final error in % of the path (Seyr §VII: about 2.5 %) and beside it the RMS
    and the maximum along the run (metrics.position_errors), which a closed path's end does not cancel."""
    fig, axes = agg_pyplot().subplots(1, 2, figsize=(12, 5.5))
    numbers = {}
    for ax, run, name in ((axes[0], corner, "corner"), (axes[1], square, "square")):
        a = run.arrays
        fused, odometry = percent_errors(run), percent_errors(run, "odo")
        ax.plot(run.reference.x, run.reference.y, "k--", lw=0.8, label="reference")
        ax.plot(a["true_x"], a["true_y"], "C0", lw=4, alpha=0.4, label="true")
        ax.plot(a["est_x"], a["est_y"], "C3", lw=1, label=f"fused ({percent_errors_text(fused)})")
        odometry_label = f"odometry only ({percent_errors_text(odometry)})"
        ax.plot(a["odo_x"], a["odo_y"], "C2", lw=0.8, label=odometry_label)
        ax.set_aspect("equal", adjustable="datalim")
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")
        ax.set_title(name)
        ax.legend(fontsize=7)
        ax.grid(True, alpha=0.3)
        numbers[f"{name}_fused_pct"] = percent_of_path(run)
        numbers[f"{name}_odometry_pct"] = percent_of_path(run, "odo")
        for figure in ("rms", "max"):
            numbers[f"{name}_fused_{figure}_pct"] = fused[figure]
            numbers[f"{name}_odometry_{figure}_pct"] = odometry[figure]
        numbers[f"{name}_fused_max_time_s"] = position_errors(a, "est")["max_time_s"]
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
        f"{numbers['corner_odometry_pct']:.2f} %, {numbers['square_odometry_pct']:.2f} %. Along the run "
        f"(the paper's figure is a final error): fused RMS {numbers['corner_fused_rms_pct']:.2f} %, "
        f"{numbers['square_fused_rms_pct']:.2f} %, max {numbers['corner_fused_max_pct']:.2f} % "
        f"(at {numbers['corner_fused_max_time_s']:.2f} s), {numbers['square_fused_max_pct']:.2f} % "
        f"(at {numbers['square_fused_max_time_s']:.2f} s); odometry only RMS "
        f"{numbers['corner_odometry_rms_pct']:.2f} %, {numbers['square_odometry_rms_pct']:.2f} %, max "
        f"{numbers['corner_odometry_max_pct']:.2f} %, {numbers['square_odometry_max_pct']:.2f} %.",
        f"{corner.command}; {square.command}",
        numbers,
    )


def slip_control_effect(with_sc: Run, without: Run) -> dict:
    """What slip control does on one scenario: peak |alpha| (deg), time with a wheel's |slip ratio| >
    EXCESSIVE_SLIP (s), fused final error (``pct``), its RMS and maximum along the run (``rms_pct``,
    ``max_pct``; % of the path), following time (s), with (``_on``) and without (``_off``)."""
    out = {}
    for tag, run in (("on", with_sc), ("off", without)):
        a = run.arrays
        slip = np.maximum(np.abs(a["true_slip_R"]), np.abs(a["true_slip_L"]))
        out[f"alpha_{tag}"] = float(np.degrees(np.nanmax(np.abs(moving_alpha(a)))))
        out[f"slip_time_{tag}"] = time_above(a, np.where(moving_mask(a), slip, 0.0), EXCESSIVE_SLIP)
        out[f"pct_{tag}"] = percent_of_path(run)
        errors = percent_errors(run)
        out[f"rms_pct_{tag}"], out[f"max_pct_{tag}"] = errors["rms"], errors["max"]
        out[f"time_{tag}"] = following_time(run)
    return out
