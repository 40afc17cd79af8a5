"""Mesh motion (seed §5.2): solid vertices move with the material, fluid vertices by harmonic extension.

Each step the solid vertices move by δt u^{n+1}. The fluid vertices follow the harmonic extension of the
solid displacement, zero on the outer boundary. The extension is solved on the *reference* mesh for the
total displacement (Laplace is linear, so this equals the sum of the seed's incremental extensions with a
fixed operator): its matrix is assembled and factorised once, and the mesh never drifts. The Laplacian is
stiffened by 1/|cell| (Jasak–Tuković), so small cells near the body deform less.
"""

from __future__ import annotations

import numpy as np
from mpi4py import MPI

from .. import compat
from ..errors import DivergenceError

import dolfinx
import dolfinx.fem.petsc as fem_petsc
import ufl
from petsc4py import PETSc

SOLID = 2


class MeshMotion:
    def __init__(self, mesh, cell_tags, comm=MPI.COMM_WORLD, stiffening: bool = True):
        self.mesh, self.comm = mesh, comm
        tdim = mesh.topology.dim
        self.M = M = compat.function_space(mesh, "Lagrange", 1, shape=(2,))
        self.X0 = mesh.geometry.x[:, :2].copy()
        self.displacement = dolfinx.fem.Function(M)  # total vertex displacement from the reference
        self.solid_displacement = dolfinx.fem.Function(M)
        self.increment = dolfinx.fem.Function(M)
        solid_cells = cell_tags.indices[cell_tags.values == SOLID]
        self.solid_dofs = dolfinx.fem.locate_dofs_topological(M, tdim, solid_cells)
        mesh.topology.create_connectivity(tdim - 1, tdim)
        boundary = dolfinx.mesh.exterior_facet_indices(mesh.topology)
        outer = dolfinx.fem.locate_dofs_topological(M, tdim - 1, boundary)
        outer = np.setdiff1d(outer, self.solid_dofs).astype(np.int32)
        zero = dolfinx.fem.Function(M)
        self.bcs = [dolfinx.fem.dirichletbc(self.solid_displacement, self.solid_dofs),
                    dolfinx.fem.dirichletbc(zero, outer)]
        # geometry node <-> P1 dof (same local vertex order per cell)
        nodes, dofs = compat.geometry_dofmap(mesh), compat.cell_dofs(M)
        self.node_dof = np.empty(len(mesh.geometry.x), dtype=np.int64)
        self.node_dof[nodes.ravel()] = dofs.ravel()
        self.moves = len(self.solid_dofs) > 0 or comm.allreduce(len(self.solid_dofs), op=MPI.SUM) > 0
        self.ref_area = self._areas()
        m, v = ufl.TrialFunction(M), ufl.TestFunction(M)
        k = 1.0 / _cell_area(mesh) if stiffening else dolfinx.fem.Constant(mesh, PETSc.ScalarType(1.0))
        self.a = compat.form(k * ufl.inner(ufl.grad(m), ufl.grad(v)) * ufl.dx)
        self.L = compat.form(ufl.inner(dolfinx.fem.Constant(mesh, PETSc.ScalarType((0.0, 0.0))), v) * ufl.dx)
        A = fem_petsc.assemble_matrix(self.a, bcs=self.bcs)
        A.assemble()
        self.A = A
        self.ksp = PETSc.KSP().create(comm)
        self.ksp.setType("preonly")
        self.ksp.getPC().setType("lu")
        self.ksp.getPC().setFactorSolverType("mumps")
        self.ksp.setOperators(A)
        self.b = compat.create_vector(self.L, M)

    def _areas(self) -> np.ndarray:
        """Signed areas of the local cells (positive for the reference orientation)."""
        x = self.mesh.geometry.x[:, :2]
        n = compat.geometry_dofmap(self.mesh)[:, :3]
        e1, e2 = x[n[:, 1]] - x[n[:, 0]], x[n[:, 2]] - x[n[:, 0]]
        return 0.5 * (e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0])

    def move(self, velocity, dt: float, t: float, velocity_P1=None):
        """Move the solid vertices by δt·u and the fluid vertices by the harmonic extension.

        Returns the mesh velocity as a P1 function (increment / δt). Raises DivergenceError, before
        touching the mesh, if a cell would invert or degenerate (area below 1e-3 of its reference).
        """
        if velocity_P1 is None:
            self.increment.interpolate(velocity)
        else:
            self.increment.x.array[:] = velocity_P1.x.array
        sd = self.solid_displacement.x.array
        bs = 2
        idx = (self.solid_dofs[:, None] * bs + np.arange(bs)).ravel()
        sd[idx] += dt * self.increment.x.array[idx]
        with self.b.localForm() as loc:
            loc.set(0.0)
        fem_petsc.apply_lifting(self.b, [self.a], bcs=[self.bcs])
        self.b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        fem_petsc.set_bc(self.b, self.bcs)
        new = dolfinx.fem.Function(self.M)
        self.ksp.solve(self.b, compat.petsc_vec(new))
        new.x.scatter_forward()
        disp = new.x.array.reshape(-1, 2)[self.node_dof]
        x = self.mesh.geometry.x
        old = x[:, :2].copy()
        x[:, :2] = self.X0 + disp
        ratio = self._areas() / self.ref_area
        worst = int(np.argmin(ratio)) if len(ratio) else -1
        bad = len(ratio) > 0 and ratio[worst] < 1e-3
        if self.comm.allreduce(bad, op=MPI.LOR):
            where = None
            if bad:
                nodes = compat.geometry_dofmap(self.mesh)[worst, :3]
                where = x[nodes, :2].mean(axis=0)
            x[:, :2] = old
            wheres = [w for w in self.comm.allgather(where) if w is not None]
            kind = "inverted" if bad and ratio[worst] <= 0 else "degenerate"
            raise DivergenceError(f"t = {t:.6g}: the mesh motion would make a cell {kind} near "
                                  f"({wheres[0][0]:.4g}, {wheres[0][1]:.4g}); try a smaller time.dt, "
                                  f"or the deformation is too large for a moving mesh")
        self.increment.x.array[:] = (new.x.array - self.displacement.x.array) / dt
        self.displacement.x.array[:] = new.x.array
        return self.increment


def _cell_area(mesh):
    """|cell| as a DG0 function on the current (reference) mesh."""
    Q = compat.function_space(mesh, "DG", 0)
    area = dolfinx.fem.Function(Q)
    x = mesh.geometry.x[:, :2]
    n = compat.geometry_dofmap(mesh)[:, :3]
    e1, e2 = x[n[:, 1]] - x[n[:, 0]], x[n[:, 2]] - x[n[:, 0]]
    a = 0.5 * np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0])
    dofs = compat.cell_dofs(Q)[:, 0]
    area.x.array[dofs] = a[: len(dofs)]
    return area
