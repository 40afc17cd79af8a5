"""The pressure matrices of the iterative solver's Schur complement approximations (block_preconditioner.py for
a time step, oseen_preconditioner.py for a steady Newton step): the pressure mass M_p and Laplacian A_p,
assembled on the pressure space alone and restricted to the mixed space's numbering, the viscosity ν of the
velocity equation (seed eq. 31), and the one-cycle inner solver that applies A_p⁻¹.
"""

from __future__ import annotations

import numpy as np
from mpi4py import MPI
from petsc4py import PETSc

from .. import compat
from ..problem.model import WALL_TYPES


def viscosity(problem) -> float:
    """ν = μ + μ_r (μ without micro-rotation): the viscosity of the velocity equation (seed eq. 31)."""
    mu = float(problem.mu.value)
    return mu + float(problem.mu_r.value) if problem.mu_r is not None else mu


def pressure_order(space, pressure_is) -> PETSc.IS:
    """The collapsed pressure space's global indices of the dofs of ``pressure_is`` (the mixed space's owned
    pressure dofs, sorted), in its order: a matrix assembled on the pressure space alone, restricted to them
    (``createSubMatrix``), is the pressure block of the mixed space's numbering."""
    Q, into_W = space.collapsed["pressure"]
    imap, bs = space.W.dofmap.index_map, space.W.dofmap.index_map_bs
    into_W = np.asarray(into_W).ravel()
    mine = np.asarray(pressure_is.getIndices()) - imap.local_range[0] * bs  # W-local, sorted
    by_W = np.argsort(into_W)
    local = by_W[np.searchsorted(into_W[by_W], mine)]  # the Q-local dof of each
    globals_ = np.asarray(Q.dofmap.index_map.local_to_global(local.astype(np.int32)))
    return PETSc.IS().createGeneral(globals_.astype(PETSc.IntType), comm=pressure_is.getComm())


def _pressure_matrix(problem, integrand, order: PETSc.IS) -> PETSc.Mat:
    """``integrand(p, p̃, dx)`` assembled on the pressure space alone (a sparsity of the pressure block only),
    as the pressure block of the mixed space's numbering (``order``: :func:`pressure_order`)."""
    import dolfinx.fem.petsc as fem_petsc
    import ufl

    Q = problem.space.space("pressure")
    A = fem_petsc.assemble_matrix(compat.form(integrand(ufl.TrialFunction(Q), ufl.TestFunction(Q),
                                                        ufl.dx(domain=problem.mesh))))
    A.assemble()
    return A.createSubMatrix(order, order)


def pressure_mass_matrix(problem, order: PETSc.IS, cells=1.0) -> PETSc.Mat:
    """(``cells`` p, p̃): over all cells, or those where the DG0 field ``cells`` is 1."""
    return _pressure_matrix(problem, lambda p, q, dx: cells * p * q * dx, order)


def _diameter(mesh) -> float:
    """The diagonal of the mesh's bounding box (all ranks)."""
    x = mesh.geometry.x
    low = x.min(axis=0) if len(x) else np.full(3, np.inf)
    high = x.max(axis=0) if len(x) else np.full(3, -np.inf)
    mesh.comm.Allreduce(MPI.IN_PLACE, low, op=MPI.MIN)  # elementwise (the pickled MIN compares arrays)
    mesh.comm.Allreduce(MPI.IN_PLACE, high, op=MPI.MAX)
    return float(np.linalg.norm(high - low))


def incompressible_solid(problem) -> tuple[float, float] | None:
    """(ρ_f/ρ_s, μ_s ρ_f) of a solid whose pressure is an unknown (the incompressible law), else None."""
    if problem.fluid_cells is None or problem.pressure_in_fluid:
        return None
    fluid, solid = problem.scene.fluid, problem.scene.solid
    return float(fluid.rho) / float(solid.rho), float(solid.mu_s) * float(fluid.rho)


def _laplace_form(problem, p, q, dx, dirichlet):
    """(∇p, ∇p̃) over the fluid cells; over the solid's (ρ_f/ρ_s)(∇p, ∇p̃) where the solid's pressure is an
    unknown (the Laplacian of the inverse density: the solid's inertia ρ_s α/δt), else (p, p̃) (its pressure
    is pinned); and 10/h (p, p̃) on the boundaries of the types ``dirichlet`` (p = 0 weakly). Without such a
    boundary (a closed flow) it adds (p, p̃)/D² (D the domain's diameter), which keeps the Laplacian definite
    (a singular one breaks the multigrid's coarse solve) and changes only its lowest modes."""
    import ufl

    mesh = problem.mesh
    fluid = problem.fluid_cells if problem.fluid_cells is not None else 1.0
    ds = ufl.Measure("ds", domain=mesh, subdomain_data=problem.facet_tags)
    fixed = [problem.facet_ids[name] for name, bc in problem.conditions().items()
             if dirichlet(bc.type) and name in problem.facet_ids]
    form = fluid * ufl.inner(ufl.grad(p), ufl.grad(q)) * dx
    solid = incompressible_solid(problem)
    if solid is not None:
        form = form + solid[0] * (1.0 - fluid) * ufl.inner(ufl.grad(p), ufl.grad(q)) * dx
    elif problem.fluid_cells is not None:
        form = form + (1.0 - fluid) * p * q * dx
    for tag in fixed:
        form = form + 10.0 / ufl.CellDiameter(mesh) * p * q * ds(tag)
    if not fixed:
        form = form + fluid / _diameter(mesh) ** 2 * p * q * dx
    return form


def _open(kind: str) -> bool:
    """A boundary that fixes the pressure (do-nothing, traction, outflow): Cahouet–Chabard's p = 0."""
    return kind not in WALL_TYPES


def pressure_laplace_matrix(problem, order: PETSc.IS, dirichlet=_open) -> PETSc.Mat:
    """The Schur approximations' pressure Laplacian A_p (:func:`_laplace_form`)."""
    return _pressure_matrix(problem, lambda p, q, dx: _laplace_form(problem, p, q, dx, dirichlet), order)


def inner_solver(A, pc_type, comm) -> PETSc.KSP:
    """One application of ``pc_type`` to ``A`` (preonly)."""
    ksp = PETSc.KSP().create(comm)
    ksp.setOperators(A)
    ksp.setType("preonly")
    ksp.getPC().setType(pc_type)
    if pc_type == "hypre":
        ksp.getPC().setHYPREType("boomeramg")
    ksp.setUp()
    return ksp
