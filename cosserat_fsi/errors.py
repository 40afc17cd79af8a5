"""Exceptions that the CLI turns into exit codes (2: bad input, 3: diverged)."""


class InputError(Exception):
    """Bad user input (YAML, CLI, mesh, parameters). The CLI prints one line and exits with code 2.

    The message names the key (dotted path) and the problem, e.g. ``time.dt: must be > 0 (got -1)``.
    """

    exit_code = 2


class DivergenceError(Exception):
    """The run diverged (NaN, inverted element). The CLI keeps the output and exits with code 3."""

    exit_code = 3
