"""The points the characteristics are traced back from: the nodes of the P2 spaces of u and ω, and the
quadrature points of every cell, with the fields' values there (``BackTrackingNodes``).

The feet of these points are located and evaluated by ``location``; this module gives their
starting positions in the current (or an earlier) configuration, the nodal values, the values of a P2
field at the quadrature points of every cell (one reference basis for all cells) and the node
permutation from the vector space V to the scalar space S.
"""

from __future__ import annotations

import numpy as np
from mpi4py import MPI

from .. import compat
from . import _kernels, location
from .location import PointLocator, is_p2, p2_coefficients, reference_basis


class BackTrackingNodes:
    """Back-tracking on the nodes of a P2 space V (vector; bs = gdim) and, optionally, a scalar P2 space S.

    All local nodes (owned and ghost) are tracked, so every local node of S has its value without a
    scatter; callers scatter forward afterwards to make ghosts bit-equal to their owners. ``V`` and ``S``
    are collapsed sub-spaces with the same element layout; the node permutation between them is built
    from their cell dofmaps.
    """

    def __init__(self, V, S=None, comm=MPI.COMM_WORLD):
        mesh = V.mesh
        self.comm = comm
        self.locator = PointLocator(mesh)
        self.V = V
        imap = V.dofmap.index_map
        self.n_nodes = imap.size_local + imap.num_ghosts
        self.S = S
        if S is not None:
            cdV, cdS = compat.cell_dofs(V), compat.cell_dofs(S)
            n_nodes = S.dofmap.index_map.size_local + S.dofmap.index_map.num_ghosts
            perm = np.empty(n_nodes, dtype=np.int64)
            perm[cdS.ravel()] = cdV.ravel()
            self.S_from_V = perm  # local S node -> local V node

    def nodes(self) -> np.ndarray:
        """Local node coordinates of V (recomputed: the mesh may move)."""
        return self.V.tabulate_dof_coordinates()[: self.n_nodes]

    def nodal(self, f) -> np.ndarray:
        """Local nodal values of a function on V, shape (n_nodes, bs)."""
        bs = f.function_space.dofmap.index_map_bs
        return f.x.array[: self.n_nodes * bs].reshape(-1, bs)

    def quadrature_nodes(self, degree: int, locator: PointLocator | None = None):
        """Quadrature points of the default rule of ``degree`` in every local cell, from the current
        geometry (or that of ``locator``): (points (n_cells·nq, 3), their cells). Kept with the locator
        until it is updated (read-only arrays)."""
        locator = locator or self.locator
        if degree not in locator.quadrature_cache:
            locator.quadrature_cache[degree] = self._quadrature_nodes(degree, locator)
        return locator.quadrature_cache[degree]

    @staticmethod
    def _quadrature_nodes(degree: int, locator: PointLocator):
        ref = compat.quadrature_points(degree, locator.tdim)
        x0, J = locator.x0, locator.J
        n_cells, nq = len(x0), len(ref)
        out = np.zeros((n_cells, nq, 3))
        if locator.tdim == 3:  # x = x0 + J ξ
            out[:] = x0[:, None, :] + np.einsum("nij,qj->nqi", J, ref)
        else:
            for i in (0, 1):  # x_i = x0_i + J_i0 ξ + J_i1 η, written out (≈ 5× faster than an einsum)
                out[:, :, i] = x0[:, i, None] + J[:, i, 0, None] * ref[:, 0] + J[:, i, 1, None] * ref[:, 1]
        points, cells = out.reshape(-1, 3), np.repeat(np.arange(n_cells, dtype=np.int32), nq)
        points.flags.writeable = cells.flags.writeable = False
        return points, cells

    def at_quadrature_nodes(self, f, degree: int) -> np.ndarray:
        """Values of the P2 field ``f`` at ``quadrature_nodes(degree)``: the basis at the reference
        points is the same in every cell, so this is Σ_k φ_k(ξ_q) c_k per cell, summed in k order from 0
        as ``combine`` (and the compiled kernels) do; a matrix product would sum in BLAS's order."""
        if self.locator.tdim != 2:  # tetrahedra: dolfinx's evaluation in the known cells
            points, cells = self.quadrature_nodes(degree)
            return location.function_eval(f, points, cells)
        phi = reference_basis(degree)  # (nq, 6)
        if location.COMPILED and is_p2(self.locator, f):
            return _kernels.at_reference_points(phi, self.locator.dofs(f.function_space), f.x.array,
                                                f.function_space.dofmap.index_map_bs, len(self.locator.x0))
        cells = np.arange(len(self.locator.x0))
        out = []
        for c in p2_coefficients(self.locator, f, cells):  # per component: (n_cells, 6) coefficients
            total = np.zeros((len(c), len(phi)))
            for k in range(6):
                total += c[:, k, None] * phi[None, :, k]
            out.append(total)
        return np.stack(out, axis=2).reshape(-1, f.function_space.dofmap.index_map_bs)

    def to_S(self, values_at_V_nodes: np.ndarray) -> np.ndarray:
        """Reorder values at local V nodes to the local nodes of S."""
        return values_at_V_nodes[self.S_from_V]
