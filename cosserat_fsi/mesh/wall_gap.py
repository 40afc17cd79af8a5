"""The gap the solid must keep from the channel's walls (``WallGap``), checked at every mesh motion.

The walls are the given facets (segments in 2D, triangles in 3D) of the reference mesh; they do not move,
so every rank keeps all of them. A solid vertex closer than the gap to a wall stops the run
(``DivergenceError``, exit 3): the fluid mesh between them could not carry the flow.

:func:`groups_inside`: the facet groups of a user's mesh that are not on its boundary (no condition by name).
"""

from __future__ import annotations

import logging

import numpy as np
from mpi4py import MPI

from .. import compat
from ..errors import DivergenceError, InputError
from ..points import _kernels

import dolfinx

log = logging.getLogger("cosserat_fsi")
PAIRS = 1 << 18
"""Point–triangle pairs per numpy pass of ``_triangle_distance`` (its temporaries: about 100 bytes a pair)."""


class WallGap:
    """The solid must stay ``gap`` away from the channel's walls: closer, no fluid mesh between them can
    carry the flow (a contact problem this scheme does not model), so the run stops (exit 3) naming where."""

    def __init__(self, motion, facets: np.ndarray | None, gap: float | str | None):
        """``motion``: the MeshMotion whose solid vertices are checked; ``facets``: the wall facets; ``gap``:
        ``solid.mesh_motion.wall_gap`` (``"off"``: no check). InputError if the gap reaches every solid vertex
        from the walls at rest (none would be checked)."""
        comm, mesh, d = motion.comm, motion.mesh, motion.dim
        off = gap == "off"
        if off:
            facets, gap = None, None
            if comm.rank == 0:
                log.info("solid.mesh_motion.wall_gap: off: the run does not stop when the solid reaches a wall")
        local = _facet_segments(mesh, facets) if facets is not None else np.zeros((0, d, d))
        self.segments = np.concatenate(comm.allgather(local))  # the walls do not move: all ranks keep them
        lengths = np.linalg.norm(self.segments[:, 1] - self.segments[:, 0], axis=1)  # (3D: an edge of the facet)
        self.gap = gap if gap is not None else 0.25 * float(lengths.min()) if len(lengths) else 0.0
        self.comm, self.motion = comm, motion
        n = len(motion.displacement.x.array) // d
        X = np.zeros((n, d))
        X[motion.node_dof[: len(motion.X0)]] = motion.X0
        dofs = motion.solid_dofs[motion.solid_dofs < motion.M.dofmap.index_map.size_local]
        # their distance to the walls at rest: a vertex displaced by |d| is at least this − |d| away, so
        # ``check`` measures only the vertices that could be within the gap
        rest = self.distance(X[dofs])[0] if len(self.segments) else np.full(len(dofs), np.inf)
        keep = rest > self.gap  # solid vertices on a wall from the start (attached) are not checked
        if gap is not None and len(self.segments):
            counts = comm.allreduce(np.array([len(dofs), int(keep.sum())]), op=MPI.SUM)
            farthest = comm.allreduce(float(rest.max()) if len(rest) else 0.0, op=MPI.MAX)
            if counts[0] and not counts[1]:
                raise InputError(f"solid.mesh_motion.wall_gap: {gap!r} m reaches every solid vertex from the walls "
                                 f"at rest (the farthest is {farthest:.4g} m away), so none would be checked; give "
                                 "a smaller gap, or off to turn the check off")
        self.dofs, self.X, self.rest_distance = dofs[keep], X[dofs[keep]], rest[keep]

    def distance(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Distance of each point to the nearest wall segment (3D: wall triangle), and its index."""
        if self.segments.shape[1] == 3:
            return triangle_distance(points, self.segments)
        a, b = self.segments[:, 0], self.segments[:, 1]
        ab = b - a
        rel = points[:, None, :] - a[None]
        s = np.clip((rel * ab[None]).sum(2) / (ab * ab).sum(1)[None], 0.0, 1.0)
        dist = np.linalg.norm(rel - s[..., None] * ab[None], axis=2)
        nearest = dist.argmin(axis=1)
        return dist[np.arange(len(points)), nearest], nearest

    def check(self, solid_displacement: np.ndarray, t: float) -> None:
        """DivergenceError if a solid vertex at X + displacement (P1 dof array) is within the gap of a wall."""
        if not len(self.segments):
            return
        displacement = solid_displacement.reshape(-1, self.X.shape[1])[self.dofs]
        near = self.rest_distance - np.linalg.norm(displacement, axis=1) < self.gap
        x = self.X[near] + displacement[near]
        dist = self.distance(x)[0] if len(x) else np.zeros(0)
        worst = (float(dist.min()), tuple(x[int(dist.argmin())])) if len(dist) else (np.inf, None)
        gap, where = min(self.comm.allgather(worst), key=lambda w: w[0])
        if gap < self.gap:
            raise DivergenceError(f"the solid is within {self.gap:.3g} of the wall near ("
                                  f"{', '.join(f'{c:.4g}' for c in where)}) at t = {t:.6g} (gap {gap:.3g}): "
                                  "no fluid mesh can carry the flow between them")


def _facet_segments(mesh, facets: np.ndarray) -> np.ndarray:
    """The end points (k, 2, 2) of the given local facets, on the current mesh (3D: the corners (k, 3, 3)
    of the triangles)."""
    top = mesh.topology
    if top.dim == 3:
        top.create_connectivity(2, 0)
        top.create_connectivity(3, 0)
        vertex_node = np.empty(top.index_map(0).size_local + top.index_map(0).num_ghosts, dtype=np.int64)
        vertex_node[top.connectivity(3, 0).array.reshape(-1, 4)] = compat.geometry_dofmap(mesh)[:, :4]
        corners = top.connectivity(2, 0).array.reshape(-1, 3)[np.asarray(facets, dtype=np.int64)]
        return mesh.geometry.x[vertex_node[corners]].copy()
    top.create_connectivity(1, 0)
    top.create_connectivity(2, 0)
    vertex_node = np.empty(top.index_map(0).size_local + top.index_map(0).num_ghosts, dtype=np.int64)
    vertex_node[top.connectivity(2, 0).array.reshape(-1, 3)] = compat.geometry_dofmap(mesh)[:, :3]
    ends = top.connectivity(1, 0).array.reshape(-1, 2)[np.asarray(facets, dtype=np.int64)]
    return mesh.geometry.x[vertex_node[ends], :2].copy()


def triangle_distance(points: np.ndarray, triangles: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Distance of each point (m, 3) to the nearest of the triangles (k, 3, 3), and its index: the distance
    to the triangle's plane where the point projects inside it, else to its nearest corner (exact for the
    flat walls of a duct, where every point near a wall projects inside one of its triangles). Compiled, or
    by numpy in passes of ``PAIRS`` point–triangle pairs: its memory does not grow with m k."""
    a, b, c = triangles[:, 0], triangles[:, 1], triangles[:, 2]
    normal = np.cross(b - a, c - a)
    area2 = np.linalg.norm(normal, axis=1)
    normal = normal / area2[:, None]
    if _kernels.ENABLED:
        return _nearest_triangle(np.ascontiguousarray(points, dtype=np.float64),
                                 np.ascontiguousarray(triangles, dtype=np.float64), normal, area2)
    chunk = max(1, PAIRS // max(len(triangles), 1))
    parts = [_triangle_distance(points[i:i + chunk], triangles, normal, area2)
             for i in range(0, len(points), chunk)]
    if not parts:
        return np.zeros(0), np.zeros(0, dtype=np.int64)
    return np.concatenate([p[0] for p in parts]), np.concatenate([p[1] for p in parts])


def _triangle_distance(points, triangles, normal, area2) -> tuple[np.ndarray, np.ndarray]:
    """``triangle_distance`` by numpy arrays of m × k (``normal``: the unit normals, ``area2``: twice the
    areas)."""
    a, b, c = triangles[:, 0], triangles[:, 1], triangles[:, 2]
    rel = points[:, None, :] - a[None]  # (m, k, 3)
    height = np.einsum("mkj,kj->mk", rel, normal)
    foot = rel - height[..., None] * normal[None]
    # barycentric coordinates of the foot: areas of the sub-triangles, signed along the normal
    l1 = np.einsum("mkj,kj->mk", np.cross(foot, (c - a)[None]), normal) / area2  # foot = l1 (b − a) + l2 (c − a)
    l2 = -np.einsum("mkj,kj->mk", np.cross(foot, (b - a)[None]), normal) / area2
    inside = (l1 >= 0) & (l2 >= 0) & (l1 + l2 <= 1)
    corner = np.min(np.linalg.norm(points[:, None, None, :] - triangles[None], axis=3), axis=2)
    dist = np.where(inside, np.abs(height), corner)
    nearest = dist.argmin(axis=1)
    return dist[np.arange(len(points)), nearest], nearest


@_kernels.jit
def _nearest_triangle(points, triangles, normal, area2):
    """``_triangle_distance`` point by point (no m × k arrays)."""
    m, k = points.shape[0], triangles.shape[0]
    dist = np.full(m, np.inf)
    nearest = np.zeros(m, dtype=np.int64)
    for i in range(m):
        for t in range(k):
            ax, ay, az = triangles[t, 0, 0], triangles[t, 0, 1], triangles[t, 0, 2]
            bx, by, bz = triangles[t, 1, 0] - ax, triangles[t, 1, 1] - ay, triangles[t, 1, 2] - az
            cx, cy, cz = triangles[t, 2, 0] - ax, triangles[t, 2, 1] - ay, triangles[t, 2, 2] - az
            nx, ny, nz = normal[t, 0], normal[t, 1], normal[t, 2]
            rx, ry, rz = points[i, 0] - ax, points[i, 1] - ay, points[i, 2] - az
            h = rx * nx + ry * ny + rz * nz
            fx, fy, fz = rx - h * nx, ry - h * ny, rz - h * nz
            l1 = ((fy * cz - fz * cy) * nx + (fz * cx - fx * cz) * ny + (fx * cy - fy * cx) * nz) / area2[t]
            l2 = -((fy * bz - fz * by) * nx + (fz * bx - fx * bz) * ny + (fx * by - fy * bx) * nz) / area2[t]
            if l1 >= 0 and l2 >= 0 and l1 + l2 <= 1:
                d = abs(h)
            else:
                d = np.inf
                for j in range(3):
                    ex = points[i, 0] - triangles[t, j, 0]
                    ey = points[i, 1] - triangles[t, j, 1]
                    ez = points[i, 2] - triangles[t, j, 2]
                    d = min(d, np.sqrt(ex * ex + ey * ey + ez * ez))
            if d < dist[i]:
                dist[i], nearest[i] = d, t
    return dist, nearest


def groups_inside(mesh, facet_tags, facet_ids: dict[str, int]) -> set[str]:
    """The facet groups none of whose facets is on the mesh's boundary (a file's curves or surfaces inside
    the domain; they take no condition). Collective."""
    tdim = mesh.topology.dim
    mesh.topology.create_connectivity(tdim - 1, tdim)
    exterior = dolfinx.mesh.exterior_facet_indices(mesh.topology)
    owned = facet_tags.indices[facet_tags.indices < mesh.topology.index_map(tdim - 1).size_local]
    values = facet_tags.values[facet_tags.indices < mesh.topology.index_map(tdim - 1).size_local]
    out = set()
    for name, tag in facet_ids.items():
        facets = owned[values == tag]
        total, on = mesh.comm.allreduce(np.array([len(facets), np.isin(facets, exterior).sum()]), op=MPI.SUM)
        if total and not on:
            out.add(name)
    return out
