"""The cells and facets of a user's mesh in dimension D (cells of dimension D, facets of dimension D − 1), as
gmsh holds them after :func:`file.build` opened (and meshed) the file.

A facet is the sorted tuple of its corner nodes: the edges of a triangle or quadrangle in 2D, the four
triangles of a tetrahedron in 3D. A facet of exactly one cell is on the boundary; one of two cells is inside
the domain (the fluid–solid interface when one is fluid and the other solid). Refusals raise :class:`Refused`
with a one-line ``geometry.path: ...`` message.
"""

from __future__ import annotations

from typing import Any

import numpy as np

CELL_TYPES = {2: {2: 3, 3: 4}, 3: {4: 4}}
"""Dimension -> the gmsh element types of its cells -> nodes per cell (first-order triangles, quadrangles;
tetrahedra)."""
FACET_TYPE = {2: 1, 3: 2}
"""Dimension -> the gmsh element type of its facets (2-node lines, 3-node triangles)."""
CELL_WORDS = {2: "triangles and quadrangles", 3: "tetrahedra"}
_LOCAL = {3: [(0, 1), (1, 2), (2, 0)], 4: [(0, 1), (1, 2), (2, 3), (3, 0)]}  # the edges of a triangle, quadrangle
_TET = [(0, 1, 2), (0, 1, 3), (0, 2, 3), (1, 2, 3)]  # the faces of a tetrahedron


class Refused(Exception):
    """Bad input found while meshing (the child prints ``geometry.<key>: ...`` and exits 2)."""


def cell_facets(gmsh, dim: int, entities, shown: str) -> tuple[np.ndarray, set]:
    """The facets of every cell of the ``entities`` of dimension ``dim`` (one row per cell and facet, nodes
    sorted) and the element types met; Refused for a cell type other than :data:`CELL_TYPES`."""
    found, kinds = [], set()
    for e in entities:
        types, _, nodes = gmsh.model.mesh.getElements(dim, e)
        for etype, enodes in zip(types, nodes):
            if int(etype) not in CELL_TYPES[dim]:
                raise Refused(f"geometry.path: {shown} has {gmsh.model.mesh.getElementProperties(etype)[0]} "
                              f"elements; only first-order {CELL_WORDS[dim]} are supported")
            k = CELL_TYPES[dim][int(etype)]
            kinds.add(int(etype))
            cells = np.asarray(enodes, dtype=np.int64).reshape(-1, k)
            local = _TET if dim == 3 else _LOCAL[k]
            found += [np.sort(cells[:, list(f)], axis=1) for f in local]
    return (np.concatenate(found) if found else np.zeros((0, dim), dtype=np.int64)), kinds


def facet_rows(gmsh, dim: int, entities) -> np.ndarray:
    """The facet elements (sorted node rows, each once) of the ``entities`` of dimension ``dim`` − 1."""
    out = []
    for e in entities:
        types, _, nodes = gmsh.model.mesh.getElements(dim - 1, e)
        out += [np.asarray(n, dtype=np.int64).reshape(-1, dim) for t, n in zip(types, nodes)
                if int(t) == FACET_TYPE[dim]]
    rows = np.concatenate(out) if out else np.zeros((0, dim), dtype=np.int64)
    return np.unique(np.sort(rows, axis=1), axis=0)


def _keys(rows: np.ndarray) -> np.ndarray:
    rows = np.ascontiguousarray(rows, dtype=np.int64)
    return rows.view(np.dtype((np.void, 8 * rows.shape[1]))).ravel()


def among(rows: np.ndarray, pool: np.ndarray) -> np.ndarray:
    """Which of ``rows`` are rows of ``pool``."""
    if not len(rows) or not len(pool):
        return np.zeros(len(rows), dtype=bool)
    return np.isin(_keys(rows), _keys(pool))


def near(gmsh, dim: int, nodes) -> str:
    """The centre of ``nodes`` as ``(x, y)`` or ``(x, y, z)``."""
    x = np.mean([gmsh.model.mesh.getNode(int(n))[0][:dim] for n in nodes], axis=0)
    return "(" + ", ".join(f"{c:.4g}" for c in x) + ")"


def split_facets(fluid: np.ndarray, solid: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(boundary, inside, interface) from the cell facets of the fluid and solid cells: facets of one cell,
    of two cells, of a fluid and a solid cell (unique sorted rows)."""
    uniq, counts = np.unique(np.concatenate([fluid, solid]), axis=0, return_counts=True)
    interface = np.zeros((0, uniq.shape[1]), dtype=np.int64)
    if len(fluid) and len(solid):
        both, twice = np.unique(np.concatenate([np.unique(fluid, axis=0), np.unique(solid, axis=0)]), axis=0,
                                return_counts=True)
        interface = both[twice > 1]
    return uniq[counts == 1], uniq[counts > 1], interface


def check_groups(gmsh, dim: int, shown: str, groups: dict[str, np.ndarray], boundary: np.ndarray,
                 inside: np.ndarray) -> tuple[np.ndarray, list[str]]:
    """The boundary facets in no group and the names of the groups inside the domain (none of their facets
    on the boundary). Refused for a facet in two groups and for a group with facets on the boundary and
    inside."""
    names = list(groups)
    if names:
        rows = np.concatenate([groups[n] for n in names])
        label = np.repeat(np.arange(len(names)), [len(groups[n]) for n in names])
        uniq, inverse, counts = np.unique(rows, axis=0, return_inverse=True, return_counts=True)
        shared = np.flatnonzero(counts > 1)
        if len(shared):
            at = np.asarray(inverse).ravel() == shared[0]
            first, second = sorted({names[i] for i in label[at]})[:2]
            raise Refused(f"geometry.path: {shown}: a facet near {near(gmsh, dim, uniq[shared[0]])} is in two "
                          f"physical groups, \"{first}\" and \"{second}\"; put each boundary facet in one group")
    interior = []
    for name in names:
        on, off = among(groups[name], boundary), among(groups[name], inside)
        if off.any() and on.any():
            raise Refused(f"geometry.path: {shown}: facet group \"{name}\" has {int(on.sum())} facets on the boundary "
                          f"and {int(off.sum())} inside the domain (one near {near(gmsh, dim, groups[name][off][0])}"
                          "); a group is either on the boundary or inside")
        if off.any():
            interior.append(name)
    named = np.concatenate([groups[n] for n in names]) if names else np.zeros((0, dim), dtype=np.int64)
    return boundary[~among(boundary, named)], interior


def check_plane(gmsh, shown: str) -> None:
    """Refused unless every node of a 2D mesh lies in the plane z = 0 (the x–y plane)."""
    _, x, _ = gmsh.model.mesh.getNodes()
    x = np.asarray(x).reshape(-1, 3)
    if not len(x):
        return
    size = max(float(np.ptp(x[:, :2], axis=0).max()), 1e-300)
    z = x[:, 2]
    if np.abs(z).max() > 1e-10 * size:
        raise Refused(f"geometry.path: {shown} is a 2D mesh outside the plane z = 0 (z from {z.min():.4g} to "
                      f"{z.max():.4g}); a 2D scene lies in the x-y plane (3D cells: Physical Volume)")


def check_nodes(gmsh, shown: str) -> None:
    """Refused if a node has a coordinate that is not a finite number (``nan``, ``inf`` in a .msh)."""
    tags, x, _ = gmsh.model.mesh.getNodes()
    x = np.asarray(x, dtype=float).reshape(-1, 3)
    bad = np.flatnonzero(~np.isfinite(x).all(axis=1))
    if len(bad):
        where = ", ".join(f"{c:.4g}" for c in x[bad[0]])
        more = f"; {len(bad)} nodes have one" if len(bad) > 1 else ""
        raise Refused(f"geometry.path: {shown}: node {int(tags[bad[0]])} has a coordinate that is not a finite number "
                      f"({where}){more}")


def check_cells(gmsh, dim: int, entities, shown: str) -> None:
    """Refused if a cell has no area (2D) or volume (3D) for its size: its nodes on one line or in one plane, as
    in a mesh whose nodes all lie in one plane but that names its cells a volume. Each cell is measured against
    its own longest node distance, so refined cells of any size pass."""
    tags, x, _ = gmsh.model.mesh.getNodes()
    row = np.zeros(int(np.max(tags, initial=0)) + 1, dtype=np.int64)
    row[np.asarray(tags, dtype=np.int64)] = np.arange(len(tags))
    x = np.asarray(x, dtype=float).reshape(-1, 3)
    flat, total, first = 0, 0, None
    for e in entities:
        types, _, nodes = gmsh.model.mesh.getElements(dim, e)
        for etype, enodes in zip(types, nodes):
            k = CELL_TYPES[dim][int(etype)]
            p = x[row[np.asarray(enodes, dtype=np.int64)]].reshape(-1, k, 3)
            edges = p[:, 1:] - p[:, :1]
            if dim == 3:
                measure = np.abs(np.linalg.det(edges)) / 6.0
            else:  # the shoelace formula, triangles and quadrangles (in the plane z = 0: check_plane)
                measure = np.abs(np.sum(p[:, :, 0] * np.roll(p[:, :, 1], -1, axis=1)
                                        - np.roll(p[:, :, 0], -1, axis=1) * p[:, :, 1], axis=1)) / 2.0
            size = np.zeros(len(p))
            for i in range(k):
                for j in range(i + 1, k):
                    size = np.maximum(size, np.linalg.norm(p[:, i] - p[:, j], axis=1))
            bad = np.flatnonzero(measure <= 1e-10 * size**dim)
            flat, total = flat + len(bad), total + len(p)
            if len(bad) and first is None:
                first = p[bad[0]].mean(axis=0)[:dim]
    if flat:
        word, what = ("tetrahedra", "volume") if dim == 3 else ("cells", "area")
        raise Refused(f"geometry.path: {shown}: {flat} of {total} {word} have no {what} (the first near "
                      f"({', '.join(f'{c:.4g}' for c in first)})): their nodes lie in one "
                      f"{'plane' if dim == 3 else 'line'}")


def count_cells(gmsh, dim: int, entities) -> int:
    return int(sum(len(tags) for e in entities for tags in gmsh.model.mesh.getElements(dim, e)[1]))


def add_facet_group(gmsh, dim: int, rows: np.ndarray, tag: int, name: str) -> None:
    """A discrete entity of dimension ``dim`` − 1 holding the facets ``rows``, as the physical group ``tag``."""
    entity = gmsh.model.addDiscreteEntity(dim - 1)
    gmsh.model.mesh.addElementsByType(entity, FACET_TYPE[dim], [], rows.ravel().tolist())
    gmsh.model.addPhysicalGroup(dim - 1, [entity], tag)
    gmsh.model.setPhysicalName(dim - 1, tag, name)


def summary(gmsh, dim: int, unnamed: np.ndarray) -> dict[str, Any]:
    """The names table's ``unnamed`` entry: how many boundary facets are in no group, and where the first is."""
    x = np.mean([gmsh.model.mesh.getNode(int(n))[0][:dim] for n in unnamed[0]], axis=0)
    return {"count": int(len(unnamed)), "near": [round(float(c), 6) for c in x]}
