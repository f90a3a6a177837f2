"""Ctrl-C that never lands inside a Drake callback.

Python runs a SIGINT handler at the next bytecode, which during ``Simulator.AdvanceTo`` is inside some
LeafSystem's Python callback; the KeyboardInterrupt raised there crosses pybind11 and sometimes comes back
as a different error. ``deferred_interrupt`` makes Ctrl-C set a flag instead; the caller checks it between
short ``AdvanceTo`` steps (``raise_if_interrupted``) and leaves with a plain KeyboardInterrupt.
"""

from __future__ import annotations

import contextlib
import signal
import threading


class _Pending:
    def __init__(self):
        self.interrupted = False

    def raise_if_interrupted(self):
        if self.interrupted:
            self.interrupted = False
            raise KeyboardInterrupt


@contextlib.contextmanager
def deferred_interrupt():
    """Within the block Ctrl-C only marks the returned object; ``raise_if_interrupted()`` raises it. On
    leaving the block the previous handler is restored and a pending Ctrl-C is raised."""
    pending = _Pending()
    if threading.current_thread() is not threading.main_thread():
        yield pending
        return
    previous = signal.getsignal(signal.SIGINT)

    def mark(signum, frame):
        pending.interrupted = True

    signal.signal(signal.SIGINT, mark)
    try:
        yield pending
    finally:
        signal.signal(signal.SIGINT, previous)
    pending.raise_if_interrupted()
