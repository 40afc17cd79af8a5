"""Automatic remeshing: gmsh meshes the fluid anew around the current solid; the solid keeps its cells.

Why the solid keeps its cells: in this Eulerian formulation the solid's vertices are material points that
carry the displacement d (the solid never distorts its own cells beyond what the material does, and the
elastic stress needs d at those points); a new solid mesh would interpolate d, whose gradient is the
stress, and blur the interface. The fluid cells are what the mesh motion distorts, so only they are
replaced.

How (``remesh_msh``, collective, gmsh on rank 0): every rank's owned cells, tagged facets and nodes go to
rank 0; the boundary of the fluid cells (outer boundary + fluid–solid interface, in the current
configuration) becomes one gmsh line per old boundary edge, each transfinite with its two end nodes only,
so the new fluid mesh keeps every boundary node and is conforming with the kept solid cells; the sizes are
those of the mesh the motion started from (per vertex, the mean reference edge length, carried to the
current positions as a gmsh PostView background field), so the grading of the original mesh follows the
solid. The fluid triangles from gmsh, the kept solid triangles and the old tagged facets (all on kept
nodes) are written into one .msh with the physical groups of tags.py, which ``compat.read_msh`` reads and
distributes like any scene mesh.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from mpi4py import MPI

from .. import compat
from ..signals import signal_handlers
from ..tags import CELL_TAGS, FLUID, SOLID


def remesh_msh(mesh, cell_tags, facet_tags, sizes: np.ndarray, facet_ids: dict[str, int], path: Path,
               comm=MPI.COMM_WORLD) -> Path:
    """Write the remeshed ``mesh`` (its current configuration) to ``path`` (.msh) on rank 0; collective.

    ``sizes``: the target cell size at each local geometry node (the mesh motion's ``mesh_size``).
    """
    node_ids = np.asarray(mesh.geometry.input_global_indices, np.int64)
    n_nodes = mesh.geometry.index_map().size_local
    geom = compat.geometry_dofmap(mesh)[:, :3]
    n_cells = compat.num_owned_cells(mesh)
    x = mesh.geometry.x[:, :2]
    tag_of_cell = np.zeros(len(geom), dtype=np.int32)
    tag_of_cell[cell_tags.indices] = cell_tags.values
    top = mesh.topology
    top.create_connectivity(1, 0)
    top.create_connectivity(2, 0)
    vertex_node = np.empty(top.index_map(0).size_local + top.index_map(0).num_ghosts, dtype=np.int64)
    vertex_node[top.connectivity(2, 0).array.reshape(-1, 3)] = geom
    facet_nodes = vertex_node[top.connectivity(1, 0).array.reshape(-1, 2)[facet_tags.indices]]
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


def _mesh_on_root(ids, coords, sizes, cells, cell_tag, facets, facet_tag, facet_ids, path: Path) -> None:
    import gmsh

    from ..files import refuse_link

    refuse_link(path, "")  # gmsh.write follows links: never write out of the run folder through one
    order = np.argsort(ids)  # every node once (owned by one rank)
    ids, coords, sizes = ids[order], coords[order], sizes[order]
    where = {int(i): k for k, i in enumerate(ids)}
    local = np.searchsorted(ids, cells)
    fluid = cells[cell_tag == FLUID]
    solid = cells[cell_tag == SOLID]
    edges = np.sort(np.concatenate([fluid[:, [0, 1]], fluid[:, [1, 2]], fluid[:, [2, 0]]]), axis=1)
    unique, counts = np.unique(edges, axis=0, return_counts=True)
    boundary = unique[counts == 1]
    loops = _boundary_loops(boundary)
    handlers = signal_handlers()
    gmsh.initialize(["-nopopup"])
    try:
        from ..geometry import _gmsh

        _gmsh.configure(gmsh)
        geo = gmsh.model.geo
        point = {n: geo.addPoint(*coords[where[n]], 0.0) for loop in loops for n in loop}
        curve_loops, areas = [], []
        for loop in loops:
            lines = [geo.addLine(point[a], point[b]) for a, b in zip(loop, loop[1:] + loop[:1])]
            for line in lines:
                geo.mesh.setTransfiniteCurve(line, 2)
            curve_loops.append(geo.addCurveLoop(lines))
            xy = coords[[where[n] for n in loop]]
            areas.append(abs(0.5 * np.sum(xy[:, 0] * np.roll(xy[:, 1], -1) - np.roll(xy[:, 0], -1) * xy[:, 1])))
        outer = int(np.argmax(areas))
        geo.addPlaneSurface([curve_loops[outer]] + [c for k, c in enumerate(curve_loops) if k != outer])
        geo.synchronize()
        view = gmsh.view.add("size")
        xs, hs = coords[local], sizes[local]  # (m, 3, 2), (m, 3)
        data = np.hstack([xs[:, :, 0], xs[:, :, 1], np.zeros((len(cells), 3)), hs])
        gmsh.view.addListData(view, "ST", len(cells), data.ravel().tolist())
        field = gmsh.model.mesh.field
        background = field.add("PostView")
        try:
            field.setNumber(background, "ViewTag", view)
        except Exception:  # noqa: BLE001 (gmsh 4.8 names it by index)
            field.setNumber(background, "ViewIndex", 0)
        field.setAsBackgroundMesh(background)
        gmsh.model.mesh.generate(2)
        # final numbering 0..N−1: the kept nodes (boundary of the fluid, solid), then gmsh's interior ones
        kept = np.unique(np.concatenate([solid.ravel(), boundary.ravel()]))
        number = {int(n): k for k, n in enumerate(kept)}
        gmsh_node = {}
        for n, p in point.items():
            tags, _, _ = gmsh.model.mesh.getNodes(0, p)
            gmsh_node[int(tags[0])] = number[n]
        tags, xyz, _ = gmsh.model.mesh.getNodes(2, -1, includeBoundary=False)
        for k, t in enumerate(tags):
            gmsh_node[int(t)] = len(kept) + k
        elements = gmsh.model.mesh.getElementsByType(2)[1]
        triangles = np.vectorize(gmsh_node.get)(np.asarray(elements, dtype=np.int64).reshape(-1, 3))
        all_coords = np.vstack([coords[[where[int(n)] for n in kept]], xyz.reshape(-1, 3)[:, :2]])
        renumber = np.vectorize(lambda n: number[int(n)])
        gmsh.view.remove(view)
        gmsh.model.remove()
        path.parent.mkdir(parents=True, exist_ok=True)
        _write_msh(gmsh, all_coords, triangles, renumber(solid) if len(solid) else solid,
                   renumber(facets), facet_tag, facet_ids, path)
    finally:
        gmsh.finalize()
        signal_handlers(handlers)


def _write_msh(gmsh, coords, fluid, solid, facets, facet_tag, facet_ids, path: Path) -> None:
    """One discrete gmsh model: fluid and solid cells, the tagged facets, physical groups of tags.py."""
    gmsh.model.add("remeshed")
    mesh = gmsh.model.mesh
    gmsh.model.addDiscreteEntity(2, FLUID)
    xyz = np.hstack([coords, np.zeros((len(coords), 1))])
    mesh.addNodes(2, FLUID, list(range(1, len(coords) + 1)), xyz.ravel().tolist())
    mesh.addElementsByType(FLUID, 2, [], (fluid + 1).ravel().tolist())
    names = {v: k for k, v in CELL_TAGS.items()}
    cells = {FLUID: fluid}
    if len(solid):
        gmsh.model.addDiscreteEntity(2, SOLID)
        mesh.addElementsByType(SOLID, 2, [], (solid + 1).ravel().tolist())
        cells[SOLID] = solid
    for tag in cells:
        gmsh.model.setPhysicalName(2, gmsh.model.addPhysicalGroup(2, [tag], tag), names[tag])
    facet_names = {v: k for k, v in facet_ids.items()}
    pairs = np.sort(facets, axis=1)
    for tag in sorted(set(int(t) for t in facet_tag)):
        edges = np.unique(pairs[facet_tag == tag], axis=0)
        gmsh.model.addDiscreteEntity(1, tag)
        mesh.addElementsByType(tag, 1, [], (edges + 1).ravel().tolist())
        gmsh.model.setPhysicalName(1, gmsh.model.addPhysicalGroup(1, [tag], tag), facet_names.get(tag, f"f{tag}"))
    gmsh.write(str(path))
