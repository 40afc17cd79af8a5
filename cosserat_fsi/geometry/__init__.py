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
        else:
            value = float(value)
        full[key] = value
    if hasattr(module, "validate"):
        module.validate(full)
    return module, full


def describe(name, params=None):
    """Cell/facet tag names -> values, named points (e.g. {"A": (0.6, 0.2)}) and dimensions of ``name``."""
    module, full = _check(name, 0, params)
    return module.describe(full)


log = logging.getLogger("cosserat_fsi")


def default_cache_dir():
    """``<repo>/meshes`` in a writable source checkout, else ``~/.cache/cosserat-fsi/meshes``."""
    repo = pathlib.Path(__file__).resolve().parents[2]
    if (repo / "pyproject.toml").is_file():
        try:
            (repo / "meshes").mkdir(exist_ok=True)
            if os.access(repo / "meshes", os.W_OK):
                return repo / "meshes"
        except OSError:
            pass
    return pathlib.Path.home() / ".cache" / "cosserat-fsi" / "meshes"


def _sha256(path: pathlib.Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def build_msh(name, level, params=None, cache_dir=None):
    """Path of the cached .msh for (name, level, params); builds it with gmsh if missing.

    Raises ``errors.InputError`` for an unknown name, level or parameter. Writes through a temporary
    file and ``os.replace``, so an interrupted run never leaves a partial mesh.
    """
    module, full = _check(name, level, params)
    key = json.dumps({"name": name, "level": level, "params": full, "version": BUILDER_VERSION}, sort_keys=True)
    cache = pathlib.Path(cache_dir) if cache_dir is not None else default_cache_dir()
    path = cache / f"{name}-L{level}-{hashlib.sha1(key.encode()).hexdigest()[:10]}.msh"
    stamp = path.with_suffix(".sha256")
    if path.exists() and stamp.exists() and stamp.read_text().strip() == _sha256(path):
        return path
    if path.exists():  # no stamp (older cache) or a damaged file: rebuild, never read a bad mesh
        log.warning("mesh cache %s is damaged or unverified: rebuilding it", path.name)
    cache.mkdir(parents=True, exist_ok=True)
    scale = module.SEED_SCALE if level == "seed" else 2.0**-level
    import gmsh

    fd, tmp = tempfile.mkstemp(prefix=f".{path.stem}-", suffix=".msh", dir=cache)
    os.close(fd)
    try:
        gmsh.initialize(["gmsh", "-nopopup"], readConfigFiles=False)
        try:
            _gmsh.configure(gmsh)
            module.build(gmsh, scale, full)
            gmsh.write(tmp)
        finally:
            gmsh.finalize()
        os.chmod(tmp, 0o644)
        digest = _sha256(pathlib.Path(tmp))
        os.replace(tmp, path)
        stamp_tmp = stamp.with_name(stamp.name + f".{os.getpid()}")
        stamp_tmp.write_text(digest + "\n")
        os.replace(stamp_tmp, stamp)
    finally:
        if os.path.exists(tmp):
            os.remove(tmp)
    return path
