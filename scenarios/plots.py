"""Figures of a run: path, speeds, slip (Agg backend; files only)."""

from __future__ import annotations

from pathlib import Path as FilePath

import numpy as np
from slipnav.scenarios.metrics import moving_alpha


def _has(a, key) -> bool:
    return key in a and np.any(np.isfinite(a[key]))


def agg_pyplot():
    """matplotlib.pyplot with the Agg backend (files only), imported where a figure is drawn: a command
    that draws none does not spend matplotlib's import time."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def save_figure_atomically(fig, path) -> FilePath:
    """Write ``fig`` to ``path`` via a temporary file and a rename (no half-written figure), close it."""
    plt = agg_pyplot()
    path = FilePath(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.stem + ".tmp.png")
    fig.savefig(tmp, dpi=110)
    plt.close(fig)
    tmp.replace(path)
    return path


def _start(a) -> float:
    """When the controller started (the standstill before it; 0 in artifacts without the key)."""
    return float(a["start_time"]) if "start_time" in a else 0.0


def plot_path(a, reference, ax):
    """Reference (None: none, e.g. a replayed log), true path (where known) and the estimates. The truth is
    a wide pale band drawn first, the estimates thin lines on top: where an estimate is good it runs inside
    the band, and neither hides the other."""
    if _has(a, "true_x"):
        ax.plot(a["true_x"], a["true_y"], "C0", lw=5, alpha=0.35, solid_capstyle="round", label="true")
    if reference is not None:
        ax.plot(reference.x, reference.y, "k--", lw=1, label="reference")
    for prefix, label, style in (
        ("est", "fused estimate", "C1"),
        ("odo", "odometry only", "C2"),
        ("gyro", "Gyrodometry", "C3"),
    ):
        if _has(a, f"{prefix}_x"):
            ax.plot(a[f"{prefix}_x"], a[f"{prefix}_y"], style, lw=1, label=label)
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.grid(True, alpha=0.3)
    ax.legend(loc="best", fontsize=8)


def loop_kind(a) -> str:
    """What ran, from the artifact: "open loop (feed-forward)" when there is no follower (V1 all NaN),
    else "closed loop"."""
    return "closed loop" if _has(a, "V1") else "open loop (feed-forward)"


def retimed_reference(a, reference):
    """The reference as the closed loop asked for it (None open loop: the nominal-time reference is what
    was played back).

    Trajectory mode: the point Pi_K that slip control reached (S(24)), played at the step size's pace:
    v = delta_K v_ref(Pi_K), omega = delta_K omega_ref(Pi_K) (S(25): the velocities expanded or compressed
    by delta). Path mode: the commanded speed u = (v_R + v_L)/2 (I(24)'s, after the saturator) and the
    path's yaw rate at it, kappa_r(s) u, at the virtual target s. Returns (v, omega, label).
    """
    if _has(a, "progress"):
        index = np.arange(reference.num_samples)
        delta = a["step_size"]
        v = delta * np.interp(a["progress"], index, reference.v)
        omega = delta * np.interp(a["progress"], index, reference.omega)
        return v, omega, "reference at $\\Pi_K$, $\\times\\delta_K$"
    if _has(a, "V1") and _has(a, "virtual_target"):
        u = 0.5 * (a["cmd_R"] + a["cmd_L"])
        kappa = np.interp(a["virtual_target"], reference.s, reference.kappa)
        return u, kappa * u, "commanded $u$ (I(24), saturated), $\\kappa_r(s)\\,u$"
    return None


def plot_speeds(a, reference, axes):
    """v_t, v_n and omega, true and estimated, against the reference as the run used it
    (retimed_reference; open loop the nominal-time reference, which is what was played back; in closed
    loop the nominal-time reference is drawn pale for comparison)."""
    t = a["t"]
    retimed = retimed_reference(a, reference)
    ax = axes[0]
    if retimed is None:
        ax.plot(reference.t + _start(a), reference.v, "k--", lw=1, label="reference v (played back)")
    else:
        ax.plot(
            reference.t + _start(a), reference.v, color="0.7", lw=1, ls="--", label="reference, nominal time"
        )
        ax.plot(t, retimed[0], "k--", lw=1, label=retimed[2])
    ax.plot(t, a["true_v_t"], "C0", label="true $v_t$")
    ax.plot(t, a["true_wheel_R"], "C1", lw=0.8, label="wheel R $r\\dot\\theta_R$")
    ax.plot(t, a["true_wheel_L"], "C2", lw=0.8, label="wheel L $r\\dot\\theta_L$")
    if _has(a, "cmd_R"):
        ax.plot(t, a["cmd_R"], "C1:", lw=0.8, label="command R")
        ax.plot(t, a["cmd_L"], "C2:", lw=0.8, label="command L")
    if _has(a, "est_v_t"):
        ax.plot(t, a["est_v_t"], "C3", lw=0.8, label="estimate $v_t$")
    ax.set_ylabel("speed (m/s)")
    ax.legend(loc="best", fontsize=7, ncol=2)
    ax = axes[1]
    ax.plot(t, a["true_v_n"], "C0", label="true $v_n$")
    if _has(a, "est_v_n"):
        ax.plot(t, a["est_v_n"], "C3", lw=0.8, label="estimate $v_n$")
    ax.set_ylabel("lateral speed (m/s)")
    ax.legend(loc="best", fontsize=7)
    ax = axes[2]
    if retimed is None:
        ax.plot(
            reference.t + _start(a), reference.omega, "k--", lw=1, label="reference $\\omega$ (played back)"
        )
    else:
        ax.plot(reference.t + _start(a), reference.omega, color="0.7", lw=1, ls="--", label="nominal time")
        ax.plot(t, retimed[1], "k--", lw=1, label=retimed[2])
    ax.plot(t, a["true_omega"], "C0", label="true $\\omega$")
    if _has(a, "est_omega"):
        ax.plot(t, a["est_omega"], "C3", lw=0.8, label="estimate $\\omega$")
    ax.set_ylabel("yaw rate (rad/s)")
    ax.set_xlabel("t (s)")
    ax.legend(loc="best", fontsize=7)
    for ax in axes:
        ax.grid(True, alpha=0.3)


def plot_slip(a, axes):
    """Tangential slip as the tyres' slip ratios (1) and as the wheels' circumferential speed minus the
    body's v_t (m/s), one quantity per axis, and the side-slip angle."""
    t = a["t"]
    ax = axes[0]
    ax.plot(t, a["true_slip_R"], "C1", label="slip ratio R")
    ax.plot(t, a["true_slip_L"], "C2", label="slip ratio L")
    ax.set_ylabel("slip ratio (1)")
    ax.legend(loc="best", fontsize=7)
    ax = axes[1]
    ax.plot(t, a["true_wheel_R"] - a["true_v_t"], "C1", lw=0.8, label="$r\\dot\\theta_R - v_t$")
    ax.plot(t, a["true_wheel_L"] - a["true_v_t"], "C2", lw=0.8, label="$r\\dot\\theta_L - v_t$")
    ax.set_ylabel("slip speed (m/s)")
    ax.legend(loc="best", fontsize=7)
    ax = axes[2]
    ax.plot(t, np.degrees(moving_alpha(a)), "C0", label="true $\\alpha$")
    if _has(a, "est_alpha"):
        ax.plot(t, np.degrees(a["est_alpha"]), "C3", lw=0.8, label="estimate $\\alpha$")
    ax.set_ylabel("side-slip angle (deg)")
    ax.set_xlabel("t (s)")
    ax.legend(loc="best", fontsize=7)
    for ax in axes:
        ax.grid(True, alpha=0.3)


def plot_position_error(a, axes):
    """Distance of each estimate's position from the true one (m) and its heading error (deg) against
    time: where the final errors of the summary and of ``slipnav accuracy`` come from."""
    t = a["t"]
    for prefix, label, color in (
        ("est", "fused estimate", "C1"),
        ("odo", "odometry only", "C2"),
        ("gyro", "Gyrodometry", "C3"),
    ):
        if not _has(a, f"{prefix}_x"):
            continue
        error = np.hypot(a[f"{prefix}_x"] - a["true_x"], a[f"{prefix}_y"] - a["true_y"])
        axes[0].plot(t, error, color, lw=1, label=label)
        heading = np.angle(np.exp(1j * (a[f"{prefix}_phi"] - a["true_phi"])))
        axes[1].plot(t, np.degrees(heading), color, lw=1, label=label)
    axes[0].set_ylabel("position error (m)")
    axes[1].set_ylabel("heading error (deg)")
    axes[1].set_xlabel("t (s)")
    for ax in axes:
        ax.grid(True, alpha=0.3)
        ax.legend(loc="best", fontsize=7)


def slip_spans(t, c1, level: float = 0.5):
    """(start, end) times where C1 < level: detected tangential slip."""
    low = c1 < level
    edges = np.flatnonzero(np.diff(low.astype(int))) + 1
    bounds = np.r_[0, edges, len(t)]
    return [(t[i], t[min(j, len(t) - 1)]) for i, j in zip(bounds[:-1], bounds[1:], strict=True) if low[i]]


def plot_navigation(a, axes):
    """Seyr & Jakubek Fig. 6-7 style: estimates vs truth with detected slip (C1 < 0.5) shaded."""
    t = a["t"]
    spans = slip_spans(t, a["C1"])
    panels = (
        (
            "$v_t$ (m/s)",
            [("true_v_t", "true", "C0"), ("est_v_t", "fused", "C3"), ("odo_v_t", "odometry", "C2")],
        ),
        ("$v_n$ (m/s)", [("true_v_n", "true", "C0"), ("est_v_n", "fused", "C3")]),
        (
            "$\\omega$ (rad/s)",
            [("true_omega", "true", "C0"), ("est_omega", "fused", "C3"), ("odo_omega", "odometry", "C2")],
        ),
    )
    for ax, (label, series) in zip(axes[:3], panels, strict=False):
        for key, name, color in series:
            ax.plot(t, a[key], color, lw=1.4 if name == "true" else 0.8, label=name)
        ax.set_ylabel(label)
    if "free_v_n" in a:  # S(17)'s tyre-model check: the free integral of the lateral kinematics
        axes[1].plot(t, a["free_v_n"], "C4", lw=0.6, ls="--", label="free integral (check)")
    axes[3].plot(t, np.degrees(moving_alpha(a)), "C0", lw=1.4, label="true")
    axes[3].plot(t, np.degrees(a["est_alpha"]), "C3", lw=0.8, label="estimate S(19)")
    axes[3].set_ylabel("$\\alpha$ (deg)")
    for key, color in (("C1", "C3"), ("C2", "C1"), ("C3", "C2")):
        axes[4].plot(t, a[key], color, lw=0.8, label=key)
    if "tyre_model_weight" in a:
        axes[4].plot(t, a["tyre_model_weight"], "C4", lw=0.8, label="w (tyre-model check)")
    axes[4].set_ylabel("mixing")
    axes[4].set_ylim(-0.05, 1.05)
    axes[4].set_xlabel("t (s)")
    if _has(a, "est_tyre_peak") and np.all(np.isfinite(a["est_tyre_peak"])):  # mixing.tyre_peak_step
        identified = a["est_tyre_peak"]
        believed = identified[0]
        peak = axes[4].twinx()
        peak.plot(t, identified, "C5", lw=1.0, label="$a_{peak}$ identified")
        peak.axhline(believed, color="C5", lw=0.6, ls=":", label="$a_{peak}$ believed at start")
        # at least +-20 % of the start, so that a change of 1 % reads flat
        peak.set_ylim(min(0.8 * believed, identified.min()), max(1.2 * believed, identified.max()))
        peak.set_ylabel("$a_{peak}$ (m/s$^2$)")
        peak.legend(loc="lower right", fontsize=7)
    for ax in axes:
        for start, end in spans:
            ax.axvspan(start, end, color="0.85", zorder=0)
        ax.grid(True, alpha=0.3)
        ax.legend(loc="best", fontsize=7)


def plot_control(a, reference, axes):
    """Step size and progress vs nominal (Seyr Fig. 5, trajectory mode), V1 of I(14), and wheel commands
    vs V_m (Indiveri Fig. 8-9); ``axes``: 3 with a step size, else 2."""
    t = a["t"]
    T_C = float(a["T_C"])
    V_m = float(a["V_m"])
    panels = list(axes)
    axes = list(axes)
    if _has(a, "step_size"):
        ax = axes.pop(0)
        ax.plot(t, a["step_size"], "C0", label="step size $\\delta_K$ S(22)")
        ax.axhline(1.0, color="k", lw=0.6, ls="--")
        ax.set_ylabel("step size $\\delta_K$ (1)", color="C0")
        ax2 = ax.twinx()
        K = np.maximum(np.ceil((t - _start(a)) / T_C - 1e-9), 0.0)  # the log holds Pi_K+1 on (t_K, t_K+1]
        ax2.plot(t, a["progress"] - K, "C1", lw=0.8, label="$\\Pi_K - K$ S(24)")
        ax2.set_ylabel("$\\Pi_K - K$ (control samples)", color="C1")
        ax.legend(loc="upper left", fontsize=7)
        ax2.legend(loc="lower left", fontsize=7)
    ax = axes.pop(0)
    V1 = np.where(np.isfinite(a["V1"]), a["V1"], np.nan)
    ax.semilogy(t, np.maximum(V1, 1e-9), "C0", label="$V_1$ I(14)")
    ax.set_ylabel("$V_1$ (m$^2$)")
    ax.legend(loc="upper left", fontsize=7)
    ax = axes.pop(0)
    ax.plot(t, a["cmd_R"], "C1", lw=0.8, label="command R")
    ax.plot(t, a["cmd_L"], "C2", lw=0.8, label="command L")
    ax.plot(t, a["true_wheel_R"], "C1:", lw=0.8, label="wheel R")
    ax.plot(t, a["true_wheel_L"], "C2:", lw=0.8, label="wheel L")
    ax.axhline(V_m, color="k", lw=0.8, ls="--", label="$V_m$")
    ax.set_ylabel("wheel speed (m/s)")
    ax.set_xlabel("t (s)")
    ax.legend(loc="best", fontsize=7, ncol=2)
    for ax in panels:
        ax.grid(True, alpha=0.3)


def plot_associated_points(a, reference, ax, every: float = 0.2):
    """Seyr Fig. 5: nominal trajectory point K linked with the interpolated point at Pi_K."""
    if not _has(a, "progress"):
        return
    T_C = float(a["T_C"])
    step = max(int(round(every / float(a["T_N"]))), 1)
    for k in range(0, len(a["t"]), step):
        K = min(max(int(round((a["t"][k] - _start(a)) / T_C)), 0), reference.num_samples - 1)
        ax.plot([reference.x[K], a["ref_x"][k]], [reference.y[K], a["ref_y"][k]], color="0.6", lw=0.6)
        ax.plot(reference.x[K], reference.y[K], "o", color="0.6", ms=2)


def _write_figure(
    out_dir, name: str, suffix: str, rows: int, size, draw, title: str, kind: str = ""
) -> FilePath:
    """``out_dir/<name>.<suffix>.png``: ``rows`` stacked axes drawn by ``draw``, titled "<name> (<kind>):
    <title>" on the first."""
    plt = agg_pyplot()
    fig, axes = plt.subplots(rows, 1, figsize=size, sharex=rows > 1)
    draw(axes)
    (axes if rows == 1 else axes[0]).set_title(f"{name}{f' ({kind})' if kind else ''}: {title}")
    path = FilePath(out_dir) / f"{name}.{suffix}.png"
    fig.savefig(path, dpi=110, bbox_inches="tight")
    plt.close(fig)
    return path


def write_figures(a, reference, out_dir, name: str) -> list[FilePath]:
    """<name>.path/.error/.speeds/.navigation/.control/.slip.png (navigation and control when present),
    each titled with what ran: open or closed loop (loop_kind)."""
    files = []
    kind = loop_kind(a)

    def figure(suffix, rows, size, draw, title, detail=""):
        title += f"\n{detail}" if detail else ""
        files.append(_write_figure(out_dir, name, suffix, rows, size, draw, title, kind))

    def path(ax):
        plot_path(a, reference, ax)
        plot_associated_points(a, reference, ax)

    linked = "grey: nominal point K linked to $\\Pi_K$" if _has(a, "progress") else ""
    figure("path", 1, (6, 6), path, "path", linked)
    if _has(a, "est_x"):
        figure(
            "error",
            2,
            (9, 6),
            lambda axes: plot_position_error(a, axes),
            "position and heading error of the estimates",
        )
    if _has(a, "progress"):
        retimed = "black dashed: the reference where slip control was ($\\Pi_K$), at its pace $\\delta_K$"
    elif _has(a, "V1"):
        retimed = "black dashed: the commanded speed u and the path's yaw rate at it"
    else:
        retimed = "black dashed: the reference played back"
    figure("speeds", 3, (9, 8), lambda axes: plot_speeds(a, reference, axes), "speeds", retimed)
    if _has(a, "est_v_t"):
        figure(
            "navigation",
            5,
            (9, 11),
            lambda axes: plot_navigation(a, axes),
            "navigation estimates vs truth",
            "grey: detected tangential slip",
        )
    if _has(a, "V1"):
        rows = 3 if _has(a, "step_size") else 2
        figure("control", rows, (9, 3 * rows), lambda axes: plot_control(a, reference, axes), "control")
    figure("slip", 3, (9, 8), lambda axes: plot_slip(a, axes), "slip")
    return files


def write_replay_figures(a, out_dir, name: str) -> list[FilePath]:
    """<name>.path.png, <name>.navigation.png and, where the log has the truth, <name>.error.png of a
    replayed sensor log (no reference, no controller: navigation only)."""
    files = []
    figures = [
        ("path", 1, (6, 6), lambda ax: plot_path(a, None, ax), "replayed path"),
        (
            "navigation",
            5,
            (9, 11),
            lambda axes: plot_navigation(a, axes),
            "navigation estimates" + (" vs truth" if _has(a, "true_v_t") else "") + " (grey: detected slip)",
        ),
    ]
    if _has(a, "true_x"):
        figures.append(
            ("error", 2, (9, 6), lambda axes: plot_position_error(a, axes), "replayed estimates minus truth")
        )
    for suffix, rows, size, draw, title in figures:
        files.append(_write_figure(out_dir, name, suffix, rows, size, draw, title))
    return files
