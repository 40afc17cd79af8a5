"""The iterative solver's block preconditioner of the monolithic saddle point [[K, Bᵀ], [B, −ζM]] (seed eq. 31):
a PETSc fieldsplit Schur complement factorisation (full), the velocity (and micro-rotation) block K by one
algebraic multigrid cycle, the Schur complement S = −B K⁻¹ Bᵀ by an approximation that holds for the regime:

- a time step (``reaction`` ρα/δt known): Cahouet–Chabard, S⁻¹ ≈ −(ν M⁻¹ + ρα/δt L⁻¹), M the pressure mass,
  L the pressure Laplacian (p = 0 weakly on the open boundaries), ν = μ + μ_r; on the solid cells of an FSI
  scene the pressure is no unknown of the flow: L carries its mass there, and the pinned pressure dofs
  (their Dirichlet rows) are the identity;
- a steady solve: the scaled pressure mass −M/(μ + μ_r) with Jacobi (spectrally equivalent to S for
  Stokes-like K).

Nothing is factorised: the memory grows linearly with the dofs. Every sub-solver reads PETSc's options
database under the solver's prefix (``solver.petsc_options``), after these defaults.
"""

from __future__ import annotations

import numpy as np
from mpi4py import MPI
from petsc4py import PETSc


def index_set(space, names, comm) -> PETSc.IS:
    """The global (PETSc) indices of the owned dofs of the sub-spaces ``names`` of the mixed space."""
    imap = space.W.dofmap.index_map
    bs = space.W.dofmap.index_map_bs
    owned = imap.size_local * bs
    local = np.concatenate([np.asarray(space.dofs(name)).ravel() for name in names])
    local = np.sort(local[local < owned])
    return PETSc.IS().createGeneral((local + imap.local_range[0] * bs).astype(PETSc.IntType), comm=comm)


def viscosity(problem) -> float:
    """ν = μ + μ_r (μ without micro-rotation): the viscosity of the velocity equation (seed eq. 31)."""
    mu = float(problem.mu.value)
    return mu + float(problem.mu_r.value) if problem.mu_r is not None else mu


def _pressure_matrix(problem, integrand) -> PETSc.Mat:
    """``integrand(p, p̃, dx)`` assembled on the mixed space (zero outside the pressure block)."""
    import dolfinx.fem.petsc as fem_petsc
    import ufl

    from .. import compat

    W = problem.space.W
    (_, p, _), (_, q, _) = problem.split(ufl.TrialFunction(W)), problem.split(ufl.TestFunction(W))
    A = fem_petsc.assemble_matrix(compat.form(integrand(p, q, ufl.dx(domain=problem.mesh))))
    A.assemble()
    return A


def pressure_mass_matrix(problem) -> PETSc.Mat:
    """(p, p̃) over all cells."""
    return _pressure_matrix(problem, lambda p, q, dx: p * q * dx)


def _diameter(mesh) -> float:
    """The diagonal of the mesh's bounding box (all ranks)."""
    x = mesh.geometry.x
    comm = mesh.comm
    low = comm.allreduce(x.min(axis=0) if len(x) else np.full(3, np.inf), op=MPI.MIN)
    high = comm.allreduce(x.max(axis=0) if len(x) else np.full(3, -np.inf), op=MPI.MAX)
    return float(np.linalg.norm(high - low))


def pressure_laplace_matrix(problem) -> PETSc.Mat:
    """(∇p, ∇p̃) over the fluid cells, (p, p̃) over the solid's, and 10/h (p, p̃) on the boundaries that fix
    the pressure (all but the walls): the Cahouet–Chabard Laplacian. A closed flow (walls only) adds
    (p, p̃)/D² (D the domain's diameter), which keeps L definite and changes only its lowest modes."""
    import ufl

    from .problem import WALL_TYPES

    mesh = problem.mesh
    fluid = problem.fluid_cells if problem.fluid_cells is not None else 1.0
    ds = ufl.Measure("ds", domain=mesh, subdomain_data=problem.facet_tags)
    open_ids = [problem.facet_ids[name] for name, bc in problem.conditions().items()
                if bc.type not in WALL_TYPES and name in problem.facet_ids]

    def integrand(p, q, dx):
        form = fluid * ufl.inner(ufl.grad(p), ufl.grad(q)) * dx
        if problem.fluid_cells is not None:
            form = form + (1.0 - fluid) * p * q * dx
        for tag in open_ids:
            form = form + 10.0 / ufl.CellDiameter(mesh) * p * q * ds(tag)
        if not open_ids:  # a closed flow: the Neumann Laplacian is singular (its AMG coarse solve breaks down)
            form = form + fluid / _diameter(mesh) ** 2 * p * q * dx
        return form

    return _pressure_matrix(problem, integrand)


class CahouetChabard:
    """S⁻¹ ≈ −(ν M⁻¹ + (ρα/δt) L⁻¹) (Cahouet & Chabard 1988) as a petsc4py ``python`` PC: M⁻¹ by Jacobi, L⁻¹ by
    one AMG cycle; ρα/δt is read from ``owner.reaction`` at each application (it changes with δt)."""

    def __init__(self, owner, mass, laplace, nu, amg, comm, pinned):
        self.owner, self.nu, self.pinned = owner, nu, pinned
        self.mass_ksp, self.lap_ksp = PETSc.KSP().create(comm), PETSc.KSP().create(comm)
        for ksp, A, pc_type in ((self.mass_ksp, mass, "jacobi"), (self.lap_ksp, laplace, amg)):
            ksp.setOperators(A)
            ksp.setType("preonly")
            ksp.getPC().setType(pc_type)
            if pc_type == "hypre":
                ksp.getPC().setHYPREType("boomeramg")
            ksp.setUp()
        self.z = laplace.createVecLeft()

    def setUp(self, pc):
        pass

    def apply(self, pc, x, y):
        self.mass_ksp.solve(x, y)
        y.scale(-self.nu)
        self.lap_ksp.solve(x, self.z)
        y.axpy(-self.owner.reaction, self.z)
        if len(self.pinned):  # a Dirichlet row of the pressure: its Schur complement is 1
            y.array[self.pinned] = x.array_r[self.pinned]

    def view(self, pc, viewer):
        viewer.printfASCII(f"Cahouet-Chabard: -(nu M^-1 + rho alpha/dt L^-1), nu = {self.nu:g}, "
                           f"rho alpha/dt = {self.owner.reaction:g}\n")


def _pinned_pressure(problem, pressure_is) -> np.ndarray:
    """Positions, within the owned pressure dofs, of the solid's pinned pressure (its Dirichlet rows)."""
    bc = problem.solid_pressure_condition(problem.space)
    if bc is None:
        return np.zeros(0, dtype=np.int32)
    imap, bs = problem.space.W.dofmap.index_map, problem.space.W.dofmap.index_map_bs
    mine = np.sort(np.asarray(problem.space.dofs("pressure")).ravel())
    mine = mine[mine < imap.size_local * bs]
    dofs, owned = bc.dof_indices()
    return np.searchsorted(mine, np.asarray(dofs[:owned])).astype(np.int32)


def configure(owner, ksp, problem, amg: str, comm) -> None:
    """Set ``ksp`` (operators set, options prefix set) up as the fieldsplit Schur preconditioned FGMRES;
    ``owner.reaction`` (ρα/δt, or None for a steady solve) selects the Schur approximation. The defaults are
    set in code, then each object reads the options database (the user's ``solver.petsc_options``)."""
    names = problem.space.names
    primal = index_set(problem.space, [n for n in names if n != "pressure"], comm)
    pressure = index_set(problem.space, ["pressure"], comm)
    pc = ksp.getPC()
    pc.setType("fieldsplit")
    pc.setFieldSplitIS(("primal", primal), ("pressure", pressure))
    pc.setFieldSplitType(PETSc.PC.CompositeType.SCHUR)
    pc.setFieldSplitSchurFactType(PETSc.PC.SchurFactType.FULL)
    nu = viscosity(problem)
    mass = pressure_mass_matrix(problem).createSubMatrix(pressure, pressure)
    if owner.reaction is None:
        mass.scale(-1.0 / nu)
    pc.setFieldSplitSchurPreType(PETSc.PC.SchurPreType.USER, mass)
    ksp.setFromOptions()
    ksp.setUp()
    primal_ksp, schur_ksp = pc.getFieldSplitSubKSP()
    primal_ksp.setType("preonly")
    primal_pc = primal_ksp.getPC()
    primal_pc.setType(amg)
    if amg == "hypre":
        primal_pc.setHYPREType("boomeramg")
    primal_ksp.setFromOptions()
    schur_ksp.setType("preonly")
    if owner.reaction is None:
        schur_ksp.getPC().setType("jacobi")
    else:
        laplace = pressure_laplace_matrix(problem).createSubMatrix(pressure, pressure)
        owner.schur_context = CahouetChabard(owner, mass, laplace, nu, amg, comm, _pinned_pressure(problem, pressure))
        schur_pc = schur_ksp.getPC()
        schur_pc.setType("python")
        schur_pc.setPythonContext(owner.schur_context)
    schur_ksp.setFromOptions()
    owner.preconditioner_objects = (primal, pressure, mass)  # alive as long as the solver
