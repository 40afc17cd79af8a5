"""CSV time series of scalar observables (forces, probes, energies), one row per time step.

Rank 0 writes; rows are appended and flushed one by one, so a killed run keeps every row written and a
reader (``plot`` on a running run) sees only complete rows plus at most one unterminated last row,
which :func:`read_timeseries` ignores. A write that fails (disk full) does not raise in the middle of
a step: it is kept in :attr:`TimeSeriesWriter.error` for the runner to share with every rank.
"""

from __future__ import annotations

import math
import os
import re
from pathlib import Path

import numpy as np

from ..errors import InputError, OutputError

_NAME = re.compile(r"\w+")


class TimeSeriesWriter:
    """``path`` gets the header ``t,<columns>`` and one row per :meth:`write`.

    Collective-safe: every rank may call it, only rank 0 touches the file.
    """

    def __init__(self, path: Path, columns: list[str], comm, keep_rows: int | None = None):
        """``keep_rows``: continue an existing file after its first ``keep_rows`` rows (a restart; later
        rows are cut off). A failure (a bad file, an unwritable folder) is raised on every rank."""
        from ..parallel import on_root

        self.columns = list(columns)
        if "t" in self.columns or len(set(self.columns)) != len(self.columns):
            raise ValueError("TimeSeriesWriter: columns must be unique and must not include 't'")
        self.path = Path(path)
        self.file = None
        self.error: OutputError | None = None
        self.rank = comm.rank

        def open_file():
            header = ",".join(["t", *self.columns]) + "\n"
            try:
                if keep_rows is None:
                    self.file = open(self.path, "w", newline="", encoding="utf-8")
                    self.file.write(header)
                    self.file.flush()
                    return
                offset = check_timeseries(self.path, keep_rows, self.columns, "--restart: ")
                os.truncate(self.path, offset)
                self.file = open(self.path, "a", newline="", encoding="utf-8")
            except OSError as exc:
                from .runfolder import output_error

                raise output_error(self.path, exc) from None

        on_root(comm, open_file, step="timeseries.open")

    def write(self, t: float, values: dict):
        """Append a row; columns missing from ``values`` are written as nan. A failed write is kept in
        :attr:`error` (the file is closed; later rows are not written)."""
        unknown = set(values) - set(self.columns)
        if unknown:
            raise ValueError(f"TimeSeriesWriter: unknown columns {sorted(unknown)}")
        from ..parallel import failpoint

        try:
            failpoint("timeseries.write")  # every rank: a fault on rank 1 is shared at the end of the step
        except OSError as exc:
            from .runfolder import output_error

            self.error = output_error(self.path, exc)
        if self.file is None:
            return
        row = [t, *(values.get(c, math.nan) for c in self.columns)]
        try:
            self.file.write(",".join(f"{float(v):.10e}" for v in row) + "\n")
            self.file.flush()
        except OSError as exc:
            from .runfolder import output_error

            self.error = output_error(self.path, exc)
            try:
                self.file.close()
            except OSError:
                pass
            self.file = None

    def close(self):
        if self.file is not None:
            try:
                self.file.close()
            except OSError as exc:
                if self.error is None:
                    from .runfolder import output_error

                    self.error = output_error(self.path, exc)
            self.file = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


def _parse(path: Path, prefix: str = "") -> tuple[list[str], list[bytes], int]:
    """(header names, complete row lines, byte offset after the header) of a time-series file."""
    from ..files import read_regular

    if not os.path.lexists(path):
        raise InputError(f"{prefix}{path} is missing")
    if os.path.isdir(path):
        raise InputError(f"{prefix}{path} is a folder, not a time series")
    data = read_regular(path, "time series", prefix)  # a FIFO or a folder: refused without blocking
    end = data.find(b"\n")
    head = data[:end] if end >= 0 else b""
    try:
        names = head.decode("ascii").split(",")
    except UnicodeDecodeError:
        names = []
    if end < 0 or names[:1] != ["t"] or not all(_NAME.fullmatch(n) for n in names) \
            or len(set(names)) != len(names):
        raise InputError(f"{prefix}{path} is not a cosserat-fsi time series (no 't,...' header)")
    body = data[end + 1:]
    lines = body.split(b"\n")
    complete = lines[:-1]  # the last element is "" or an unterminated row (a run writing or killed)
    return names, complete, end + 1


def _rows(path: Path, names: list[str], lines: list[bytes], prefix: str) -> np.ndarray:
    try:
        data = np.array([[float(v) for v in line.split(b",")] for line in lines], dtype=float)
    except ValueError:
        data = None
    if data is None or (len(lines) and data.shape != (len(lines), len(names))):
        bad = next((i for i, line in enumerate(lines) if len(line.split(b",")) != len(names)
                    or not _floats(line)), 0)
        raise InputError(f"{prefix}{path}: line {bad + 2} is not a row of {len(names)} numbers (damaged file)")
    return data.reshape(-1, len(names))


def _floats(line: bytes) -> bool:
    try:
        [float(v) for v in line.split(b",")]
        return True
    except ValueError:
        return False


def check_timeseries(path: Path, rows: int, columns: list[str] | None, prefix: str = "") -> int:
    """Check that ``path`` has the header ``t,<columns>`` (any if None) and at least ``rows`` complete
    numeric rows; returns the byte offset just after row ``rows``. InputError naming the file otherwise."""
    path = Path(path)
    names, lines, offset = _parse(path, prefix)
    if columns is not None and names != ["t", *columns]:
        raise InputError(f"{prefix}{path} has other columns than this scene's ({','.join(names)[:60]})")
    if len(lines) < rows:
        raise InputError(f"{prefix}{path} has {len(lines)} rows, the checkpoint needs {rows}")
    _rows(path, names, lines[:rows], prefix)
    return offset + sum(len(line) + 1 for line in lines[:rows])


def read_timeseries(path: Path) -> dict[str, np.ndarray]:
    """Columns of a CSV written by :class:`TimeSeriesWriter`; an unterminated last row (a run killed
    while writing it, or still writing) is ignored. InputError naming the file if it is not one."""
    path = Path(path)
    names, lines, _ = _parse(path)
    data = _rows(path, names, lines, "")
    return {name: data[:, i] for i, name in enumerate(names)}
