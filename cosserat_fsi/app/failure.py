"""How the command line ends: one line on stderr and an exit code, never a traceback (docs/reliability.md).

    error: <message>                 2   bad input, folder in use or holding a run, damaged file, disk full
    diverged: <message>              3   the run diverged (output kept)
    interrupted: <message>           130 / 143   Ctrl-C / SIGTERM
    internal error: <type>: <message> (traceback in <file>)    1   a bug

The traceback of an internal error goes to the run's run.log once the run owns its folder, else to a
file in the temporary directory. Under MPI an exception that every rank raised (``parallel``) is printed
by rank 0 and every rank returns the code; one that only this rank raised (others may wait in a
collective) is printed here and ends every rank with ``MPI_Abort(code)``.

The run log: records are kept in memory until the run owns its folder and has checked everything
(:meth:`RunLog.commit`), so that a refused run leaves no trace in the folder.
"""

from __future__ import annotations

import errno
import logging
import logging.handlers
import os
import signal
import sys
import tempfile
import traceback
from pathlib import Path

from ..errors import DivergenceError, InputError, InternalError, Interrupted, OutputError, exit_code_of
from ..files import WRITE_ERRNOS

log = logging.getLogger("cosserat_fsi")
_FORMAT = logging.Formatter("%(asctime)s %(levelname)s %(name)s: %(message)s")


class Context:
    """What the failure report needs to know about the command so far."""

    def __init__(self):
        self.traceback_file: Path | None = None  # run.log once the run owns the folder


def rank_and_size() -> tuple[int, int]:
    """(rank, size) from mpi4py if it is loaded, else from the launcher's environment."""
    mpi = sys.modules.get("mpi4py.MPI")
    if mpi is not None:
        return mpi.COMM_WORLD.rank, mpi.COMM_WORLD.size
    rank = size = None
    for var in ("OMPI_COMM_WORLD_RANK", "PMI_RANK", "PMIX_RANK"):
        if os.environ.get(var, "").isdigit():
            rank = int(os.environ[var])
            break
    for var in ("OMPI_COMM_WORLD_SIZE", "PMI_SIZE"):
        if os.environ.get(var, "").isdigit():
            size = int(os.environ[var])
            break
    return rank or 0, size or 1


def say(message: str, stream=None, every_rank: bool = False) -> None:
    """Print on rank 0 only (or on this rank if ``every_rank``); never fails on odd characters."""
    if every_rank or rank_and_size()[0] == 0:
        stream = stream or sys.stdout
        try:
            print(message, file=stream, flush=True)
        except (OSError, ValueError):  # a closed or broken stream: nothing else can be done
            pass


def robust_streams() -> None:
    """stdout/stderr escape what they cannot encode (a non-UTF-8 path) instead of raising."""
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.reconfigure(errors="backslashreplace")
        except (AttributeError, ValueError, OSError):
            pass


def _raise_interrupted(signum, frame):
    raise Interrupted(f"{signal.Signals(signum).name}; stopped before the time loop (no checkpoint)", signum)


def install_signal_handlers() -> None:
    """SIGTERM raises Interrupted (like Ctrl-C raises KeyboardInterrupt) until the time loop installs its
    own handlers, which write a checkpoint first. A closed stdout pipe ends quietly."""
    try:
        signal.signal(signal.SIGTERM, _raise_interrupted)
        signal.signal(signal.SIGINT, signal.default_int_handler)
    except ValueError:  # not the main thread (tests)
        pass


def check_utf8_arguments(argv: list[str]) -> None:
    """InputError if an argument holds bytes that are not UTF-8 (Python keeps them as surrogates)."""
    for i, arg in enumerate(argv, 1):
        try:
            arg.encode("utf-8")
        except UnicodeEncodeError as exc:
            bad = ord(arg[exc.start]) - 0xDC00 if 0xDC80 <= ord(arg[exc.start]) <= 0xDCFF else None
            byte = f" (byte 0x{bad:02x})" if bad is not None else ""
            raise InputError(f"argument {i} is not valid UTF-8{byte}: "
                             f"{arg.encode('utf-8', 'backslashreplace').decode()[:80]}") from None


def _one_line(text: str) -> str:
    return " ".join(str(text).split())[:2000]


def write_traceback(exc: BaseException, context: Context) -> str:
    """Append the traceback to run.log (or a temporary file); returns where it went."""
    rank, size = rank_and_size()
    text = "".join(traceback.format_exception(type(exc), exc, exc.__traceback__))
    header = f"internal error on rank {rank} of {size} (pid {os.getpid()}):\n"
    target = context.traceback_file
    if target is not None:
        try:
            with open(target, "a", encoding="utf-8", errors="backslashreplace") as f:
                f.write(header + text)
            return str(target)
        except OSError:
            pass
    try:
        fd, path = tempfile.mkstemp(prefix=f"cosserat-fsi-traceback-{os.getpid()}-", suffix=".log")
        with os.fdopen(fd, "w", encoding="utf-8", errors="backslashreplace") as f:
            f.write(header + text)
        return path
    except OSError:
        return "nowhere: the temporary directory is not writable"


def report(exc: BaseException, context: Context) -> int:
    """Print the one line for ``exc`` and return its exit code (or end every rank with MPI_Abort)."""
    if isinstance(exc, OSError) and exc.errno == errno.ENAMETOOLONG:  # a path the file system cannot hold
        shared = getattr(exc, "shared", False)
        exc = InputError(f"{exc.filename or 'a path'}: file name too long")
        exc.shared = shared
    elif isinstance(exc, OSError) and exc.errno in WRITE_ERRNOS:
        shared = getattr(exc, "shared", False)
        exc = OutputError(f"{exc.filename or 'output'}: cannot write ({exc.strerror})")
        exc.shared = shared
    code = exit_code_of(exc)
    if isinstance(exc, (InputError,)):
        line = "error: " + _one_line(exc)
    elif isinstance(exc, DivergenceError):
        line = "diverged: " + _one_line(exc)
    elif isinstance(exc, (Interrupted, KeyboardInterrupt)):
        line = "interrupted: " + (_one_line(exc) if isinstance(exc, Interrupted) else "Ctrl-C (SIGINT)")
    elif isinstance(exc, InternalError):  # another rank's bug, shared: the message says where its traceback is
        line = f"internal error: {exc.kind}: {_one_line(exc)}"
    else:
        where = getattr(exc, "traceback_file", None) or write_traceback(exc, context)
        line = f"internal error: {type(exc).__name__}: {_one_line(exc)} (traceback in {where})"
    rank, size = rank_and_size()
    shared = getattr(exc, "shared", False) or isinstance(exc, DivergenceError)
    if size == 1 or shared:
        say(line, sys.stderr)
        return code
    # only this rank knows: say it, then end every rank (the others may wait in a collective)
    say(line, sys.stderr, every_rank=True)
    try:
        sys.stdout.flush()
        sys.stderr.flush()
    except (OSError, ValueError):
        pass
    mpi = sys.modules.get("mpi4py.MPI")
    if mpi is not None:
        mpi.COMM_WORLD.Abort(code)
    os._exit(code)


class RunLog:
    """The ``cosserat_fsi`` logger of a run: information on stdout and warnings on stderr at once, run.log
    once the run owns its folder."""

    def __init__(self, comm):
        self.rank = comm.rank
        for handler in list(log.handlers):
            log.removeHandler(handler)
            handler.close()
        log.propagate = False
        self.memory = None
        if self.rank != 0:
            log.addHandler(logging.NullHandler())
            return
        log.setLevel(logging.INFO)
        for stream, keep in ((sys.stdout, lambda r: r.levelno < logging.WARNING),
                             (sys.stderr, lambda r: r.levelno >= logging.WARNING)):
            handler = logging.StreamHandler(stream)  # progress on stdout, problems on stderr
            handler.setFormatter(logging.Formatter("%(message)s"))
            handler.addFilter(keep)
            log.addHandler(handler)
        self.memory = logging.handlers.MemoryHandler(capacity=1 << 30, flushLevel=logging.CRITICAL + 1)
        log.addHandler(self.memory)

    def commit(self, out_dir: Path, append: bool) -> Path:
        """Rank 0: write the kept records to ``out_dir/run.log`` (appended on a restart) and go on there."""
        path = Path(out_dir) / "run.log"
        try:
            handler = logging.FileHandler(path, mode="a" if append else "w", encoding="utf-8")
        except OSError as exc:
            raise OutputError(f"{path}: cannot write ({exc.strerror})") from None
        handler.setFormatter(_FORMAT)
        if self.memory is not None:
            self.memory.setTarget(handler)
            self.memory.flush()
            log.removeHandler(self.memory)
            self.memory.close()
            self.memory = None
        log.addHandler(handler)
        return path

    def close(self) -> None:
        """Close the handlers (files)."""
        for handler in list(log.handlers):
            log.removeHandler(handler)
            try:
                handler.close()
            except OSError:
                pass


__all__ = ["Context", "RunLog", "check_utf8_arguments", "install_signal_handlers", "report", "robust_streams",
           "say", "errno"]
