"""The Python handlers of SIGINT and SIGTERM, kept around libraries that replace them (gmsh, PETSc)."""

from __future__ import annotations

import signal
import threading


def signal_handlers(restore: dict | None = None) -> dict:
    """The Python handlers of SIGINT and SIGTERM; with ``restore``, install those again (which also puts
    Python's C-level handler back where a library replaced it). Main thread only."""
    if threading.current_thread() is not threading.main_thread():
        return {}
    for sig, handler in (restore or {}).items():
        if handler is not None:
            signal.signal(sig, handler)
    return {sig: signal.getsignal(sig) for sig in (signal.SIGINT, signal.SIGTERM)}
