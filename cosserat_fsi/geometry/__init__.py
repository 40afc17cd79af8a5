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

cells: fluid 1, solid 2 (turek_hron with flag: solid, flag (all cells), box (the disk)).
facets: inlet 1 (x = 0), outlet 2 (x = L), walls 3 (y = 0 and y = H; square: left, right, bottom; box: all four
sides), cylinder 4 (circle), interface 5 (turek_hron flag boundary off the cylinder; flag: bottom, right, top
edges, exterior; box: the circle, interior), lid 6 (square top), clamp 7 (flag: left edge x = 0).
"""

from __future__ import annotations

import hashlib
import json
import logging
import os
import pathlib
import tempfile
import sys
from typing import Annotated, get_args

from pydantic import Field

from . import _gmsh
from ._model import MAX_LEVEL, GeometryBase
from .box import Box
from .channel import Channel
from .flag import Flag
from .schaefer_turek import SchaeferTurek
from .square import Square
from .turek_hron import TurekHron

BUILDER_VERSION = 1  # bump whenever a builder changes its output: it is part of the cache key
Geometry = Annotated[TurekHron | SchaeferTurek | Channel | Square | Flag | Box, Field(discriminator="name")]
"""The ``geometry`` section of a scene: one model per geometry, chosen by ``name``."""
MODELS: dict[str, type[GeometryBase]] = {m.model_fields["name"].default: m for m in get_args(get_args(Geometry)[0])}
"""Geometry name -> its model class."""
GEOMETRIES = tuple(MODELS)
__all__ = ["BUILDER_VERSION", "GEOMETRIES", "MAX_LEVEL", "Box", "Channel", "Flag", "Geometry", "GeometryBase", "MODELS",
           "SchaeferTurek", "Square", "TurekHron", "build_msh", "default_cache_dir"]

log = logging.getLogger("cosserat_fsi")


def default_cache_dir() -> pathlib.Path:
    """Where meshes are cached: ``$COSSERAT_FSI_MESH_CACHE`` if set (the Makefile and the tests set it to the
    repository's ``meshes/``), else ``$XDG_CACHE_HOME/cosserat-fsi/meshes`` (default ``~/.cache/...``)."""
    explicit = os.environ.get("COSSERAT_FSI_MESH_CACHE")
    if explicit:
        return pathlib.Path(explicit).expanduser()
    base = os.environ.get("XDG_CACHE_HOME") or pathlib.Path.home() / ".cache"
    return pathlib.Path(base).expanduser() / "cosserat-fsi" / "meshes"


def _sha256(path: pathlib.Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def build_msh(geometry: GeometryBase, cache_dir: str | os.PathLike | None = None) -> pathlib.Path:
    """Path of the cached .msh of a (validated) geometry model; builds it with gmsh if missing.

    Writes through a temporary file and ``os.replace``, so an interrupted run never leaves a partial mesh.
    """
    name, level, full = geometry.name, geometry.level, geometry.msh_params()
    module = sys.modules[type(geometry).__module__]  # the builder module that defines the model
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
