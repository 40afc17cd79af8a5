"""The iterative solver's block preconditioner of the monolithic saddle point [[K, Bᵀ], [B, −ζM]] (seed eq. 31):
a PETSc fieldsplit Schur complement factorisation (full), the velocity (and micro-rotation) block K by one
algebraic multigrid cycle, the Schur complement S = −B K⁻¹ Bᵀ by an approximation that holds for the regime:

- a time step (``reaction`` ρα/δt known): Cahouet–Chabard, S⁻¹ ≈ −(ν M⁻¹ + ρα/δt L⁻¹), M the pressure mass,
  L the pressure Laplacian (p = 0 weakly on the open boundaries), ν = μ + μ_r; an incompressible solid's cells
  enter as a fluid of density ρ_s and viscosity ν + μ_s δt/α; a compressible solid's pressure is no unknown
  of the flow: L carries its mass there, and the pinned pressure dofs (their Dirichlet rows) are the identity;
- a steady Newton step (``convecting_velocity`` known): the pressure convection–diffusion approximation
  −(ν I + L⁻¹K_p)M⁻¹ (solvers/oseen_preconditioner.py), the velocity block's AMG built on the Jacobian with
  a streamline diffusion (the preconditioning matrix the Newton solver assembles);
- otherwise: the scaled pressure mass −M/(μ + μ_r) with Jacobi (spectrally equivalent to S for Stokes-like K).

Nothing is factorised: the memory grows linearly with the dofs. Every sub-solver reads PETSc's options
database under the solver's prefix (``solver.petsc_options``), after these defaults.
"""

from __future__ import annotations

import numpy as np
from mpi4py import MPI
from petsc4py import PETSc

from .oseen_preconditioner import PressureConvectionDiffusion
from .pressure_matrices import (incompressible_solid, inner_solver, pressure_laplace_matrix,
                                pressure_mass_matrix, pressure_order, viscosity)


def index_set(space, names, comm) -> PETSc.IS:
    """The global (PETSc) indices of the owned dofs of the sub-spaces ``names`` of the mixed space."""
    imap = space.W.dofmap.index_map
    bs = space.W.dofmap.index_map_bs
    owned = imap.size_local * bs
    local = np.concatenate([np.asarray(space.dofs(name)).ravel() for name in names])
    local = np.sort(local[local < owned])
    return PETSc.IS().createGeneral((local + imap.local_range[0] * bs).astype(PETSc.IntType), comm=comm)


def _owned_velocity_nodes(space) -> tuple[np.ndarray, np.ndarray]:
    """The owned velocity nodes: their W-local dofs (one row of d per node) and which of the collapsed
    velocity space's nodes they are (a mask)."""
    V, u = space.collapsed["velocity"]
    gdim = V.dofmap.index_map_bs
    imap, bs = space.W.dofmap.index_map, space.W.dofmap.index_map_bs
    nodes = np.asarray(u).reshape(-1, gdim)
    owned = nodes[:, 0] < imap.size_local * bs
    return nodes[owned], owned


def primal_index_set(space, comm) -> PETSc.IS:
    """The owned velocity (and micro-rotation) dofs of the mixed space. Without micro-rotation, where the
    mixed numbering keeps a node's velocity components adjacent (dolfinx does), the index set carries the
    block size d, which the velocity block's matrix inherits: its multigrid then coarsens the components of a
    node together (a vector operator: the solid's elasticity)."""
    iset = index_set(space, [n for n in space.names if n != "pressure"], comm)
    if "micro_rotation" in space.names:
        return iset
    nodes, owned = _owned_velocity_nodes(space)
    gdim = nodes.shape[1]
    rows = np.sort(nodes.ravel()).reshape(-1, gdim)  # the index set's order, cut into blocks of d
    blocked = np.all(rows - rows[:, :1] == np.arange(gdim)) and np.array_equal(np.sort(nodes[:, 0]), rows[:, 0])
    if comm.allreduce(bool(blocked), op=MPI.LAND):
        iset.setBlockSize(gdim)
        modes = rigid_body_modes(space, iset, nodes, owned, comm)
        iset.compose("nearnullspace", modes)  # the fieldsplit hands it to the AMG
    return iset


def rigid_body_modes(space, iset, nodes, owned, comm) -> PETSc.NullSpace:
    """The velocity block's near null space: the rigid motions (d translations, d(d−1)/2 rotations) on the
    velocity dofs of the index set ``iset`` (sorted); ``nodes``, ``owned``: :func:`_owned_velocity_nodes`.
    Orthonormalised."""
    V = space.collapsed["velocity"][0]
    gdim = nodes.shape[1]
    xo = V.tabulate_dof_coordinates()[owned, :gdim]
    imap, bs = space.W.dofmap.index_map, space.W.dofmap.index_map_bs
    local = np.asarray(iset.getIndices()) - imap.local_range[0] * bs  # W-local dofs, the order of iset
    rows = np.searchsorted(local, nodes)  # positions in the index set (sorted) of each node's dofs
    modes = []
    for c in range(gdim):
        m = np.zeros(len(local))
        m[rows[:, c]] = 1.0
        modes.append(m)
    for a, b in ([(0, 1)] if gdim == 2 else [(0, 1), (1, 2), (2, 0)]):
        m = np.zeros(len(local))
        m[rows[:, a]], m[rows[:, b]] = -xo[:, b], xo[:, a]
        modes.append(m)
    vectors = []
    for m in modes:
        v = PETSc.Vec().createMPI((len(local), PETSc.DECIDE), comm=comm)
        v.setArray(m)
        vectors.append(v)
    PETSc.Vec.normalize(vectors[0])
    for i in range(len(vectors)):  # modified Gram-Schmidt
        for j in range(i):
            vectors[i].axpy(-vectors[i].dot(vectors[j]), vectors[j])
        vectors[i].normalize()
    return PETSc.NullSpace().create(vectors=vectors, comm=comm)


class _PressureSchur:
    """A Schur approximation from the pressure mass M_p (by its diagonal) and Laplacian A_p (by one AMG cycle),
    as a petsc4py ``python`` PC (``apply`` in the subclasses)."""

    def __init__(self, mass, laplace, nu, amg, comm):
        self.nu = nu
        self.lap_ksp = inner_solver(laplace, amg, comm)
        self.diagonal = mass.getDiagonal()
        self.inverse = self.diagonal.copy()
        self.inverse.reciprocal()  # 1/diag(M_p): M_p⁻¹ by its diagonal (Jacobi)

    def setUp(self, pc):
        pass


class CahouetChabard(_PressureSchur):
    """S⁻¹ ≈ −(ν M⁻¹ + (ρα/δt) L⁻¹) (Cahouet & Chabard 1988) as a petsc4py ``python`` PC: M⁻¹ by its diagonal,
    L⁻¹ by one AMG cycle; ρα/δt is read from ``owner.reaction`` at each application (it changes with δt).

    An incompressible solid's cells are, within a step, a fluid of density ρ_s and viscosity ν + μ_s δt/α (its
    stress linearised with d = d* + δt/α u, seed eq. 28): L weights them by ρ_f/ρ_s (:func:`_laplace_form`), M
    by ν/(ν + μ_s δt/α), refreshed when δt changes (``solid_mass``: the solid cells' pressure mass,
    ``solid_stiffness``: μ_s ρ_f, so that μ_s δt/α = μ_s ρ_f/(ρ_f α/δt))."""

    def __init__(self, owner, mass, laplace, nu, amg, comm, pinned, solid_mass=None, solid_stiffness=0.0):
        super().__init__(mass, laplace, nu, amg, comm)
        self.owner, self.pinned = owner, pinned
        self.z = laplace.createVecLeft()
        self.solid_diagonal = solid_mass.getDiagonal() if solid_mass is not None else None
        self.solid_stiffness = solid_stiffness
        self.weighted_for = None  # the ρα/δt the solid's weights were computed for

    def mass_inverse(self) -> PETSc.Vec:
        """1/diag(M), an incompressible solid's cells weighted for the current δt."""
        reaction = self.owner.reaction
        if self.solid_diagonal is not None and reaction != self.weighted_for:
            self.diagonal.copy(self.inverse)
            weight = self.nu / (self.nu + self.solid_stiffness / reaction)
            self.inverse.axpy(weight - 1.0, self.solid_diagonal)
            self.inverse.reciprocal()
            self.weighted_for = reaction
        return self.inverse

    def apply(self, pc, x, y):
        y.pointwiseMult(self.mass_inverse(), x)
        y.scale(-self.nu)
        self.lap_ksp.solve(x, self.z)
        y.axpy(-self.owner.reaction, self.z)
        if len(self.pinned):  # a Dirichlet row of the pressure: its Schur complement is 1
            y.array[self.pinned] = x.array_r[self.pinned]

    def view(self, pc, viewer):
        viewer.printfASCII(f"Cahouet-Chabard: -(nu M^-1 + rho alpha/dt L^-1), nu = {self.nu:g}, "
                           f"rho alpha/dt = {self.owner.reaction:g}\n")


def _pinned_pressure(problem, pressure_is) -> np.ndarray:
    """Positions, within the owned pressure dofs (``pressure_is``), of the solid's pinned pressure (its
    Dirichlet rows)."""
    bc = problem.solid_pressure_condition(problem.space)
    if bc is None:
        return np.zeros(0, dtype=np.int32)
    imap, bs = problem.space.W.dofmap.index_map, problem.space.W.dofmap.index_map_bs
    mine = np.asarray(pressure_is.getIndices()) - imap.local_range[0] * bs  # W-local, sorted
    dofs, owned = bc.dof_indices()
    return np.searchsorted(mine, np.asarray(dofs[:owned])).astype(np.int32)


def configure(owner, ksp, problem, amg: str, comm) -> None:
    """Set ``ksp`` (operators set, options prefix set) up as the fieldsplit Schur preconditioned FGMRES;
    ``owner.reaction`` (ρα/δt of a time step) or else ``owner.convecting_velocity`` (a steady Newton step)
    selects the Schur approximation (module docstring). The defaults are set in code, then each object reads
    the options database (the user's ``solver.petsc_options``)."""
    primal = primal_index_set(problem.space, comm)
    pressure = index_set(problem.space, ["pressure"], comm)
    pc = ksp.getPC()
    pc.setType("fieldsplit")
    pc.setFieldSplitIS(("primal", primal), ("pressure", pressure))
    pc.setFieldSplitType(PETSc.PC.CompositeType.SCHUR)
    pc.setFieldSplitSchurFactType(PETSc.PC.SchurFactType.FULL)
    nu = viscosity(problem)
    order = pressure_order(problem.space, pressure)
    mass = pressure_mass_matrix(problem, order)
    if owner.reaction is None and owner.convecting_velocity is None:
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
    if owner.reaction is None and owner.convecting_velocity is None:
        schur_ksp.getPC().setType("jacobi")
    else:
        if owner.reaction is not None:
            solid = incompressible_solid(problem)
            solid_mass = pressure_mass_matrix(problem, order, 1.0 - problem.fluid_cells) if solid else None
            owner.schur_context = CahouetChabard(
                owner, mass, pressure_laplace_matrix(problem, order), nu, amg, comm,
                _pinned_pressure(problem, pressure), solid_mass, solid[1] if solid else 0.0)
        else:
            owner.schur_context = PressureConvectionDiffusion(problem, mass, order, owner.convecting_velocity, nu,
                                                              amg, comm)
            owner.schur_context.update()
        schur_pc = schur_ksp.getPC()
        schur_pc.setType("python")
        schur_pc.setPythonContext(owner.schur_context)
    schur_ksp.setFromOptions()
    owner.preconditioner_objects = (primal, pressure, order, mass)  # alive as long as the solver
