"""The sensor log: a CSV file a real robot can write, one row per navigation sample T_N.

Format (README.md "Sensor log", docs/artifacts.md):

- optional comment lines starting with ``#`` before the header; a comment ``# key: value`` with a key of
  METADATA_KEYS is read as metadata (robot name, periods, encoder resolution, initial state), any other
  comment is ignored;
- one header row naming the columns (any order, each once);
- one row per sample, comma separated, SI units, radians. Required columns (REQUIRED_COLUMNS): ``t`` (s),
  ``gyro`` (rad/s), ``acc1_t acc1_n acc2_t acc2_n`` (m/s^2, tangential and lateral of accelerometer 1
  and 2), ``enc_R enc_L`` (cumulative encoder counts, integers). Optional: ``cmd_R cmd_L`` (commanded
  circumferential wheel speeds, m/s, both or neither), ``cur_R cur_L`` (the motor drivers' current
  readings, A, both or neither: the sensor checks' force reference), ground truth ``true_x true_y
  true_phi`` (m, m, rad; all three or none) and ``true_v_t true_v_n true_omega`` (m/s, m/s, rad/s).

Row k holds what the navigation reads at t_k = t_0 + k T_N. Floats are written with ``repr`` (the
shortest string that reads back to the same double), so a log written and read again is bit-identical.
``nan`` (or an empty cell) in a sensor column is a missing sample: it passes to the navigation, whose
sensor check holds the last valid value and flags it, as in a live run. ``t`` must be finite, increase,
and step by T_N (within SPACING_TOLERANCE).

Every malformed file raises SensorLogError (a ValueError) naming the column, the data row (1 = the first
row after the header) and the file line.
"""

from __future__ import annotations

import csv
import dataclasses as dc
import math
from pathlib import Path as FilePath

import numpy as np
from slipnav.scenarios.files import write_text_atomically
from slipnav.scenarios.progress import TaskProgress
from slipnav.systems.rates import SampleRates

FORMAT_VERSION = 1
REQUIRED_COLUMNS = ("t", "gyro", "acc1_t", "acc1_n", "acc2_t", "acc2_n", "enc_R", "enc_L")
COMMAND_COLUMNS = ("cmd_R", "cmd_L")
CURRENT_COLUMNS = ("cur_R", "cur_L")
TRUTH_POSE_COLUMNS = ("true_x", "true_y", "true_phi")
TRUTH_VELOCITY_COLUMNS = ("true_v_t", "true_v_n", "true_omega")
OPTIONAL_COLUMNS = COMMAND_COLUMNS + CURRENT_COLUMNS + TRUTH_POSE_COLUMNS + TRUTH_VELOCITY_COLUMNS
ALL_COLUMNS = REQUIRED_COLUMNS + OPTIONAL_COLUMNS
ENCODER_COLUMNS = ("enc_R", "enc_L")
ACCELEROMETER_COLUMNS = ("acc1_t", "acc1_n", "acc2_t", "acc2_n")

UNITS = {
    "t": "s",
    "gyro": "rad/s",
    "acc1_t": "m/s^2",
    "acc1_n": "m/s^2",
    "acc2_t": "m/s^2",
    "acc2_n": "m/s^2",
    "enc_R": "counts",
    "enc_L": "counts",
    "cmd_R": "m/s",
    "cmd_L": "m/s",
    "cur_R": "A",
    "cur_L": "A",
    "true_x": "m",
    "true_y": "m",
    "true_phi": "rad",
    "true_v_t": "m/s",
    "true_v_n": "m/s",
    "true_omega": "rad/s",
}

METADATA_KEYS = {
    "format": "format version (1)",
    "robot": "the nominal robot the log belongs to (tinyphoon, kurt3d)",
    "T_N": "navigation period (s), the row spacing",
    "T_C": "control period (s)",
    "encoder_counts_per_revolution": "encoder counts per wheel revolution",
    "initial_pose": "x y phi of the robot at the first row (m m rad)",
    "initial_speed": "forward speed at the first row (m/s)",
    "start_time": "when the controller started (s); the robot stood still before (informative)",
    "scenario": "what ran (informative)",
    "seed": "noise seed of a simulated run (informative)",
}

SPACING_TOLERANCE = 0.01
"""Allowed relative deviation of a row spacing t_k - t_k-1 from T_N (1 %)."""

DEFAULT_T_N = 0.002


class SensorLogError(ValueError):
    """A sensor log that cannot be read; the message names the file, the column and the row."""


@dc.dataclass
class SensorLog:
    """A sensor log in memory.

    Args:
        columns: column name -> (N,) float array (encoder counts as integer-valued floats, NaN allowed).
        metadata: the ``# key: value`` metadata (typed: floats, int, str, tuple for initial_pose).
    """

    columns: dict
    metadata: dict = dc.field(default_factory=dict)

    def __len__(self) -> int:
        return len(self.columns["t"])

    @property
    def t(self) -> np.ndarray:
        return self.columns["t"]

    @property
    def accelerometers(self) -> np.ndarray:
        """(N, 4): a_t1, a_n1, a_t2, a_n2 (m/s^2)."""
        return np.column_stack([self.columns[c] for c in ACCELEROMETER_COLUMNS])

    @property
    def gyro(self) -> np.ndarray:
        return self.columns["gyro"]

    @property
    def encoder_counts(self) -> np.ndarray:
        """(N, 2): cumulative counts of the right and left encoder."""
        return np.column_stack([self.columns[c] for c in ENCODER_COLUMNS])

    def encoder_angles(self, counts_per_revolution: int) -> np.ndarray:
        """(N, 2): wheel angles (rad) = counts * 2 pi / counts_per_revolution (what systems.robot.sensors'
        encoders output: for a simulated log bit-identical to the run's samples)."""
        step = 2.0 * math.pi / counts_per_revolution
        return self.encoder_counts * step

    @property
    def has_truth(self) -> bool:
        return all(c in self.columns for c in TRUTH_POSE_COLUMNS)

    @property
    def has_commands(self) -> bool:
        return all(c in self.columns for c in COMMAND_COLUMNS)

    @property
    def commands(self) -> np.ndarray | None:
        """(N, 2) wheel speed commands cmd_R, cmd_L (m/s), or None when the log has none."""
        if not self.has_commands:
            return None
        return np.column_stack([self.columns[c] for c in COMMAND_COLUMNS])

    @property
    def currents(self) -> np.ndarray | None:
        """(N, 2) motor current readings cur_R, cur_L (A), or None when the log has none."""
        if not all(c in self.columns for c in CURRENT_COLUMNS):
            return None
        return np.column_stack([self.columns[c] for c in CURRENT_COLUMNS])


def _where(path, column: str | None, row: int | None, line: int | None) -> str:
    parts = [f"sensor log {str(path)!r}"]
    if column is not None:
        parts.append(f"column {column!r}")
    if row is not None:
        parts.append(f"row {row} (line {line})")
    return ", ".join(parts)


def _metadata_value(key: str, text: str, path, line: int):
    where = f"sensor log {str(path)!r}, line {line}: metadata {key!r}"
    try:
        if key in ("robot", "scenario"):
            return text
        if key in ("format", "encoder_counts_per_revolution", "seed"):
            value = int(text)
            if key == "format" and value != FORMAT_VERSION:
                raise SensorLogError(f"{where}={text!r} is unknown: allowed {FORMAT_VERSION}")
            if key == "encoder_counts_per_revolution" and not 1 <= value <= 10**7:
                raise SensorLogError(f"{where}={text!r} is out of range: allowed integers in [1, 10000000]")
            return value
        if key == "initial_pose":
            values = tuple(float(v) for v in text.replace(",", " ").split())
            if len(values) != 3 or not all(math.isfinite(v) for v in values):
                raise SensorLogError(f"{where}={text!r}: allowed three finite numbers 'x y phi'")
            return values
        value = float(text)
        if not math.isfinite(value):
            raise SensorLogError(f"{where}={text!r}: allowed a finite number")
        if key in ("T_N", "T_C") and not 0.0 < value <= 1.0:
            raise SensorLogError(f"{where}={text!r} is out of range: allowed (0, 1] s")
        return value
    except ValueError as e:
        if isinstance(e, SensorLogError):
            raise
        raise SensorLogError(f"{where}={text!r} is not a valid value: {METADATA_KEYS[key]}") from None


def _check_header(header: list[str], path, line: int) -> None:
    names = [h.strip() for h in header]
    seen = set()
    for name in names:
        if name in seen:
            raise SensorLogError(
                f"{_where(path, name, None, None)} appears twice in the header (line {line})"
            )
        seen.add(name)
        if name not in ALL_COLUMNS:
            raise SensorLogError(
                f"{_where(path, name, None, None)} (header, line {line}) is unknown: allowed "
                f"{', '.join(ALL_COLUMNS)} (README.md: Sensor log)"
            )
    for name in REQUIRED_COLUMNS:
        if name not in seen:
            raise SensorLogError(
                f"{_where(path, name, None, None)} is missing (header, line {line}): the required columns "
                f"are {', '.join(REQUIRED_COLUMNS)}"
            )
    for group in (COMMAND_COLUMNS, CURRENT_COLUMNS, TRUTH_POSE_COLUMNS):
        present = [c for c in group if c in seen]
        if present and len(present) != len(group):
            missing = [c for c in group if c not in seen][0]
            raise SensorLogError(
                f"{_where(path, missing, None, None)} is missing (header, line {line}): "
                f"{', '.join(group)} come together"
            )


def _parse_cell(text: str, column: str, path, row: int, line: int) -> float:
    text = text.strip()
    if text == "":
        value = math.nan
    else:
        try:
            value = float(text)
        except ValueError:
            raise SensorLogError(
                f"{_where(path, column, row, line)}: {text!r} is not a number (allowed: a decimal number, "
                "nan or an empty cell for a missing sample)"
            ) from None
    if column == "t" and not math.isfinite(value):
        raise SensorLogError(f"{_where(path, column, row, line)}: {text!r}: the time must be a finite number")
    if column in ENCODER_COLUMNS and math.isfinite(value) and value != math.floor(value):
        raise SensorLogError(
            f"{_where(path, column, row, line)}: {text!r} is not a whole number of encoder counts"
        )
    return value


def _numbers(rows: list, header: list) -> np.ndarray | None:
    """The rows as _parse_cell reads them where every cell is a number, a time finite, a count whole."""
    try:
        data = np.array([[float(cell) for cell in row] for row in rows], float)
    except ValueError:  # an empty cell (NaN), no number, or rows of unequal lengths
        return None
    if data.shape != (len(rows), len(header)):
        return None
    t, counts = data[:, header.index("t")], data[:, [header.index(c) for c in ENCODER_COLUMNS]]
    whole = ~np.isfinite(counts) | (counts == np.floor(counts))
    return data if np.all(np.isfinite(t)) and np.all(whole) else None


def check_time(t: np.ndarray, T_N: float, path="<arrays>", lines=None) -> None:
    """t increases by T_N per row (within SPACING_TOLERANCE); SensorLogError naming the row."""
    if len(t) < 2:
        raise SensorLogError(f"{_where(path, None, None, None)} has {len(t)} rows: allowed at least 2")
    dt = np.diff(t)
    for k in np.flatnonzero(~(dt > 0.0)):
        row = int(k) + 2
        line = lines[k + 1] if lines is not None else row
        raise SensorLogError(
            f"{_where(path, 't', row, line)}: {float(t[k + 1])!r} s is not after the previous row's "
            f"{float(t[k])!r} s: "
            "the time must increase"
        )
    off = np.flatnonzero(np.abs(dt - T_N) > SPACING_TOLERANCE * T_N)
    if len(off):
        k = int(off[0])
        row = k + 2
        line = lines[k + 1] if lines is not None else row
        raise SensorLogError(
            f"{_where(path, 't', row, line)}: spacing {float(dt[k])!r} s from the previous row is off "
            f"T_N = {T_N!r} s: "
            f"allowed T_N +- {100 * SPACING_TOLERANCE:g} % (one row per navigation sample)"
        )


def read_metadata(path) -> dict:
    """The ``# key: value`` metadata of a sensor log's comment lines before its header, without reading
    the rows (SensorLogError as read_sensor_log)."""
    path = FilePath(path)
    metadata: dict = {}
    try:
        with open(path, newline="", encoding="utf-8") as handle:
            for line, text in enumerate(handle, start=1):
                text = text.strip()
                if not text:
                    continue
                if not text.startswith("#"):
                    break
                key, sep, value = text[1:].partition(":")
                if sep and key.strip() in METADATA_KEYS:
                    metadata[key.strip()] = _metadata_value(key.strip(), value.strip(), path, line)
    except OSError as e:
        raise SensorLogError(f"sensor log {str(path)!r} cannot be read: {e.strerror or e}") from None
    except UnicodeDecodeError as e:
        raise SensorLogError(f"sensor log {str(path)!r} is not UTF-8 text (offset {e.start})") from None
    return metadata


def read_sensor_log(path, T_N: float | None = None) -> SensorLog:
    """Read and check a sensor log (the module's format).

    Args:
        path: the CSV file.
        T_N: the navigation period the rows must be spaced by (s); None: the log's ``# T_N`` metadata, or
            DEFAULT_T_N. A log whose ``# T_N`` differs from a given T_N is an error.

    Raises:
        SensorLogError naming the column, the row and the line.
    """
    path = FilePath(path)
    records = _read_records(path)
    columns = _parse_columns(records, path)
    T_N = _navigation_period(records.metadata, T_N, path)
    check_time(columns["t"], T_N, path, records.lines)
    return SensorLog(columns=columns, metadata=records.metadata)


@dc.dataclass
class _Records:
    """A log's text split: metadata, the header (and its line) and the data rows with their lines."""

    metadata: dict = dc.field(default_factory=dict)
    header: list[str] | None = None
    header_line: int = 0
    rows: list[list[str]] = dc.field(default_factory=list)
    lines: list[int] = dc.field(default_factory=list)


def _blank(record: list[str]) -> bool:
    return not record or (len(record) == 1 and not record[0].strip())


def _read_records(path: FilePath) -> _Records:
    """The CSV records of ``path``: comments before the header as metadata, then the header and the rows
    (blank lines skipped); progress on stderr by the megabytes read."""
    try:
        handle = open(path, newline="", encoding="utf-8")  # noqa: SIM115 (closed below)
    except OSError as e:
        raise SensorLogError(f"sensor log {str(path)!r} cannot be read: {e.strerror or e}") from None
    records = _Records()
    size = path.stat().st_size / 1e6
    progress = TaskProgress(size, f"slipnav: reading {path.name}", "MB")
    read = [0]

    def counted(handle):
        """The handle's lines, their characters (about the bytes: ASCII) told to the progress."""
        for number, text in enumerate(handle):
            read[0] += len(text)
            if number % 20000 == 0:
                progress.update(read[0] / 1e6)
            yield text

    try:
        with handle, progress:
            reader = csv.reader(counted(handle))
            for record in reader:
                if _blank(record):
                    continue
                if records.header is None:
                    _read_preamble(record, reader.line_num, records, path)
                    continue
                records.rows.append(record)
                records.lines.append(reader.line_num)
            progress.update(size)
    except UnicodeDecodeError as e:
        raise SensorLogError(f"sensor log {str(path)!r} is not UTF-8 text (offset {e.start})") from None
    except csv.Error as e:
        raise SensorLogError(f"sensor log {str(path)!r} is not valid CSV: {e}") from None
    if records.header is None:
        raise SensorLogError(
            f"sensor log {str(path)!r} has no header row: allowed '{','.join(REQUIRED_COLUMNS)}' (+ optional)"
        )
    return records


def _read_preamble(record: list[str], line: int, records: _Records, path: FilePath) -> None:
    """A record before the header: a ``# key: value`` comment (known keys kept) or the header itself."""
    if record[0].lstrip().startswith("#"):
        key, sep, value = ",".join(record).lstrip()[1:].partition(":")
        if sep and key.strip() in METADATA_KEYS:
            records.metadata[key.strip()] = _metadata_value(key.strip(), value.strip(), path, line)
        return
    _check_header(record, path, line)
    records.header = [h.strip() for h in record]
    records.header_line = line


def _parse_columns(records: _Records, path: FilePath) -> dict[str, np.ndarray]:
    """Every cell parsed (a row with another number of cells than the header is an error), by column: all
    at once where every cell is a number (_numbers), else cell by cell, which names the first bad one."""
    header = records.header
    data = _numbers(records.rows, header)
    if data is not None:
        return {name: data[:, j].copy() for j, name in enumerate(header)}
    data = np.empty((len(records.rows), len(header)))
    for i, (record, line) in enumerate(zip(records.rows, records.lines, strict=True)):
        if len(record) != len(header):
            raise SensorLogError(
                f"{_where(path, None, i + 1, line)} has {len(record)} cells: allowed {len(header)}, one per "
                f"header column (line {records.header_line})"
            )
        for j, (cell, column) in enumerate(zip(record, header, strict=True)):
            data[i, j] = _parse_cell(cell, column, path, i + 1, line)
    return {name: data[:, j].copy() for j, name in enumerate(header)}


def _navigation_period(metadata: dict, T_N: float | None, path: FilePath) -> float:
    """The period the rows must be spaced by: the given T_N (the log's ``# T_N`` must agree), else the
    log's, else DEFAULT_T_N; a logged T_C must be a multiple of it (systems/rates.py SampleRates)."""
    logged_T_N = metadata.get("T_N")
    if T_N is not None and logged_T_N is not None and abs(logged_T_N - T_N) > 1e-12 * T_N:
        raise SensorLogError(
            f"sensor log {str(path)!r}: metadata T_N={logged_T_N!r} s differs from the navigation's "
            f"T_N={T_N!r} s: allowed a log sampled at the navigation period"
        )
    T_N = T_N if T_N is not None else logged_T_N if logged_T_N is not None else DEFAULT_T_N
    if "T_C" in metadata:
        try:
            SampleRates(T_N=T_N, T_C=metadata["T_C"])
        except ValueError as e:
            raise SensorLogError(f"sensor log {str(path)!r}: metadata {e}") from None
    return T_N


def _format(value: float) -> str:
    return repr(float(value))


def _format_count(value: float) -> str:
    return str(int(value)) if math.isfinite(value) else repr(float(value))


def sensor_log_chunks(log: SensorLog, rows: int = 10000):
    """The CSV text of ``log`` in pieces: metadata comments and header, then ``rows`` rows at a time
    (floats by repr: exact round trip), so that a long log is written without its whole text in memory."""
    names = [c for c in ALL_COLUMNS if c in log.columns]
    out = [
        f"# slipnav sensor log, format {FORMAT_VERSION}; one row per T_N sample, SI units "
        "(README.md: Sensor log)",
        "# units: " + " ".join(f"{c}[{UNITS[c]}]" for c in names),
    ]
    meta = {"format": FORMAT_VERSION, **{k: v for k, v in log.metadata.items() if k != "format"}}
    for key, value in meta.items():
        if key not in METADATA_KEYS:
            raise ValueError(f"metadata key {key!r} is unknown: allowed {sorted(METADATA_KEYS)}")
        if key == "initial_pose":
            value = " ".join(_format(v) for v in value)
        elif isinstance(value, float):
            value = _format(value)
        out.append(f"# {key}: {value}")
    out.append(",".join(names))
    yield "\n".join(out) + "\n"
    columns = [(_format_count if c in ENCODER_COLUMNS else repr, log.columns[c]) for c in names]
    for start in range(0, len(log), rows):
        cells = [map(f, np.asarray(column[start : start + rows], float).tolist()) for f, column in columns]
        yield "\n".join(map(",".join, zip(*cells, strict=True))) + "\n"


def sensor_log_text(log: SensorLog) -> str:
    """The CSV text of ``log``: metadata comments, header, rows (floats by repr: exact round trip)."""
    return "".join(sensor_log_chunks(log))


def write_sensor_log(log: SensorLog, path) -> FilePath:
    """Write ``log`` to ``path`` atomically (write_text_atomically)."""
    return write_text_atomically(path, sensor_log_chunks(log))


def sensor_log_from_arrays(
    arrays: dict, counts_per_revolution: int, metadata: dict | None = None
) -> SensorLog:
    """The sensor log of a run artifact's arrays (``meas_*``, ``cmd_*``, ``true_*``): the encoder angles
    become counts (the sensor model's floor(theta / step) exactly), NaN columns are left out."""
    step = 2.0 * math.pi / counts_per_revolution
    columns = {"t": np.asarray(arrays["t"], float)}
    columns["gyro"] = np.asarray(arrays["meas_gyro"], float)
    for column, key in zip(
        ACCELEROMETER_COLUMNS, ("meas_a_t1", "meas_a_n1", "meas_a_t2", "meas_a_n2"), strict=True
    ):
        columns[column] = np.asarray(arrays[key], float)
    for column, key in (("enc_R", "meas_enc_R"), ("enc_L", "meas_enc_L")):
        angle = np.asarray(arrays[key], float)
        with np.errstate(invalid="ignore"):
            columns[column] = np.where(np.isfinite(angle), np.round(angle / step), np.nan)
    for column, key in zip(CURRENT_COLUMNS, ("meas_current_R", "meas_current_L"), strict=True):
        if key in arrays and np.any(np.isfinite(arrays[key])):
            columns[column] = np.asarray(arrays[key], float)
    for column in OPTIONAL_COLUMNS:
        if column in arrays and np.any(np.isfinite(arrays[column])):
            columns[column] = np.asarray(arrays[column], float)
    if any(c in columns for c in COMMAND_COLUMNS) and not all(c in columns for c in COMMAND_COLUMNS):
        for c in COMMAND_COLUMNS:
            columns.pop(c, None)
    return SensorLog(columns=columns, metadata=dict(metadata or {}))
