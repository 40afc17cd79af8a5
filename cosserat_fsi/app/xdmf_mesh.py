"""The XDMF/HDF5 form of a scene's mesh (geometry/xdmf_file.py has the format and its checks): :func:`convert`
writes it (``cosserat-fsi mesh SCENE --format xdmf``, one process), :func:`load` reads it on every rank for
``run``."""

from __future__ import annotations

import json
import os
import pathlib
from typing import Any

from ..errors import InputError
from ..geometry.xdmf_file import CELLS, FACETS, MESH, check_pair, check_read, is_xdmf, names_path, table


def load(scene, comm):
    """(mesh, cell_tags, facet_tags) of an .xdmf scene: checked on rank 0 (the pair, the scene against the
    table: file.check_scene), read distributed, the tags checked against the table."""
    from .. import compat
    from ..parallel import on_root
    from ..geometry.file import check_scene

    path = pathlib.Path(scene.geometry.path)

    def checked():
        names = table(path)
        check_pair(path, names)
        check_scene(scene, names)
        return names

    names = on_root(comm, checked, step="mesh")
    mesh, cell_tags, facet_tags = compat.read_xdmf(path, comm, (MESH, CELLS, FACETS))
    check_read(comm, mesh, cell_tags, facet_tags, names, path.name, names_path(path).name)
    return mesh, cell_tags, facet_tags


def convert(scene, out_dir: str | os.PathLike) -> pathlib.Path:
    """One process: the scene's mesh, built and checked as ``run`` does (a file scene: its table and
    file.check_scene), into ``out_dir/NAME.xdmf`` + ``NAME.h5`` + ``NAME.names.json`` (NAME: the file's stem,
    or ``<geometry>-L<level>``); written in a temporary folder there and moved in when complete."""
    import shutil

    from mpi4py import MPI

    from .. import compat
    from ..geometry import build_msh
    from ..geometry.file import check_scene, read_names

    geo = scene.geometry
    if geo.name == "file" and is_xdmf(geo.path):
        raise InputError(f"geometry.path: {pathlib.Path(geo.path).name} is an XDMF mesh already")
    msh = build_msh(geo)
    names = read_names(msh) if geo.name == "file" else None
    if names is not None:
        check_scene(scene, names)
    mesh, cell_tags, facet_tags = compat.read_msh(msh, MPI.COMM_SELF, gdim=geo.DIM)
    if names is None:
        names = _builtin_table(mesh, cell_tags, facet_tags)
    stem = pathlib.Path(geo.path).stem if geo.name == "file" else f"{geo.name}-L{geo.level}"
    out = pathlib.Path(out_dir)
    tmp = out / f".{stem}.{os.getpid()}.tmp"
    try:
        tmp.mkdir(parents=True)
        compat.write_xdmf(tmp / f"{stem}.xdmf", mesh, cell_tags, facet_tags, (CELLS, FACETS))
        (tmp / f"{stem}.names.json").write_text(json.dumps(names, indent=1, sort_keys=True) + "\n")
        for suffix in (".h5", ".names.json", ".xdmf"):  # the .xdmf last: it names the others
            os.replace(tmp / f"{stem}{suffix}", out / f"{stem}{suffix}")
    except OSError as exc:
        raise InputError(f"--out: cannot write to {out} ({exc.strerror or exc})") from None
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return out / f"{stem}.xdmf"


def _builtin_table(mesh, cell_tags, facet_tags) -> dict[str, Any]:
    """The names table of a built-in geometry's mesh (one process): its tags.FACET_TAGS present, the groups
    with no boundary facet as ``interior`` (the fluid-solid interface apart), untagged boundary facets."""
    import dolfinx.mesh
    import numpy as np

    from ..tags import FACET_TAGS

    tdim = mesh.topology.dim
    mesh.topology.create_connectivity(tdim - 1, tdim)
    links = np.diff(mesh.topology.connectivity(tdim - 1, tdim).offsets)[facet_tags.indices]
    used = set(np.unique(facet_tags.values).tolist())
    facets = {name: tag for name, tag in FACET_TAGS.items() if tag in used}
    cells = {"fluid": int(np.sum(cell_tags.values == 1)), "solid": int(np.sum(cell_tags.values == 2))}
    both = cells["fluid"] and cells["solid"]
    interior = sorted(n for n, t in facets.items() if np.all(links[facet_tags.values == t] == 2)
                      and not (both and n == "interface"))
    out: dict[str, Any] = {"dim": tdim, "facets": facets, "cells": cells, "interior": interior}
    unnamed = np.setdiff1d(dolfinx.mesh.exterior_facet_indices(mesh.topology), facet_tags.indices)
    if len(unnamed):
        near = dolfinx.mesh.compute_midpoints(mesh, tdim - 1, unnamed[:1].astype(np.int32))[0][:tdim]
        out["unnamed"] = {"count": int(len(unnamed)), "near": [float(c) for c in near]}
    return out
