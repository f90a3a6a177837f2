"""Figures of a run: path, speeds, slip (Agg backend; files only)."""

from __future__ import annotations

from pathlib import Path as FilePath

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from slipnav.scenarios.metrics import moving_alpha  # noqa: E402


def _has(a, key) -> bool:
    return key in a and np.any(np.isfinite(a[key]))


def save_figure_atomically(fig, path) -> FilePath:
    """Write ``fig`` to ``path`` via a temporary file and a rename (no half-written figure), close it."""
    import matplotlib.pyplot as plt

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
    """Reference (None: none, e.g. a replayed log), true path (where known) and the estimates."""
    if reference is not None:
        ax.plot(reference.x, reference.y, "k--", lw=1, label="reference")
    if _has(a, "true_x"):
        ax.plot(a["true_x"], a["true_y"], "C0", lw=1.5, label="true")
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


def plot_speeds(a, reference, axes):
    t = a["t"]
    ax = axes[0]
    ax.plot(reference.t + _start(a), reference.v, "k--", lw=1, label="reference v")
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
    ax.plot(reference.t + _start(a), reference.omega, "k--", lw=1, label="reference $\\omega$")
    ax.plot(t, a["true_omega"], "C0", label="true $\\omega$")
    if _has(a, "est_omega"):
        ax.plot(t, a["est_omega"], "C3", lw=0.8, label="estimate $\\omega$")
    ax.set_ylabel("yaw rate (rad/s)")
    ax.set_xlabel("t (s)")
    ax.legend(loc="best", fontsize=7)
    for ax in axes:
        ax.grid(True, alpha=0.3)


def plot_slip(a, axes):
    t = a["t"]
    ax = axes[0]
    ax.plot(t, a["true_slip_R"], "C1", label="slip ratio R")
    ax.plot(t, a["true_slip_L"], "C2", label="slip ratio L")
    ax.plot(t, a["true_wheel_R"] - a["true_v_t"], "C1:", lw=0.8, label="$r\\dot\\theta_R - v_t$ (m/s)")
    ax.set_ylabel("tangential slip")
    ax.legend(loc="best", fontsize=7)
    ax = axes[1]
    ax.plot(t, np.degrees(moving_alpha(a)), "C0", label="true $\\alpha$")
    if _has(a, "est_alpha"):
        ax.plot(t, np.degrees(a["est_alpha"]), "C3", lw=0.8, label="estimate $\\alpha$")
    ax.set_ylabel("side-slip angle (deg)")
    ax.set_xlabel("t (s)")
    ax.legend(loc="best", fontsize=7)
    for ax in axes:
        ax.grid(True, alpha=0.3)


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
    axes[3].plot(t, np.degrees(moving_alpha(a)), "C0", lw=1.4, label="true")
    axes[3].plot(t, np.degrees(a["est_alpha"]), "C3", lw=0.8, label="estimate S(19)")
    axes[3].set_ylabel("$\\alpha$ (deg)")
    for key, color in (("C1", "C3"), ("C2", "C1"), ("C3", "C2")):
        axes[4].plot(t, a[key], color, lw=0.8, label=key)
    axes[4].set_ylabel("mixing")
    axes[4].set_ylim(-0.05, 1.05)
    axes[4].set_xlabel("t (s)")
    for ax in axes:
        for start, end in spans:
            ax.axvspan(start, end, color="0.85", zorder=0)
        ax.grid(True, alpha=0.3)
        ax.legend(loc="best", fontsize=7)


def plot_control(a, reference, axes):
    """Step size and progress vs nominal (Seyr Fig. 5) and wheel commands vs V_m (Indiveri Fig. 8-9)."""
    t = a["t"]
    T_C = float(a["T_C"])
    V_m = float(a["V_m"])
    ax = axes[0]
    if _has(a, "step_size"):
        ax.plot(t, a["step_size"], "C0", label="step size $\\delta_K$")
        ax.axhline(1.0, color="k", lw=0.6, ls="--")
        ax2 = ax.twinx()
        K = np.maximum(np.ceil((t - _start(a)) / T_C - 1e-9), 0.0)  # the log holds Pi_K+1 on (t_K, t_K+1]
        ax2.plot(t, a["progress"] - K, "C1", lw=0.8, label="$\\Pi_K - K$")
        ax2.set_ylabel("$\\Pi_K - K$ (samples)", color="C1")
    else:
        V1 = np.where(np.isfinite(a["V1"]), a["V1"], np.nan)
        ax.semilogy(t, np.maximum(V1, 1e-9), "C0", label="$V_1$ I(14)")
    ax.legend(loc="upper left", fontsize=7)
    ax = axes[1]
    ax.plot(t, a["cmd_R"], "C1", lw=0.8, label="command R")
    ax.plot(t, a["cmd_L"], "C2", lw=0.8, label="command L")
    ax.plot(t, a["true_wheel_R"], "C1:", lw=0.8, label="wheel R")
    ax.plot(t, a["true_wheel_L"], "C2:", lw=0.8, label="wheel L")
    ax.axhline(V_m, color="k", lw=0.8, ls="--", label="$V_m$")
    ax.set_ylabel("wheel speed (m/s)")
    ax.set_xlabel("t (s)")
    ax.legend(loc="best", fontsize=7, ncol=2)
    for ax in axes:
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


def _write_figure(out_dir, name: str, suffix: str, rows: int, size, draw, title: str) -> FilePath:
    """``out_dir/<name>.<suffix>.png``: ``rows`` stacked axes drawn by ``draw``, titled on the first."""
    fig, axes = plt.subplots(rows, 1, figsize=size, sharex=rows > 1)
    draw(axes)
    (axes if rows == 1 else axes[0]).set_title(f"{name}: {title}")
    path = FilePath(out_dir) / f"{name}.{suffix}.png"
    fig.savefig(path, dpi=110, bbox_inches="tight")
    plt.close(fig)
    return path


def write_figures(a, reference, out_dir, name: str) -> list[FilePath]:
    """<name>.path/.speeds/.navigation/.control/.slip.png (navigation and control when present)."""
    files = []

    def figure(suffix, rows, size, draw, title):
        files.append(_write_figure(out_dir, name, suffix, rows, size, draw, title))

    def path(ax):
        plot_path(a, reference, ax)
        plot_associated_points(a, reference, ax)

    linked = " (grey: nominal point K linked to Pi_K)" if _has(a, "progress") else ""
    figure("path", 1, (6, 6), path, "path" + linked)
    figure("speeds", 3, (9, 8), lambda axes: plot_speeds(a, reference, axes), "speeds")
    if _has(a, "est_v_t"):
        figure(
            "navigation",
            5,
            (9, 11),
            lambda axes: plot_navigation(a, axes),
            "navigation estimates vs truth (grey: detected tangential slip)",
        )
    if _has(a, "V1") or _has(a, "step_size"):
        figure("control", 2, (9, 6), lambda axes: plot_control(a, reference, axes), "control")
    figure("slip", 2, (9, 6), lambda axes: plot_slip(a, axes), "slip")
    return files


def write_replay_figures(a, out_dir, name: str) -> list[FilePath]:
    """<name>.path.png and <name>.navigation.png of a replayed sensor log (no reference; the truth where
    the log has it)."""
    files = []
    for suffix, rows, size, draw, title in (
        ("path", 1, (6, 6), lambda ax: plot_path(a, None, ax), "replayed path"),
        (
            "navigation",
            5,
            (9, 11),
            lambda axes: plot_navigation(a, axes),
            "navigation estimates" + (" vs truth" if _has(a, "true_v_t") else "") + " (grey: detected slip)",
        ),
    ):
        files.append(_write_figure(out_dir, name, suffix, rows, size, draw, title))
    return files
