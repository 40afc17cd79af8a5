"""Automatic remeshing: gmsh meshes the fluid anew around the current solid; the solid keeps its cells.

Why the solid keeps its cells: in this Eulerian formulation the solid's vertices are material points that
carry the displacement d (the solid never distorts its own cells beyond what the material does, and the
elastic stress needs d at those points); a new solid mesh would interpolate d, whose gradient is the
stress, and blur the interface. The fluid cells are what the mesh motion distorts, so only they are
replaced.

How (``remesh_msh``, collective, gmsh on rank 0; triangles in 2D, tetrahedra in 3D): every rank's owned
cells, tagged facets and nodes go to rank 0, in an order that does not depend on the partition; the
boundary of the fluid cells (the facets of exactly one fluid cell: outer boundary + fluid–solid interface,
in the current configuration) is handed to gmsh as it is, so the new fluid mesh keeps every boundary node
and facet and is conforming with the kept solid cells. In 2D it becomes one gmsh line per old boundary
edge, each transfinite with its two end nodes only, and a plane surface; in 3D its triangles become one
discrete surface per connected shell and a volume bounded by them, which gmsh's Delaunay mesher fills
without touching the surfaces (checked: a node or facet gmsh would add on the boundary is an error). The
sizes are those of the mesh the motion started from (per vertex, the mean reference edge length, carried
to the current positions as a gmsh PostView background field), so the grading of the original mesh
follows the solid. The fluid cells from gmsh, the kept solid cells and the old tagged facets (all on kept
nodes) are written into one .msh with the physical groups of tags.py, which ``compat.read_msh`` reads
and distributes like any scene mesh.
"""

from __future__ import annotations

from itertools import combinations
from pathlib import Path

import numpy as np
from mpi4py import MPI

from .. import compat
from ..signals import signal_handlers
from ..tags import CELL_TAGS, FLUID, SOLID


def remesh_msh(mesh, cell_tags, facet_tags, sizes: np.ndarray, facet_ids: dict[str, int], path: Path,
               comm=MPI.COMM_WORLD) -> Path:
    """Write the remeshed ``mesh`` (its current configuration; triangles or tetrahedra) to ``path`` (.msh) on
    rank 0; collective. The same mesh whatever the partition (rank 0 sorts what it gathers).

    ``sizes``: the target cell size at each local geometry node (the mesh motion's ``mesh_size``).
    """
    dim = mesh.topology.dim
    node_ids = np.asarray(mesh.geometry.input_global_indices, np.int64)
    n_nodes = mesh.geometry.index_map().size_local
    geom = compat.geometry_dofmap(mesh)[:, :dim + 1]
    n_cells = compat.num_owned_cells(mesh)
    x = mesh.geometry.x[:, :dim]
    tag_of_cell = np.zeros(len(geom), dtype=np.int32)
    tag_of_cell[cell_tags.indices] = cell_tags.values
    top = mesh.topology
    top.create_connectivity(dim - 1, 0)
    top.create_connectivity(dim, 0)
    vertex_node = np.empty(top.index_map(0).size_local + top.index_map(0).num_ghosts, dtype=np.int64)
    vertex_node[top.connectivity(dim, 0).array.reshape(-1, dim + 1)] = geom
    facet_nodes = vertex_node[top.connectivity(dim - 1, 0).array.reshape(-1, dim)[facet_tags.indices]]
    local = (node_ids[:n_nodes], x[:n_nodes].copy(), np.asarray(sizes)[:n_nodes].copy(), node_ids[geom[:n_cells]],
             tag_of_cell[:n_cells], node_ids[facet_nodes], np.asarray(facet_tags.values))
    parts = comm.gather(local, root=0)
    error = None
    if comm.rank == 0:
        try:
            _mesh_on_root(*(np.concatenate([p[k] for p in parts]) for k in range(7)), facet_ids, Path(path))
        except Exception as exc:  # noqa: BLE001 (shared below: every rank raises)
            error = f"{type(exc).__name__}: {exc}"
    error = comm.bcast(error, root=0)
    from ..parallel import failpoint

    failpoint("remesh")  # the fault suite: a signal right after gmsh had the process
    if error is not None:
        from ..errors import DivergenceError

        raise DivergenceError(f"remeshing failed ({error})")
    return Path(path)


def _mesh_on_root(ids, coords, sizes, cells, cell_tag, facets, facet_tag, facet_ids, path: Path) -> None:
    import gmsh

    from ..files import refuse_link

    refuse_link(path, "")  # gmsh.write follows links: never write out of the run folder through one
    dim = cells.shape[1] - 1
    order = np.argsort(ids)  # every node once (owned by one rank)
    ids, coords, sizes = ids[order], coords[order], sizes[order]
    order = np.lexsort(np.sort(cells, axis=1).T[::-1])  # the cells in an order independent of the partition
    cells, cell_tag = cells[order], cell_tag[order]
    fluid = cells[cell_tag == FLUID]
    solid = cells[cell_tag == SOLID]
    boundary = _boundary_facets(fluid)
    handlers = signal_handlers()
    gmsh.initialize(["-nopopup"])
    try:
        from ..geometry import _gmsh

        _gmsh.configure(gmsh)
        if dim == 2:
            _plane_surface(gmsh, ids, coords, boundary)
        else:
            _discrete_volume(gmsh, ids, coords, boundary)
        local = np.searchsorted(ids, cells)
        view = _size_view(gmsh, coords[local], sizes[local])
        gmsh.model.mesh.generate(dim)
        # final numbering 0..N−1: the kept nodes (boundary of the fluid, solid), then gmsh's interior ones
        kept = np.unique(np.concatenate([solid.ravel(), boundary.ravel()]))
        all_coords, new_fluid = _new_fluid(gmsh, dim, coords[np.searchsorted(ids, kept)])
        gmsh.view.remove(view)
        gmsh.model.remove()
        if not np.array_equal(_boundary_facets(new_fluid), _renumber(kept, boundary)):
            raise ValueError("gmsh changed the boundary of the fluid (the new fluid cells would not be "
                             "conforming with the kept ones)")
        path.parent.mkdir(parents=True, exist_ok=True)
        _write_msh(gmsh, all_coords, new_fluid, _renumber(kept, solid), _renumber(kept, facets), facet_tag,
                   facet_ids, path)
    finally:
        gmsh.finalize()
        signal_handlers(handlers)


def _boundary_facets(cells: np.ndarray) -> np.ndarray:
    """The facets of exactly one of ``cells`` (node rows sorted, the rows in lexicographic order)."""
    dim = cells.shape[1] - 1
    faces = np.sort(np.concatenate([cells[:, list(f)] for f in combinations(range(dim + 1), dim)]), axis=1)
    unique, counts = np.unique(faces, axis=0, return_counts=True)
    return unique[counts == 1]


def _boundary_loops(edges: np.ndarray) -> list[list[int]]:
    """Closed node cycles of the boundary edges (each node on exactly two edges)."""
    neighbours: dict[int, list[int]] = {}
    for a, b in edges:
        neighbours.setdefault(int(a), []).append(int(b))
        neighbours.setdefault(int(b), []).append(int(a))
    if any(len(v) != 2 for v in neighbours.values()):
        raise ValueError("the fluid boundary is not a set of simple closed curves")
    loops, seen = [], set()
    for start in neighbours:
        if start in seen:
            continue
        loop, prev, node = [start], None, start
        seen.add(start)
        while True:
            a, b = neighbours[node]
            nxt = a if a != prev else b
            if nxt == start:
                break
            loop.append(nxt)
            seen.add(nxt)
            prev, node = node, nxt
        loops.append(loop)
    return loops




def _shells(faces: np.ndarray) -> list[np.ndarray]:
    """The connected parts of a set of boundary facets (joined by shared nodes): the rows of each."""
    nodes, local = np.unique(faces, return_inverse=True)
    local = local.reshape(faces.shape)
    label = np.arange(len(nodes))
    while True:
        face_label = label[local].min(axis=1)
        new = label.copy()
        np.minimum.at(new, local.ravel(), np.repeat(face_label, faces.shape[1]))
        new = new[new]
        if np.array_equal(new, label):
            break
        label = new
    return [np.flatnonzero(face_label == k) for k in np.unique(face_label)]


def _renumber(kept: np.ndarray, nodes: np.ndarray) -> np.ndarray:
    """The positions of ``nodes`` (global ids) in the sorted ``kept``; every one must be there."""
    index = np.searchsorted(kept, nodes)
    if nodes.size and not np.array_equal(kept[np.minimum(index, len(kept) - 1)], nodes):
        raise ValueError("a tagged facet lies inside the fluid (only the fluid's boundary is kept)")
    return index


def _plane_surface(gmsh, ids, coords, edges) -> None:
    """2D: the boundary edges as gmsh lines with their end nodes only, the plane surface they bound."""
    geo = gmsh.model.geo
    loops = _boundary_loops(edges)
    xy_of = lambda nodes: coords[np.searchsorted(ids, nodes)]  # noqa: E731
    point = {n: geo.addPoint(*xy_of(n), 0.0) for loop in loops for n in loop}
    curve_loops, areas = [], []
    for loop in loops:
        lines = [geo.addLine(point[a], point[b]) for a, b in zip(loop, loop[1:] + loop[:1])]
        for line in lines:
            geo.mesh.setTransfiniteCurve(line, 2)
        curve_loops.append(geo.addCurveLoop(lines))
        xy = xy_of(np.array(loop))
        areas.append(abs(0.5 * np.sum(xy[:, 0] * np.roll(xy[:, 1], -1) - np.roll(xy[:, 0], -1) * xy[:, 1])))
    outer = int(np.argmax(areas))
    geo.addPlaneSurface([curve_loops[outer]] + [c for k, c in enumerate(curve_loops) if k != outer])
    geo.synchronize()


def _discrete_volume(gmsh, ids, coords, triangles) -> None:
    """3D: the boundary triangles as one discrete surface per connected shell (nodes and triangles as they
    are: gmsh does not remesh a discrete surface) and the volume they bound, the outermost shell first."""
    loops, extents = [], []
    for shell in _shells(triangles):
        faces = triangles[shell]
        nodes = np.unique(faces)
        xyz = coords[np.searchsorted(ids, nodes)]
        surface = gmsh.model.addDiscreteEntity(2)
        gmsh.model.mesh.addNodes(2, surface, (nodes + 1).tolist(), xyz.ravel().tolist())
        gmsh.model.mesh.addElementsByType(surface, 2, [], (faces + 1).ravel().tolist())
        loops.append(gmsh.model.geo.addSurfaceLoop([surface]))
        extents.append(float(np.prod(xyz.max(axis=0) - xyz.min(axis=0))))
    outer = int(np.argmax(extents))  # the outer boundary's box holds every other shell's
    gmsh.model.geo.addVolume([loops[outer]] + [loop for k, loop in enumerate(loops) if k != outer])
    gmsh.model.geo.synchronize()
    gmsh.option.setNumber("Mesh.Algorithm3D", 1)  # Delaunay


def _size_view(gmsh, xs: np.ndarray, hs: np.ndarray) -> int:
    """The background size field: the sizes ``hs`` (cells × nodes) at the nodes ``xs`` (cells × nodes × dim),
    linear on each cell, as a gmsh list-based view (ST: triangles, SS: tetrahedra). Returns the view."""
    dim = xs.shape[2]
    view = gmsh.view.add("size")
    zero = [np.zeros(hs.shape)] if dim == 2 else []
    data = np.hstack([xs[:, :, k] for k in range(dim)] + zero + [hs])
    gmsh.view.addListData(view, "ST" if dim == 2 else "SS", len(xs), data.ravel().tolist())
    field = gmsh.model.mesh.field
    background = field.add("PostView")
    try:
        field.setNumber(background, "ViewTag", view)
    except Exception:  # noqa: BLE001 (gmsh 4.8 names it by index)
        field.setNumber(background, "ViewIndex", 0)
    field.setAsBackgroundMesh(background)
    return view


def _new_fluid(gmsh, dim: int, kept_xyz: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """After ``generate``: the coordinates of the final nodes (the kept ones, then gmsh's interior ones, in
    gmsh's order) and the fluid cells gmsh made in that numbering. gmsh's boundary nodes are the kept ones,
    found by their coordinates (given to gmsh, so equal bit for bit); any other is an error."""
    interior, inner_xyz, _ = gmsh.model.mesh.getNodes(dim, -1, includeBoundary=False)
    number = {int(t): len(kept_xyz) + k for k, t in enumerate(interior)}
    known = {tuple(p): k for k, p in enumerate(np.hstack([kept_xyz, np.zeros((len(kept_xyz), 3 - dim))]).tolist())}
    tags, xyz, _ = gmsh.model.mesh.getNodes()
    added = 0
    for t, p in zip(tags.tolist(), np.asarray(xyz).reshape(-1, 3).tolist()):
        if t not in number:
            k = known.get(tuple(p))
            added += k is None
            number[t] = k
    if added:
        raise ValueError(f"gmsh added {added} nodes on the boundary of the fluid")
    _, nodes = gmsh.model.mesh.getElementsByType(2 if dim == 2 else 4)
    cells = np.fromiter((number[t] for t in np.asarray(nodes).tolist()), np.int64).reshape(-1, dim + 1)
    return np.vstack([kept_xyz, np.asarray(inner_xyz).reshape(-1, 3)[:, :dim]]), cells


def _write_msh(gmsh, coords, fluid, solid, facets, facet_tag, facet_ids, path: Path) -> None:
    """One discrete gmsh model: fluid and solid cells, the tagged facets, physical groups of tags.py."""
    dim = fluid.shape[1] - 1
    cell_type, facet_type = (2, 1) if dim == 2 else (4, 2)  # triangle, line / tetrahedron, triangle
    gmsh.model.add("remeshed")
    mesh = gmsh.model.mesh
    gmsh.model.addDiscreteEntity(dim, FLUID)
    xyz = np.hstack([coords, np.zeros((len(coords), 3 - dim))])
    mesh.addNodes(dim, FLUID, list(range(1, len(coords) + 1)), xyz.ravel().tolist())
    mesh.addElementsByType(FLUID, cell_type, [], (fluid + 1).ravel().tolist())
    names = {v: k for k, v in CELL_TAGS.items()}
    cells = {FLUID: fluid}
    if len(solid):
        gmsh.model.addDiscreteEntity(dim, SOLID)
        mesh.addElementsByType(SOLID, cell_type, [], (solid + 1).ravel().tolist())
        cells[SOLID] = solid
    for tag in cells:
        gmsh.model.setPhysicalName(dim, gmsh.model.addPhysicalGroup(dim, [tag], tag), names[tag])
    facet_names = {v: k for k, v in facet_ids.items()}
    rows = np.sort(facets, axis=1)
    for tag in sorted(set(int(t) for t in facet_tag)):
        faces = np.unique(rows[facet_tag == tag], axis=0)
        gmsh.model.addDiscreteEntity(dim - 1, tag)
        mesh.addElementsByType(tag, facet_type, [], (faces + 1).ravel().tolist())
        gmsh.model.setPhysicalName(dim - 1, gmsh.model.addPhysicalGroup(dim - 1, [tag], tag),
                                   facet_names.get(tag, f"f{tag}"))
    gmsh.write(str(path))
