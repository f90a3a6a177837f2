"""Progress of one long task on stderr: reading a large sensor log, replaying it, driving the calibration
manoeuvres. A task done within DELAY seconds prints nothing; a longer one shows a tqdm bar on a terminal
and, on anything else (a log file, a pipe, where a redrawn bar is one growing line), plain lines at every
10 % of the work: ``slipnav: reading big.sensors.csv: 30 % (60.1 of 200.4 MB), 4.2 s``. A task in a
study's worker process prints nothing: the study reports its runs (studies/sweep.py Progress)."""

from __future__ import annotations

import multiprocessing
import sys
import time

DELAY = 2.0
"""s a task runs before its progress shows."""


class TaskProgress:
    """Progress of ``total`` units of work (MB, simulated s, manoeuvres), told by ``update(done)``.

    Args:
        total: the whole work, in ``unit``.
        label: what is done, e.g. ``slipnav replay: reading big.sensors.csv``.
        unit: the unit's name.
        stream: where to (default stderr).
    """

    def __init__(self, total: float, label: str, unit: str, stream=None):
        self.stream = stream or sys.stderr
        self.total, self.label, self.unit = float(total), label, unit
        self.start = time.perf_counter()
        self.done = 0.0
        self._tenths = 0
        self._shown = False
        self._bar = None
        self.quiet = multiprocessing.parent_process() is not None  # a worker of a study
        if not self.quiet and bool(getattr(self.stream, "isatty", lambda: False)()):
            from tqdm import tqdm

            self._bar = tqdm(
                total=self.total,
                desc=label,
                unit=unit,
                file=self.stream,
                delay=DELAY,
                dynamic_ncols=True,
                bar_format="{l_bar}{bar}| {n:.1f}/{total:.1f} " + unit + " [{elapsed}<{remaining}]",
            )

    def __enter__(self) -> TaskProgress:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def update(self, done: float) -> None:
        """``done`` units of the total are done (an absolute amount, not an increment)."""
        done = min(float(done), self.total)
        if self._bar is not None:
            self._bar.update(done - self.done)
        self.done = done
        if self._bar is None and not self.quiet:
            tenths = int(10 * done / self.total) if self.total > 0 else 10
            if tenths > self._tenths and time.perf_counter() - self.start >= DELAY:
                self._tenths = tenths
                self._line()

    def _line(self) -> None:
        pct = 100.0 * self.done / self.total if self.total > 0 else 100.0
        elapsed = time.perf_counter() - self.start
        print(
            f"{self.label}: {pct:.0f} % ({_amount(self.done)} of {_amount(self.total)} {self.unit}), "
            f"{elapsed:.1f} s",
            file=self.stream,
            flush=True,
        )
        self._shown = True

    def close(self) -> None:
        """The last line (100 %, where lines were shown and the work is done) or the bar closed."""
        if self._bar is not None:
            self._bar.close()
            self._bar = None
        elif self._shown and self._tenths < 10 and self.done >= self.total:
            self._tenths = 10
            self._line()


def _amount(value: float) -> str:
    """18 manoeuvres, 52.8 s."""
    return f"{value:.0f}" if value == int(value) else f"{value:.1f}"
