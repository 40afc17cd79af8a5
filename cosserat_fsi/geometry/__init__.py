"""Deterministic gmsh builders with the project's physical tags, cached as MSH 4.1 ASCII files.

Each builder module defines one pydantic model of its parameters (``channel.Channel``, ...); ``Geometry`` is
their discriminated union on ``name`` (the ``geometry`` section of a scene, validated once, by config). To
add a geometry: a module with ``describe(params)``, ``build(gmsh, scale, params)`` (and ``SEED_SCALE`` if it has
level "seed") and a ``GeometryBase`` subclass, listed in ``Geometry`` below.

``build_msh(geometry, cache_dir)`` returns the path of ``<name>-L<level>-<sha1>.msh``, running
gmsh (on the calling process only) when the file is not cached yet. Level L halves the element size of
level L-1 (about 4x the vertices); ``"seed"`` (turek_hron only) matches the seed paper's mesh size.
Importing this package imports neither gmsh nor dolfinx.

Tags (cosserat_fsi/tags.py: ``CELL_TAGS`` / ``FACET_TAGS``; each geometry's ``describe`` lists the ones it uses):

cells: fluid 1, solid 2 (turek_hron with flag: solid, turek_hron_3d, flag (all cells), box (the disk)).
facets: inlet 1 (x = 0), outlet 2 (x = L), walls 3 (y = 0 and y = H; square: left, right, bottom; box: all
four sides; cube: five sides; duct, schaefer_turek_3d: four sides), cylinder 4 (circle; schaefer_turek_3d: the
cylinder's surface; turek_hron_3d: also the face where the flag is clamped), interface 5 (turek_hron(_3d) flag
boundary off the cylinder; flag: bottom, right, top edges, exterior; box: the circle, interior), lid 6 (square
and cube top, y = length), clamp 7 (flag: left edge x = 0).
"""

from __future__ import annotations

import functools
import hashlib
import json
import logging
import math
import os
import pathlib
import sys
from typing import Annotated, get_args

from pydantic import Field

from ..errors import InputError
from . import _gmsh  # noqa: F401  (python -m cosserat_fsi.geometry imports it from here)
from ._model import MAX_LEVEL, GeometryBase
from .builtin.box import Box
from .builtin.channel import Channel
from .builtin.cube import Cube
from .builtin.duct import Duct
from .file import FileGeometry, names_path, read_names
from .builtin.flag import Flag
from .builtin.schaefer_turek import SchaeferTurek
from .builtin.schaefer_turek_3d import SchaeferTurek3D
from .builtin.square import Square
from .builtin.turek_hron import TurekHron
from .builtin.turek_hron_3d import TurekHron3D

BUILDER_VERSION = 1  # bump whenever a builder changes its output: it is part of the cache key


@functools.cache
def gmsh_version() -> str:
    """The gmsh that builds the meshes: part of the cache key, since two gmsh versions mesh the same geometry
    differently (4.8 and 4.15 do), and two stacks may share a cache. Read from its Python module's source, not
    imported: importing gmsh resets SIGINT to the default action (a Ctrl-C would then kill the run unhandled);
    gmsh itself runs in a child process."""
    import importlib.util
    import re

    spec = importlib.util.find_spec("gmsh")
    try:
        source = pathlib.Path(spec.origin).read_text(errors="replace") if spec and spec.origin else ""
    except OSError:
        source = ""
    found = re.search(r'GMSH_API_VERSION\s*=\s*"([^"]+)"', source)
    return found.group(1) if found else "unknown"


Geometry = Annotated[TurekHron | SchaeferTurek | Channel | Square | Flag | Box | FileGeometry | Cube | Duct
                     | SchaeferTurek3D | TurekHron3D,
                     Field(discriminator="name")]
"""The ``geometry`` section of a scene: one model per geometry, chosen by ``name``."""
MODELS: dict[str, type[GeometryBase]] = {m.model_fields["name"].default: m for m in get_args(get_args(Geometry)[0])}
"""Geometry name -> its model class."""
_MODULES = {name: sys.modules[model.__module__] for name, model in MODELS.items()}  # name -> builder module
GEOMETRIES = tuple(MODELS)
__all__ = ["BUILDER_VERSION", "GEOMETRIES", "MAX_LEVEL", "Box", "Channel", "Cube", "Duct", "FileGeometry", "Flag",
           "Geometry", "GeometryBase", "MODELS", "SchaeferTurek", "SchaeferTurek3D", "Square", "TurekHron",
           "TurekHron3D", "build_msh",
           "default_cache_dir", "facet_ids"]

log = logging.getLogger("cosserat_fsi")


def facet_ids(geometry: GeometryBase, msh: str | os.PathLike | None = None) -> dict[str, int]:
    """Facet name -> tag of a scene's mesh: the file's own table for ``name: file`` (read beside the cached
    ``msh``, built if not given), else the project's (tags.FACET_TAGS). Call it on one rank and share it."""
    if geometry.name != "file":
        from ..tags import FACET_TAGS

        return dict(FACET_TAGS)
    return {str(k): int(v) for k, v in read_names(msh if msh is not None else build_msh(geometry))["facets"].items()}


def default_cache_dir() -> pathlib.Path:
    """Where meshes are cached: ``$COSSERAT_FSI_MESH_CACHE`` if set (the Makefile and the tests set it to the
    repository's ``meshes/``; InputError if it cannot be written), else ``$XDG_CACHE_HOME/cosserat-fsi/meshes``
    (default ``~/.cache/...``), else a folder in the temporary directory (cache.py)."""
    from ..cache import mesh_cache_dir

    return mesh_cache_dir()


def _sha256(path: pathlib.Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _clean_stale_temporaries(cache: pathlib.Path) -> None:
    """Remove ``.<stem>.<pid>.tmp*`` files of processes that are gone (a run killed while meshing)."""
    for tmp in cache.glob(".*.tmp*"):
        try:
            pid = int(tmp.name.split(".")[-2] if tmp.name.endswith(".tmp") else tmp.name.rsplit(".tmp", 1)[0]
                      .rsplit(".", 1)[1])
        except (ValueError, IndexError):
            continue
        if pid != os.getpid() and not _alive(pid):
            try:
                tmp.unlink()
            except OSError:
                pass


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def build_msh(geometry: GeometryBase, cache_dir: str | os.PathLike | None = None) -> pathlib.Path:
    """Path of the cached .msh of a (validated) geometry model; builds it with gmsh if missing.

    gmsh runs in a child process (``python -m cosserat_fsi.geometry``): a signal stops it at once, its
    crash (e.g. out of memory) is a one-line InputError, and it writes to a temporary name that is renamed
    when complete, so the cache never holds a partial mesh (temporaries of dead processes are removed).
    """
    name, level, full = geometry.name, geometry.level, geometry.msh_params()
    if full.get("format") == "xdmf":  # a converted mesh (geometry/xdmf_file.py): read as it is, not cached
        return pathlib.Path(full["path"])
    gmsh_timeout()  # a bad $COSSERAT_FSI_GMSH_TIMEOUT is refused whether or not the mesh is cached
    keyed = {k: v for k, v in full.items() if not (name == "file" and k == "path")}  # a file: by content
    key = json.dumps({"name": name, "level": level, "params": keyed, "version": BUILDER_VERSION,
                      "gmsh": gmsh_version()}, sort_keys=True)
    cache = pathlib.Path(cache_dir) if cache_dir is not None else default_cache_dir()
    path = cache / f"{name}-L{level}-{hashlib.sha1(key.encode()).hexdigest()[:10]}.msh"
    stamp = path.with_suffix(".sha256")
    names = names_path(path) if name == "file" else None
    try:
        if (path.exists() and stamp.exists() and stamp.read_text().strip() == _sha256(path)
                and (names is None or "dim" in read_names(path))):  # a table of every current key
            return path
    except (OSError, ValueError):  # a damaged stamp or names table: rebuilt
        pass
    if path.exists():  # no stamp (older cache) or a damaged file: rebuild, never read a bad mesh
        log.warning("mesh cache %s is damaged or unverified: rebuilding it", path.name)
    try:
        cache.mkdir(parents=True, exist_ok=True)
        _clean_stale_temporaries(cache)
    except OSError as exc:
        raise InputError(f"mesh cache: cannot write to {cache} ({exc.strerror or exc})") from None
    tmp = cache / f".{path.stem}.{os.getpid()}.tmp.msh"
    stamp_tmp = cache / f".{stamp.name}.{os.getpid()}.tmp"
    try:
        _run_gmsh(name, level, full, tmp)
        digest = _sha256(tmp)
        if names is not None:
            os.replace(names_path(tmp), names)
        os.replace(tmp, path)
        stamp_tmp.write_text(digest + "\n")
        os.replace(stamp_tmp, stamp)
    except OSError as exc:
        raise InputError(f"mesh cache: cannot write to {cache} ({exc.strerror or exc})") from None
    finally:
        for leftover in (tmp, stamp_tmp, names_path(tmp)):
            try:
                leftover.unlink()
            except OSError:
                pass
    return path


GMSH_TIMEOUT = 1800.0
"""Seconds gmsh may take to mesh one geometry (``$COSSERAT_FSI_GMSH_TIMEOUT`` overrides it)."""


def gmsh_timeout() -> float:
    """``$COSSERAT_FSI_GMSH_TIMEOUT`` (unset: GMSH_TIMEOUT); InputError unless a finite number of seconds > 0."""
    text = os.environ.get("COSSERAT_FSI_GMSH_TIMEOUT")
    if text is None:
        return GMSH_TIMEOUT
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and value > 0):
        raise InputError(f"COSSERAT_FSI_GMSH_TIMEOUT: must be a finite number of seconds > 0 (got {text[:40]!r}; "
                         f"unset: {GMSH_TIMEOUT:g})")
    return value


def _run_gmsh(name, level, full, tmp: pathlib.Path) -> None:
    """Mesh in a child process into ``tmp``; InputError if gmsh fails or dies."""
    import subprocess
    import sys

    drop = ("OMPI_", "PMIX_", "PMI_", "HYDRA_", "MPI_LOCALRANKID", "MPI_LOCALNRANKS")
    env = {k: v for k, v in os.environ.items() if not k.startswith(drop)}
    import tempfile

    package_root = str(pathlib.Path(__file__).resolve().parents[2])  # the child runs in a folder of its own
    env["PYTHONPATH"] = os.pathsep.join(p for p in (package_root, env.get("PYTHONPATH")) if p)
    request = json.dumps({"name": name, "level": level, "params": full, "out": os.path.abspath(tmp),
                          "parent": os.getpid()})  # the child dies with this process (its __main__.py)
    with tempfile.TemporaryDirectory(prefix="cosserat-fsi-gmsh-") as cwd:  # what a .geo writes stays there
        _wait_gmsh(subprocess.Popen([sys.executable, "-m", "cosserat_fsi.geometry", request], env=env, cwd=cwd,
                                    stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=subprocess.STDOUT),
                   name, level, full, tmp)


def _wait_gmsh(proc, name, level, full, tmp: pathlib.Path) -> None:
    import subprocess

    limit = gmsh_timeout()
    try:
        output, _ = proc.communicate(timeout=limit)
    except subprocess.TimeoutExpired:  # a .geo that never finishes meshing (or one far too fine)
        proc.kill()
        proc.wait()
        what = (f"geometry.path: gmsh did not finish meshing {pathlib.Path(full['path']).name}" if name == "file"
                else f"geometry: gmsh did not finish meshing {name} level {level}")
        raise InputError(f"{what} within {limit:g} s (COSSERAT_FSI_GMSH_TIMEOUT; a coarser mesh or a lower "
                         "level?)") from None
    except BaseException:  # a signal or Ctrl-C in the parent: stop gmsh now, then go on unwinding
        proc.kill()
        proc.wait()
        raise
    lines = output.decode("utf-8", "replace").strip().splitlines()
    if proc.returncode == 2 and lines:  # the child refused the input (a user's file): its one line
        raise InputError(lines[-1][:300])
    if proc.returncode != 0 or not tmp.is_file():
        why = lines[-1] if lines else (f"killed by signal {-proc.returncode}" if proc.returncode < 0
                                       else f"exit code {proc.returncode}")
        what = (f"geometry.path: gmsh could not mesh {pathlib.Path(full['path']).name}" if name == "file"
                else f"geometry: gmsh could not mesh {name} level {level}")
        raise InputError(f"{what} ({why[:200]})")
