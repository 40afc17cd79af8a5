"""Parallel point location and evaluation of P2 fields at arbitrary points of a (moving) mesh.

Used for the feet of the characteristics X^n(x) = x − δt (u^n − w)(x) (seed §5.1; w the mesh velocity,
w = 0 on a fixed mesh), for probes and for the transfer of fields between meshes:

1. local search (``PointLocator``): bounding-box candidates among the rank's cells (owned + ghost) and a
   vectorised barycentric test (dolfinx 0.11's exact GJK test is 10–15× slower,
   shared/reference/dolfinx_stacks.md);
2. cross-rank search: points found on no local cell (≈ 0.15 % of the feet with shared-facet ghosts) are
   gathered on every rank, located among owned cells and evaluated by the owner;
3. feet outside the domain are pulled back towards their node (halving the step) until they are inside,
   so they take the value at the boundary crossing ("points that leave the domain take the boundary value").

On tetrahedra (3D) the same steps run in numpy (barycentric tests) and dolfinx's ``Function.eval`` in the
located cells (the P2 evaluation); the compiled kernels below are for triangles.

The barycentric tests and the P2 evaluation run in compiled kernels (``_kernels``, numba) when numba is
available (``COMPILED``; ``COSSERAT_FSI_NO_NUMBA=1`` turns them off); the numpy functions here are the
reference they reproduce operation by operation, and the fallback: the two paths (tested equal to
round-off) stay side by side so that they are read and changed together. The points the feet start from
(P2 nodes, quadrature points of every cell) are in ``back_tracking_nodes``.
"""

from __future__ import annotations

import functools
import weakref

import numpy as np
from mpi4py import MPI

from .. import compat
from . import _kernels

COMPILED = _kernels.ENABLED  # use the numba kernels (module flag: tests compare both paths)
_TOL = 1e-10  # barycentric tolerance, relative to the reference triangle
_WALK_STEPS = 64  # cells crossed by a compiled walk before the bounding-box tree takes over
_NEIGHBOURS = weakref.WeakKeyDictionary()  # mesh -> cell neighbour table (the topology does not move)
_TREES = weakref.WeakKeyDictionary()  # mesh -> (coordinates, slack, padded tree): PointLocator.tree


EVAL_POINTS = 1 << 16
"""Points per pass of a search in the bounding-box tree and of dolfinx's Function.eval: their temporaries
grow with the points (about 0.8 GB at 1.4 M points in 3D)."""


class PointLocator:
    """Finds, for points in physical space, a local cell containing each (affine triangles or tetrahedra)."""

    def __init__(self, mesh, coordinates: np.ndarray | None = None):
        self.mesh = mesh
        self._dofs = {}
        self.update(coordinates)

    def update(self, coordinates: np.ndarray | None = None):
        """Rebuild the search structures (call after the mesh moved). ``coordinates``: the (n, d) node
        coordinates of another configuration of the same mesh (an earlier time level) to locate in."""
        mesh = self.mesh
        tdim = mesh.topology.dim
        imap = mesh.topology.index_map(tdim)
        self.num_owned = imap.size_local
        n_cells = imap.size_local + imap.num_ghosts
        self.tdim = tdim
        gdim = tdim  # 2D meshes keep only (x, y): dolfinx stores z = 0
        # the bounding-box tree is built when first asked for (``tree``): a compiled walk from a hint
        # cell rarely needs it, and building it is 1.7 ms of a 43 ms seed step
        self._tree = None
        self._tree_coordinates = mesh.geometry.x[:, :gdim].copy() if coordinates is None \
            else np.array(coordinates[:, :gdim], dtype=float)
        x = self._tree_coordinates
        nodes = compat.geometry_dofmap(mesh)[:n_cells, :tdim + 1]
        self.nodes = nodes
        x0 = x[nodes[:, 0]]
        J = np.stack([x[nodes[:, k]] - x0 for k in range(1, tdim + 1)], axis=2)  # (n, d, d): columns edges
        self.x0, self.J = x0, J
        if tdim == 2:  # the 2 × 2 inverse in closed form (np.linalg.inv: 0.5 ms of a seed step)
            det = J[:, 0, 0] * J[:, 1, 1] - J[:, 0, 1] * J[:, 1, 0]
            self.Jinv = np.stack([np.stack([J[:, 1, 1], -J[:, 0, 1]], axis=1),
                                  np.stack([-J[:, 1, 0], J[:, 0, 0]], axis=1)], axis=1) / det[:, None, None]
        else:
            self.Jinv = np.linalg.inv(J)
        self.Jinv_flat = np.ascontiguousarray(self.Jinv.reshape(-1, tdim * tdim))
        self.x0 = np.ascontiguousarray(self.x0)
        self.quadrature_cache = {}  # degree -> back_tracking_nodes.BackTrackingNodes.quadrature_nodes here

    @property
    def tree(self):
        """A bounding-box tree whose boxes hold the cells in the configuration given to ``update``.

        Built on first use, and shared by every configuration of the mesh that is within its slack: the
        boxes are padded by a quarter of the median cell size, so a tree built at coordinates X serves
        any X' with max |X' − X| ≤ that (it then gives more candidates, and ``locate`` keeps the first
        that contains the point, as with a tree of X' itself). A moving mesh rebuilds it every few
        steps, not at every step and time level (1.7 ms each on the seed mesh)."""
        if self._tree is None:
            cached = _TREES.get(self.mesh)
            if cached is not None and np.abs(self._tree_coordinates - cached[0]).max(initial=0.0) <= cached[1]:
                self._tree = cached[2]
            else:
                x, gdim = self.mesh.geometry.x, self.tdim
                slack = 0.25 * float(np.median(np.abs(np.linalg.det(self.J))) ** (1.0 / gdim)) if len(self.J) else 0.0
                current = x[:, :gdim].copy()
                x[:, :gdim] = self._tree_coordinates
                try:
                    self._tree = compat.bb_tree(self.mesh, self.tdim, padding=1e-10 + slack)
                finally:
                    x[:, :gdim] = current
                _TREES[self.mesh] = (self._tree_coordinates, slack, self._tree)
        return self._tree

    @property
    def neighbours(self) -> np.ndarray:
        """(n_cells, 3): the local cell across the edge opposite each geometry node, −1 on the boundary
        of the local mesh (the domain's, or the ghost layer's)."""
        if self.mesh not in _NEIGHBOURS:
            _NEIGHBOURS[self.mesh] = neighbour_table(self.nodes)
        return _NEIGHBOURS[self.mesh]

    def dofs(self, V) -> np.ndarray:
        """Cell dof table of a space (cached per space)."""
        key = id(V)
        if key not in self._dofs:
            self._dofs[key] = (V, np.ascontiguousarray(compat.cell_dofs(V), dtype=np.int32))
        return self._dofs[key][1]

    def _inside(self, points: np.ndarray, cells: np.ndarray, owned_only: bool = False) -> np.ndarray:
        """Barycentric test: is each point in the given local cell (and is the cell owned)?"""
        if self.tdim == 3:
            lam = barycentric_3d(self, points, cells)
            hit = np.minimum(lam.min(axis=1), 1.0 - lam.sum(axis=1)) >= -_TOL
        else:
            l1, l2 = barycentric(self, points, cells)
            hit = np.minimum(np.minimum(l1, l2), 1.0 - l1 - l2) >= -_TOL
        if owned_only:
            hit &= cells < self.num_owned
        return hit

    def _limit(self, owned_only: bool) -> int:
        """Cells at or above this index are not searched."""
        return self.num_owned if owned_only else np.iinfo(np.int32).max

    def locate(self, points: np.ndarray, owned_only: bool = False, hint=None) -> np.ndarray:
        """Local cell index per point (−1 if none). ``points`` has shape (n, 3).

        ``hint``: a likely cell per point (e.g. the cell a foot started from), tested first; only the
        points outside it go through the bounding-box tree (compiled: a walk through neighbouring cells
        from the hint first; it finds the same cell unless the point is within the tolerance of an edge,
        where both cells contain it).
        """
        cells = np.full(len(points), -1, dtype=np.int32)
        if len(points) == 0:
            return cells
        compiled = COMPILED and self.tdim == 2  # the kernels are for triangles
        if not compiled and len(points) > EVAL_POINTS:  # numpy's arrays (3D: ≈ 30 candidate cells a point)
            for i in range(0, len(points), EVAL_POINTS):
                part = slice(i, i + EVAL_POINTS)
                cells[part] = self.locate(points[part], owned_only, None if hint is None else hint[part])
            return cells
        if hint is not None and compiled:  # walk from the hint cell; the tree only where the walk fails
            cells = _kernels.walk(np.ascontiguousarray(points), np.ascontiguousarray(hint, dtype=np.int32),
                                  self.x0, self.Jinv_flat, self.neighbours, _TOL, self._limit(owned_only),
                                  _WALK_STEPS)
            rest = np.flatnonzero(cells < 0)
            if len(rest):
                cells[rest] = self.locate(points[rest], owned_only)
            return cells
        if hint is not None:
            hit = self._inside(points, hint, owned_only)
            cells[hit] = hint[hit]
            rest = np.flatnonzero(~hit)
            cells[rest] = self.locate(points[rest], owned_only)
            return cells
        offsets, candidates = compat.collision_candidates(self.tree, points)
        if compiled:
            return _kernels.first_inside(np.ascontiguousarray(points), offsets, candidates, self.x0,
                                         self.Jinv_flat, _TOL, self._limit(owned_only))
        counts = np.diff(offsets)
        point_of = np.repeat(np.arange(len(points)), counts)
        if owned_only:
            keep = candidates < self.num_owned
            point_of, candidates = point_of[keep], candidates[keep]
        if len(candidates) == 0:
            return cells
        inside = self._inside(points[point_of], candidates)
        # first inside candidate per point (pairs are sorted by point)
        pts_in, first = np.unique(point_of[inside], return_index=True)
        cells[pts_in] = candidates[inside][first]
        return cells


def neighbour_table(triangles: np.ndarray) -> np.ndarray:
    """Cell neighbours across the edges of triangles given by node indices (n, 3): entry (c, i) is the
    cell sharing the edge opposite node i of c, or −1."""
    n = len(triangles)
    a = triangles[:, [1, 2, 0]].astype(np.int64).ravel()
    b = triangles[:, [2, 0, 1]].astype(np.int64).ravel()
    key = np.minimum(a, b) * (int(triangles.max(initial=0)) + 1) + np.maximum(a, b)
    order = np.argsort(key, kind="stable")
    pair = np.flatnonzero(key[order][1:] == key[order][:-1])  # interior edges: two (cell, edge) entries
    out = np.full(3 * n, -1, dtype=np.int32)
    first, second = order[pair], order[pair + 1]
    out[first], out[second] = second // 3, first // 3
    return out.reshape(n, 3)


def barycentric(locator: PointLocator, points: np.ndarray, cells: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Barycentric coordinates (λ1, λ2) of points in given local cells (λ0 = 1 − λ1 − λ2)."""
    Jinv = locator.Jinv_flat[cells]  # (n, 4): rows of J^{-1}
    x0 = locator.x0[cells]
    dx, dy = points[:, 0] - x0[:, 0], points[:, 1] - x0[:, 1]
    return Jinv[:, 0] * dx + Jinv[:, 1] * dy, Jinv[:, 2] * dx + Jinv[:, 3] * dy


def barycentric_3d(locator: PointLocator, points: np.ndarray, cells: np.ndarray) -> np.ndarray:
    """Barycentric coordinates (λ1, λ2, λ3) of points in given local tetrahedra, shape (n, 3)
    (λ0 = 1 − λ1 − λ2 − λ3)."""
    return np.einsum("nij,nj->ni", locator.Jinv[cells], points[:, :3] - locator.x0[cells])


def p2_basis(l1: np.ndarray, l2: np.ndarray) -> np.ndarray:
    """The six P2 Lagrange basis functions at barycentric points, shape (n, 6).

    λ_i(2λ_i − 1) at the vertices and 4λ_jλ_k at the edges (basix order: edge 0 = (1, 2), 1 = (0, 2),
    2 = (0, 1)).
    """
    l0 = 1.0 - l1 - l2
    return np.stack([l0 * (2 * l0 - 1), l1 * (2 * l1 - 1), l2 * (2 * l2 - 1),
                     4 * l1 * l2, 4 * l0 * l2, 4 * l0 * l1], axis=1)


@functools.cache
def reference_basis(degree: int) -> np.ndarray:
    """The P2 basis at the reference points of the quadrature rule of ``degree``, shape (nq, 6)
    (cached, read-only)."""
    ref = compat.quadrature_points(degree)
    phi = np.ascontiguousarray(p2_basis(ref[:, 0], ref[:, 1]))
    phi.flags.writeable = False
    return phi


def p2_coefficients(locator: PointLocator, f, cells: np.ndarray) -> list[np.ndarray]:
    """The P2 coefficients of ``f`` in ``cells``, one (n, 6) array per component: a gather per component
    (np.take on a contiguous copy) is ~4× faster than one (n, 6, bs) fancy-index gather."""
    bs = f.function_space.dofmap.index_map_bs
    idx = locator.dofs(f.function_space)[cells]  # (n, 6)
    values = f.x.array.reshape(-1, bs)
    return [np.take(np.ascontiguousarray(values[:, b]), idx) for b in range(bs)]


def combine(locator: PointLocator, f, phi: np.ndarray, cells: np.ndarray) -> np.ndarray:
    """Σ_k φ_k c_k: values of the P2 field ``f`` from basis values ``phi`` (n, 6) in ``cells``."""
    return np.stack([(phi * c).sum(axis=1) for c in p2_coefficients(locator, f, cells)], axis=1)


def is_p2(locator: PointLocator, f) -> bool:
    """A P2 field on triangles (what the vectorised and compiled evaluations do; tetrahedra go to
    dolfinx's Function.eval)."""
    return locator.tdim == 2 and locator.dofs(f.function_space).shape[1] == 6


def _compiled_p2(locator: PointLocator, f, points: np.ndarray, cells: np.ndarray) -> np.ndarray:
    """``combine(p2_basis(barycentric(...)))`` in one compiled pass (same operations, same order)."""
    return _kernels.p2_values(np.ascontiguousarray(points), np.ascontiguousarray(cells, dtype=np.int32),
                              locator.x0, locator.Jinv_flat, locator.dofs(f.function_space), f.x.array,
                              f.function_space.dofmap.index_map_bs)


def function_eval(f, points: np.ndarray, cells: np.ndarray) -> np.ndarray:
    """dolfinx's ``f.eval`` at points in known local cells, (n, value_size), in passes of ``EVAL_POINTS``."""
    parts = [f.eval(points[i:i + EVAL_POINTS], cells[i:i + EVAL_POINTS]).reshape(min(EVAL_POINTS, len(points) - i), -1)
             for i in range(0, len(points), EVAL_POINTS)]
    return np.concatenate(parts) if parts else np.zeros((0, _value_count(f)))


def eval_at(locator: PointLocator, f, points: np.ndarray, cells: np.ndarray) -> np.ndarray:
    """Values of ``f`` at points in known local cells, shape (n, value_size).

    P2 Lagrange fields on affine triangles (every field the characteristics transport) are evaluated
    here, vectorised (``p2_basis``) or compiled; anything else goes to dolfinx's Function.eval.
    """
    if len(points) == 0 or not is_p2(locator, f):
        return function_eval(f, points, cells)
    if COMPILED:
        return _compiled_p2(locator, f, points, cells)
    return combine(locator, f, p2_basis(*barycentric(locator, points, cells)), cells)


def eval_many(locator: PointLocator, functions, points: np.ndarray, cells: np.ndarray) -> list[np.ndarray]:
    """``eval_at`` for several fields at the same points: the basis is computed once."""
    if COMPILED or locator.tdim != 2:
        return [eval_at(locator, f, points, cells) for f in functions]
    phi = p2_basis(*barycentric(locator, points, cells)) if len(points) else None
    return [combine(locator, f, phi, cells) if phi is not None and is_p2(locator, f)
            else eval_at(locator, f, points, cells) for f in functions]


def evaluate(locator: PointLocator, functions, points: np.ndarray, anchors: np.ndarray,
             comm=MPI.COMM_WORLD, bisections: int = 12, hint=None):
    """Values of ``functions`` at ``points`` (n, 3), parallel; outside points are pulled to ``anchors``.

    ``anchors`` are points known to be in a local cell (the nodes the feet start from; ``hint``: the
    cells they are in, if known). A foot outside
    the domain is replaced by the last inside point of the segment anchor → foot, found by bisection to
    2^-bisections of its length. Returns a list of (n, value_size) arrays, one per function. Collective.
    """
    values, found = _evaluate_anywhere(locator, functions, points, comm, hint)
    out = np.flatnonzero(~found)
    if comm.allreduce(len(out), op=MPI.SUM) == 0:
        return values
    lo, hi = np.zeros(len(out)), np.ones(len(out))
    seg = points[out] - anchors[out]
    for _ in range(bisections):
        mid = 0.5 * (lo + hi)
        _, inside = _evaluate_anywhere(locator, [], anchors[out] + mid[:, None] * seg, comm)
        lo = np.where(inside, mid, lo)
        hi = np.where(inside, hi, mid)
    vals_in, inside = _evaluate_anywhere(locator, functions, anchors[out] + lo[:, None] * seg, comm)
    if not comm.allreduce(bool(inside.all()), op=MPI.LAND):
        raise RuntimeError("characteristics: a node of the mesh is in no cell (corrupt mesh?)")
    for val, v_in in zip(values, vals_in):
        val[out] = v_in
    return values


def _evaluate_anywhere(locator, functions, pts, comm, hint=None):
    """Values at points searched among local cells, then among the other ranks' owned cells. Collective.

    Returns (list of (n, size) arrays, found mask).
    """
    cells = locator.locate(pts, hint=hint)
    found = cells >= 0
    if COMPILED and all(is_p2(locator, f) for f in functions):  # all points in one pass, 0 where not found
        values = [_compiled_p2(locator, f, pts, cells) for f in functions]
    else:
        values = [np.zeros((len(pts), _value_count(f))) for f in functions]
        if found.any() and functions:
            for val, v in zip(values, eval_many(locator, functions, pts[found], cells[found])):
                val[found] = v
    lost = np.flatnonzero(~found)
    found[lost] = _remote_evaluate(locator, functions, pts[lost], values, lost, comm)
    return values, found


def values_anywhere(locator: PointLocator, functions, points: np.ndarray, comm=MPI.COMM_WORLD):
    """Values of ``functions`` at ``points`` (n, 3) that may lie on any rank's cells; (list of (n, size)
    arrays, found mask). Collective."""
    return _evaluate_anywhere(locator, functions, points, comm)


def _value_count(f):
    shape = f.ufl_shape
    return int(np.prod(shape)) if shape else 1


def _remote_evaluate(locator, functions, pts, values, lost, comm):
    """Evaluate at points that no local cell contains, on the rank that owns them. Collective."""
    if comm.size == 1:
        return np.zeros(len(pts), dtype=bool)
    counts = comm.allgather(len(pts))
    if sum(counts) == 0:
        return np.zeros(0, dtype=bool)
    all_pts = np.concatenate(comm.allgather(pts)) if sum(counts) else np.zeros((0, 3))
    cells = locator.locate(all_pts, owned_only=True)
    found = cells >= 0
    hit = comm.allreduce(found.astype(np.int64), op=MPI.SUM)
    start = int(np.sum(counts[:comm.rank]))
    mine = slice(start, start + len(pts))
    for f, val in zip(functions, values):
        local = np.zeros((len(all_pts), val.shape[1]))
        if found.any():
            local[found] = eval_at(locator, f, all_pts[found], cells[found])
        total = comm.allreduce(local, op=MPI.SUM)
        ok = hit[mine] > 0
        val[lost[ok]] = total[mine][ok] / hit[mine][ok, None]
    return hit[mine] > 0


def probe(locator: PointLocator, functions, points: np.ndarray, comm=MPI.COMM_WORLD):
    """Values of ``functions`` at fixed points (same on every rank), from the ranks owning them. Collective.

    Returns a list of (n, size) arrays (NaN where no rank owns the point: outside the domain).
    """
    points = np.atleast_2d(np.asarray(points, dtype=np.float64))
    if points.shape[1] == 2:
        points = np.hstack([points, np.zeros((len(points), 1))])
    cells = locator.locate(points, owned_only=True)
    found = cells >= 0
    hits = comm.allreduce(found.astype(np.int64), op=MPI.SUM)
    out = []
    for f in functions:
        local = np.zeros((len(points), _value_count(f)))
        if found.any():
            local[found] = eval_at(locator, f, points[found], cells[found])
        total = comm.allreduce(local, op=MPI.SUM)
        with np.errstate(invalid="ignore", divide="ignore"):
            out.append(np.where(hits[:, None] > 0, total / np.maximum(hits, 1)[:, None], np.nan))
    return out
