"""Exceptions that the CLI turns into exit codes.

    2    bad input (InputError), including a folder in use, a damaged file read, a disk that fills
         (OutputError): one line ``error: ...``
    3    the run diverged (DivergenceError): ``diverged: ...``, output kept
    1    anything else, a bug: ``internal error: <type>: <message> (traceback in <file>)``
    128 + signal   SIGINT (130) / SIGTERM (143): ``interrupted: ...``
"""


class InputError(Exception):
    """Bad user input (YAML, CLI, mesh, parameters). The CLI prints one line and exits with code 2.

    The message names the key (dotted path) and the problem, e.g. ``time.dt: must be > 0 (got -1)``.
    """

    exit_code = 2


class OutputError(InputError):
    """An output file could not be written (disk full, read-only, removed folder). Exit code 2; the files
    written before are kept and summary.json (if it could be written) says ``failed``."""


class DivergenceError(Exception):
    """The run diverged (NaN, inverted element). The CLI keeps the output and exits with code 3."""

    exit_code = 3


class Interrupted(Exception):
    """SIGTERM/SIGINT. Exit code 128 + the signal number. In the time loop a checkpoint is written first."""

    def __init__(self, message: str, signum: int):
        super().__init__(message)
        self.signum = signum
        self.exit_code = 128 + signum


class InternalError(Exception):
    """An unexpected exception of another rank, re-raised on this one (see ``parallel``): exit code 1."""

    exit_code = 1

    def __init__(self, kind: str, message: str):
        super().__init__(message)
        self.kind = kind


def exit_code_of(exc: BaseException) -> int:
    """The CLI's exit code for ``exc``."""
    if isinstance(exc, KeyboardInterrupt):
        return 130
    return getattr(exc, "exit_code", 1) if isinstance(exc, (InputError, DivergenceError, Interrupted,
                                                            InternalError)) else 1
