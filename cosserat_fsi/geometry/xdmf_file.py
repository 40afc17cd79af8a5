"""A scene's mesh as an XDMF/HDF5 pair, read distributed: ``geometry: {name: file, path: NAME.xdmf}``.

``cosserat-fsi mesh SCENE --format xdmf`` (app/xdmf_mesh.py, on one process) writes ``NAME.xdmf`` + ``NAME.h5``
(dolfinx's XDMFFile: the Grid ``mesh``, the cell tags ``cells`` with the project's fluid 1 / solid 2 and the
facet tags ``facets`` with the ids of the names table) and ``NAME.names.json`` (the table of a file mesh:
``dim``, ``facets``, ``cells`` counts, ``interior``, ``unnamed``). A run reads the pair with every rank reading
its share of the .h5 (compat.read_xdmf, shared-facet ghosting): no rank holds the whole mesh.

Checked before dolfinx reads (rank 0, :func:`check_pair`): the table is there and well formed (its ``dim`` is
the scene's dimension), the .xdmf is XML with the three Grids, their topology fits the dimension, every
dataset it names is in its .h5 with the declared shape and inside the file (a truncated copy is refused),
the mesh's cell count is the table's. After the read (collective, :func:`check_read`): the cells tagged
fluid and solid are the table's counts and every facet tag id is one of its names. Every refusal is one line
``geometry.path: ...``. An .xdmf is not meshed, so not cached; its identity (the checkpoint's fingerprint)
is the sha256 of the .xdmf, its .h5 and the table (:func:`digest`).
"""

from __future__ import annotations

import functools
import hashlib
import json
import math
import os
import pathlib
from typing import Any
from xml.etree import ElementTree

from ..errors import InputError

MESH, CELLS, FACETS = "mesh", "cells", "facets"
"""The names of the Grids of the mesh, its cell tags and its facet tags."""
CELL_TYPES = {2: ("Triangle", "Quadrilateral"), 3: ("Tetrahedron",)}
HOW = "write them with `cosserat-fsi mesh SCENE --format xdmf`"


def names_path(path: str | os.PathLike) -> pathlib.Path:
    """NAME.names.json beside NAME.xdmf (as file.names_path beside a cached mesh)."""
    return pathlib.Path(path).with_suffix(".names.json")


def is_xdmf(path: str | os.PathLike) -> bool:
    return str(path).lower().endswith(".xdmf")


def table(path: str | os.PathLike) -> dict[str, Any]:
    """The names table beside ``path`` (NAME.names.json), checked for its form; InputError if missing or bad."""
    where = names_path(path)
    shown = pathlib.Path(path).name
    if not where.is_file():
        raise InputError(f"geometry.path: {shown} has no names table {where.name} beside it ({HOW})")
    try:
        names = json.loads(where.read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        raise InputError(f"geometry.path: {where.name} cannot be read ({' '.join(str(exc).split())[:120]})") from None
    facets, cells = (names.get("facets"), names.get("cells")) if isinstance(names, dict) else (None, None)
    if not (isinstance(facets, dict) and all(isinstance(k, str) and type(v) is int for k, v in facets.items())
            and isinstance(cells, dict) and all(type(cells.get(k)) is int and cells[k] >= 0 for k in ("fluid", "solid"))
            and names.get("dim") in (2, 3) and isinstance(names.get("interior", []), list)):
        raise InputError(f"geometry.path: {where.name} is not a names table (dim 2 or 3, facets name -> id, cells "
                         f"fluid and solid counts; {HOW})")
    return names


def dimension(path: str | os.PathLike) -> int:
    """The dimension of an .xdmf scene (FileGeometry.DIM, when the scene is validated): its table's ``dim``,
    which its mesh's cell type must agree with (InputError: the scene's keys would be checked against it)."""
    names = table(path)
    mesh = _grids(path).get(MESH)
    topology = mesh.find("Topology") if mesh is not None else None
    kind = topology.get("TopologyType", "") if topology is not None else ""
    if kind and kind not in CELL_TYPES[names["dim"]]:
        raise InputError(f"geometry.path: {pathlib.Path(path).name} holds {kind} cells but "
                         f"{names_path(path).name} says {names['dim']}D ({' or '.join(CELL_TYPES[names['dim']])})")
    return names["dim"]


@functools.cache
def _digest(path: str, stamp: tuple) -> str:
    digest = hashlib.sha256()
    for file in (pathlib.Path(path), *_h5_files(path), names_path(path)):
        if not file.is_file():
            digest.update(b"missing:" + file.name.encode())
            continue
        part = hashlib.sha256()
        with open(file, "rb") as stream:  # by blocks: a large .h5 is never held whole
            for block in iter(lambda: stream.read(1 << 22), b""):
                part.update(block)
        digest.update(part.digest())
    return digest.hexdigest()


def digest(path: str | os.PathLike) -> str:
    """sha256 over the .xdmf, the .h5 it names and its names table (the mesh's identity)."""
    path = str(pathlib.Path(path).resolve())
    stamp = tuple((f.stat().st_size, f.stat().st_mtime_ns) if f.is_file() else None
                  for f in (pathlib.Path(path), *_h5_files(path), names_path(path)))
    return _digest(path, stamp)


def _grids(path: str | os.PathLike) -> dict[str, ElementTree.Element]:
    """Grid name -> element of the .xdmf; InputError if it is not XDMF."""
    shown = pathlib.Path(path).name
    try:
        root = ElementTree.parse(path).getroot()
    except (OSError, ElementTree.ParseError) as exc:
        raise InputError(f"geometry.path: {shown} is not an XDMF file ({' '.join(str(exc).split())[:120]})") from None
    if root.tag != "Xdmf":
        raise InputError(f"geometry.path: {shown} is not an XDMF file (its root element is <{root.tag}>)")
    return {grid.get("Name", ""): grid for grid in root.iter("Grid")}


def _h5_files(path: str) -> list[pathlib.Path]:
    try:
        items = [item for grid in _grids(path).values() for item in grid.iter("DataItem")]
    except InputError:
        return []
    folder = pathlib.Path(path).parent
    return sorted({folder / (item.text or "").strip().split(":/", 1)[0] for item in items
                   if item.get("Format") == "HDF"})


def check_pair(path: str | os.PathLike, names: dict[str, Any]) -> None:
    """Rank 0, before dolfinx reads: the .xdmf's Grids and the datasets of its .h5 (see the module docstring)."""
    import h5py

    shown, folder = pathlib.Path(path).name, pathlib.Path(path).parent
    grids = _grids(path)
    for grid, what in ((MESH, "mesh"), (CELLS, "cell tags"), (FACETS, "facet tags")):
        if grid not in grids:
            raise InputError(f"geometry.path: {shown} has no {what} (a Grid named {grid!r}; it has: "
                             f"{', '.join(repr(n) for n in grids) or 'none'}; {HOW})")
    topology = grids[MESH].find("Topology")
    kind = topology.get("TopologyType", "") if topology is not None else ""
    if kind not in CELL_TYPES[names["dim"]]:
        raise InputError(f"geometry.path: {shown} holds {kind or 'no'} cells but {names_path(path).name} says "
                         f"{names['dim']}D ({' or '.join(CELL_TYPES[names['dim']])})")
    files: dict[pathlib.Path, Any] = {}
    try:
        for grid in (MESH, CELLS, FACETS):
            for item in grids[grid].iter("DataItem"):
                if item.get("Format") != "HDF":
                    continue
                name, _, dataset = (item.text or "").strip().partition(":")
                file = folder / name
                if file not in files:
                    if not file.is_file():
                        raise InputError(f"geometry.path: {file.name}, the data of {shown}, is missing")
                    try:
                        files[file] = h5py.File(file, "r")
                    except OSError as exc:
                        raise InputError(f"geometry.path: {file.name} cannot be read (truncated or damaged: "
                                         f"{' '.join(str(exc).split())[:100]})") from None
                _check_dataset(files[file], file, dataset, item.get("Dimensions", ""))
    finally:
        for h5 in files.values():
            h5.close()
    count = int(topology.get("NumberOfElements", "-1"))
    if count != names["cells"]["fluid"] + names["cells"]["solid"]:
        raise InputError(f"geometry.path: {names_path(path).name} does not match {shown} ({names['cells']['fluid']}"
                         f" + {names['cells']['solid']} cells in the table, {count} in the mesh)")


def _check_dataset(h5, file: pathlib.Path, dataset: str, dims: str) -> None:
    if dataset not in h5:
        raise InputError(f"geometry.path: {file.name} has no dataset {dataset} (truncated or not this mesh's data)")
    data = h5[dataset]
    try:
        shape = tuple(int(d) for d in dims.split()) if dims.strip() else data.shape
    except ValueError:
        shape = ()
    if math.prod(shape) != data.size:
        raise InputError(f"geometry.path: {file.name}'s {dataset} has shape {data.shape}, not {shape}")
    offset = data.id.get_offset()
    if offset is not None and offset + data.id.get_storage_size() > file.stat().st_size:
        raise InputError(f"geometry.path: {file.name} is truncated ({dataset} ends past its end)")


def check_read(comm, mesh, cell_tags, facet_tags, names: dict[str, Any], shown: str, table_name: str) -> None:
    """Collective, after the read: the tags against the table; the same InputError on every rank."""
    import numpy as np
    from mpi4py import MPI

    tdim = mesh.topology.dim
    owned = cell_tags.indices < mesh.topology.index_map(tdim).size_local
    values = cell_tags.values[owned]
    local = np.array([np.sum(values == 1), np.sum(values == 2), np.sum((values != 1) & (values != 2))], dtype=np.int64)
    fluid, solid, other = comm.allreduce(local, op=MPI.SUM)
    ids = sorted(set().union(*comm.allgather(set(np.unique(facet_tags.values).tolist()))))
    problem = None
    if tdim != names["dim"]:
        problem = f"{shown} holds a {tdim}D mesh but {table_name} says {names['dim']}D"
    elif other or (fluid, solid) != (names["cells"]["fluid"], names["cells"]["solid"]):
        problem = (f"{table_name} does not match {shown} (cells tagged fluid {fluid}, solid {solid}, other {other}; "
                   f"the table: {names['cells']['fluid']} fluid, {names['cells']['solid']} solid)")
    elif set(ids) - set(names["facets"].values()):
        problem = (f"{shown}'s facet tags hold ids {sorted(set(ids) - set(names['facets'].values()))} that "
                   f"{table_name} does not name")
    if problem is not None:
        exc = InputError(f"geometry.path: {problem}")
        exc.shared = True  # every rank found it from the same sums: said once
        raise exc
