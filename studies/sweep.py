"""The sweep engine on dask.distributed, and ``slipnav sweep SCENARIO --seeds N [--set KEY=V1,V2 ...]``.

A study gives ``run_jobs`` a run function and its jobs. A job is a plain dict of str, int, float, bool or
None naming one run (e.g. ``{"scenario": "corner", "seed": 3}``); its key (``job_key``) names it in the
results file. The run function is a module-level function or a functools.partial of one (the workers
import it by name) that takes the job and returns a flat dict of such plain values; the job's items and
these make the run's row. ``run_jobs`` returns the rows in job order, whatever order the runs finish in.

Runs go to a dask.distributed LocalCluster of ``workers`` long-lived worker processes (one thread each;
a process starts once per sweep, not per run), to an existing cluster (``scheduler``: its address), or,
with ``workers=0``, run one after the other in this process (the reference of the tests). Every finished
run is appended to the results CSV (header first, flushed per row); ``resume`` keeps the rows already
there (a partial last line, left by a kill, is dropped) and runs only the jobs whose key is missing.
Each line carries the version of what made it (``run_version``: the package's sources and the contents of
any file the job names, such as a scenario YAML); a resumed line of another version is run again and
its line replaced, so a file resumed after an upgrade or an edited scenario never mixes the two.

``slipnav sweep`` runs the cartesian product of the ``--set`` values (dotted scenario keys, checked as a
loaded scenario is before any run starts) times seeds 0..N-1, prints per combination the mean (worst)
final position error of the fused estimate, odometry-only and Gyrodometry (% of path length), writes
``DIR/sweep-<scenario>.csv`` and ``DIR/sweep-<scenario>.png`` (the distributions) and ends with
``sweep runs=<n> workers=<n> wall_s=<f> runs_per_s=<f> mean_fused_pct=<f> worst_fused_pct=<f>``.
"""

from __future__ import annotations

import contextlib
import csv
import functools
import hashlib
import itertools
import logging
import math
import os
import re
import signal
import socket
import sys
import threading
import time
from pathlib import Path as FilePath

import numpy as np
from slipnav.scenarios.config import (
    ScenarioError,
    check_duration,
    check_seed_count,
    load_scenario,
    parse_value,
    with_keys,
)
from slipnav.scenarios.plots import save_figure_atomically

DEFAULT_WORKERS = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1
"""Worker processes of the local cluster: one per core this process may use."""
MAX_WORKERS = 64
WORKER_CONFIG = {
    "distributed.worker.profile.enabled": False,
    "distributed.admin.tick.interval": "1s",
    "distributed.admin.system-monitor.interval": "5s",
    "distributed.worker.memory.monitor-interval": "1s",
}
"""dask settings of the local workers: no statistical profiler (it samples the running thread's stack
every 10 ms) and the event loop's housekeeping every second instead of every 20-500 ms; every wake-up
takes the GIL from the simulation (corner, one worker: 0.72 -> 0.68 s per run; in process 0.64 s)."""
PLAIN = (str, int, float, bool, type(None))
KEY = "key"
"""The results file's first column: the job's key."""
VERSION = "code_version"
"""The results file's second column: run_version of the job when its line was written."""
SOURCE_SUFFIXES = (".py", ".yaml")


# ---------------------------------------------------------------------------------------------------
# Jobs and rows


def job_key(job: dict) -> str:
    """``name=value;...`` of the job's items in order: the run's identity in the results file."""
    return ";".join(f"{name}={value}" for name, value in job.items())


@functools.lru_cache(maxsize=1)
def code_fingerprint() -> str:
    """12 hex digits of the sha256 over the installed slipnav sources (every .py and .yaml file of
    slipnav.systems, .diagrams, .scenarios with its built-in scenarios, and .studies, in path order)."""
    import importlib

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


def _plain(value, where: str):
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


# ---------------------------------------------------------------------------------------------------
# The results file


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
        except UnicodeDecodeError:
            lines = ["(not UTF-8 text)"]
        if lines and next(csv.reader(lines[:1]))[:1] != [KEY]:
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


# ---------------------------------------------------------------------------------------------------
# Progress


class Progress:
    """A tqdm bar on a terminal; on anything else (a log file, a pipe) plain lines, one per 10 % of the
    runs and one at the end, since a redrawn bar there is a single growing line."""

    def __init__(self, total: int, done: int, label: str, stream=None, note: str = ""):
        self.stream = stream or sys.stderr
        self.total, self.done, self.label = total, done, label
        self.start = time.perf_counter()
        self.terminal = bool(getattr(self.stream, "isatty", lambda: False)())
        self._bar = None
        if self.terminal:
            from tqdm import tqdm

            if note:
                print(f"{label}: {note}", file=self.stream, flush=True)
            self._bar = tqdm(
                total=total, initial=done, desc=label, unit="run", file=self.stream, dynamic_ncols=True
            )
        elif done or note:
            resumed = f"{done} finished runs resumed" if done else ""
            self._line("; ".join(text for text in (resumed, note) if text))

    def _line(self, note: str = "") -> None:
        pct = 100.0 * self.done / self.total if self.total else 100.0
        elapsed = time.perf_counter() - self.start
        text = f"{self.label}: {self.done}/{self.total} runs ({pct:.0f} %), {elapsed:.1f} s"
        print(text + (f"; {note}" if note else ""), file=self.stream, flush=True)

    def update(self) -> None:
        before = self.done
        self.done += 1
        if self._bar is not None:
            self._bar.update(1)
        elif self.done == self.total or 10 * self.done // self.total > 10 * before // self.total:
            self._line()

    def close(self) -> None:
        if self._bar is not None:
            self._bar.close()


# ---------------------------------------------------------------------------------------------------
# The engine


def check_engine_options(workers, scheduler) -> None:
    """--workers in 0 .. MAX_WORKERS; not with --scheduler (that cluster has its own workers)."""
    if workers is not None:
        if isinstance(workers, bool) or not isinstance(workers, int) or not 0 <= workers <= MAX_WORKERS:
            raise ScenarioError(
                f"--workers={workers!r} is out of range: allowed 0 (in this process) .. {MAX_WORKERS}"
            )
        if scheduler is not None:
            raise ScenarioError(
                f"--workers={workers} with --scheduler={scheduler!r}: allowed one of them (the scheduler's "
                "cluster has its own workers)"
            )
    if scheduler is not None and (not isinstance(scheduler, str) or not scheduler.strip()):
        raise ScenarioError(f"--scheduler={scheduler!r}: allowed an address such as tcp://127.0.0.1:8786")
    if scheduler is not None:
        check_scheduler_address(scheduler)


SCHEDULER_SCHEMES = ("tcp", "tls", "ws", "wss")
SCHEDULER_TIMEOUT = 10.0
"""s a scheduler has to connect and answer (a dask client, once connected, waits for its answer forever)."""


def check_scheduler_address(address: str) -> None:
    """``[scheme://]host:port`` with a scheme of SCHEDULER_SCHEMES (dask's default tcp) and a port in
    1 .. 65535; ScenarioError naming --scheduler."""
    from distributed.comm.addressing import parse_address, parse_host_port

    allowed = f"allowed [{'|'.join(SCHEDULER_SCHEMES)}://]HOST:PORT, e.g. tcp://127.0.0.1:8786"
    try:
        scheme, location = parse_address(address, strict=False)
        if scheme not in SCHEDULER_SCHEMES:
            raise ValueError(f"the scheme {scheme!r} is not a dask scheduler's")
        host, port = parse_host_port(location)
        if not host or not 1 <= port <= 65535:
            raise ValueError(f"host {host!r}, port {port}")
    except ValueError as e:
        raise ScenarioError(f"--scheduler={address!r} is not an address ({e}): {allowed}") from None


def probe_scheduler(address: str, timeout: float | None = None) -> dict:
    """The scheduler at ``address``'s identity (its kind, address and workers), asked with a deadline of
    ``timeout`` s (default SCHEDULER_TIMEOUT) in all; ScenarioError naming --scheduler if it cannot be
    reached, does not answer in time (a server that is no dask scheduler) or answers as something else."""
    import asyncio
    import concurrent.futures

    from distributed.comm import connect
    from distributed.comm.addressing import parse_address, parse_host_port

    timeout = SCHEDULER_TIMEOUT if timeout is None else timeout

    async def identity():
        comm = await connect(address, timeout=timeout)
        try:
            await comm.write({"op": "identity", "reply": True})
            return await comm.read()
        finally:
            comm.abort()

    def ask():
        return asyncio.run(asyncio.wait_for(identity(), timeout))

    allowed = "allowed the address of a running dask scheduler ('dask scheduler' prints it)"
    try:  # a refused or unroutable port at once, before dask's connect retries it until the timeout
        socket.create_connection(parse_host_port(parse_address(address, strict=False)[1]), timeout).close()
    except OSError as e:
        reason = e.strerror or str(e)
        raise ScenarioError(f"--scheduler={address!r} cannot be reached: {reason}: {allowed}") from None
    with concurrent.futures.ThreadPoolExecutor(1) as pool:  # its own event loop, whatever runs in this one
        try:
            reply = pool.submit(ask).result()
        except (asyncio.TimeoutError, TimeoutError):
            raise ScenarioError(
                f"--scheduler={address!r} did not answer as a dask scheduler within {timeout:g} s: {allowed}"
            ) from None
        except Exception:  # closed, or bytes that are no dask message
            raise ScenarioError(
                f"--scheduler={address!r} did not answer as a dask scheduler (the connection closed, or its "
                f"reply is no dask message): {allowed}"
            ) from None
    if not isinstance(reply, dict) or reply.get("type") != "Scheduler":
        raise ScenarioError(f"--scheduler={address!r} answered, but not as a dask scheduler: {allowed}")
    return reply


@contextlib.contextmanager
def _workers_ignore_ctrl_c():
    """SIGINT ignored while the worker processes start: they inherit it, so that Ctrl-C, which the
    terminal sends to the whole process group, reaches this process only (which then stops the cluster)
    instead of printing a traceback from every worker."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


class Engine:
    """Where the runs go: ``workers`` local worker processes (0: this process) or the cluster at
    ``scheduler``. A context manager; the local cluster lives until it is left, for any number of
    ``map`` calls."""

    def __init__(self, workers: int | None = None, scheduler: str | None = None):
        check_engine_options(workers, scheduler)
        self.scheduler = scheduler
        self.workers = DEFAULT_WORKERS if workers is None and scheduler is None else workers
        self.client = self._cluster = None
        self.start_s = 0.0

    def __enter__(self) -> Engine:
        if self.scheduler is None and self.workers == 0:
            return self
        start = time.perf_counter()
        import dask
        from dask.distributed import Client, LocalCluster

        quiet = logging.CRITICAL  # no start/stop chatter, "unresponsive" warnings, nor a failed run twice
        try:
            if self.scheduler is not None:
                for name in ("distributed", "distributed.client"):
                    logging.getLogger(name).setLevel(quiet)
                probe_scheduler(self.scheduler)
                try:
                    self.client = Client(self.scheduler, timeout=f"{SCHEDULER_TIMEOUT:g}s")
                except OSError as e:
                    raise ScenarioError(f"--scheduler={self.scheduler!r} cannot be reached: {e}") from None
                self.workers = len(self.client.scheduler_info().get("workers", {}))
                if not self.workers:
                    raise ScenarioError(
                        f"--scheduler={self.scheduler!r} has no workers: allowed a cluster with at least one"
                    )
            else:
                with _workers_ignore_ctrl_c(), dask.config.set(WORKER_CONFIG):
                    self._cluster = LocalCluster(
                        n_workers=self.workers,
                        threads_per_worker=1,
                        processes=True,
                        dashboard_address=None,
                        silence_logs=quiet,
                    )
                self.client = Client(self._cluster)
        except BaseException:
            self.__exit__(None, None, None)
            raise
        self.start_s = time.perf_counter() - start
        return self

    def __exit__(self, *exc) -> None:
        for part in (self.client, self._cluster):
            if part is not None:
                with contextlib.suppress(Exception):
                    part.close()
        self.client = self._cluster = None

    def map(self, run, jobs: list, results: ResultsFile | None = None, label: str = "sweep", stream=None):
        """The rows ``{**job, **run(job)}`` of every job, in job order; the runs already in ``results`` are
        taken from it, every new one is appended to it as it finishes. Progress on ``stream`` (default
        stderr). A run's exception ends the sweep (the finished runs stay in ``results``)."""
        keys = [job_key(job) for job in jobs]
        for job in jobs:
            for name, value in job.items():
                _plain(value, f"job {name}")
        if len(set(keys)) < len(keys):
            raise ValueError("two jobs have the same key: every job must name a different run")
        versions = [run_version(job) for job in jobs]
        note = ""
        if results is not None:
            results.check_jobs(jobs)
            stale = [
                key
                for key, version in zip(keys, versions, strict=True)
                if key in results.done and not results.finished(key, version)
            ]
            results.discard(stale)
            rerun = len(stale) + results.older_format
            if results.older_format:
                results.columns = None  # the first finished run starts the file anew
            if rerun:
                note = f"{rerun} lines of another code or scenario version run again"
        rows = [
            results.row(key, job) if results is not None and results.finished(key, version) else None
            for key, job, version in zip(keys, jobs, versions, strict=True)
        ]
        pending = [i for i, row in enumerate(rows) if row is None]
        if results is not None:
            resumed = [i for i, row in enumerate(rows) if row is not None]
            results.check_resumed(keys, rows, resumed)
        progress = Progress(len(jobs), len(jobs) - len(pending), label, stream, note)

        def finish(i, result):
            row = {**jobs[i], **{name: _plain(value, name) for name, value in result.items()}}
            if results is not None:
                results.append(keys[i], row, versions[i])
            rows[i] = row
            progress.update()

        try:
            if self.client is None:
                for i in pending:
                    finish(i, run(jobs[i]))
            elif pending:
                from dask.distributed import as_completed

                futures = self.client.map(run, [jobs[i] for i in pending], pure=False)
                index = {future.key: i for future, i in zip(futures, pending, strict=True)}
                try:
                    for future in as_completed(futures):
                        finish(index[future.key], future.result())
                finally:
                    self.client.cancel(futures)
        finally:
            progress.close()
        if results is not None:  # against the new runs' rows too
            results.check_resumed(keys, rows, resumed)
        return rows


def run_jobs(
    run,
    jobs: list,
    *,
    workers: int | None = None,
    scheduler: str | None = None,
    results=None,
    resume: bool = False,
    label: str = "sweep",
    stream=None,
    columns=None,
) -> list:
    """One call for a study: ``run`` over ``jobs`` on a fresh Engine, the rows in job order, appended
    to the CSV ``results`` (a path, or None for none) as they finish (``resume``: keep its finished
    runs; ``columns``: the result columns a row has, if known, checked against a resumed file first)."""
    file = ResultsFile(results, resume) if results is not None else None
    if file is not None:
        file.check_columns(columns)
    try:
        with Engine(workers, scheduler) as engine:
            return engine.map(run, jobs, file, label, stream)
    finally:
        if file is not None:
            file.close()


# ---------------------------------------------------------------------------------------------------
# slipnav sweep


def split_values(text: str) -> list[str]:
    """``v1,v2,[0, 0, 1]`` -> ['v1', 'v2', '[0, 0, 1]']: commas inside brackets or braces do not split."""
    values, depth, current = [], 0, ""
    for char in text:
        if char in "[{":
            depth += 1
        elif char in "]}":
            depth -= 1
        if char == "," and depth == 0:
            values.append(current.strip())
            current = ""
        else:
            current += char
    return values + [current.strip()]


def parse_set_options(options: list[str]) -> dict[str, list[str]]:
    """``["KEY=V1,V2", ...]`` -> {KEY: ['V1', 'V2']} (the values' text, in order)."""
    sets = {}
    for option in options:
        key, equals, text = option.partition("=")
        key = key.strip()
        if not equals or not key:
            raise ScenarioError(
                f"--set {option!r}: allowed KEY=VALUE[,VALUE ...], e.g. navigation.mixing.b1=0.03,0.05"
            )
        if key in sets:
            raise ScenarioError(f"--set {key} is given twice: allowed once per key, with all its values")
        values = split_values(text)
        if any(v == "" for v in values):
            raise ScenarioError(f"--set {option!r} has an empty value: allowed KEY=VALUE[,VALUE ...]")
        if len(set(values)) < len(values):
            raise ScenarioError(f"--set {option!r} repeats a value: allowed each value once")
        sets[key] = values
    return sets


def combinations(sets: dict[str, list[str]]) -> list[dict[str, str]]:
    """The cartesian product of the --set values, the first key varying slowest."""
    return [dict(zip(sets, values, strict=True)) for values in itertools.product(*sets.values())]


@functools.lru_cache(maxsize=32)
def _scenario(name: str, changes: tuple):
    """The scenario ``name`` with ``changes`` ((key, value text) pairs) set; cached per process."""
    scenario = load_scenario(name)
    for key, text in changes:
        try:
            scenario = with_keys(scenario, {key: parse_value(text)})
        except ScenarioError as e:
            raise ScenarioError(f"--set {key}={text}: {e}") from None
    return scenario


def check_sweep(name: str, sets: dict, seeds: int, duration=None) -> None:
    """Every combination's scenario loads and validates, seeds in 1 .. MAX_SEEDS, the duration fits: before
    any run."""
    check_seed_count(seeds)
    if "seed" in sets:
        raise ScenarioError("--set seed=...: the sweep runs seeds 0..N-1 of --seeds N; allowed any other key")
    for combination in combinations(sets):
        scenario = _scenario(name, tuple(combination.items()))
        if duration is not None:
            check_duration(scenario, duration)


def final_errors(a: dict) -> dict:
    """The final position error (% of path length) and heading error (deg) of the fused estimate,
    odometry-only and Gyrodometry, and the side-slip RMS error (deg, where |alpha| > 1 deg) of a run's
    arrays."""
    from slipnav.scenarios.metrics import ESTIMATES, final_position_error, side_slip_rms_error

    length = float(a["path_length"])
    out = {}
    for label, prefix in ESTIMATES:
        out[f"{label}_pct"] = 100.0 * final_position_error(a, prefix) / length
        heading = float(a[f"{prefix}_phi"][-1] - a["true_phi"][-1])
        out[f"{label}_heading_deg"] = math.degrees(math.remainder(heading, 2.0 * math.pi))
    out["alpha_rms_deg"] = math.degrees(side_slip_rms_error(a))
    return out


SET_PREFIX = "set:"
"""Job columns of the --set keys: ``set:navigation.mixing.b1``."""


def run_sweep_job(job: dict) -> dict:
    """One run of ``slipnav sweep``: the job's scenario with its ``set:`` keys, at its seed."""
    from slipnav.scenarios.runner import run_scenario

    changes = tuple((k[len(SET_PREFIX) :], v) for k, v in job.items() if k.startswith(SET_PREFIX))
    scenario = _scenario(job["scenario"], changes)
    result = run_scenario(scenario, seed=job["seed"], duration=job["duration"], open_loop=job["open_loop"])
    return {**final_errors(result.arrays), "completed": bool(result.summary["completed"])}


def sweep_jobs(name: str, sets: dict, seeds: int, duration=None, open_loop=None) -> list[dict]:
    """Every combination of the --set values times seeds 0..seeds-1."""
    return [
        {
            "scenario": name,
            **{SET_PREFIX + key: value for key, value in combination.items()},
            "seed": seed,
            "duration": duration,
            "open_loop": open_loop,
        }
        for combination in combinations(sets)
        for seed in range(seeds)
    ]


def _groups(jobs: list, rows: list) -> dict:
    """{combination label: rows} in job order; the label is ``key=value key=value`` or ``as is``."""
    groups = {}
    for job, row in zip(jobs, rows, strict=True):
        label = " ".join(f"{k[len(SET_PREFIX) :]}={v}" for k, v in job.items() if k.startswith(SET_PREFIX))
        groups.setdefault(label or "as is", []).append(row)
    return groups


def summary_table(name: str, jobs: list, rows: list) -> tuple[list[str], dict]:
    """The summary's lines (per combination: runs, mean (worst) fused, odometry-only and Gyrodometry
    final error in % of path, mean fused over the mean better baseline, runs not completed) and the
    figures of the last line."""
    groups = _groups(jobs, rows)
    width = max(26, *(len(label) + 2 for label in groups))
    lines = [
        f"{name}: final position error, % of path length, mean (worst) over seeds",
        f"{'combination':<{width}}{'runs':>5}{'fused %':>16}{'odometry %':>16}{'Gyrodom. %':>16}"
        f"{'fused/best':>11}{'incomplete':>11}",
    ]
    for label, sel in groups.items():
        col = {
            k: np.array([r[k] for r in sel], float) for k in ("fused_pct", "odometry_pct", "gyrodometry_pct")
        }
        best = np.minimum(col["odometry_pct"], col["gyrodometry_pct"])

        def mw(k, col=col):
            return f"{col[k].mean():.3f} ({col[k].max():.3f})"

        # a baseline that ended exactly on the truth (a run too short to move) gives no ratio
        ratio = f"{col['fused_pct'].mean() / best.mean():.3f}" if best.mean() > 0 else "-"
        lines.append(
            f"{label:<{width}}{len(sel):>5}{mw('fused_pct'):>16}{mw('odometry_pct'):>16}"
            f"{mw('gyrodometry_pct'):>16}{ratio:>11}"
            f"{sum(not r['completed'] for r in sel):>11}"
        )
    fused = np.array([r["fused_pct"] for r in rows], float)
    return lines, {"mean_fused_pct": float(fused.mean()), "worst_fused_pct": float(fused.max())}


def plot_distributions(name: str, jobs: list, rows: list, path) -> FilePath:
    """Per combination, the distribution over seeds of the final error (% of path) of fused,
    odometry-only and Gyrodometry: boxes with every run as a dot. Written atomically."""
    import matplotlib
    import matplotlib.ticker

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    path = FilePath(path)
    groups = _groups(jobs, rows)
    estimators = (
        ("fused", "fused_pct"),
        ("odometry-only", "odometry_pct"),
        ("Gyrodometry", "gyrodometry_pct"),
    )
    fig, ax = plt.subplots(figsize=(max(6.0, 1.6 * len(groups) + 2.0), 4.5))
    x = np.arange(len(groups))
    for j, (label, key) in enumerate(estimators):
        data = [[r[key] for r in sel] for sel in groups.values()]
        positions = x + (j - 1) * 0.27
        color = f"C{j}"
        ax.boxplot(
            data,
            positions=positions,
            widths=0.22,
            showfliers=False,
            patch_artist=True,
            boxprops={"facecolor": color, "alpha": 0.35},
            medianprops={"color": color},
        )
        for p, values in zip(positions, data, strict=True):
            jitter = np.linspace(-0.06, 0.06, len(values)) if len(values) > 1 else [0.0]
            ax.plot(
                p + np.asarray(jitter),
                values,
                ".",
                color=color,
                ms=4,
                label=label if p == positions[0] else None,
            )
    ax.set_yscale("log")
    ax.set_xticks(x, [label.replace(" ", "\n") for label in groups], fontsize=8)
    ax.yaxis.set_major_formatter(matplotlib.ticker.ScalarFormatter())
    ax.yaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
    ax.set_ylabel("final position error (% of path)")
    ax.set_title(f"{name}: {len(rows)} runs, final position error per combination (box: quartiles)")
    ax.axhline(1.0, color="k", lw=0.8, ls="--")
    ax.legend(fontsize=8)
    fig.tight_layout()
    return save_figure_atomically(fig, path)


def sweep(
    name: str,
    seeds: int,
    sets: dict | None = None,
    *,
    duration=None,
    open_loop=None,
    workers: int | None = None,
    scheduler: str | None = None,
    out_dir="runs",
    resume: bool = False,
    stream=None,
) -> list:
    """``slipnav sweep``: run, print the summary and the last line, write the CSV and the figure;
    returns the rows in job order (combinations of ``sets`` {key: [value text]} x seeds)."""
    stream = stream or sys.stdout
    sets = sets or {}
    check_engine_options(workers, scheduler)
    check_sweep(name, sets, seeds, duration)
    jobs = sweep_jobs(name, sets, seeds, duration, open_loop)
    stem = f"sweep-{load_scenario(name).name}"
    results = FilePath(out_dir) / f"{stem}.csv"
    start = time.perf_counter()
    file = ResultsFile(results, resume)
    try:
        file.check_jobs(jobs)
        with Engine(workers, scheduler) as engine:
            resumed = sum(file.finished(job_key(job), run_version(job)) for job in jobs)
            rows = engine.map(run_sweep_job, jobs, file, label=f"sweep {name}")
            wall = time.perf_counter() - start
            used = engine.workers
            cluster_s = engine.start_s
    finally:
        file.close()
    lines, figures = summary_table(name, jobs, rows)
    ran = len(jobs) - resumed
    local = scheduler is None and used == 0
    where = "in this process" if local else f"on {used} workers, cluster start {cluster_s:.1f} s"
    lines += [
        f"{ran} runs in {wall:.1f} s {where} ({ran / wall:.2f} runs/s)"
        + (f"; {resumed} finished runs resumed from the results file" if resumed else ""),
        f"results: {results}",
        f"figure: {plot_distributions(name, jobs, rows, FilePath(out_dir) / f'{stem}.png')}",
        f"sweep runs={ran} workers={used} wall_s={wall:.3f} runs_per_s={ran / wall:.3f} "
        f"mean_fused_pct={figures['mean_fused_pct']:.4f} worst_fused_pct={figures['worst_fused_pct']:.4f}",
    ]
    print("\n".join(lines), file=stream)
    return rows


@contextlib.contextmanager
def session(study: str, workers=None, scheduler=None, out_dir=None, resume: bool = False):
    """(Engine, ResultsFile of ``out_dir/<study>.csv`` or None without ``out_dir``) for a study that maps
    several batches of jobs on one cluster."""
    file = ResultsFile(FilePath(out_dir) / f"{study}.csv", resume) if out_dir is not None else None
    try:
        with Engine(workers, scheduler) as engine:
            yield engine, file
    finally:
        if file is not None:
            file.close()
