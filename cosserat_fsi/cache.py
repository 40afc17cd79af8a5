"""Where the caches live: gmsh meshes and the form compiler's (FFCx/dolfinx JIT) compiled forms.

Each can be moved by an environment variable; without one the first writable place of a list is used,
ending with a folder in the system's temporary directory, so a read-only checkout or HOME does not stop
a run. A folder named by the variable that cannot be written is bad input (``InputError`` naming the
variable and the folder, exit 2): the user asked for it.

    COSSERAT_FSI_MESH_CACHE   meshes (default $XDG_CACHE_HOME or ~/.cache, then /cosserat-fsi/meshes; the
                              Makefile, the tests and the campaigns set it to the repository's meshes/:
                              installed code never looks for the repository)
    COSSERAT_FSI_JIT_CACHE    compiled forms (default $XDG_CACHE_HOME or ~/.cache, then /fenics)

Light module: no dolfinx, gmsh or mpi4py import.
"""

from __future__ import annotations

import functools
import os
import tempfile
from pathlib import Path

from cosserat_fsi.errors import InputError

MESH_ENV = "COSSERAT_FSI_MESH_CACHE"
JIT_ENV = "COSSERAT_FSI_JIT_CACHE"


def writable(folder: Path) -> bool:
    """True if ``folder`` exists or can be made, and a file can be created in it."""
    try:
        folder.mkdir(parents=True, exist_ok=True)
        fd, probe = tempfile.mkstemp(prefix=".write-test-", dir=folder)
        os.close(fd)
        os.unlink(probe)
        return True
    except OSError:
        return False


def _fallback(kind: str) -> Path:
    return Path(tempfile.gettempdir()) / f"cosserat-fsi-{os.getuid()}" / kind


def _home_cache() -> Path | None:
    xdg = os.environ.get("XDG_CACHE_HOME")
    if xdg:
        return Path(xdg)
    try:
        return Path.home() / ".cache"
    except (RuntimeError, KeyError):  # no HOME and no passwd entry
        return None


def _choose(env: str, candidates: list[Path | None], kind: str) -> Path:
    named = os.environ.get(env)
    if named:
        folder = Path(named)
        if not writable(folder):
            raise InputError(f"{env}: cannot write to {folder} (set it to a writable folder or unset it)")
        return folder
    for folder in [c for c in candidates if c is not None] + [_fallback(kind)]:
        if writable(folder):
            return folder
    raise InputError(f"{env}: no writable {kind} cache (tried {', '.join(map(str, candidates))} and "
                     f"{_fallback(kind)}); set {env} to a writable folder")


def mesh_cache_dir() -> Path:
    """Folder of the gmsh mesh cache (see the module docstring)."""
    home = _home_cache()
    return _choose(MESH_ENV, [home / "cosserat-fsi" / "meshes" if home else None], "meshes")


@functools.cache
def jit_cache_dir() -> Path:
    """Folder of the form compiler's cache (see the module docstring); decided once per process."""
    home = _home_cache()
    return _choose(JIT_ENV, [home / "fenics" if home else None], "fenics")


def check_caches() -> None:
    """Resolve both caches now (exit 2 early for an unwritable one named by its variable), and give
    matplotlib a writable config folder when HOME is not writable (it warns on stderr otherwise)."""
    mesh_cache_dir()
    jit_cache_dir()
    if "MPLCONFIGDIR" not in os.environ:
        home = _home_cache()
        if home is None or not writable(home.parent / ".config" / "matplotlib"):
            folder = _fallback("matplotlib")
            if writable(folder):
                os.environ["MPLCONFIGDIR"] = str(folder)
