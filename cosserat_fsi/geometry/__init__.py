"""Deterministic gmsh builders with the project's physical tags, cached as MSH 4.1 ASCII files.

``build_msh(name, level, params, cache_dir)`` returns the path of ``<name>-L<level>-<sha1>.msh``, running
gmsh (on the calling process only) when the file is not cached yet. Level L halves the element size of
level L-1 (about 4x the vertices); ``"seed"`` (turek_hron only) matches the seed paper's mesh size.
Importing this package imports neither gmsh nor dolfinx.

Tags (cosserat_fsi/tags.py: ``CELL_TAGS`` / ``FACET_TAGS``; each geometry's ``describe`` lists the ones it uses):

cells: fluid 1, solid 2 (turek_hron with flag: solid, flag (all cells), box (the disk)).
facets: inlet 1 (x = 0), outlet 2 (x = L), walls 3 (y = 0 and y = H; square: left, right, bottom; box: all four
sides), cylinder 4 (circle), interface 5 (turek_hron flag boundary off the cylinder; flag: bottom, right, top
edges, exterior; box: the circle, interior), lid 6 (square top), clamp 7 (flag: left edge x = 0).
"""

import hashlib
import logging
import json
import os
import pathlib
import tempfile

from .. import errors
from . import _gmsh, box, channel, flag, schaefer_turek, square, turek_hron

BUILDER_VERSION = 1  # bump whenever a builder changes its output: it is part of the cache key
_MODULES = {"turek_hron": turek_hron, "schaefer_turek": schaefer_turek, "channel": channel, "square": square,
            "flag": flag, "box": box}
GEOMETRIES = tuple(_MODULES)
MIN_DIMENSION, MAX_DIMENSION = 1e-6, 1e6
"""Bounds of every length parameter (m): below, gmsh's geometric tolerance merges points."""
SCENE_KEY = {"thickness": "height", "size": "length"}
"""Builder parameter -> the scene's geometry key it comes from (for messages)."""
MAX_CELLS = 10_000_000
"""Largest mesh built (cells, estimated before gmsh runs): level 6 of turek_hron has about 6.5 M."""
LEVELS = {name: module.LEVELS for name, module in _MODULES.items()}


def _module(name):
    if name not in _MODULES:
        raise errors.InputError(f"geometry.name: must be one of {', '.join(GEOMETRIES)} (got {name!r})")
    return _MODULES[name]


def _check(name, level, params):
    """Validate name, level and params; returns (module, params with defaults, as floats/strings)."""
    module = _module(name)
    if isinstance(level, bool) or level not in module.LEVELS:
        allowed = ", ".join(map(str, module.LEVELS))
        raise errors.InputError(f"geometry.level: must be one of {allowed} for {name} (got {level!r})")
    full = dict(module.DEFAULTS)
    for key, value in (params or {}).items():
        if key not in full:
            allowed = ", ".join(full) or "none"
            raise errors.InputError(f"geometry.{key}: not a parameter of {name} (allowed: {allowed})")
        if key in module.CHOICES:
            if value not in module.CHOICES[key]:
                allowed = ", ".join(module.CHOICES[key])
                raise errors.InputError(f"geometry.{key}: must be one of {allowed} (got {value!r})")
        elif isinstance(value, bool) or not isinstance(value, (int, float)) or not value > 0:
            raise errors.InputError(f"geometry.{key}: must be a number > 0 (got {value!r})")
        elif not MIN_DIMENSION <= value <= MAX_DIMENSION:
            raise errors.InputError(f"geometry.{SCENE_KEY.get(key, key)}: must be between {MIN_DIMENSION:g} "
                                    f"and {MAX_DIMENSION:g} "
                                    f"(m; got {value!r})")
        else:
            value = float(value)
        full[key] = value
    if hasattr(module, "validate"):
        module.validate(full)
    if hasattr(module, "estimate_cells"):
        scale = module.SEED_SCALE if level == "seed" else 2.0**-level
        cells = module.estimate_cells(scale, full)
        if cells > MAX_CELLS:
            keys = ", ".join(f"geometry.{SCENE_KEY.get(k, k)}"
                             for k in ("level", *sorted(set(full) - set(module.CHOICES))))
            raise errors.InputError(f"geometry: {keys} give about {cells:.3g} cells, more than {MAX_CELLS:,} "
                                    "(lower the level or make the sides less elongated)")
    return module, full


def describe(name, params=None):
    """Cell/facet tag names -> values, named points (e.g. {"A": (0.6, 0.2)}) and dimensions of ``name``."""
    module, full = _check(name, 0, params)
    return module.describe(full)


log = logging.getLogger("cosserat_fsi")


def default_cache_dir():
    """The mesh cache folder: ``$COSSERAT_FSI_MESH_CACHE``, else ``<repo>/meshes`` in a writable source
    checkout, else ``~/.cache/cosserat-fsi/meshes``, else a folder in the temporary directory."""
    from ..cache import mesh_cache_dir

    return mesh_cache_dir()


def check(name, level, params=None) -> None:
    """Validate a geometry (names, bounds, estimated cell count) without running gmsh."""
    _check(name, level, params)


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


def build_msh(name, level, params=None, cache_dir=None):
    """Path of the cached .msh for (name, level, params); builds it with gmsh if missing.

    Raises ``errors.InputError`` for an unknown name, level or parameter, a mesh estimated too large, or
    a gmsh that fails. gmsh runs in a child process (``python -m cosserat_fsi.geometry``): a signal stops
    it at once, its crash (e.g. out of memory) is a one-line error, and it writes to a temporary name
    that is renamed when complete, so the cache never holds a partial mesh.
    """
    module, full = _check(name, level, params)
    key = json.dumps({"name": name, "level": level, "params": full, "version": BUILDER_VERSION}, sort_keys=True)
    cache = pathlib.Path(cache_dir) if cache_dir is not None else default_cache_dir()
    path = cache / f"{name}-L{level}-{hashlib.sha1(key.encode()).hexdigest()[:10]}.msh"
    stamp = path.with_suffix(".sha256")
    try:
        if path.exists() and stamp.exists() and stamp.read_text().strip() == _sha256(path):
            return path
    except (OSError, UnicodeDecodeError):
        pass
    if path.exists():  # no stamp (older cache) or a damaged file: rebuild, never read a bad mesh
        log.warning("mesh cache %s is damaged or unverified: rebuilding it", path.name)
    try:
        cache.mkdir(parents=True, exist_ok=True)
        _clean_stale_temporaries(cache)
    except OSError as exc:
        raise errors.InputError(f"mesh cache: cannot write to {cache} ({exc.strerror or exc})") from None
    tmp = cache / f".{path.stem}.{os.getpid()}.tmp.msh"
    stamp_tmp = cache / f".{stamp.name}.{os.getpid()}.tmp"
    try:
        _run_gmsh(name, level, full, tmp)
        digest = _sha256(tmp)
        os.replace(tmp, path)
        stamp_tmp.write_text(digest + "\n")
        os.replace(stamp_tmp, stamp)
    except OSError as exc:
        raise errors.InputError(f"mesh cache: cannot write to {cache} ({exc.strerror or exc})") from None
    finally:
        for leftover in (tmp, stamp_tmp):
            try:
                leftover.unlink()
            except OSError:
                pass
    return path


def _run_gmsh(name, level, full, tmp: pathlib.Path) -> None:
    """Mesh in a child process into ``tmp``; InputError if gmsh fails or dies."""
    import subprocess
    import sys

    drop = ("OMPI_", "PMIX_", "PMI_", "HYDRA_", "MPI_LOCALRANKID", "MPI_LOCALNRANKS")
    env = {k: v for k, v in os.environ.items() if not k.startswith(drop)}
    request = json.dumps({"name": name, "level": level, "params": full, "out": str(tmp)})
    proc = subprocess.Popen([sys.executable, "-m", "cosserat_fsi.geometry", request], env=env,
                            stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
    try:
        output, _ = proc.communicate()
    except BaseException:  # a signal or Ctrl-C in the parent: stop gmsh now, then go on unwinding
        proc.kill()
        proc.wait()
        raise
    if proc.returncode != 0 or not tmp.is_file():
        lines = output.decode("utf-8", "replace").strip().splitlines()
        why = lines[-1] if lines else (f"killed by signal {-proc.returncode}" if proc.returncode < 0
                                       else f"exit code {proc.returncode}")
        raise errors.InputError(f"geometry: gmsh could not mesh {name} level {level} ({why[:200]})")
