"""A run's record (RunResult) and its files: ``write_artifacts`` writes ``DIR/<stem>.npz``, the sensor log,
the model, the figures and ``DIR/<stem>.summary.json`` (stem: ``artifact_stem``, e.g. ``corner-seed0``),
atomically (docs/artifacts.md)."""

from __future__ import annotations

import dataclasses as dc
import json
import os
import shutil
import tempfile
from pathlib import Path as FilePath

import numpy as np
from slipnav.scenarios.config import Scenario, ScenarioError
from slipnav.scenarios.interrupt import deferred_interrupt
from slipnav.scenarios.model import RobotModel, model_text
from slipnav.scenarios.sensor_log import SensorLog, sensor_log_chunks
from slipnav.scenarios.trajectories import Trajectory


@dc.dataclass
class RunResult:
    """A run: its artifact arrays and summary, the reference, and what the robot logged (``sensor_log``:
    the CSV of scenarios/sensor_log.py) with the model its navigation read (``model``)."""

    scenario: Scenario
    seed: int
    arrays: dict
    summary: dict
    reference: Trajectory
    sensor_log: SensorLog | None = None
    model: RobotModel | None = None


def artifact_stem(result: RunResult) -> str:
    """File stem of a run's artifacts: ``<scenario>-seed<N>`` plus the switches that changed what ran,
    ``-open-loop``, ``-no-slip-control``, ``-speed-law-constant``, ``-tolerances``,
    ``-localised-by-<source>``, ``-paper``, ``-model-<model file stem>`` (README: Run artifacts)."""
    s = result.summary
    stem = f"{s['scenario'] or 'scenario'}-seed{s['seed']}"
    if s["controller"] != "closed loop":
        stem += "-open-loop"
    if s["slip_control"] is False:
        stem += "-no-slip-control"
    if s["speed_law"] == "constant":
        stem += "-speed-law-constant"
    if s.get("tolerances"):
        stem += "-tolerances"
    if s.get("localisation") not in (None, "fused"):
        stem += f"-localised-by-{s['localisation']}"
    if s.get("paper"):
        stem += "-paper"
    if s.get("model"):
        stem += f"-model-{model_stem(s['model'])}"
    return stem


def model_stem(path) -> str:
    """``runs/tinyphoon-seed3.calibrated.model.yaml`` -> ``tinyphoon-seed3.calibrated``."""
    name = FilePath(path).name
    for suffix in (".yaml", ".yml", ".model"):
        name = name.removesuffix(suffix)
    return name or "model"


FIGURE_SAMPLES = 150_000
"""Most samples a figure plots (300 s at T_N = 2 ms); a longer run's figures plot every k-th sample."""


def figure_arrays(arrays: dict, limit: int = FIGURE_SAMPLES) -> dict:
    """The arrays the figures plot: every sample up to ``limit`` samples, else every k-th sample with
    k = ceil(samples / limit) (matplotlib would otherwise hold millions of points per line for an
    hour's run; the npz keeps every sample)."""
    n = len(arrays["t"])
    stride = -(-n // limit)
    if stride == 1:
        return arrays
    return {key: v[::stride] if np.ndim(v) == 1 and len(v) == n else v for key, v in arrays.items()}


def check_output_directory(out_dir) -> FilePath:
    """Create ``out_dir`` if needed and prove it writable (before a simulation, so that a bad --out
    fails at once); raises ScenarioError naming --out."""
    out = FilePath(out_dir)
    if out.exists() and not out.is_dir():
        raise ScenarioError(f"--out={str(out_dir)!r} is a file: allowed a directory (created if missing)")
    try:
        out.mkdir(parents=True, exist_ok=True)
        probe, name = tempfile.mkstemp(dir=out, prefix=".slipnav-probe-")
        os.close(probe)
        os.unlink(name)
    except OSError as e:
        reason = e.strerror or str(e)
        raise ScenarioError(f"--out={str(out_dir)!r} is not a writable directory: {reason}") from None
    return out


def write_artifacts(result: RunResult, out_dir, figures: bool = True) -> list[FilePath]:
    """Write ``<stem>.npz``, ``<stem>.sensors.csv`` (the sensor log), ``<stem>.model.yaml`` (the model
    navigation read), the figures and ``<stem>.summary.json`` (stem: artifact_stem) into ``out_dir``;
    returns the written paths.

    Atomic: everything is first written into a temporary folder inside ``out_dir``, then renamed into
    place (``os.replace``) with Ctrl-C deferred, the summary last. An interruption or error while
    writing leaves no new file and the previous run's files untouched.
    """

    out = check_output_directory(out_dir)
    stem = artifact_stem(result)
    staging = FilePath(tempfile.mkdtemp(dir=out, prefix=f".{stem}.partial-"))
    try:
        np.savez(staging / f"{stem}.npz", **{k: np.asarray(v, dtype=float) for k, v in result.arrays.items()})
        staged = [staging / f"{stem}.npz"]
        if result.sensor_log is not None:
            staged.append(staging / f"{stem}.sensors.csv")
            with open(staged[-1], "w") as handle:  # in pieces: a long run's text never whole in memory
                handle.writelines(sensor_log_chunks(result.sensor_log))
        if result.model is not None:
            staged.append(staging / f"{stem}.model.yaml")
            staged[-1].write_text(model_text(result.model))
        if figures:
            from slipnav.scenarios import plots  # matplotlib, set to Agg: only where figures are written

            staged += plots.write_figures(figure_arrays(result.arrays), result.reference, staging, stem)
        return publish_artifacts(staging, staged, stem, result.summary, out)
    finally:
        shutil.rmtree(staging, ignore_errors=True)


def publish_artifacts(staging, staged: list, stem: str, summary_data: dict, out: FilePath) -> list[FilePath]:
    """Write the summary into ``staging`` and move every staged file into ``out``, the summary last (a
    summary means the files are complete), with Ctrl-C deferred."""
    summary = staging / f"{stem}.summary.json"
    summary.write_text(json.dumps(summary_data, indent=2) + "\n")
    staged = [*staged, summary]
    with deferred_interrupt():
        written = []
        for path in staged:
            os.replace(path, out / path.name)
            written.append(out / path.name)
    return written
