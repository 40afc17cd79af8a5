"""Exceptions that the CLI turns into exit codes (2: bad input, 3: diverged, 128 + signal: stopped)."""


class InputError(Exception):
    """Bad user input (YAML, CLI, mesh, parameters). The CLI prints one line and exits with code 2.

    The message names the key (dotted path) and the problem, e.g. ``time.dt: must be > 0 (got -1)``.
    """

    exit_code = 2


class DivergenceError(Exception):
    """The run diverged (NaN, inverted element). The CLI keeps the output and exits with code 3."""

    exit_code = 3


class Interrupted(Exception):
    """SIGTERM/SIGINT: a checkpoint was written and the files closed. Exit code 128 + the signal number."""

    def __init__(self, message: str, signum: int):
        super().__init__(message)
        self.exit_code = 128 + signum
