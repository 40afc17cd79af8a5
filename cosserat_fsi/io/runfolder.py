"""The run folder is owned: one run at a time, nothing of an earlier run lost by accident.

``RunFolder(out).acquire(mode)`` (rank 0, before anything is written):

1. creates ``out`` if needed and checks that a file can be written there;
2. takes ``out/.lock``, an advisory ``flock`` holding the PID (released by the kernel when the process
   dies, so a lock left by a dead process is taken over with a warning); a folder in use is an
   InputError naming the PID;
3. checks what the folder holds: a folder that already holds a run (any of :data:`RUN_FILES`) is
   refused unless ``mode`` is ``overwrite`` or ``restart``; an output name taken by a folder or by
   something that is not a regular file is refused in every mode.

``commit_overwrite()`` removes the earlier run's files, called only once the new scene is validated and
set up. Files rewritten during a run go through :func:`atomic_write_text` (temporary name + rename).
``release()`` drops the lock (and its file).

Light module: standard library only.
"""

from __future__ import annotations

import errno
import fcntl
import json
import logging
import os
import shutil
import socket
import stat
import tempfile
from pathlib import Path

from ..errors import InputError, OutputError
from ..files import read_json, refuse_link

log = logging.getLogger("cosserat_fsi")

LOCK_NAME = ".lock"
RUN_FILES = ("config.yaml", "timeseries.csv", "fields.xdmf", "fields.h5", "summary.json", "run.log")
"""Files a run writes; any of them in --out means the folder holds a run."""
RUN_DIRS = ("checkpoint", "checkpoint.tmp", "checkpoint.old")
"""Folders a run writes (checkpoints)."""


def output_error(path, exc: OSError) -> OutputError:
    """``OutputError("<path>: cannot write (<reason>)")`` for an OSError while writing ``path``."""
    return OutputError(f"{path}: cannot write ({exc.strerror or exc.__class__.__name__})")


def atomic_write_text(path: Path, text: str) -> None:
    """Write ``text`` to ``path`` through a temporary file in the same folder, flushed and renamed: a
    reader or a crash sees the old content or the new one, never a part. OutputError on failure (the old
    file, if any, is kept)."""
    path = Path(path)
    tmp = None
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
        with os.fdopen(fd, "w", encoding="utf-8") as f:
            f.write(text)
            f.flush()
            os.fsync(f.fileno())
        os.chmod(tmp, 0o644)
        os.replace(tmp, path)
        tmp = None
    except OSError as exc:
        raise output_error(path, exc) from None
    finally:
        if tmp is not None:
            try:
                os.unlink(tmp)
            except OSError:
                pass


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


class RunFolder:
    """Owner of an output folder (rank 0 only). See the module docstring."""

    def __init__(self, path: Path):
        self.path = Path(path)
        self.lock_fd: int | None = None
        self.mode = "new"
        self.created = False
        self.held_run = False

    # ------------------------------------------------------------------ acquire
    def acquire(self, mode: str = "new") -> RunFolder:
        """Create, lock and check the folder for a run of ``mode`` (new, overwrite, restart)."""
        self.mode = mode
        out = self.path
        if mode == "restart":
            if not out.is_dir():
                raise InputError(f"--restart: {out} is not a folder")
        elif out.exists() and not out.is_dir():
            raise InputError(f"--out: {out} exists and is not a folder")
        try:
            if not out.exists():
                out.mkdir(parents=True)
                self.created = True
            probe = tempfile.NamedTemporaryFile(prefix=".write-test-", dir=out)
            probe.close()
        except OSError as exc:
            raise InputError(f"--out: cannot write to {out} ({exc.strerror or exc})") from None
        self._lock()
        try:
            self._check_content(mode)
        except BaseException:
            self.release()
            raise
        return self

    def _lock(self) -> None:
        lock = self.path / LOCK_NAME
        for _ in range(10):  # the file may be replaced between open and flock by a run that ends
            refuse_link(lock)  # never open the lock through a link (O_NOFOLLOW below closes the race)
            try:
                fd = os.open(lock, os.O_RDWR | os.O_CREAT | os.O_NOFOLLOW | os.O_NONBLOCK, 0o644)
            except OSError as exc:
                if exc.errno == errno.ELOOP:
                    raise InputError(f"--out: {lock} is a link (nothing is written through a link; move it "
                                     "away)") from None
                raise InputError(f"--out: cannot create {lock} ({exc.strerror or exc})") from None
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except OSError as exc:
                holder = _read_holder(fd)
                os.close(fd)
                if exc.errno in (errno.EWOULDBLOCK, errno.EAGAIN, errno.EACCES):
                    who = f"process {holder['pid']}" if holder.get("pid") else "another process"
                    host = f" on {holder['host']}" if holder.get("host") not in (None, socket.gethostname()) else ""
                    raise InputError(f"--out: {self.path} is in use by {who}{host} (a run is writing "
                                     "there; wait for it to end or choose another --out)") from None
                raise InputError(f"--out: cannot lock {lock} ({exc.strerror or exc})") from None
            if not stat.S_ISREG(os.fstat(fd).st_mode):
                os.close(fd)
                raise InputError(f"--out: {lock} is not a regular file (move it away)")
            try:
                same = os.fstat(fd).st_ino == os.stat(lock).st_ino
            except FileNotFoundError:
                same = False
            if not same:
                os.close(fd)
                continue
            holder = _read_holder(fd)
            pid = holder.get("pid")
            if pid and pid != os.getpid() and holder.get("host", socket.gethostname()) == socket.gethostname():
                if not _pid_alive(pid):
                    log.warning("warning: %s: took over the lock of process %d, which is no longer running",
                                self.path, pid)
            record = json.dumps({"pid": os.getpid(), "host": socket.gethostname()}) + "\n"
            os.ftruncate(fd, 0)
            os.pwrite(fd, record.encode(), 0)
            self.lock_fd = fd
            return
        raise InputError(f"--out: cannot lock {lock} (it keeps being replaced)")

    def _check_content(self, mode: str) -> None:
        out = self.path
        held = []
        for name in RUN_FILES:
            p = out / name
            refuse_link(p)
            if p.exists():
                held.append(name)
        for name in RUN_DIRS:
            p = out / name
            refuse_link(p, folder=True)
            if p.is_dir():
                held.append(name)
                for inner in p.iterdir():  # meta.json, rank files: never written or removed through a link
                    refuse_link(inner)
        for name in ("plots", "meshes"):  # plot PNGs, the meshes of automatic remeshing
            refuse_link(out / name, folder=True)
            if (out / name).is_dir():
                for inner in (out / name).iterdir():
                    refuse_link(inner)
        self.held_run = bool(held)
        if held and mode == "new":
            status = _status_of(out)
            raise InputError(f"--out: {out} already holds a run{status} ({', '.join(held[:3])}...); "
                             "give --overwrite to replace it or --restart to continue it")

    # ------------------------------------------------------------------ commit
    def commit_overwrite(self) -> None:
        """Remove the earlier run's files (mode overwrite), after the new run is set up."""
        if self.mode != "overwrite" or not self.held_run:
            return
        names = [n for n in RUN_FILES if (self.path / n).is_file()] + \
                [n for n in RUN_DIRS if (self.path / n).is_dir()]
        plots = self.path / "plots"
        if plots.is_dir() and all(p.suffix == ".png" and p.is_file() for p in plots.iterdir()):
            names.append("plots")
        # first moved aside (renames, undone if one fails: the old run is whole or gone), then removed
        trash = self.path / f".overwritten.{os.getpid()}"
        moved = []
        try:
            trash.mkdir()
            from ..parallel import failpoint

            for name in names:
                failpoint("overwrite")  # the fault suite: a rename that fails half-way
                os.rename(self.path / name, trash / name)  # not truncated: a reader of fields.h5 keeps it
                moved.append(name)
        except OSError as exc:
            for name in reversed(moved):
                try:
                    os.rename(trash / name, self.path / name)
                except OSError:
                    pass
            try:
                trash.rmdir()
            except OSError:
                pass
            raise output_error(exc.filename or self.path, exc) from None
        shutil.rmtree(trash, ignore_errors=True)
        self.held_run = False

    def release(self) -> None:
        """Drop the lock (unlinking its file first, so that no one waits on a stale inode)."""
        if self.lock_fd is None:
            return
        try:
            os.unlink(self.path / LOCK_NAME)
        except OSError:
            pass
        try:
            os.close(self.lock_fd)
        except OSError:
            pass
        self.lock_fd = None
        if self.created:
            try:
                self.path.rmdir()  # only if the run left nothing (it failed before writing)
            except OSError:
                pass


def _read_holder(fd: int) -> dict:
    try:
        data = json.loads(os.pread(fd, 4096, 0).decode("utf-8", "replace") or "{}")
        return data if isinstance(data, dict) and isinstance(data.get("pid", 0), int) else {}
    except (OSError, ValueError):
        return {}


def _status_of(out: Path) -> str:
    try:
        status = read_json(out / "summary.json", "summary file").get("status")
        return f" ({status})" if isinstance(status, str) and len(status) < 20 else ""
    except (InputError, AttributeError):
        return ""


def folder_in_use(path: Path) -> int | None:
    """PID of the process holding ``path``'s lock, or None if no run holds it (readers call this)."""
    lock = Path(path) / LOCK_NAME
    try:
        fd = os.open(lock, os.O_RDONLY)
    except OSError:
        return None
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_SH | fcntl.LOCK_NB)
        except OSError:
            return _read_holder(fd).get("pid") or -1
        fcntl.flock(fd, fcntl.LOCK_UN)
        return None
    finally:
        os.close(fd)


def file_in_use(path: Path) -> bool:
    """True if another process holds an HDF5-style lock (flock) on ``path`` (e.g. ParaView reading it)."""
    try:
        fd = os.open(path, os.O_RDONLY)
    except OSError:
        return False
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        fcntl.flock(fd, fcntl.LOCK_UN)
        return False
    except OSError:
        return True
    finally:
        os.close(fd)
