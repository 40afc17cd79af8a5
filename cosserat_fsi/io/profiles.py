"""CSV profiles along segments (``observables.lines``): ``<run>/line_NAME.csv``, one block per output time.

Long format: the header ``t,s,x,y,u,v,p[,omega]`` then N rows per output time (``s`` the arc length from the
segment's start), so ``pandas.read_csv(...).groupby("t")`` gives the profiles and ParaView's CSV reader a
table. Rank 0 writes and flushes each block whole, like timeseries.csv (io/timeseries.py): a killed run
keeps every block written, a failed write is kept in :attr:`ProfileWriter.error` for the runner to share.
A restart keeps the blocks up to the checkpoint's time and cuts off the rest (:func:`check_profile`).
"""

from __future__ import annotations

import io
import os
from pathlib import Path

import numpy as np

from ..errors import InputError, OutputError
from ..files import read_regular


def profile_path(run_dir: Path, name: str) -> Path:
    return Path(run_dir) / f"line_{name}.csv"


def check_profile(path: Path, columns: list[str], t: float, prefix: str = "") -> int:
    """The byte offset just after the last complete row of ``path`` at a time <= ``t`` (the checkpoint's);
    InputError naming the file if it is missing, foreign or damaged before that offset."""
    try:
        if not os.path.lexists(path):
            raise InputError(f"{prefix}{path} is missing")
    except OSError as exc:
        raise InputError(f"{prefix}{path}: cannot read ({exc.strerror or exc})") from None
    data = read_regular(path, "profile", prefix)  # a FIFO or a folder: refused without blocking
    header = (",".join(["t", *columns]) + "\n").encode()
    if not data.startswith(header):
        raise InputError(f"{prefix}{path} has other columns than this scene's line ({','.join(['t', *columns])})")
    offset = len(header)
    tol = 1e-9 * max(1.0, abs(t))
    for number, line in enumerate(data[len(header):].split(b"\n")[:-1]):  # the last: "" or unterminated
        try:
            row = [float(v) for v in line.split(b",")]
        except ValueError:
            row = []
        if len(row) != len(columns) + 1:
            raise InputError(f"{prefix}{path}: line {number + 2} is not a row of {len(columns) + 1} numbers "
                             "(damaged file)")
        if row[0] > t + tol:
            break
        offset += len(line) + 1
    return offset


class ProfileWriter:
    """Appends blocks to one ``line_NAME.csv``; collective-safe (only rank 0 touches the file).

    ``keep_until``: a restart, continue after the rows up to that time (later rows are cut off)."""

    def __init__(self, path: Path, columns: list[str], comm, keep_until: float | None = None):
        from ..parallel import on_root

        self.path, self.columns, self.file = Path(path), list(columns), None
        self.error: OutputError | None = None

        def open_file():
            try:
                if keep_until is None:
                    self.file = open(self.path, "w", newline="", encoding="utf-8")
                    self.file.write(",".join(["t", *self.columns]) + "\n")
                    self.file.flush()
                    return
                os.truncate(self.path, check_profile(self.path, self.columns, keep_until, "--restart: "))
                self.file = open(self.path, "a", newline="", encoding="utf-8")
            except OSError as exc:
                from .runfolder import output_error

                raise output_error(self.path, exc) from None

        on_root(comm, open_file, step="profile.open")

    def write(self, t: float, values: np.ndarray):
        """Append the block (N, len(columns)) at time ``t`` (rank 0; a no-op elsewhere)."""
        if self.file is None:
            return
        buffer = io.StringIO()
        np.savetxt(buffer, np.column_stack([np.full(len(values), t), values]), fmt="%.10e", delimiter=",")
        try:
            self.file.write(buffer.getvalue())
            self.file.flush()
        except OSError as exc:
            from .runfolder import output_error

            self.error = output_error(self.path, exc)
            self.close()

    def close(self):
        if self.file is not None:
            try:
                self.file.close()
            except OSError as exc:
                from .runfolder import output_error

                self.error = self.error or output_error(self.path, exc)
            self.file = None


def open_profiles(run_dir: Path, lines: dict, comm, keep_until: float | None = None) -> dict:
    """{name: ProfileWriter} for the observables' ``lines`` ({name: (columns, ...)})."""
    return {name: ProfileWriter(profile_path(run_dir, name), columns, comm, keep_until)
            for name, (columns, *_) in lines.items()}


def check_profiles(run_dir: Path, lines: dict, t: float) -> None:
    """Rank 0, before a restart writes anything: every line file continues to the checkpoint's time ``t``."""
    for name, (columns, *_) in lines.items():
        check_profile(profile_path(run_dir, name), columns, t, "--restart: ")


def write_profiles(profiles: dict, observables, sim) -> None:
    """One block per ``observables.lines`` profile at the current state (collective evaluation, rank 0
    writes)."""
    with sim.timers("observables"):
        for name, values in observables.profiles().items():
            profiles[name].write(sim.t, values)
