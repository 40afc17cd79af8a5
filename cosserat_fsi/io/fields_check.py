"""Reading a run's fields.xdmf + fields.h5 safely (readers: ``plot``, ``--restart``): a damaged, foreign or
locked pair is an InputError naming the file, never a traceback; a pair still being written is read up
to the last step the .xdmf lists (the .h5 is flushed before the .xdmf is replaced, see xdmf.py).

No dolfinx import: h5py and numpy only.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np

from ..errors import InputError
from .safe_yaml import read_text_file

_TIME = re.compile(r'<Time Value="([^"]+)"')
MAX_XDMF_BYTES = 256 << 20


def xdmf_times(xdmf: Path, prefix: str = "") -> np.ndarray:
    """Output times listed in ``xdmf`` (InputError if it is not a moving-mesh XDMF of a run)."""
    try:
        text = read_text_file(xdmf, "XDMF file", MAX_XDMF_BYTES)
    except InputError as exc:
        raise InputError(f"{prefix}{exc}") from None
    if "<Xdmf" not in text or "</Xdmf>" not in text:
        raise InputError(f"{prefix}{xdmf} is not a complete XDMF file (damaged or foreign)")
    try:
        times = np.array([float(t) for t in _TIME.findall(text)])
    except ValueError:
        times = np.array([math.nan])
    if not np.isfinite(times).all() or (len(times) > 1 and np.any(np.diff(times) < 0)):
        raise InputError(f"{prefix}{xdmf} lists times that are not increasing numbers (damaged file)")
    return times


def open_h5(h5: Path, prefix: str = ""):
    """``h5py.File(h5, 'r')`` without taking HDF5's file lock (a running run holds it), InputError naming the
    file if it is not an HDF5 file."""
    import h5py

    if not h5.is_file():
        what = "missing" if not h5.exists() else "not a file"
        raise InputError(f"{prefix}{h5} is {what}")
    try:
        try:
            return h5py.File(h5, "r", locking=False)
        except TypeError:  # h5py without the locking argument
            return h5py.File(h5, "r")
    except Exception as exc:  # noqa: BLE001 (h5py raises OSError, KeyError, RuntimeError, ...)
        reason = "open in a program that locks it" if "lock" in str(exc).lower() else "damaged or not HDF5"
        raise InputError(f"{prefix}{h5} cannot be read ({reason})") from None


def step_names(f, count: int, h5: Path, prefix: str = "") -> list[str]:
    """The first ``count`` geometry step names of an open fields.h5, checked (InputError otherwise)."""
    try:
        topology = f["mesh/topology"]
        if topology.ndim != 2 or topology.shape[1] < 3 or topology.dtype.kind not in "iu":
            raise ValueError
        names = sorted(f["mesh/geometry"].keys())
        for name in names[:count]:
            g = f[f"mesh/geometry/{name}"]
            if g.ndim != 2 or g.shape[1] not in (2, 3) or g.dtype.kind != "f":
                raise ValueError
    except Exception:  # noqa: BLE001
        raise InputError(f"{prefix}{h5} is not the fields file of a cosserat-fsi run (damaged or foreign)") \
            from None
    if len(names) < count or names[:count] != [f"{k:06d}" for k in range(count)]:
        raise InputError(f"{prefix}{h5} has {len(names)} steps, {count} are needed (damaged file)")
    return names[:count]


def check_fields(xdmf: Path, h5: Path, need: int, prefix: str = "") -> None:
    """Both files readable, listing at least ``need`` steps that fields.h5 holds."""
    times = xdmf_times(xdmf, prefix)
    if len(times) < need:
        raise InputError(f"{prefix}{xdmf} lists {len(times)} steps, the checkpoint needs {need}")
    f = open_h5(h5, prefix)
    try:
        step_names(f, need, h5, prefix)
    finally:
        f.close()
