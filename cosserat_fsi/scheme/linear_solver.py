"""The linear solver of the monolithic system: MUMPS LU, the last LU as a GMRES preconditioner, or an
iterative block preconditioner (``solver.type: iterative``).

On a fixed mesh the matrix is constant (per BDF coefficient), so one factorisation serves every step
(``preonly``). On a moving mesh, with ``solver.reuse_factorization``, GMRES is preconditioned by the last
factorisation and the matrix is refactorised only when GMRES does not converge within
``solver.max_krylov_iterations``. :meth:`LinearSolver.solve` may be called again with the same operator
(corrector passes) and reuses the factorisation.

``solver.type: iterative``: FGMRES (relative tolerance ``solver.krylov_rtol`` on the unpreconditioned
residual, at most ``solver.max_iterations``) preconditioned by a PETSc fieldsplit Schur complement
factorisation (full) of the saddle point [[K, Bᵀ], [B, −ζM]]: the velocity (and micro-rotation) block K by one
algebraic multigrid cycle (``solver.amg``: GAMG, in both PETSc builds, or hypre BoomerAMG, Debian's only), the
Schur complement by the pressure mass matrix scaled by −1/(μ + μ_r) (spectrally equivalent to −B K⁻¹ Bᵀ for
Stokes-like K), with Jacobi. It needs no factorisation: its memory grows linearly with the dofs.
"""

from __future__ import annotations

import numpy as np
from mpi4py import MPI
from petsc4py import PETSc

from ..errors import DivergenceError

MUMPS_ORDERING = {"amd": 0, "pord": 4, "metis": 5, "auto": 7}


def _index_set(space, names, comm) -> PETSc.IS:
    """The global (PETSc) indices of the owned dofs of the sub-spaces ``names`` of the mixed space."""
    imap = space.W.dofmap.index_map
    bs = space.W.dofmap.index_map_bs
    owned = imap.size_local * bs
    local = np.concatenate([np.asarray(space.dofs(name)).ravel() for name in names])
    local = np.sort(local[local < owned])
    return PETSc.IS().createGeneral((local + imap.local_range[0] * bs).astype(PETSc.IntType), comm=comm)


def pressure_mass_matrix(problem) -> PETSc.Mat:
    """(p, p̃) on the mixed space (zero outside the pressure block), assembled."""
    import dolfinx.fem.petsc as fem_petsc
    import ufl

    from .. import compat

    W = problem.space.W
    (_, p, _), (_, q, _) = problem.split(ufl.TrialFunction(W)), problem.split(ufl.TestFunction(W))
    M = fem_petsc.assemble_matrix(compat.form(p * q * ufl.dx(domain=problem.mesh)))  # (all cells)
    M.assemble()
    return M


def pressure_schur_matrix(problem) -> PETSc.Mat:
    """−1/(μ + μ_r) (p, p̃) on the mixed space (zero outside the pressure block), assembled: the Schur
    complement's preconditioning matrix (the fieldsplit takes its pressure block)."""
    import dolfinx.fem.petsc as fem_petsc
    import ufl

    from .. import compat

    W = problem.space.W
    (_, p, _), (_, q, _) = problem.split(ufl.TrialFunction(W)), problem.split(ufl.TestFunction(W))
    viscosity = problem.mu + problem.mu_r if problem.mu_r is not None else problem.mu
    M = fem_petsc.assemble_matrix(compat.form(-p * q / viscosity * ufl.dx(domain=problem.mesh)))
    M.assemble()
    return M


def solve_counts(kind: str, solves: int, factorisations: int, iterations: int | None, largest: int) -> dict:
    """summary.json's "linear_solver" record (``iterations`` None: a direct solve, no Krylov iterations)."""
    record = {"type": kind, "solves": int(solves), "factorisations": int(factorisations)}
    if iterations is not None:
        record["krylov_iterations"] = {"total": int(iterations), "mean": iterations / max(solves, 1),
                                       "max": int(largest)}
    return record


def pressure_laplace_matrix(problem) -> PETSc.Mat:
    """(∇p, ∇p̃) on the mixed space (zero outside the pressure block), with p = 0 imposed weakly (10/h) on the
    boundaries that fix the pressure (outflow), assembled: the Cahouet–Chabard Schur preconditioner's
    Laplacian."""
    import dolfinx.fem.petsc as fem_petsc
    import ufl

    from .. import compat
    from .problem import WALL_TYPES

    W = problem.space.W
    mesh = problem.mesh
    (_, p, _), (_, q, _) = problem.split(ufl.TrialFunction(W)), problem.split(ufl.TestFunction(W))
    fluid = problem.fluid_cells if problem.fluid_cells is not None else 1.0
    # in the fluid the Laplacian; the solid's pressure is no unknown of the flow: its own mass there
    form = fluid * ufl.inner(ufl.grad(p), ufl.grad(q)) * ufl.dx(domain=mesh)
    if problem.fluid_cells is not None:
        form = form + (1.0 - fluid) * p * q * ufl.dx(domain=mesh)
    ds = ufl.Measure("ds", domain=mesh, subdomain_data=problem.facet_tags)
    h = ufl.CellDiameter(mesh)
    for name, bc in problem.conditions().items():
        if bc.type not in WALL_TYPES and name in problem.facet_ids:
            form = form + 10.0 / h * p * q * ds(problem.facet_ids[name])
    L = fem_petsc.assemble_matrix(compat.form(form))
    L.assemble()
    return L


class _CahouetChabard:
    """S⁻¹ ≈ −(ν M⁻¹ + (ρα/δt) L⁻¹) (Cahouet & Chabard 1988): the inverse Schur complement of the
    time-discrete Stokes operator ρα/δt u − ν Δu, as a petsc4py ``python`` PC; M⁻¹ by Jacobi, L⁻¹ by one AMG
    cycle; ρα/δt is read from the solver at each application (it changes with δt)."""

    def __init__(self, owner, mass, laplace, viscosity, amg, comm):
        self.owner, self.viscosity = owner, viscosity
        self.mass_ksp, self.lap_ksp = PETSc.KSP().create(comm), PETSc.KSP().create(comm)
        for ksp, A, pc_type in ((self.mass_ksp, mass, "jacobi"), (self.lap_ksp, laplace, amg)):
            ksp.setOperators(A)
            ksp.setType("preonly")
            ksp.getPC().setType(pc_type)
            if pc_type == "hypre":
                ksp.getPC().setHYPREType("boomeramg")
            ksp.setUp()
        self.z = laplace.createVecLeft()
        self.pinned = np.zeros(0, dtype=np.int32)  # positions of the Dirichlet pressure dofs (identity rows)

    def setUp(self, pc):
        pass

    def apply(self, pc, x, y):
        self.mass_ksp.solve(x, y)
        y.scale(-self.viscosity)
        self.lap_ksp.solve(x, self.z)
        y.axpy(-self.owner.reaction, self.z)
        if len(self.pinned):  # a Dirichlet row of the pressure: its Schur complement is 1
            y.array[self.pinned] = x.array_r[self.pinned]


class LinearSolver:
    """``set_operator(A)`` after (re)assembly, ``solve(b, x)``; counts ``factorisations`` and
    ``krylov_iterations`` (GMRES reuse only) and exposes the PETSc ``ksp``."""

    def __init__(self, solver_config, comm=MPI.COMM_WORLD, reuse_factorization: bool = False, problem=None):
        """``problem``: the scheme's Problem (its mixed space and viscosities); needed by ``type: iterative``."""
        self.config, self.comm = solver_config, comm
        self.iterative = getattr(solver_config, "type", "direct") == "iterative"
        self.reuse = reuse_factorization and not self.iterative
        self.factorisations = 0
        self.krylov_iterations = 0
        self.solves, self.max_krylov_iterations = 0, 0  # counts(): summary.json "linear_solver"
        self._factorise = False  # direct: the operator changed since the last factorisation
        self.reaction = None  # ρα/δt of a time step (iterative: the Cahouet–Chabard Schur preconditioner)
        self.A = None
        self._configured = False
        ksp = self.ksp = PETSc.KSP().create(comm)
        if self.iterative:
            if problem is None:
                raise ValueError("solver.type: iterative needs the problem (its fields)")
            self.problem = problem
            ksp.setType("fgmres")
            ksp.setTolerances(rtol=solver_config.krylov_rtol, atol=1e-50, max_it=solver_config.max_iterations)
            ksp.setGMRESRestart(200)
            return
        ksp.setType("preonly")
        pc = ksp.getPC()
        pc.setType("lu")
        pc.setFactorSolverType("mumps")
        if self.reuse:  # the last LU preconditions GMRES until GMRES needs too many iterations
            ksp.setType("gmres")
            ksp.setTolerances(rtol=solver_config.krylov_rtol, atol=1e-50,
                              max_it=solver_config.max_krylov_iterations)
            ksp.setInitialGuessNonzero(True)
            ksp.setNormType(PETSc.KSP.NormType.UNPRECONDITIONED)
            pc.setReusePreconditioner(True)

    def set_operator(self, A) -> None:
        """The matrix changed (values, same pattern): a direct solver refactorises at the next solve, the
        reusing one keeps its factorisation as the preconditioner."""
        self.A = A
        self._factorise = True
        self.ksp.setOperators(A)
        if not self._configured:
            if self.iterative:
                self._fieldsplit()
            else:
                self._mumps_options()
            self._configured = True

    def _fieldsplit(self):
        """Schur-complement fieldsplit: AMG on the velocity (and micro-rotation) block, the scaled pressure
        mass matrix with Jacobi on the Schur complement (module docstring)."""
        problem, comm, ksp = self.problem, self.comm, self.ksp
        names = problem.space.names
        primal = _index_set(problem.space, [n for n in names if n != "pressure"], comm)
        pressure = _index_set(problem.space, ["pressure"], comm)
        self._mass = pressure_schur_matrix(problem)
        self._schur_pre = self._mass.createSubMatrix(pressure, pressure)
        pc = ksp.getPC()
        pc.setType("fieldsplit")
        pc.setFieldSplitIS(("primal", primal), ("pressure", pressure))
        pc.setFieldSplitType(PETSc.PC.CompositeType.SCHUR)
        pc.setFieldSplitSchurFactType(PETSc.PC.SchurFactType.FULL)
        pc.setFieldSplitSchurPreType(PETSc.PC.SchurPreType.USER, self._schur_pre)
        ksp.setUp()
        primal_ksp, schur_ksp = pc.getFieldSplitSubKSP()
        primal_ksp.setType("preonly")
        amg = primal_ksp.getPC()
        amg.setType(self.config.amg)
        if self.config.amg == "hypre":
            amg.setHYPREType("boomeramg")
        import os  # WIP: options of the AMG cycles from the environment, to measure
        if os.environ.get("AMG_OPTS"):
            opts = PETSc.Options()
            for item in os.environ["AMG_OPTS"].split():
                key, _, value = item.partition("=")
                opts[key] = value
            primal_ksp.setOptionsPrefix("primal_")
            amg.setFromOptions()
        schur_ksp.setType("preonly")
        if self.reaction is None:
            schur_ksp.getPC().setType("jacobi")
        else:
            viscosity = float(problem.scene.fluid.mu)  # (+ μ_r with micro-rotation: not yet)
            mass = pressure_mass_matrix(problem).createSubMatrix(pressure, pressure)
            laplace = pressure_laplace_matrix(problem).createSubMatrix(pressure, pressure)
            self._cc = _CahouetChabard(self, mass, laplace, viscosity, self.config.amg, comm)
            bc = problem.solid_pressure_condition(problem.space)
            if bc is not None:
                imap, bs = problem.space.W.dofmap.index_map, problem.space.W.dofmap.index_map_bs
                mine = np.sort(np.asarray(problem.space.dofs("pressure")).ravel())
                mine = mine[mine < imap.size_local * bs]
                dofs, ghosts = bc.dof_indices()
                self._cc.pinned = np.searchsorted(mine, np.asarray(dofs[:ghosts])).astype(np.int32)
            schur_pc = schur_ksp.getPC()
            schur_pc.setType("python")
            schur_pc.setPythonContext(self._cc)
        self._index_sets = (primal, pressure)

    def _mumps_options(self):
        """MUMPS controls, set on the factor matrix (no options database, nothing left unused)."""
        pc = self.ksp.getPC()
        pc.setFactorSetUpSolverType()
        F = pc.getFactorMatrix()
        F.setMumpsIcntl(7, MUMPS_ORDERING[self.config.mumps_ordering])  # fill-reducing ordering
        F.setMumpsIcntl(14, 100)  # workspace relaxation (%)
        F.setMumpsIcntl(24, 1)  # null-pivot detection (pure-Dirichlet pressure)

    def reset(self) -> None:
        """Forget the operator (after a restore): the next :meth:`set_operator` configures anew."""
        self.A, self._configured = None, False

    def solve(self, b, x) -> None:
        """x = A⁻¹ b; with reuse, refactorise when GMRES does not converge in time."""
        ksp = self.ksp
        ksp.solve(b, x)
        self.solves += 1
        if not (self.iterative or self.reuse):  # preonly LU: a new operator is factorised at its first solve
            self.factorisations += int(self._factorise)
            self._factorise = False
            return
        self.max_krylov_iterations = max(self.max_krylov_iterations, ksp.getIterationNumber())
        if self.iterative:
            self.krylov_iterations += ksp.getIterationNumber()
            if ksp.getConvergedReason() <= 0:
                raise DivergenceError(f"solver.type iterative: FGMRES did not converge in {ksp.getIterationNumber()} "
                                      f"iterations (reason {ksp.getConvergedReason()}); try solver.type: direct")
            return
        self.krylov_iterations += ksp.getIterationNumber()
        if self.factorisations == 0 or ksp.getConvergedReason() <= 0:
            if self.factorisations > 0:  # the old factorisation no longer does: refactorise
                ksp.getPC().setReusePreconditioner(False)
                ksp.setOperators(self.A)
                x.set(0.0)  # a failed GMRES may have left NaN in the initial guess
                ksp.solve(b, x)
                ksp.getPC().setReusePreconditioner(True)
            self.factorisations += 1

    def counts(self) -> dict:
        """The run's linear solves (summary.json "linear_solver"): the solver, solves, factorisations and,
        for the Krylov modes, the iterations (total, mean and largest per solve)."""
        kind = ("iterative: FGMRES, fieldsplit Schur (AMG " + self.config.amg + ")" if self.iterative
                else "direct: MUMPS LU as GMRES preconditioner, refactorised when GMRES stalls" if self.reuse
                else "direct: MUMPS LU")
        return solve_counts(kind, self.solves, self.factorisations,
                            None if not (self.iterative or self.reuse) else self.krylov_iterations,
                            self.max_krylov_iterations)

    def converged_reason(self) -> int:
        return self.ksp.getConvergedReason()
