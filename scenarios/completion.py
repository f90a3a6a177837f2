"""Where a track runs against a path and whether it arrived: the path projection and the completion
judged on the true pose (a run summary's ``completed``, ``path_error_*``)."""

from __future__ import annotations

import numpy as np
from slipnav.scenarios.trajectories import (
    Path,
)
from slipnav.systems.robot.parameters import RobotParameters


def path_projection(x, y, path_x, path_y, block: int = 256, margin: float = 0.2):
    """Distance of each point (x, y) from the polyline (path_x, path_y), measured to its segments (the
    foot of the perpendicular, or a segment's end), and the arc length of that foot: (distance, s).

    The search is local: the points are taken as a track in time order, in blocks of ``block``; a block
    searches only the segments from ``margin`` m behind the previous block's foot to ``margin`` m plus
    twice the distance the block's points travel ahead of it. Memory stays O(block x window), and a path
    that passes its start again (a circle) is not matched to its end too early.
    """
    x, y = np.asarray(x, float), np.asarray(y, float)
    px, py = np.asarray(path_x, float), np.asarray(path_y, float)
    if len(px) < 2:
        raise ValueError("path_projection needs a polyline of at least 2 points")
    seg_len = np.hypot(np.diff(px), np.diff(py))
    s_vertex = np.concatenate([[0.0], np.cumsum(seg_len)])
    distance, progress = np.empty(len(x)), np.empty(len(x))
    s_prev = 0.0
    for i in range(0, len(x), block):
        bx, by = x[i : i + block], y[i : i + block]
        travelled = float(np.sum(np.hypot(np.diff(bx), np.diff(by)))) if len(bx) > 1 else 0.0
        lo = max(int(np.searchsorted(s_vertex, s_prev - margin, side="right")) - 1, 0)
        hi = min(int(np.searchsorted(s_vertex, s_prev + margin + 2.0 * travelled, side="left")) + 1, len(px))
        hi = max(hi, lo + 2)
        ax, ay = px[lo : hi - 1], py[lo : hi - 1]  # segment starts
        dx, dy, length = np.diff(px[lo:hi]), np.diff(py[lo:hi]), seg_len[lo : hi - 1]
        # Foot of the perpendicular as a fraction of each segment, clipped to the segment.
        rx, ry = bx[:, None] - ax[None, :], by[:, None] - ay[None, :]
        with np.errstate(invalid="ignore", divide="ignore"):
            u = np.where(length > 0.0, (rx * dx + ry * dy) / (length * length), 0.0)
        u = np.clip(u, 0.0, 1.0)
        d2 = (rx - u * dx) ** 2 + (ry - u * dy) ** 2
        j = np.argmin(d2, axis=1)
        rows = np.arange(len(bx))
        distance[i : i + block] = np.sqrt(d2[rows, j])
        progress[i : i + block] = s_vertex[lo + j] + u[rows, j] * length[j]
        s_prev = float(progress[i + len(bx) - 1])
    return distance, progress


def path_distance(x, y, path: Path) -> np.ndarray:
    """Distance of each point (x, y) of a track from the path polyline's segments (see path_projection)."""
    return path_projection(x, y, path.x, path.y)[0]


def moving_distance(tolerance: float, path_length: float) -> float:
    """The true distance a run must travel to count as moved (m): the completion tolerance, or half the
    path where that is shorter. A robot that stayed within it of its start (no grip, a wheel held) has
    no path error to report: its distance from the path is the start's, a few nanometres."""
    return min(tolerance, 0.5 * path_length)


def completion_tolerance(robot: RobotParameters) -> float:
    """How close to the end of its path the robot must really be to count as arrived (m):
    max(0.05 m, 2 track widths) (Tinyphoon 0.136 m, Kurt3D 0.8 m)."""
    return max(0.05, 2.0 * robot.track_width)


def judge_completion(t, x, y, path_x, path_y, tolerance: float) -> dict:
    """Completion judged on the true track: the robot reached the end of the path (polyline path_x,
    path_y) when its true position came within ``tolerance`` of the path's end point with its
    along-path progress within ``tolerance`` of the path's length; ``completion_time_s`` is the first
    such sample (None if never). ``end_distance_m`` is where it finally stopped (an overshoot shows there)."""
    distance, progress = path_projection(x, y, path_x, path_y)
    length = float(np.sum(np.hypot(np.diff(path_x), np.diff(path_y))))
    to_end = np.hypot(np.asarray(x) - path_x[-1], np.asarray(y) - path_y[-1])
    arrived = np.flatnonzero((to_end <= tolerance) & (progress >= length - tolerance))
    completed = len(arrived) > 0
    completion = float(t[arrived[0]]) if completed else None
    return {
        "completed": completed,
        "completion_time_s": completion,
        "completion_tolerance_m": float(tolerance),
        "end_distance_m": float(to_end[-1]),
        "end_progress_m": float(progress[-1]),
        "distance": distance,
    }
