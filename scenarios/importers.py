"""``slipnav import ADAPTER DIR --out OUT [--model MODEL.yaml] [--resample interpolate|hold]``: a real
robot's logs as the project's sensor log, ground truth and model (docs/robot-logs.md).

An adapter reads one recording's files, estimates what ties them together (each clock's lag, the sensors'
axes, the truth's frame; scenarios/alignment.py) and returns an ImportResult: the sensor log
(scenarios/sensor_log.py) on the model's T_N grid, the truth table and the model. ``write_import`` writes
``<name>.sensors.csv``, ``<name>.model.yaml`` (the log's companion: ``slipnav replay`` reads it),
``<name>.truth.csv`` (``t,x,y,yaw,quality``; ``slipnav evaluate --truth`` reads it) and
``<name>.import.json`` (what was estimated).

Adapters: ``phil-turtlebot`` (scenarios/import_turtlebot.py), ``norlab-warthog``
(scenarios/import_warthog.py), ``ros-bag`` (scenarios/import_rosbag.py); the command line
(studies/cli.py, ADAPTERS) picks one by name.
"""

from __future__ import annotations

import csv
import dataclasses as dc
import json
import math
from pathlib import Path as FilePath

import numpy as np
from slipnav.scenarios.artifacts import check_output_directory
from slipnav.scenarios.config import ScenarioError
from slipnav.scenarios.files import write_text_atomically
from slipnav.scenarios.model import ModelError, RobotModel, load_model, model_text
from slipnav.scenarios.sensor_log import SensorLog, sensor_log_chunks

RESAMPLING = ("interpolate", "hold")
HOLD_MARGIN = 2.0
"""A model that states no hold time of a stream (SensorParameters.inertial_hold_time, encoder_hold_time)
gets this many times the longest one the trial shows (with_measured_hold): the checks judge a held
reading frozen, or a speed step a jump, only beyond it."""


class LogImportError(ScenarioError):
    """A trial folder or file that cannot be imported; the message names the file and the column."""


@dc.dataclass
class ImportResult:
    name: str
    log: SensorLog
    truth: dict
    model: RobotModel
    model_text: str
    report: dict


def read_table(path: FilePath, columns, skip: int = 0) -> dict:
    """The named float columns of a CSV file (header after ``skip`` lines); empty cells are NaN."""
    try:
        with open(path, newline="", encoding="utf-8-sig") as handle:
            rows = list(csv.reader(handle))
    except (OSError, UnicodeDecodeError) as e:
        raise LogImportError(f"{str(path)!r} cannot be read: {getattr(e, 'strerror', None) or e}") from None
    if len(rows) <= skip + 2:
        raise LogImportError(f"{str(path)!r} has no data rows after its header (line {skip + 1})")
    header = [h.strip() for h in rows[skip]]
    out = {}
    for name in columns:
        if name not in header:
            raise LogImportError(f"{str(path)!r}: column {name!r} is missing (header, line {skip + 1})")
        j = header.index(name)
        values = np.full(len(rows) - skip - 1, np.nan)
        for i, row in enumerate(rows[skip + 1 :]):
            cell = row[j].strip() if j < len(row) else ""
            if cell:
                try:
                    values[i] = float(cell)
                except ValueError:
                    raise LogImportError(
                        f"{str(path)!r}, column {name!r}, line {skip + i + 2}: {cell!r} is not a number"
                    ) from None
        out[name] = values
    return out


def log_summary(report: dict) -> str:
    """The start of an import's summary line: its name, rows, T_N and resampling (report's keys)."""
    log = report["log"]
    return f"{report['name']}: {log['rows']} rows at T_N {log['T_N_s']:g} s ({log['resampling']}); "


def with_measured_hold(model: RobotModel, text: str, field: str, measured: float, limit: float):
    """(model, its YAML text) with SensorParameters ``field`` at HOLD_MARGIN x ``measured`` (s, at most
    ``limit``, the field's range) when the model states none (0); else as given."""
    if getattr(model.sensor_parameters(), field) != 0.0:
        return model, text
    overrides = {**model.sensor_overrides, field: min(HOLD_MARGIN * float(measured), limit)}
    model = dc.replace(model, sensor_overrides=overrides).validate()
    return model, model_text(model)


def resolve_model(model_path, default) -> tuple[RobotModel, str]:
    """(model, its YAML text): ``--model``'s file, else ``default()``."""
    if model_path is None:
        model = default()
        return model, model_text(model)
    try:
        model = load_model(model_path)
    except ModelError as e:
        raise LogImportError(f"--model: {e}") from None
    return model, FilePath(model_path).read_text(encoding="utf-8")


def truth_text(table: dict, source: str = "") -> str:
    """The ground-truth CSV: ``t,x,y,yaw,quality`` (s on the log's clock, m, m, rad; quality 1 where the
    truth saw the robot, 0 where not, its pose then empty)."""
    lines = [
        "# slipnav ground truth: the robot's axle centre and heading in the truth's frame "
        "(docs/robot-logs.md)",
        "# units: t[s] x[m] y[m] yaw[rad] quality[1 seen, 0 unseen]; t on the sensor log's clock",
    ]
    if source:
        lines.append(f"# source: {source}")
    lines.append("t,x,y,yaw,quality")
    for k in range(len(table["t"])):
        values = [table[c][k] for c in ("t", "x", "y", "yaw")]
        cells = [repr(float(v)) if math.isfinite(v) else "" for v in values]
        lines.append(",".join(cells + [str(int(table["quality"][k]))]))
    return "\n".join(lines) + "\n"


def write_import(result: ImportResult, out_dir) -> list[FilePath]:
    """``<name>.sensors.csv``, ``<name>.model.yaml`` (slipnav replay's companion), ``<name>.truth.csv`` and
    ``<name>.import.json`` in ``out_dir``, each written atomically."""

    out = check_output_directory(out_dir)
    stem = out / result.name
    return [
        write_text_atomically(stem.with_name(f"{result.name}.sensors.csv"), sensor_log_chunks(result.log)),
        write_text_atomically(stem.with_name(f"{result.name}.model.yaml"), [result.model_text]),
        write_text_atomically(
            stem.with_name(f"{result.name}.truth.csv"),
            [truth_text(result.truth, result.report["truth_source"])],
        ),
        write_text_atomically(
            stem.with_name(f"{result.name}.import.json"), [json.dumps(result.report, indent=2) + "\n"]
        ),
    ]
