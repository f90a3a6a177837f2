"""The sweep engine's results file (studies/engine.py): one CSV line per finished run, keyed by its job
(job_key) and versioned by what made it (run_version); resumed by key.

A study gives ``run_jobs`` a run function and its jobs. A job is a plain dict of str, int, float, bool or
None naming one run (e.g. ``{"scenario": "corner", "seed": 3}``); its key (``job_key``) names it in the
results file. The run function is a module-level function or a functools.partial of one (the workers
import it by name) that takes the job and returns a flat dict of such plain values; the job's items and
these make the run's row. ``run_jobs`` returns the rows in job order, whatever order the runs finish in.
"""

from __future__ import annotations

import csv
import functools
import hashlib
import importlib
import os
import re
from pathlib import Path as FilePath

import numpy as np
from slipnav.scenarios.typed_yaml import ScenarioError

PLAIN = (str, int, float, bool, type(None))
KEY = "key"
"""The results file's first column: the job's key."""
VERSION = "code_version"
"""The results file's second column: run_version of the job when its line was written."""
SOURCE_SUFFIXES = (".py", ".yaml")


def job_key(job: dict) -> str:
    """``name=value;...`` of the job's items in order: the run's identity in the results file."""
    return ";".join(f"{name}={value}" for name, value in job.items())


@functools.lru_cache(maxsize=1)
def code_fingerprint() -> str:
    """12 hex digits of the sha256 over the installed slipnav sources (every .py and .yaml file of
    slipnav.systems, .diagrams, .scenarios with its built-in scenarios, and .studies, in path order)."""
    digest = hashlib.sha256()
    for name in ("systems", "diagrams", "scenarios", "studies"):
        for folder in importlib.import_module(f"slipnav.{name}").__path__:
            root = FilePath(folder)
            files = sorted(
                f for f in root.rglob("*") if f.suffix in SOURCE_SUFFIXES and "__pycache__" not in f.parts
            )
            for file in files:
                digest.update(f"{name}/{file.relative_to(root).as_posix()}\0".encode())
                digest.update(file.read_bytes())
    return digest.hexdigest()[:12]


def run_version(job: dict) -> str:
    """The version of a run of ``job``: code_fingerprint, and the contents of every file a str value of
    the job names (a scenario or model YAML), 12 hex digits."""
    digest = hashlib.sha256(code_fingerprint().encode())
    for name, value in job.items():
        if isinstance(value, str) and os.path.isfile(value):
            digest.update(f"\0{name}\0".encode())
            digest.update(FilePath(value).read_bytes())
    return digest.hexdigest()[:12]


def plain_value(value, where: str):
    """``value`` as a plain Python value (numpy scalars unwrapped); TypeError for anything else."""
    if isinstance(value, np.generic):
        value = value.item()
    if not isinstance(value, PLAIN):
        raise TypeError(f"{where}={value!r}: a sweep row holds str, int, float, bool or None only")
    return value


_INT = re.compile(r"^[-+]?\d+$")


def _is_number(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _parse_cell(text: str):
    """A CSV cell as written by ResultsFile: '' -> None, True/False, integers, floats (repr round trip,
    so exact), else the string."""
    if text == "":
        return None
    if text in ("True", "False"):
        return text == "True"
    if _INT.match(text):
        return int(text)
    try:
        return float(text)
    except ValueError:
        return text


class ResultsFile:
    """The incremental results CSV: header ``key, code_version, <the row's columns>`` (the job's first),
    one line per finished run, appended and flushed as the run finishes.

    Args:
        path: the CSV file; its folder is created.
        resume: keep the finished runs of an existing file (``done``) and append; otherwise the file is
            started anew at the first finished run. A file without the code_version column (an older
            release's) is started anew too.
    """

    def __init__(self, path, resume: bool = False):
        self.path = FilePath(path)
        self.columns: list[str] | None = None
        self.done: dict[str, dict] = {}
        self.older_format = 0
        """Lines of a resumed file without the code_version column (none of them is kept)."""
        self._file = None
        if self.path.exists() and not self.path.is_file():
            raise ScenarioError(
                f"--out: the results file {str(self.path)!r} is a directory: allowed a file (or none) there"
            )
        if resume and self.path.is_file():
            self._read()

    def _read(self) -> None:
        try:
            data = self.path.read_bytes()
        except OSError as e:
            raise ScenarioError(f"--resume: {str(self.path)!r} cannot be read: {e.strerror or e}") from None
        complete = data[: data.rfind(b"\n") + 1]  # a partial last line (the run being written) is dropped
        try:
            lines = complete.decode("utf-8").splitlines()
            first = lines[0] if lines else data.decode("utf-8")  # a header cut short is judged by its start
        except UnicodeDecodeError:
            lines, first = ["(not UTF-8 text)"], "(not UTF-8 text)"
        if first and not (KEY.startswith(first) or next(csv.reader([first]))[:1] == [KEY]):
            raise ScenarioError(
                f"--resume: {str(self.path)!r} is not a sweep results file (its first column is not "
                f"{KEY!r}): allowed a file written by a sweep"
            )
        if len(complete) < len(data):
            with open(self.path, "r+b") as f:
                f.truncate(len(complete))
        if not lines:
            return
        reader = csv.reader(lines)
        try:
            header = next(reader)
            self.columns = header
            if header[1:2] != [VERSION]:
                self.older_format = len(lines) - 1
                return
            for cells in reader:
                if len(cells) == len(header):
                    self.done[cells[0]] = dict(zip(header, cells, strict=True))
        except csv.Error as e:
            raise ScenarioError(
                f"--resume: {str(self.path)!r} line {reader.line_num} is not a results line ({e}): allowed a "
                "file as a sweep wrote it, or no --resume to start it anew"
            ) from None

    def check_resumed(self, keys: list, rows: list, resumed: list) -> None:
        """Each resumed row's text cell in a column where the other rows (resumed, or finished: None while
        running) hold numbers is a corrupted line, which the study's table would fail on: ScenarioError
        naming the line's key and column."""
        for i in resumed:
            for name, value in rows[i].items():
                if not isinstance(value, str) or name not in self.columns[2:]:
                    continue
                numbers = [row[name] for row in rows if row is not None and _is_number(row.get(name))]
                if numbers:
                    raise ScenarioError(
                        f"--resume: {str(self.path)!r}: the line of {keys[i]!r} holds {name}={value!r} where "
                        f"the other lines hold numbers (e.g. {numbers[0]!r}): allowed a file as a sweep "
                        "wrote it, or no --resume to start it anew"
                    )

    def finished(self, key: str, version: str) -> bool:
        """The run ``key`` has a line written by ``version`` (run_version of its job)."""
        line = self.done.get(key)
        return line is not None and line[VERSION] == version

    def discard(self, keys) -> None:
        """Remove the lines of ``keys`` (runs of another version, to be run again) from the file, which
        is rewritten whole (a temporary file renamed over it) before any new line is appended."""
        keys = set(keys) & set(self.done)
        if not keys:
            return
        for key in keys:
            del self.done[key]
        temporary = self.path.with_name(self.path.name + ".tmp")
        with open(temporary, "w", newline="", encoding="utf-8") as f:
            writer = csv.writer(f)
            writer.writerow(self.columns)
            for line in self.done.values():
                writer.writerow(line[name] for name in self.columns)
        os.replace(temporary, self.path)

    def check_jobs(self, jobs: list) -> None:
        """A resumed file must have the job columns of this sweep (before any run starts)."""
        if self.columns is None or not jobs:
            return
        missing = [name for name in jobs[0] if name not in self.columns]
        if missing:
            raise ScenarioError(
                f"--resume: {str(self.path)!r} has no column {missing[0]!r}: it holds another sweep's "
                f"runs ({', '.join(self.columns[1:6])}, ...); allowed: the same study and --set keys, or "
                "no --resume to start the file anew"
            )

    def check_columns(self, columns) -> None:
        """A resumed file must have the result columns this study's runs give (before any run starts:
        a release that adds a column cannot append to an older file)."""
        if self.columns is None or columns is None or self.older_format:
            return
        missing = [name for name in columns if name not in self.columns]
        if missing:
            raise ScenarioError(
                f"--resume: {str(self.path)!r} has no column {missing[0]!r}: an older release wrote it; "
                "allowed: no --resume to start the file anew"
            )

    def row(self, key: str, job: dict) -> dict:
        """The finished run ``key``'s row (its job's values from ``job``, the rest parsed)."""
        return {
            name: job[name] if name in job else _parse_cell(text)
            for name, text in self.done[key].items()
            if name not in (KEY, VERSION)
        }

    def append(self, key: str, row: dict, version: str | None = None) -> None:
        """Write the finished run's line (the header first, at the first line of a new file);
        ``version``: run_version of its job (default: code_fingerprint)."""
        columns = [KEY, VERSION, *row]
        if self._file is None:
            if self.columns is None:
                self.path.parent.mkdir(parents=True, exist_ok=True)
                self._file = open(self.path, "w", newline="", encoding="utf-8")
                csv.writer(self._file).writerow(columns)
                self.columns = columns
            else:
                self._file = open(self.path, "a", newline="", encoding="utf-8")
        if columns != self.columns:
            raise RuntimeError(
                f"{self.path}: the run {key!r} gives the columns {columns}, the file has {self.columns}"
            )
        values = ["" if value is None else value for value in row.values()]
        csv.writer(self._file).writerow([key, version or code_fingerprint(), *values])
        self._file.flush()

    def close(self) -> None:
        if self._file is not None:
            self._file.close()
            self._file = None
