"""SIGINT and SIGTERM during a run: a checkpoint, then a clean stop, instead of a killed process.

``signal_handlers`` (cosserat_fsi/signals.py) saves the Python handlers and puts them back after a library
replaced them (gmsh and PETSc install their own, even at the C level); ``StopSignals`` makes the signals only
record their number within the time loop, which then writes a checkpoint and stops (``Interrupted``).
"""

from __future__ import annotations

import signal
import threading


class StopSignals:
    """Within the block, SIGTERM and SIGINT only record their number (``signum``); the time loop then
    writes a checkpoint and stops. Outside the main thread (tests) nothing is installed."""

    SIGNALS = (signal.SIGTERM, signal.SIGINT)

    def __init__(self):
        self.signum = 0
        self._old = {}

    def _handler(self, signum, frame):
        self.signum = signum

    def __enter__(self):
        if threading.current_thread() is threading.main_thread():
            for sig in self.SIGNALS:
                self._old[sig] = signal.signal(sig, self._handler)
        return self

    def reinstall(self):
        """Install the handlers again where a library (gmsh, PETSc, while remeshing) replaced them."""
        if self._old:
            for sig in self.SIGNALS:
                signal.signal(sig, self._handler)

    def __exit__(self, *exc):
        for sig, old in self._old.items():
            signal.signal(sig, old)
