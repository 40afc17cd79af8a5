"""Newton's method on a UFL residual: MUMPS for each linear step, backtracking line search, continuation.

``Newton(residual, state, bcs)`` differentiates the residual form F(state; test) with UFL and solves
F = 0 from the current value of ``state``. The Dirichlet values are put into the state first, so every
correction vanishes on the Dirichlet dofs (no lifting is needed). The line search halves the step until
the residual is finite (``line_search=False``, PETSc's "basic"), or until its norm decreases (Armijo with
c = 1e-4, ``line_search=True``; the norm mixes equations of different units, so a full step that raises it
may still be the right one: the solid's first step raises it 2000-fold and converges in four more). ``continuation``
solves a sequence of problems, each from the solution of the previous one, by setting a ``Constant``
(the fraction of the convection or of the load) to the given values.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass, field

import numpy as np

from .. import compat
from .linear_solver import solve_counts

import dolfinx.fem.petsc as fem_petsc
import ufl
from petsc4py import PETSc

log = logging.getLogger("cosserat_fsi")


@dataclass
class NewtonReport:
    """What a Newton solve did: convergence, iterations and the residual history (one entry per iterate)."""

    converged: bool = False
    iterations: int = 0
    history: list = field(default_factory=list)  # dicts: stage, iteration, residual, relative, step
    stages: list = field(default_factory=list)  # continuation values that were solved
    wall: float = 0.0
    message: str = ""

    def as_dict(self) -> dict:
        return {"converged": self.converged, "iterations": self.iterations, "stages": self.stages,
                "wall": self.wall, "message": self.message, "history": self.history}


class Newton:
    """F(state) = 0 by Newton's method with a direct solver (MUMPS) and a backtracking line search."""

    def __init__(self, residual, state, bcs, comm, *, compiled=None, jacobian=None, max_iterations: int = 25,
                 rtol: float = 1e-10, atol: float = 1e-300, max_halvings: int = 8, name: str = "newton",
                 line_search: bool = False, stol: float = 1e-10, linear_solver=None, preconditioning=None):
        """``linear_solver``: a :class:`~.linear_solver.LinearSolver` for the linear steps (e.g. the
        iterative one); default MUMPS on a KSP of its own. ``preconditioning``: a bilinear form added to the
        Jacobian in the matrix the linear solver builds its preconditioner from (the Krylov solve keeps J)."""
        self.state, self.bcs, self.comm, self.name = state, bcs, comm, name
        self.linear_solver = linear_solver
        self.F = compiled if compiled is not None else compat.form(residual)
        jacobian = jacobian if jacobian is not None else ufl.derivative(residual, state)
        self.J = compat.form(jacobian)
        self.max_iterations, self.rtol, self.atol, self.max_halvings = max_iterations, rtol, atol, max_halvings
        self.line_search, self.stol = line_search, stol
        self.A = fem_petsc.assemble_matrix(self.J, bcs=bcs)
        self.A.assemble()
        self.J_pc = self.P = None
        if preconditioning is not None:
            self.J_pc = compat.form(jacobian + preconditioning)
            self.P = fem_petsc.assemble_matrix(self.J_pc, bcs=bcs)
            self.P.assemble()
        self.b = compat.create_vector(self.F, state.function_space)
        self.delta = self.b.duplicate()
        self.x = compat.petsc_vec(state)
        self.ksp = ksp = PETSc.KSP().create(comm)
        ksp.setType("preonly")
        ksp.getPC().setType("lu")
        ksp.getPC().setFactorSolverType("mumps")
        ksp.setOperators(self.A)
        self._mumps = False
        self.solves = 0  # with its own MUMPS: each solve follows a new Jacobian (a factorisation)

    # --------------------------------------------------------------------------------- pieces
    def apply_bcs(self):
        """Put the Dirichlet values into the state."""
        fem_petsc.set_bc(self.x, self.bcs)
        self.x.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)

    def residual_norm(self) -> float:
        """Assemble F(state) into ``self.b`` (zero on the Dirichlet dofs when the state satisfies them)."""
        b = self.b
        with b.localForm() as loc:
            loc.set(0.0)
        fem_petsc.assemble_vector(b, self.F)
        b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        fem_petsc.set_bc(b, self.bcs, self.x, -1.0)
        return b.norm()

    def _jacobian(self):
        self.A.zeroEntries()
        fem_petsc.assemble_matrix(self.A, self.J, bcs=self.bcs)
        self.A.assemble()
        if self.linear_solver is not None:
            if self.P is not None:
                self.P.zeroEntries()
                fem_petsc.assemble_matrix(self.P, self.J_pc, bcs=self.bcs)
                self.P.assemble()
            self.linear_solver.set_operator(self.A, self.P)
            return
        self.ksp.setOperators(self.A)
        if not self._mumps:
            pc = self.ksp.getPC()
            pc.setFactorSetUpSolverType()
            F = pc.getFactorMatrix()
            F.setMumpsIcntl(14, 200)  # workspace relaxation (%)
            F.setMumpsIcntl(24, 1)  # null-pivot detection
            self._mumps = True

    def counts(self) -> dict:
        """The linear solves of this Newton's iterations (LinearSolver.counts)."""
        if self.linear_solver is not None:
            return self.linear_solver.counts()
        return solve_counts("direct: MUMPS LU", self.solves, self.solves, None, 0)

    def _set(self, x0, step: float):
        """state = x0 − step·δ."""
        x0.copy(self.x)
        self.x.axpy(-step, self.delta)
        self.x.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)

    # --------------------------------------------------------------------------------- solves
    def solve(self, report: NewtonReport | None = None, stage=None, reference: float | None = None) -> NewtonReport:
        """Newton iterations from the current state. Converged when |F| ≤ rtol·reference (reference: the
        first residual, or the one given) or |F| ≤ atol, or when a full step changes the state by less
        than ``stol`` of its size (the residual at round-off: stresses of 1e5 Pa leave |F| ≈ 1e-9 |F₀|)."""
        report = report if report is not None else NewtonReport()
        t0 = time.perf_counter()
        self.apply_bcs()
        norm = self.residual_norm()
        ref = reference if reference else max(norm, 1e-300)
        x0 = self.x.duplicate()
        converged = False
        for it in range(self.max_iterations + 1):
            entry = {"stage": stage, "iteration": it, "residual": float(norm), "relative": float(norm / ref)}
            report.history.append(entry)
            if not np.isfinite(norm):
                report.message = f"non-finite residual at iteration {it}"
                break
            if norm <= self.rtol * ref or norm <= self.atol:
                converged = True
                log.info("%s%s: |F| = %.3e (relative %.2e), converged in %d iterations", self.name,
                         "" if stage is None else f" [{stage:g}]", norm, norm / ref, it)
                break
            if it == self.max_iterations:
                report.message = f"no convergence in {self.max_iterations} iterations"
                break
            self._jacobian()  # self.b holds F at the current state
            if self.linear_solver is not None:
                self.linear_solver.solve(self.b, self.delta)
            else:
                self.ksp.solve(self.b, self.delta)
                self.solves += 1
            self.x.copy(x0)
            step, trial = 1.0, np.inf
            for k in range(self.max_halvings + 1):
                self._set(x0, step)
                trial = self.residual_norm()
                if np.isfinite(trial) and (not self.line_search or trial <= (1.0 - 1e-4 * step) * norm):
                    break
                if k < self.max_halvings:
                    step *= 0.5
            if not np.isfinite(trial):
                self._set(x0, 0.0)
                report.message = f"line search found no finite residual at iteration {it + 1}"
                norm = self.residual_norm()
                break
            small = self.delta.norm() * step <= self.stol * max(self.x.norm(), 1e-300)
            entry["step"] = step
            krylov = ""
            if self.linear_solver is not None and self.linear_solver.iterative:
                entry["krylov_iterations"] = self.linear_solver.ksp.getIterationNumber()
                krylov = f", {entry['krylov_iterations']} FGMRES iterations"
            log.info("%s%s it %d: |F| = %.3e (relative %.2e), step %.3g%s", self.name,
                     "" if stage is None else f" [{stage:g}]", it + 1, trial, trial / ref, step, krylov)
            norm = trial
            report.iterations += 1
            if small and step == 1.0:
                report.history.append({"stage": stage, "iteration": it + 1, "residual": float(norm),
                                       "relative": float(norm / ref)})
                converged = True
                log.info("%s: the step is below %.0e of the state (|F| = %.3e): converged", self.name, self.stol, norm)
                break
        self.state.x.scatter_forward()
        report.converged = converged
        report.wall += time.perf_counter() - t0
        return report

    def continuation(self, scale, values, initial: np.ndarray, stokes_first: bool = False) -> NewtonReport:
        """Newton at scale = 1 from ``initial``; if that fails, from ``initial`` again through scale 0 (the
        Stokes solution of a flow, one linear solve) and then ``values``. ``stokes_first``: start Newton from
        the Stokes solution (one linear solve; the relative residual stays that of ``initial``)."""
        report = NewtonReport()
        scale.value = 1.0
        reference = None
        if stokes_first:
            self.apply_bcs()
            reference = self.residual_norm()
            scale.value, limit, self.max_iterations = 0.0, self.max_iterations, 1
            self.solve(report, stage=0.0, reference=reference)
            self.max_iterations, scale.value, report.message = limit, 1.0, ""
            report.stages = [0.0]
        self.solve(report, stage=1.0, reference=reference)
        report.stages.append(1.0)
        if reference is None:
            reference = report.history[0]["residual"] if report.history else None
        if report.converged or list(values) in ([], [1.0]):
            return report
        log.info("%s: no convergence at full scale (%s); continuation through 0 (Stokes/unloaded), %s", self.name,
                 report.message, ", ".join(f"{v:g}" for v in values))
        self.state.x.array[:] = initial
        for value in [0.0, *values]:  # from the Stokes iterate (or the unloaded state): then each fraction
            scale.value = value
            report.stages.append(value)
            report.converged = False
            report.message = ""
            self.solve(report, stage=value, reference=reference)
            if not report.converged:
                break
        return report

