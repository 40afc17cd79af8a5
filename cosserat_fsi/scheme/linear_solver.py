"""The linear solver of the monolithic system: MUMPS LU, or the last LU as a GMRES preconditioner.

On a fixed mesh the matrix is constant (per BDF coefficient), so one factorisation serves every step
(``preonly``). On a moving mesh, with ``solver.reuse_factorization``, GMRES is preconditioned by the last
factorisation and the matrix is refactorised only when GMRES does not converge within
``solver.max_krylov_iterations``. :meth:`LinearSolver.solve` may be called again with the same operator
(corrector passes) and reuses the factorisation. An iterative fieldsplit solver would be another
``kind`` behind the same three methods.
"""

from __future__ import annotations

from mpi4py import MPI
from petsc4py import PETSc

MUMPS_ORDERING = {"amd": 0, "pord": 4, "metis": 5, "auto": 7}


class LinearSolver:
    """``set_operator(A)`` after (re)assembly, ``solve(b, x)``; counts ``factorisations`` and
    ``krylov_iterations`` (GMRES reuse only) and exposes the PETSc ``ksp``."""

    def __init__(self, solver_config, comm=MPI.COMM_WORLD, reuse_factorization: bool = False):
        self.config, self.comm = solver_config, comm
        self.reuse = reuse_factorization
        self.factorisations = 0
        self.krylov_iterations = 0
        self.A = None
        self._configured = False
        ksp = self.ksp = PETSc.KSP().create(comm)
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
        self.ksp.setOperators(A)
        if not self._configured:
            self._mumps_options()
            self._configured = True

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
        if not self.reuse:
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

    def converged_reason(self) -> int:
        return self.ksp.getConvergedReason()
