"""The sweep engine on dask.distributed: ``run_jobs`` and ``session`` (the results file:
studies/results_file.py).

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
"""

from __future__ import annotations

import contextlib
import logging
import os
import signal
import socket
import sys
import threading
import time
from pathlib import Path as FilePath

from slipnav.scenarios.typed_yaml import ScenarioError
from slipnav.studies.results_file import ResultsFile, job_key, plain_value, run_version

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
every 10 ms) and the event loop's housekeeping every second instead of every 20-500 ms: every wake-up
takes the GIL from the simulation."""


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
                plain_value(value, f"job {name}")
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
            row = {**jobs[i], **{name: plain_value(value, name) for name, value in result.items()}}
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
