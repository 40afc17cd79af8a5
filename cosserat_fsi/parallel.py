"""One error path under MPI: an exception on any rank ends every rank with the same exit code.

A step that runs on rank 0 only (meshing, creating or rewriting a file, the summary) goes through
:func:`on_root`; a step that every rank runs on its own (reading its checkpoint file) through
:func:`agree`. Both end with one collective that tells every rank the outcome: if a rank failed, every
rank raises the same exception (same class for the CLI's exit code, same message), marked ``shared``
so that the CLI prints it once (rank 0) and every rank exits normally. An exception raised where the
other ranks cannot hear of it (inside a collective numerical step) is not shared: the CLI prints it and
calls ``MPI_Abort`` with the exit code (app/cli.py), the last resort.

:func:`failpoint` is the test hook of the fault suite (tests/faults/): ``COSSERAT_FSI_FAILPOINT=
"<name>@<rank>[:<kind>[:<hit>]]"`` makes the named step fail on that rank (``*``: every rank) at its
``hit``-th passage (default 1), with ``kind`` one of ``error`` (a RuntimeError, a bug), ``enospc``
(OSError: no space left), ``input`` (InputError), ``sigterm``/``sigint`` (the signal to this process),
``abort`` (SIGABRT, as a C library that dies), ``hang`` (sleeps an hour, as a .geo gmsh never finishes).
Unset, it costs one dictionary lookup.
"""

from __future__ import annotations

import errno
import os
import signal
from typing import Any
from collections.abc import Callable

from cosserat_fsi.errors import (DivergenceError, InputError, InternalError, Interrupted, OutputError,
                                 exit_code_of)
from cosserat_fsi.files import WRITE_ERRNOS


def _wire(exc: BaseException | None):
    """A picklable description of ``exc`` (None for success)."""
    if exc is None:
        return None
    if isinstance(exc, KeyboardInterrupt):
        return ("interrupted", "Ctrl-C (SIGINT)", 2)
    if isinstance(exc, Interrupted):
        return ("interrupted", str(exc), exc.signum)
    if isinstance(exc, OutputError):
        return ("output", str(exc), None)
    if isinstance(exc, OSError) and exc.errno in WRITE_ERRNOS:
        return ("output", f"{exc.filename or 'output'}: cannot write ({exc.strerror})", None)
    if isinstance(exc, InputError):
        return ("input", str(exc), None)
    if isinstance(exc, DivergenceError):
        return ("diverged", str(exc), None)
    if isinstance(exc, InternalError):
        return ("internal", str(exc), exc.kind)
    where = getattr(exc, "traceback_file", None)
    if where is None and traceback_sink is not None:  # the origin rank keeps the traceback, says where
        where = exc.traceback_file = traceback_sink(exc)
    return ("internal", str(exc) + (f" (traceback in {where})" if where else ""), type(exc).__name__)


traceback_sink: Callable[[BaseException], str] | None = None
"""Set by the CLI: writes an exception's traceback (run.log or a temporary file), returns where."""


def _rebuild(wire) -> BaseException:
    kind, message, extra = wire
    exc: BaseException = {
        "interrupted": lambda: Interrupted(message, extra),
        "output": lambda: OutputError(message),
        "input": lambda: InputError(message),
        "diverged": lambda: DivergenceError(message),
        "internal": lambda: InternalError(extra, message),
    }[kind]()
    exc.shared = True
    return exc


def _raise_first(comm, wires: list, mine: BaseException | None):
    """Raise on every rank the failure of the lowest failing rank (this rank's own exception if it is that
    rank, with its traceback), marked shared."""
    first = next((r for r, w in enumerate(wires) if w is not None), None)
    if first is None:
        return
    if first == comm.rank and mine is not None:
        if isinstance(mine, KeyboardInterrupt):
            mine = Interrupted("Ctrl-C (SIGINT)", 2)
        mine.shared = True
        raise mine
    raise _rebuild(wires[first])


def agree(comm, fn: Callable[..., Any], *args, **kwargs) -> Any:
    """``fn(*args, **kwargs)`` on every rank, then one allgather: if any rank raised, every rank raises
    (see the module docstring). ``fn`` must not itself be collective."""
    result, mine = None, None
    try:
        result = fn(*args, **kwargs)
    except BaseException as exc:  # noqa: BLE001 (shared, then re-raised)
        mine = exc
    if comm is None or comm.size == 1:
        if mine is not None:
            raise mine
        return result
    _raise_first(comm, comm.allgather(_wire(mine)), mine)
    return result


def on_root(comm, fn: Callable[..., Any] | None, *args, step: str | None = None, **kwargs) -> Any:
    """``fn(*args, **kwargs)`` on rank 0 only; its result (picklable) or the failure of any rank (rank 0's
    in ``fn``, or any rank's at the failpoint ``step``, e.g. a signal) on every rank."""
    if step is not None and os.environ.get("COSSERAT_FSI_FAILPOINT"):
        agree(comm, failpoint, step)  # a fault of any rank before rank 0 acts
    result, mine = None, None
    if comm is None or comm.rank == 0:
        try:
            result = fn(*args, **kwargs)
        except BaseException as exc:  # noqa: BLE001 (shared, then re-raised)
            mine = exc
    if comm is None or comm.size == 1:
        if mine is not None:
            raise mine
        return result
    wire, result = comm.bcast((_wire(mine), result) if comm.rank == 0 else None, root=0)
    _raise_first(comm, [wire] + [None] * (comm.size - 1), mine)
    return result


def share(comm, local: BaseException | None) -> None:
    """Collective: raise everywhere the failure that some rank recorded in ``local`` (None: no failure)."""
    if comm is None or comm.size == 1:
        if local is not None:
            raise local
        return
    _raise_first(comm, comm.allgather(_wire(local)), local)


def raise_if_any(comm, failed: bool, exc: BaseException) -> None:
    """Collective: if ``failed`` on any rank, every rank raises ``exc`` (the same on every rank), marked
    shared so that it is said once."""
    if comm.allreduce(bool(failed), op=_lor()):
        exc.shared = True
        raise exc


def _lor():
    from mpi4py import MPI

    return MPI.LOR


def is_shared(exc: BaseException) -> bool:
    """True if every rank raised ``exc`` (through this module)."""
    return bool(getattr(exc, "shared", False))


# ------------------------------------------------------------------------------------------- faults
_hits: dict[str, int] = {}


def _rank() -> int:
    import sys

    mpi = sys.modules.get("mpi4py.MPI")
    return mpi.COMM_WORLD.rank if mpi is not None else 0


def failpoint(name: str) -> None:
    """Fail here if ``COSSERAT_FSI_FAILPOINT`` names this step for this rank (test hook, see above)."""
    spec = os.environ.get("COSSERAT_FSI_FAILPOINT")
    if not spec:
        return
    where, _, rest = spec.partition(":")
    point, _, rank = where.partition("@")
    if point != name or (rank not in ("", "*") and int(rank) != _rank()):
        return
    kind, _, hit = rest.partition(":")
    _hits[name] = _hits.get(name, 0) + 1
    if _hits[name] != int(hit or 1):
        return
    kind = kind or "error"
    if kind == "enospc":
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
    if kind == "input":
        raise InputError(f"injected fault at {name}")
    if kind == "abort":  # as a C library that dies (gmsh's std::bad_alloc)
        os.abort()
    if kind == "hang":
        import time

        time.sleep(3600)
    if kind in ("sigterm", "sigint"):
        os.kill(os.getpid(), signal.SIGTERM if kind == "sigterm" else signal.SIGINT)
        return
    raise RuntimeError(f"injected fault at {name}")


__all__ = ["agree", "on_root", "share", "raise_if_any", "is_shared", "failpoint", "exit_code_of"]
