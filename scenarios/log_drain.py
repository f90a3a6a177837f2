"""A diagram's shared log drained into preallocated arrays after every simulator step (a run's memory:
one float64 per logged channel and sample)."""

from __future__ import annotations

import numpy as np


class LogDrain:
    """Moves the samples of a diagram's shared log (loggers.add_loggers: one VectorLogSink) into
    preallocated arrays after every simulator step and clears the sink, so that a run's memory is one
    float64 per logged channel and sample (Drake's log would double its capacity as it grows, and
    collect_arrays copy it). ``loggers()`` gives SignalLog look-alikes over the drained samples.

    Args:
        loggers: the LoggedDiagram's loggers (SignalLog, all on one sink). context: the root context.
        capacity: the number of samples expected (grown by half if exceeded).
    """

    def __init__(self, loggers: dict, context, capacity: int):
        self._signals = loggers
        self._sink = next(iter(loggers.values())).sink
        self._context = context
        rows = max(signal.rows.stop for signal in loggers.values())
        self.buffer, self._t, self.n = np.empty((rows, capacity)), np.empty(capacity), 0

    @property
    def t(self) -> np.ndarray:
        return self._t[: self.n]

    def signal(self, name: str) -> np.ndarray:
        """The drained rows of one signal (a view: rows x samples)."""
        return self.buffer[self._signals[name].rows, : self.n]

    def drain(self) -> slice:
        """Take the sink's new samples; returns their slice in the drained arrays."""
        log = self._sink.FindMutableLog(self._context)
        m = log.num_samples()
        if self.n + m > self._t.size:
            grown = max(self.n + m, self._t.size + self._t.size // 2)
            buffer, times = np.empty((self.buffer.shape[0], grown)), np.empty(grown)
            buffer[:, : self.n], times[: self.n] = self.buffer[:, : self.n], self._t[: self.n]
            self.buffer, self._t = buffer, times
        self.buffer[:, self.n : self.n + m] = log.data()
        self._t[self.n : self.n + m] = log.sample_times()
        log.Clear()
        self.n += m
        return slice(self.n - m, self.n)

    def loggers(self) -> dict:
        """SignalLog look-alikes (``FindLog(context).data()``, ``.sample_times()``) over the drained
        samples, for collect_arrays (views, no copies)."""
        return {name: _DrainedSignal(self, name) for name in self._signals}


class _DrainedSignal:
    def __init__(self, drain: LogDrain, name: str):
        self._drain, self._name = drain, name

    def FindLog(self, context):  # noqa: N802 (the VectorLogSink API)
        return _DrainedRows(self._drain.signal(self._name), self._drain.t)


class _DrainedRows:
    def __init__(self, data, times):
        self._data, self._times = data, times

    def data(self):
        return self._data

    def sample_times(self):
        return self._times

    def num_samples(self):
        return len(self._times)
