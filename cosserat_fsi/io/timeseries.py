"""CSV time series of scalar observables (forces, probes, energies), one row per time step.

Rank 0 writes; each row is flushed, so a killed run keeps every row written.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ..errors import InputError


class TimeSeriesWriter:
    """``path`` gets the header ``t,<columns>`` and one row per :meth:`write`.

    Collective-safe: every rank may call it, only rank 0 touches the file.
    """

    def __init__(self, path: Path, columns: list[str], comm, keep_rows: int | None = None):
        """``keep_rows``: continue an existing file after its first ``keep_rows`` rows (a restart)."""
        self.columns = list(columns)
        if "t" in self.columns or len(set(self.columns)) != len(self.columns):
            raise ValueError("TimeSeriesWriter: columns must be unique and must not include 't'")
        self.file = None
        error = None
        if comm.rank == 0:
            header = ",".join(["t", *self.columns]) + "\n"
            kept = []
            if keep_rows is not None:
                lines = Path(path).read_text().splitlines(keepends=True) if Path(path).exists() else []
                if not lines or lines[0] != header or len(lines) - 1 < keep_rows:
                    error = (f"--restart: {path} does not match the checkpoint "
                             f"(needs its header and {keep_rows} rows)")
                kept = lines[1: keep_rows + 1]
            if error is None:
                self.file = open(path, "w", newline="")
                self.file.write(header + "".join(kept))
                self.file.flush()
        error = comm.bcast(error, root=0)
        if error:
            raise InputError(error)

    def write(self, t: float, values: dict):
        """Append a row; columns missing from ``values`` are written as nan."""
        unknown = set(values) - set(self.columns)
        if unknown:
            raise ValueError(f"TimeSeriesWriter: unknown columns {sorted(unknown)}")
        if self.file is None:
            return
        row = [t, *(values.get(c, math.nan) for c in self.columns)]
        self.file.write(",".join(f"{float(v):.10e}" for v in row) + "\n")
        self.file.flush()

    def close(self):
        if self.file is not None:
            self.file.close()
            self.file = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


def read_timeseries(path: Path) -> dict[str, np.ndarray]:
    """Columns of a CSV written by :class:`TimeSeriesWriter`; an unterminated last row (a run killed
    while writing it) is ignored."""
    with open(path) as f:
        lines = f.readlines()
    header = lines[0].strip().split(",")
    rows = [[float(v) for v in line.split(",")] for line in lines[1:] if line.endswith("\n")]
    data = np.array(rows, dtype=float).reshape(-1, len(header))
    return {name: data[:, i] for i, name in enumerate(header)}
