"""What ``slipnav reproduce``'s figures and claims are made of: a recreated figure (Reproduced), a run of
the set (Run), and the measures computed from the runs (errors in % of the path, masks of the moving and
following samples, detection onsets, divergence, wheel-command saturation and switches)."""

from __future__ import annotations

import dataclasses as dc

import numpy as np
from slipnav.scenarios.metrics import (
    DETECTION_C1_LEVEL,
    POSITION_ERROR_FIGURES,
    final_position_error,
    position_errors_in_percent,
)

DIVERGENCE = 0.05
"""m/s: |fused v_t - true v_t| above which Seyr Fig. 7's light grey marks a divergence of the estimate."""


EXCESSIVE_SLIP = 0.15
"""Slip ratio above which a wheel slips excessively (the slip-episode threshold of scenarios/metrics)."""


HOLD, PUSH = (2.5, 3.0), (5.0, 5.5)


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


def percent_of_path(run: Run, prefix: str = "est") -> float:
    """Final position error of an estimate in % of the path."""
    return 100.0 * final_position_error(run.arrays, prefix) / float(run.arrays["path_length"])


def percent_errors(run: Run, prefix: str = "est") -> dict:
    """An estimate's final, RMS and maximum position error along the run in % of the path
    (metrics.position_errors_in_percent)."""
    return position_errors_in_percent(run.arrays, prefix)


def percent_errors_text(errors: dict) -> str:
    """percent_errors as "final 0.16 %, RMS 0.68 %, max 1.12 %"."""
    return ", ".join(
        f"{'RMS' if figure == 'rms' else figure} {errors[figure]:.2f} %" for figure in POSITION_ERROR_FIGURES
    )


def moving_mask(a) -> np.ndarray:
    """Samples after the controller started."""
    return a["t"] >= float(a["start_time"])


def following_mask(run: Run) -> np.ndarray:
    """Samples while the controller followed (start to controller completion)."""
    a, end = run.arrays, run.summary["controller_completion_time_s"]
    return moving_mask(a) & (a["t"] <= (end if end is not None else np.inf))


def time_above(a, values, level) -> float:
    """Time (s) where |values| > level."""
    return float(np.sum(np.abs(np.nan_to_num(values)) > level) * float(a["T_N"]))


def true_spans(t, mask):
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


def time_axis(ax, last: bool = True):
    if last:
        ax.set_xlabel("t (s)")
    ax.grid(True, alpha=0.3)


AT_V_M = 0.95
"""A wheel command at or above this fraction of V_m counts as at the bound (Indiveri Figs. 8-9)."""


def saturation_fractions(run: Run) -> tuple[float, float]:
    """Fractions of the following time with one wheel command at V_m (>= AT_V_M V_m) and with both."""
    a = run.arrays
    V_m, following = float(a["V_m"]), following_mask(run)
    at = np.column_stack([a["cmd_R"], a["cmd_L"]])[following] >= AT_V_M * V_m
    return float(np.mean(at.any(axis=1))), float(np.mean(at.all(axis=1)))


def speed_switches(run: Run) -> int:
    """How often the larger wheel command crosses 3/4 V_m while following: I(24)'s switches between
    V_m/2 (V1 >= epsilon) and V_m/(1 + b|kappa_r|) (V1 < epsilon)."""
    a = run.arrays
    high = (np.maximum(a["cmd_R"], a["cmd_L"]) > 0.75 * float(a["V_m"]))[following_mask(run)]
    return int(np.sum(high[1:] != high[:-1]))


def following_time(run: Run) -> float:
    """Time from the controller's start to its completion (s; to the run's end if it did not finish)."""
    a, end = run.arrays, run.summary["controller_completion_time_s"]
    return float((end if end is not None else a["t"][-1]) - float(a["start_time"]))
