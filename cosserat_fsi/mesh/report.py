"""How many cells a solid region has across, for run.log (a thin solid needs several: a compressible strip with
one cell across locks).

Estimate, per connected solid region (cells joined by a shared facet): the depth of a vertex is the number
of edges on the shortest path from the region's boundary (the vertices of facets that only one solid cell
has: the interface, clamps, outer walls); with D the largest depth, the region has about 2·D cells across
(at least 1: D = 0 means every vertex is on the boundary, one cell across). A structured strip of k rows
gives 2·⌊k/2⌋ (k rounded down to even), so the estimate never overstates the resolution.
"""

from __future__ import annotations

import itertools

import numpy as np

from .. import compat
from ..tags import SOLID

THIN = 2
"""Fewer cells across than this: a warning."""


def solid_regions(mesh, cell_tags, comm) -> list[dict]:
    """[{cells, across}] per solid region, largest first, on every rank (computed on rank 0 from the
    gathered owned solid cells: solids are small next to the fluid). Collective."""
    tdim = mesh.topology.dim
    n_owned = compat.num_owned_cells(mesh)
    solid = cell_tags.indices[(cell_tags.values == SOLID) & (cell_tags.indices < n_owned)] \
        if cell_tags is not None else np.zeros(0, dtype=np.int32)
    nodes = compat.geometry_dofmap(mesh)[solid, :tdim + 1]
    corners = mesh.geometry.x[nodes][..., :tdim]  # (n, tdim + 1, tdim)
    gathered = comm.gather(corners, root=0)
    regions = _regions(np.concatenate(gathered)) if comm.rank == 0 else None
    return comm.bcast(regions, root=0)


def _regions(corners: np.ndarray) -> list[dict]:
    if not len(corners):
        return []
    n, k, dim = corners.shape
    scale = max(float(np.ptp(corners.reshape(-1, dim), axis=0).max()), 1e-300)
    keys = np.round(corners.reshape(-1, dim) / scale * 1e9).astype(np.int64)
    _, vertex = np.unique(keys, axis=0, return_inverse=True)
    cells = vertex.reshape(n, k)
    facets = np.sort(np.concatenate([cells[:, list(f)] for f in itertools.combinations(range(k), k - 1)]), axis=1)
    unique, owner_count = np.unique(facets, axis=0, return_counts=True)
    boundary = np.unique(unique[owner_count == 1])
    edges = np.unique(np.sort(np.concatenate([cells[:, [a, b]] for a, b in itertools.combinations(range(k), 2)]),
                              axis=1), axis=0)
    nv = int(cells.max()) + 1
    label = np.arange(nv)
    while True:  # connected components: smallest vertex label along edges
        low = np.minimum(label[edges[:, 0]], label[edges[:, 1]])
        new = label.copy()
        np.minimum.at(new, edges[:, 0], low)
        np.minimum.at(new, edges[:, 1], low)
        new = new[new]
        if np.array_equal(new, label):
            break
        label = new
    depth = np.full(nv, -1)
    depth[boundary] = 0
    d = 0
    while (depth < 0).any():
        a, b = edges[:, 0], edges[:, 1]
        grow = np.concatenate([b[(depth[a] == d) & (depth[b] < 0)], a[(depth[b] == d) & (depth[a] < 0)]])
        if not len(grow):
            break
        depth[grow] = d + 1
        d += 1
    out = []
    cell_label = label[cells[:, 0]]
    for region in np.unique(cell_label):
        D = int(depth[label == region].max())
        out.append({"cells": int(np.sum(cell_label == region)), "across": max(1, 2 * D)})
    return sorted(out, key=lambda r: -r["cells"])


def log_solid_resolution(mesh, cell_tags, comm) -> list[dict]:
    """Log a line per solid region (run.log), a ``warning:`` (stderr too) for one under :data:`THIN` cells
    across; returns the regions. Collective."""
    import logging

    log = logging.getLogger("cosserat_fsi")
    regions = solid_regions(mesh, cell_tags, comm)
    for i, region in enumerate(regions):
        text = f"solid region {i + 1}: {region['cells']} cells, about {region['across']} cells across"
        if region["across"] < THIN:
            log.warning("warning: %s: a thin solid needs several cells across (a compressible strip with 1 cell "
                        "across locks); refine it (geometry.level, or the mesh size of the file)", text)
        else:
            log.info("%s", text)
    return regions
