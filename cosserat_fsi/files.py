"""Opening the user's files and the run folder's files without surprises (standard library only).

:func:`open_regular` is how every reader opens a file it was given (a scene, a .geo and what it includes,
a .msh, a checkpoint): a FIFO or a device would block or never end, so it opens with ``O_NONBLOCK`` and
refuses anything but a regular file before reading a byte. :func:`refuse_link` is how the run folder's
writers check an output name before they write: a link (even a dangling one) or a non-regular file is
refused, so that nothing is written through a link out of the folder.
"""

from __future__ import annotations

import errno
import os
import stat
from pathlib import Path

from .errors import InputError

WRITE_ERRNOS = {errno.ENOSPC, errno.EDQUOT, errno.EROFS, errno.EACCES, errno.EPERM, errno.EIO, errno.EFBIG,
                errno.ENOENT, errno.ENOTDIR, errno.EISDIR}
"""The errnos of a write that failed for a reason of the file system (full, read-only, no permission, gone):
an output error (exit 2), not an internal one."""


def open_regular(path: str | os.PathLike, what: str = "file", prefix: str = ""):
    """``open(path, "rb")`` of a regular file; InputError ``<prefix><path>: ...`` for a FIFO, a device, a
    socket, a folder, a missing or unreadable file or a name too long. Never blocks on a FIFO."""
    path = Path(path)
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_CLOEXEC", 0))
    except FileNotFoundError:
        raise InputError(f"{prefix}{path}: file not found") from None
    except IsADirectoryError:
        raise InputError(f"{prefix}{path}: is a folder, not a {what}") from None
    except OSError as exc:
        if exc.errno == errno.ENAMETOOLONG:
            raise InputError(f"{prefix}{path}: file name too long") from None
        if exc.errno == errno.ENXIO:  # a FIFO without a writer opened for writing, a socket
            raise InputError(f"{prefix}{path}: not a regular file (not a {what})") from None
        raise InputError(f"{prefix}{path}: could not read ({exc.strerror or exc.__class__.__name__})") from None
    try:
        mode = os.fstat(fd).st_mode
        if stat.S_ISDIR(mode):
            raise InputError(f"{prefix}{path}: is a folder, not a {what}")
        if not stat.S_ISREG(mode):
            raise InputError(f"{prefix}{path}: not a regular file (not a {what})")
        os.set_blocking(fd, True)
        return os.fdopen(fd, "rb")
    except BaseException:
        os.close(fd)
        raise


def read_regular(path: str | os.PathLike, what: str = "file", prefix: str = "", max_bytes: int = -1) -> bytes:
    """The bytes of a regular file (at most ``max_bytes + 1`` when given): :func:`open_regular`, read."""
    try:
        with open_regular(path, what, prefix) as f:
            return f.read(max_bytes + 1 if max_bytes >= 0 else -1)
    except OSError as exc:
        raise InputError(f"{prefix}{path}: could not read ({exc.strerror or exc.__class__.__name__})") from None


def read_json(path: str | os.PathLike, what: str = "file", max_bytes: int = 16 << 20):
    """The JSON value of a small regular file (:func:`read_regular`: a FIFO or a device refused, never waited
    on); InputError naming it if it cannot be read, is too large or is not JSON."""
    import json

    data = read_regular(path, what, max_bytes=max_bytes)
    if len(data) > max_bytes:
        raise InputError(f"{path}: larger than {max_bytes >> 10} KiB (not a {what}?)")
    try:
        return json.loads(data.decode("utf-8"))
    except (UnicodeDecodeError, ValueError):
        raise InputError(f"{path}: not a {what} (damaged?)") from None


def refuse_link(path: str | os.PathLike, prefix: str = "--out: ", folder: bool = False) -> None:
    """InputError if the output name ``path`` is taken by a link (even a dangling one) or by something that
    is not a regular file (``folder``: not a folder); nothing is written through a link out of the run folder."""
    path = Path(path)
    try:
        mode = os.lstat(path).st_mode
    except FileNotFoundError:
        return
    except OSError as exc:
        if exc.errno == errno.ENAMETOOLONG:
            raise InputError(f"{prefix}{path}: file name too long") from None
        raise InputError(f"{prefix}{path}: cannot check it ({exc.strerror or exc})") from None
    if stat.S_ISLNK(mode):
        raise InputError(f"{prefix}{path} is a link (nothing is written through a link; move it away)")
    if folder and not stat.S_ISDIR(mode):
        raise InputError(f"{prefix}{path} is not a folder (move it away)")
    if not folder and not stat.S_ISREG(mode):
        raise InputError(f"{prefix}{path} is not a regular file (a folder or a link has the name of an output "
                         "file; move it away)")


FREE_MARGIN = 1 << 20
"""Bytes kept free beyond a write's own size (HDF5's metadata, the .xdmf and summary.json rewritten)."""


def check_free_space(path: str | os.PathLike, nbytes: int) -> None:
    """``OSError(ENOSPC)`` naming ``path`` if its file system has less than ``2 * nbytes + FREE_MARGIN``
    bytes free: checked before handing a write to a library (HDF5) that does not survive a full disk."""
    try:
        st = os.statvfs(Path(path).parent)
    except OSError:
        return
    if st.f_bavail * st.f_frsize < 2 * nbytes + FREE_MARGIN:
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(path))
