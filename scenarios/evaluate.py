"""``slipnav evaluate LOG --truth TRUTH [--model MODEL.yaml] [--out DIR] [--engine plain|diagram]``: the
fused estimate, odometry-only and Gyrodometry of a replayed sensor log against a ground truth
(docs/robot-logs.md).

LOG is a sensor log (``.csv``: replayed first, as ``slipnav replay --no-figures`` does, by the replay
engine ``--engine``, its npz and summary written beside the evaluation) or a replay's or run's artifact
(``.npz``). TRUTH is a ground-truth CSV (``t,x,y,yaw,quality``, t on the log's clock; ``slipnav import``
writes one). Per estimate, on the log's samples the truth covers (the truth linearly interpolated
between seen rows, outages left out):

- the estimate is first aligned on its start pose (the rigid motion that puts its first pose on the
  truth's); nothing else is fitted;
- ``final_error_m``: distance of the last positions; ``ate_m``: RMS of the position distances (absolute
  trajectory error); ``final_heading_error_deg`` and ``rms_heading_error_deg``;
- ``rpe_per_m``: relative pose error over 1 m of the truth's path (from each sample to the first one at
  least 1 m farther along), the RMS of the translation error of the relative motion (m, per metre
  driven) and of its rotation (deg); ``rpe_per_10s``: the same over 10 s;
- ``windowed_ate``: on a log of two ATE_WINDOW (30 s) windows or more, the estimate aligned afresh on the
  truth's pose at the start of each consecutive window and the RMS of its position distances over the
  window; the median and the 90th percentile over the windows (m): how far an estimate drifts in
  30 s wherever it starts, which a long log's one-start ATE hides.

It writes ``<name>.evaluation.json`` (the figures, the health shares of the npz's ``health_*``, ``fault``
and C1 < 0.75), ``<name>.evaluation.png`` (the three paths over the truth, the position errors) and
TUM trajectories ``<name>-{truth,fused,odometry,gyrodometry}.tum`` (``timestamp x y z qx qy qz qw``; evo
reads them: ``evo_ape tum <name>-truth.tum <name>-fused.tum``).
"""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path as FilePath

import numpy as np
from slipnav.scenarios.artifacts import check_output_directory
from slipnav.scenarios.config import ScenarioError
from slipnav.scenarios.files import write_text_atomically
from slipnav.scenarios.metrics import ESTIMATES
from slipnav.scenarios.replay import replay_file, write_replay_artifacts
from slipnav.scenarios.replay_engines import REPLAY_ENGINES

TRUTH_COLUMNS = ("t", "x", "y", "yaw", "quality")
RPE_DISTANCE = 1.0
RPE_TIME = 10.0
SLIP_C1 = 0.75
"""C1 below this is read as slip (Seyr's mixing trusts the wheels less)."""
ATE_WINDOW = 30.0
"""Length (s) of the windows of the windowed ATE (module docstring)."""
TRUTH_GAP_ROWS = 2.5
"""A log sample is judged where the seen truth rows around it are at most this many of the truth's median
row intervals apart (one unseen row is bridged, a longer outage is not)."""


class EvaluationError(ScenarioError):
    """A truth file or LOG that cannot be evaluated; the message names the file, the column, the row."""


def read_truth(path) -> dict:
    """The ground-truth CSV: ``t,x,y,yaw,quality`` (any order; ``#`` comment lines before the header);
    rows with quality 0 or an empty pose are unseen. Returns the seen rows' arrays."""
    path = FilePath(path)
    try:
        with open(path, newline="", encoding="utf-8") as handle:
            rows = [r for r in csv.reader(handle)]
    except (OSError, UnicodeDecodeError) as e:
        raise EvaluationError(
            f"--truth={str(path)!r} cannot be read: {getattr(e, 'strerror', None) or e}"
        ) from None
    lines = [(k + 1, r) for k, r in enumerate(rows) if r and not r[0].lstrip().startswith("#")]
    if not lines:
        raise EvaluationError(
            f"--truth={str(path)!r} has no header: allowed columns {','.join(TRUTH_COLUMNS)}"
        )
    header = [h.strip() for h in lines[0][1]]
    for name in TRUTH_COLUMNS:
        if name not in header:
            raise EvaluationError(f"--truth={str(path)!r}: column {name!r} is missing (line {lines[0][0]})")
    index = [header.index(c) for c in TRUTH_COLUMNS]
    data = np.full((len(lines) - 1, len(TRUTH_COLUMNS)), np.nan)
    for i, (line, row) in enumerate(lines[1:]):
        for j, k in enumerate(index):
            cell = row[k].strip() if k < len(row) else ""
            try:
                data[i, j] = float(cell) if cell else math.nan
            except ValueError:
                raise EvaluationError(
                    f"--truth={str(path)!r}, column {TRUTH_COLUMNS[j]!r}, line {line}: {cell!r} is not a "
                    "number"
                ) from None
    t = data[:, 0]
    if len(t) < 2 or not np.all(np.diff(t) > 0):
        raise EvaluationError(f"--truth={str(path)!r}: column 't' must increase over two rows or more")
    seen = (data[:, 4] > 0) & np.all(np.isfinite(data[:, :4]), axis=1)
    if seen.sum() < 2:
        raise EvaluationError(f"--truth={str(path)!r}: fewer than two seen rows (quality 1)")
    return {c: data[seen, j] for j, c in enumerate(TRUTH_COLUMNS[:4])}


def truth_on(t, truth: dict) -> tuple[np.ndarray, np.ndarray]:
    """(poses (N, 3) x, y, yaw of the truth at ``t``, covered (N,) bool): linear interpolation (yaw
    unwrapped) between the seen rows around each instant, where they are at most TRUTH_GAP_ROWS median
    row intervals apart."""
    tt = truth["t"]
    yaw = np.unwrap(truth["yaw"])
    pose = np.column_stack(
        [np.interp(t, tt, truth["x"]), np.interp(t, tt, truth["y"]), np.interp(t, tt, yaw)]
    )
    k = np.clip(np.searchsorted(tt, t), 1, len(tt) - 1)
    gap = TRUTH_GAP_ROWS * float(np.median(np.diff(tt)))
    covered = (t >= tt[0]) & (t <= tt[-1]) & (tt[k] - tt[k - 1] <= gap)
    return pose, covered


def align_start(estimate: np.ndarray, truth: np.ndarray) -> np.ndarray:
    """``estimate`` (N, 3) moved rigidly so that its first pose is the truth's first pose."""
    turn = truth[0, 2] - estimate[0, 2]
    c, s = math.cos(turn), math.sin(turn)
    dx, dy = estimate[:, 0] - estimate[0, 0], estimate[:, 1] - estimate[0, 1]
    return np.column_stack(
        [truth[0, 0] + c * dx - s * dy, truth[0, 1] + s * dx + c * dy, estimate[:, 2] + turn]
    )


def _wrap(angle):
    return (np.asarray(angle) + math.pi) % (2 * math.pi) - math.pi


def relative_pose_error(estimate, truth, pairs) -> tuple[float, float]:
    """RMS translation (m) and rotation (deg) errors of the relative motions between the index pairs
    (i, j): the truth's motion from i to j seen from pose i against the estimate's (evo's RPE)."""
    i, j = pairs
    if len(i) == 0:
        return math.nan, math.nan

    def motion(p):
        dx, dy = p[j, 0] - p[i, 0], p[j, 1] - p[i, 1]
        c, s = np.cos(p[i, 2]), np.sin(p[i, 2])
        return c * dx + s * dy, -s * dx + c * dy, p[j, 2] - p[i, 2]

    ex, ey, ea = motion(estimate)
    tx, ty, ta = motion(truth)
    # (truth motion)^-1 * (estimate motion): the translation error in the truth motion's end frame
    c, s = np.cos(ta), np.sin(ta)
    ux, uy = ex - tx, ey - ty
    err_t = np.hypot(c * ux + s * uy, -s * ux + c * uy)
    err_r = _wrap(ea - ta)
    return float(np.sqrt(np.mean(err_t**2))), float(np.degrees(np.sqrt(np.mean(err_r**2))))


def pairs_by(values, delta: float) -> tuple[np.ndarray, np.ndarray]:
    """Index pairs (i, j): j the first index with values[j] >= values[i] + delta (values non-decreasing)."""
    values = np.asarray(values, float)
    j = np.searchsorted(values, values + delta - 1e-12, side="left")
    keep = j < len(values)
    return np.flatnonzero(keep), j[keep]


def windowed_ate(t, estimate, truth, window: float = ATE_WINDOW) -> dict | None:
    """The windowed ATE (module docstring) of ``estimate`` (N, 3) against ``truth`` (N, 3) at instants
    ``t`` (s): consecutive windows of ``window`` s from the first instant, the last partial one left out,
    a window with fewer than two samples skipped; None for fewer than two windows."""
    starts = np.arange(t[0], t[-1] - window + 1e-9, window)
    errors = []
    for start in starts:
        inside = (t >= start) & (t < start + window)
        if inside.sum() < 2:
            continue
        aligned = align_start(estimate[inside], truth[inside])
        d = np.hypot(aligned[:, 0] - truth[inside, 0], aligned[:, 1] - truth[inside, 1])
        errors.append(float(np.sqrt(np.mean(d**2))))
    if len(errors) < 2:
        return None
    return {
        "window_s": window,
        "windows": len(errors),
        "median_m": float(np.median(errors)),
        "p90_m": float(np.percentile(errors, 90)),
        "per_window_m": errors,
    }


def trajectory_metrics(t, estimate, truth) -> dict:
    """The figures of one estimate (N, 3) against the truth (N, 3) on the same instants (module
    docstring)."""
    aligned = align_start(estimate, truth)
    d = np.hypot(aligned[:, 0] - truth[:, 0], aligned[:, 1] - truth[:, 1])
    heading = _wrap(aligned[:, 2] - truth[:, 2])
    path = np.r_[0.0, np.cumsum(np.hypot(np.diff(truth[:, 0]), np.diff(truth[:, 1])))]
    rpe_m = relative_pose_error(aligned, truth, pairs_by(path, RPE_DISTANCE))
    rpe_s = relative_pose_error(aligned, truth, pairs_by(t, RPE_TIME))
    return {
        "final_error_m": float(d[-1]),
        "ate_m": float(np.sqrt(np.mean(d**2))),
        "final_heading_error_deg": float(np.degrees(heading[-1])),
        "rms_heading_error_deg": float(np.degrees(np.sqrt(np.mean(heading**2)))),
        "rpe_per_m": {"translation_m": rpe_m[0], "rotation_deg": rpe_m[1]},
        "rpe_per_10s": {"translation_m": rpe_s[0], "rotation_deg": rpe_s[1]},
        "windowed_ate": windowed_ate(t, estimate, truth),
        "path_length_m": float(path[-1]),
    }


def health_shares(a: dict) -> dict:
    """Shares of the samples: any ``health_*`` channel flagged (code > 0), each channel, ``fault`` set and
    C1 < SLIP_C1."""
    channels = sorted(k for k in a if k.startswith("health_"))
    n = len(a["t"])
    flags = {k.removeprefix("health_"): np.nan_to_num(np.asarray(a[k], float)) > 0 for k in channels}
    out = {
        "any_health_channel": float(np.mean(np.any(list(flags.values()), axis=0))) if flags else None,
        "channels": {k: float(np.mean(v)) for k, v in flags.items()},
    }
    if "fault" in a:
        out["fault"] = float(np.mean(np.nan_to_num(np.asarray(a["fault"], float)) > 0))
    if "C1" in a and np.any(np.isfinite(a["C1"])):
        out[f"C1_below_{SLIP_C1}"] = float(np.sum(np.asarray(a["C1"]) < SLIP_C1) / n)
    return out


def evaluate_arrays(a: dict, truth: dict) -> dict:
    """Every estimate of the artifact arrays ``a`` (ESTIMATES: ``est``, ``odo``, ``gyro``) against the
    truth; the health shares; what the truth covered."""
    t = np.asarray(a["t"], float)
    pose, covered = truth_on(t, truth)
    result = {"estimates": {}, "truth": {}}
    for label, prefix in ESTIMATES:
        est = np.column_stack([np.asarray(a[f"{prefix}_{c}"], float) for c in ("x", "y", "phi")])
        ok = covered & np.all(np.isfinite(est), axis=1)
        if ok.sum() < 2:
            result["estimates"][label] = None
            continue
        est[:, 2] = np.unwrap(est[:, 2])
        result["estimates"][label] = trajectory_metrics(t[ok], est[ok], pose[ok])
    result["truth"] = {
        "covered_share": float(np.mean(covered)),
        "start_s": float(t[covered][0]) if covered.any() else None,
        "end_s": float(t[covered][-1]) if covered.any() else None,
    }
    result["health"] = health_shares(a)
    return result


def windowed_text(windowed: dict | None) -> str:
    """The printed line's part of the windowed ATE (empty without one)."""
    if windowed is None:
        return ""
    return (
        f", ATE over {windowed['window_s']:g} s windows median {windowed['median_m']:.3f} m, 90 % "
        f"{windowed['p90_m']:.3f} m"
    )


def tum_text(t, x, y, yaw) -> str:
    """TUM trajectory lines ``timestamp x y z qx qy qz qw`` (z = 0, the rotation about z)."""
    lines = [
        f"{ti:.6f} {xi!r} {yi!r} 0 0 0 {math.sin(0.5 * p)!r} {math.cos(0.5 * p)!r}"
        for ti, xi, yi, p in zip(*(np.asarray(v, float).tolist() for v in (t, x, y, yaw)), strict=True)
        if math.isfinite(xi) and math.isfinite(yi) and math.isfinite(p)
    ]
    return "# timestamp x y z qx qy qz qw\n" + "\n".join(lines) + "\n"


def plot_evaluation(a: dict, truth: dict, title: str, path) -> FilePath:
    """The truth's path (a wide pale band) under the three estimates; each one's position error."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from slipnav.scenarios.plots import save_figure_atomically

    fig, (ax, bx) = plt.subplots(1, 2, figsize=(13, 6), gridspec_kw={"width_ratios": [1.1, 1]})
    ax.plot(truth["x"], truth["y"], "C0", lw=6, alpha=0.35, solid_capstyle="round", label="truth")
    t = np.asarray(a["t"], float)
    pose, covered = truth_on(t, truth)
    for (label, prefix), style in zip(ESTIMATES, ("C1", "C2", "C3"), strict=True):
        est = np.column_stack([np.asarray(a[f"{prefix}_{c}"], float) for c in ("x", "y", "phi")])
        ok = covered & np.all(np.isfinite(est), axis=1)
        if ok.sum() < 2:
            continue
        aligned = align_start(est[ok], pose[ok])
        ax.plot(aligned[:, 0], aligned[:, 1], style, lw=1, label=label)
        bx.plot(t[ok], np.hypot(*(aligned[:, :2] - pose[ok, :2]).T), style, lw=1, label=label)
    ax.set_aspect("equal", adjustable="datalim")
    ax.set(xlabel="x (m)", ylabel="y (m)", title="paths (start pose aligned)")
    bx.set(xlabel="t (s)", ylabel="position error (m)", title="distance from the truth")
    for axis in (ax, bx):
        axis.grid(True, alpha=0.3)
        axis.legend(loc="best", fontsize=8)
    fig.suptitle(title)
    fig.tight_layout()
    return save_figure_atomically(fig, path)


def load_estimates(log, truth_path, model=None, out_dir="runs", engine=None) -> tuple[str, dict, list]:
    """(name, arrays, written files) of LOG: an npz's arrays, or a sensor log replayed by ``engine`` (None:
    the default, REPLAY_ENGINES[0]; its npz and summary written into ``out_dir``)."""
    path = FilePath(log)
    if path.suffix == ".npz":
        for option, value in (("--model", model), ("--engine", engine)):
            if value is not None:
                raise EvaluationError(
                    f"{option} applies to a sensor log (.csv), not to an npz: allowed no {option}"
                )
        try:
            with np.load(path) as data:
                a = {k: data[k] for k in data.files}
        except (OSError, ValueError) as e:
            raise EvaluationError(f"LOG={str(path)!r} cannot be read as an npz: {e}") from None
        missing = [k for k in ("t", "est_x", "est_y", "est_phi") if k not in a]
        if missing:
            raise EvaluationError(
                f"LOG={str(path)!r} lacks {', '.join(missing)}: allowed a run or replay npz"
            )
        return path.stem, a, []
    if path.suffix != ".csv":
        raise EvaluationError(f"LOG={str(path)!r}: allowed a sensor log (.csv) or a run or replay npz (.npz)")

    result = replay_file(path, model, engine or REPLAY_ENGINES[0])
    written = write_replay_artifacts(result, out_dir, figures=False)
    return f"{result.name}-replay", result.arrays, written


def evaluate_command(log, truth_path, out_dir="runs", model=None, engine=None) -> dict:
    """``slipnav evaluate``: check the inputs, replay where needed (by ``engine``, load_estimates),
    evaluate, write, print one line per estimate."""

    truth = read_truth(truth_path)
    out = check_output_directory(out_dir)
    if not FilePath(log).is_file():
        raise EvaluationError(f"LOG={str(log)!r} is not a file: allowed a sensor log (.csv) or an npz")
    name, a, written = load_estimates(log, truth_path, model, out, engine)
    result = evaluate_arrays(a, truth)
    result.update(log=str(log), truth_file=str(truth_path))
    if result["truth"]["start_s"] is None:
        raise EvaluationError(
            f"--truth={str(truth_path)!r} covers none of LOG's times: allowed the log's clock"
        )
    t = np.asarray(a["t"], float)
    files = list(written)
    files.append(
        write_text_atomically(
            out / f"{name}-truth.tum", [tum_text(truth["t"], truth["x"], truth["y"], truth["yaw"])]
        )
    )
    for label, prefix in ESTIMATES:
        x, y, p = (np.asarray(a[f"{prefix}_{c}"], float) for c in ("x", "y", "phi"))
        files.append(write_text_atomically(out / f"{name}-{label}.tum", [tum_text(t, x, y, p)]))
    files.append(
        plot_evaluation(a, truth, f"{name}: estimates against the truth", out / f"{name}.evaluation.png")
    )
    files.append(
        write_text_atomically(out / f"{name}.evaluation.json", [json.dumps(result, indent=2) + "\n"])
    )
    for path in files:
        print(path)
    for label, m in result["estimates"].items():
        if m is None:
            print(f"{name} {label}: not estimated")
            continue
        print(
            f"{name} {label}: final {m['final_error_m']:.3f} m, ATE {m['ate_m']:.3f} m, heading "
            f"{m['final_heading_error_deg']:+.2f} deg, RPE {m['rpe_per_m']['translation_m']:.3f} m per m, "
            f"{m['rpe_per_10s']['translation_m']:.3f} m per 10 s"
            + windowed_text(m["windowed_ate"])
        )
    return result
