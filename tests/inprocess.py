"""The command line run in the test process: ``cli.main(ARGS)``, the same code a ``python -m cosserat_fsi``
subprocess runs after the interpreter's start and imports (2 of a small run's 3 s). Used by the fault suite's
``cli`` and by the ``run_cli`` fixture whenever a case needs no process of its own (a launcher, a working
folder, environment variables, a signal or a kill from outside, ``plot``'s VTK window, or a pytest itself
under MPI)."""

from __future__ import annotations

import io
import logging
import os
import signal
import sys
import tempfile
import time


def under_mpi() -> bool:
    """Whether this pytest is one rank of several (a CLI case is then a serial run of its own)."""
    return any(os.environ.get(key, "1") != "1" for key in ("OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_SIZE"))


def own_process(args) -> bool:
    """Whether the command needs a process of its own: ``plot`` renders its snapshots with VTK, whose
    off-screen window aborts the process the second time one is opened in it (measured: "Fatal Python error:
    Aborted" in pyvista's render, in a pytest worker that had plotted before)."""
    return bool(args) and (os.fsdecode(args[0]) if isinstance(args[0], bytes) else str(args[0])) == "plot"


class Hang(BaseException):
    """The case did not end within its timeout (raised by SIGALRM inside the run)."""


def main_in_process(args, timeout: float) -> tuple[int | None, str, str, float]:
    """(exit code or None for a hang, stdout, stderr, seconds) of ``cli.main(ARGS)``. What it writes is caught
    at the file descriptors too (what PETSc or gmsh print from C), in files as a pipe would; SIGALRM after
    ``timeout`` s stops it; the signal handlers, streams and the package's log handlers are put back."""
    from cosserat_fsi.app import cli as cli_module

    argv = [os.fsdecode(a) if isinstance(a, bytes) else str(a) for a in args]
    handlers = {s: signal.getsignal(s) for s in (signal.SIGTERM, signal.SIGINT, signal.SIGALRM)}
    streams = (sys.stdout, sys.stderr)
    for stream in streams:
        stream.flush()
    saved = (os.dup(1), os.dup(2))

    def hang(signum, frame):
        raise Hang

    start = time.monotonic()
    with tempfile.TemporaryFile() as out, tempfile.TemporaryFile() as err:
        os.dup2(out.fileno(), 1)
        os.dup2(err.fileno(), 2)
        sys.stdout, sys.stderr = (io.TextIOWrapper(os.fdopen(os.dup(fd), "wb"), encoding="utf-8",
                                                   line_buffering=True) for fd in (1, 2))
        signal.signal(signal.SIGALRM, hang)
        signal.setitimer(signal.ITIMER_REAL, timeout)
        try:
            code = cli_module.main(argv)
        except Hang:
            code = None
        finally:
            signal.setitimer(signal.ITIMER_REAL, 0)
            logger = logging.getLogger("cosserat_fsi")  # its handlers write to the streams closed here
            for handler in list(logger.handlers):
                logger.removeHandler(handler)
                handler.close()
            for stream in (sys.stdout, sys.stderr):
                stream.close()
            for fd, target in zip(saved, (1, 2)):
                os.dup2(fd, target)
                os.close(fd)
            sys.stdout, sys.stderr = streams
            for sig, handler in handlers.items():
                signal.signal(sig, handler)
        texts = []
        for f in (out, err):
            f.seek(0)
            texts.append(f.read().decode("utf-8", "replace"))
    return code, texts[0], texts[1], time.monotonic() - start
