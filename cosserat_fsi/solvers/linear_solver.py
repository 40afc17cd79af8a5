"""The linear solver of the monolithic system: MUMPS LU, the last LU as a GMRES preconditioner, or an
iterative block preconditioner (``solver.type: iterative``).

On a fixed mesh the matrix is constant (per BDF coefficient), so one factorisation serves every step
(``preonly``). On a moving mesh, with ``solver.reuse_factorization``, GMRES is preconditioned by the last
factorisation and the matrix is refactorised only when GMRES does not converge within
``solver.max_krylov_iterations``. :meth:`LinearSolver.solve` may be called again with the same operator
(corrector passes) and reuses the factorisation.

``solver.type: iterative``: FGMRES (relative tolerance ``solver.krylov_rtol`` on the unpreconditioned
residual, at most ``solver.max_iterations``) preconditioned by the fieldsplit Schur complement of
block_preconditioner.py (Cahouet–Chabard for a time step, PCD for a steady Newton step).

``solver.petsc_options``: PETSc options (without the leading dash) read after the defaults by every PETSc
object of the solver, under a prefix of its own: ``ksp_*``/``pc_*`` the outer solver,
``fieldsplit_primal_*`` the velocity (+ micro-rotation) block, ``fieldsplit_pressure_*`` the Schur
complement, ``mat_mumps_*`` the direct factorisation. An option that PETSc does not use by the end of the
first solve is an input error.
"""

from __future__ import annotations

import atexit
import functools
import itertools
import logging
import weakref

from mpi4py import MPI
from petsc4py import PETSc

from .. import compat
from ..errors import DivergenceError, InputError
from . import block_preconditioner

MUMPS_ORDERING = {"amd": 0, "pord": 4, "metis": 5, "auto": 7}
GAMG_THRESHOLD = 0.02
"""The velocity block's GAMG graph threshold: with PETSc's default (−1, no dropping) the iterations grow
with the mesh (2D-1: 25 / 59.5 / 146.5 per solve on L1/L2/L3), with 0.02 they stay flat (18.5 / 21 / 23.5)."""
STEADY_BOOMERAMG = {"fieldsplit_primal_pc_hypre_boomeramg_coarsen_type": "HMIS",
                    "fieldsplit_primal_pc_hypre_boomeramg_interp_type": "ext+i",
                    "fieldsplit_primal_pc_hypre_boomeramg_strong_threshold": 0.5}
"""BoomerAMG on a steady Newton step's velocity block (hypre's recommendation for 3D): on 3D-1Z level 1 the same
FGMRES iterations as the default Falgout coarsening (64 / 63 per solve), at half its time per solve; the
default's hierarchy did not fit 24 GB on level 2 (docs/perf_linear_solvers.md,
"Steady Newton: PCD with outflow conditions and a streamline-diffusion AMG")."""
RESIDUAL_SLACK, RESIDUAL_FLOOR = 10.0, 1e-8
"""An iterative solve is accepted when its true relative residual is at most max(RESIDUAL_SLACK x the Krylov
rtol, RESIDUAL_FLOOR): FGMRES's own estimate drifts from the true residual by rounding, 1.1e-9 against an rtol of
1e-10 after 189 iterations on the 3D flag (level 1); an option that stops the solve early leaves 1e-1 or more."""
AUTO_ITERATIVE_FROM = {"refactorised": 30_000, "kept": 500_000}
"""``solver.type: auto``: the 3D unknowns from which a time step takes the iterative solver. Where MUMPS
refactorises every step (the convection in the matrix, or a moving mesh without reuse): the measured tie of a
factorisation step with an iterative step (the 3D flag, 31,883 unknowns: 3.05 s against 3.19 s; MUMPS's step
grows like N^1.5, the iterative one like N^1.07). Where MUMPS keeps its factorisation (a fixed mesh, or reuse):
its memory (6.8 GB at 250k 3D unknowns, growing like N^1.1-1.2: 24 GB near 0.5-0.7 M); the same for a
steady Newton solve in 3D (MUMPS refactorises each Newton step, but is 10x faster than the iterative solve on
3D-1Z's level 0: memory decides), with BoomerAMG (GAMG does not converge a developed flow's velocity block).
In 2D MUMPS is taken at every size: 2-2.5x faster per step at every measured size with the same growth, and a
small 2D fill (docs/perf_linear_solvers.md, "Direct or iterative: `solver.type: auto`")."""
_PREFIXES = itertools.count()
log = logging.getLogger("cosserat_fsi")
_ITERATIVE: list[weakref.ref] = []  # the iterative solvers in the order of creation (their KSPs destroyed at exit)


@atexit.register
def _destroy_iterative_solvers() -> None:
    """Destroy the iterative solvers' KSPs while Python still runs: their Schur approximations are petsc4py
    ``python`` PCs, whose destruction calls back into Python; left to PetscFinalize, which runs after the
    interpreter has ended, it crashed the process at exit (SIGSEGV, exit code 59) after a completed run. In
    the order of creation, the same on every rank (a destruction may be collective)."""
    for ref in _ITERATIVE:
        solver = ref()
        if solver is not None:
            solver.ksp.destroy()


@functools.cache
def resolved_amg(amg: str) -> str:
    """``solver.amg``, with ``auto`` resolved: hypre BoomerAMG where this PETSc has it, else GAMG (the PETSc
    build is probed once per process)."""
    if amg == "gamg":
        return amg
    pc = PETSc.PC().create(MPI.COMM_SELF)
    try:
        pc.setType("hypre")
        return "hypre"
    except PETSc.Error:
        if amg == "hypre":
            raise InputError("solver.amg: this PETSc has no hypre (use gamg, or auto)") from None
        return "gamg"
    finally:
        pc.destroy()


def resolved_type(config, problem, steady: bool = False, refactorised: bool = True) -> tuple[str, str]:
    """``solver.type`` with ``auto`` resolved for ``problem`` (its unknowns and dimension) and for whether MUMPS
    would refactorise every step, and the run log's line saying why."""
    if config.type != "auto":
        return config.type, f"solver.type: {config.type}"
    if problem is None:
        return "direct", "solver.type auto: direct (MUMPS) (no problem to size)"
    unknowns, dim = problem.num_dofs()["total"], problem.mesh.geometry.dim
    if steady:  # MUMPS is 10x faster on 3D-1Z level 0; the iterative path converges with BoomerAMG only
        threshold = AUTO_ITERATIVE_FROM["kept"]
        if dim == 3 and unknowns >= threshold and resolved_amg(config.amg) == "hypre":
            return "iterative", (f"solver.type auto: iterative for steady Newton ({unknowns:,} unknowns in 3D, at "
                                 f"least {threshold:,}: MUMPS's memory)")
        return "direct", (f"solver.type auto: direct (MUMPS) for steady Newton ({unknowns:,} unknowns; iterative "
                          f"from {threshold:,} in 3D with BoomerAMG)")
    if dim == 2:
        return "direct", f"solver.type auto: direct (MUMPS) ({unknowns:,} unknowns: MUMPS at every size in 2D)"
    kind = "refactorised" if refactorised else "kept"
    threshold = AUTO_ITERATIVE_FROM[kind]
    what = "a factorisation every step" if refactorised else "a kept factorisation"
    if unknowns >= threshold:
        return "iterative", (f"solver.type auto: iterative ({unknowns:,} unknowns in 3D, at least {threshold:,} "
                             f"for {what})")
    return "direct", f"solver.type auto: direct (MUMPS) ({unknowns:,} unknowns in 3D, below {threshold:,} for {what})"


def solve_counts(kind: str, solves: int, factorisations: int, iterations: int | None, largest: int) -> dict:
    """summary.json's "linear_solver" record (``iterations`` None: a direct solve, no Krylov iterations)."""
    record = {"type": kind, "solves": int(solves), "factorisations": int(factorisations)}
    if iterations is not None:
        record["krylov_iterations"] = {"total": int(iterations), "mean": iterations / max(solves, 1),
                                       "max": int(largest)}
    return record


class LinearSolver:
    """``set_operator(A)`` after (re)assembly, ``solve(b, x)``; counts ``factorisations`` and
    ``krylov_iterations`` (GMRES reuse only) and exposes the PETSc ``ksp``."""

    def __init__(self, solver_config, comm=MPI.COMM_WORLD, reuse_factorization: bool = False, problem=None,
                 steady: bool = False, refactorised: bool = True):
        """``problem``: the scheme's Problem (its mixed space and viscosities); needed by ``type: iterative``
        and ``auto``; ``steady``: the solver of steady Newton; ``refactorised``: the matrix changes every step
        (``auto`` weighs a factorisation per step)."""
        self.config, self.comm = solver_config, comm
        kind, why = resolved_type(solver_config, problem, steady, refactorised and not reuse_factorization)
        if solver_config.type == "auto":
            log.info(why)
        self.iterative = kind == "iterative"
        if self.iterative:
            _ITERATIVE[:] = [ref for ref in _ITERATIVE if ref() is not None] + [weakref.ref(self)]
        self.amg = resolved_amg(getattr(solver_config, "amg", "auto"))
        self.reuse = reuse_factorization and not self.iterative
        self.factorisations = 0
        self.krylov_iterations = 0
        self.solves, self.max_krylov_iterations = 0, 0  # counts(): summary.json "linear_solver"
        self._factorise = False  # direct: the operator changed since the last factorisation
        self.schur_context = None  # block_preconditioner.CahouetChabard or PressureConvectionDiffusion
        self.convecting_velocity = None  # the steady Newton iterate's w in (w·∇)u (iterative: PCD)
        self.reaction = None  # ρα/δt of a time step (iterative: the Cahouet–Chabard Schur preconditioner)
        self.A = None
        self._residual, self.largest_residual = None, 0.0  # iterative: b − A x, its largest relative norm
        self._configured = self._checked = False
        self._inserted: list[str] = []  # the keys _insert_options put in the options database
        ksp = self.ksp = PETSc.KSP().create(comm)
        self.prefix = f"cosserat{next(_PREFIXES)}_"  # solver.petsc_options go under it
        ksp.setOptionsPrefix(self.prefix)
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

    def set_operator(self, A, P=None) -> None:
        """The matrix changed (values, same pattern): a direct solver refactorises at the next solve, the
        reusing one keeps its factorisation as the preconditioner. ``P``: the matrix the iterative solver's
        preconditioner is built from (default A)."""
        self.A = A
        self._factorise = True
        self.ksp.setOperators(A, P if P is not None else A)
        if self._configured and hasattr(self.schur_context, "update"):
            self.schur_context.update()  # PCD: F_p of the new iterate
        if not self._configured:
            self._insert_options()
            try:
                if self.iterative:
                    block_preconditioner.configure(self, self.ksp, self.problem, self.amg, self.comm)
                else:
                    self._mumps_options()
                    self.ksp.setFromOptions()
            except PETSc.Error as exc:
                raise self._rejected(exc) from None
            self._configured = True
            if self.iterative:
                log.info("iterative solver: FGMRES, fieldsplit Schur (%s), %s (solver.amg: %s)",
                         self._schur_name(), self._primal_name(), self.config.amg)

    def _insert_options(self) -> None:
        """The defaults that live in the options database, then the user's ``solver.petsc_options`` over them,
        under this solver's prefix."""
        options = {}
        if self.iterative and self.amg == "gamg":
            options["fieldsplit_primal_pc_gamg_threshold"] = GAMG_THRESHOLD
        if self.iterative and self.amg == "hypre" and self.convecting_velocity is not None:
            options.update(STEADY_BOOMERAMG)
        options.update(self.config.petsc_options)
        database = PETSc.Options()
        for key, value in options.items():
            database[self.prefix + key] = str(value).lower() if isinstance(value, bool) else str(value)
        self._inserted = list(options)

    def _remove_options(self) -> None:
        """The options :meth:`_insert_options` put in the database leave it."""
        database = PETSc.Options()
        for key in self._inserted:
            if database.hasName(self.prefix + key):
                database.delValue(self.prefix + key)

    def _rejected(self, exc: PETSc.Error) -> Exception:
        """A PETSc error while the solver reads its options or first solves: the user's options' fault
        (InputError) if there are any, else the error itself."""
        self._remove_options()
        if not self.config.petsc_options:
            return exc
        return InputError(f"solver.petsc_options: PETSc could not apply them (PETSc error code {exc.ierr}: a "
                          f"value of the wrong kind, or a type this PETSc does not have)")

    def _check_options(self) -> None:
        """InputError for the first of the user's options that PETSc has not used (after the first solve,
        when every object has read the database); then the options leave the database."""
        unused = [key for key in self.config.petsc_options if not compat.option_used(self.prefix + key)]
        self._remove_options()
        if unused:
            raise InputError(f"solver.petsc_options.{unused[0]}: PETSc did not use this option (not an option of "
                             f"the {'iterative' if self.iterative else 'direct'} solver's objects)")

    def _mumps_options(self):
        """MUMPS controls, set on the factor matrix (no options database, nothing left unused)."""
        pc = self.ksp.getPC()
        pc.setFactorSetUpSolverType()
        F = pc.getFactorMatrix()
        F.setOptionsPrefix(self.prefix)  # solver.petsc_options mat_mumps_* (read at the first factorisation)
        F.setMumpsIcntl(7, MUMPS_ORDERING[self.config.mumps_ordering])  # fill-reducing ordering
        F.setMumpsIcntl(14, 100)  # workspace relaxation (%)
        F.setMumpsIcntl(24, 1)  # null-pivot detection (pure-Dirichlet pressure)

    def reset(self) -> None:
        """Forget the operator (after a restore): the next :meth:`set_operator` configures anew."""
        self.A, self._configured, self._checked, self._residual = None, False, False, None

    def solve(self, b, x) -> None:
        """x = A⁻¹ b; with reuse, refactorise when GMRES does not converge in time."""
        ksp = self.ksp
        try:
            ksp.solve(b, x)
        except PETSc.Error as exc:
            if self._checked:
                raise
            raise self._rejected(exc) from None
        self.solves += 1
        if not self._checked:
            self._checked = True
            self._check_options()
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
            self._check_residual(b, x)
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

    def _check_residual(self, b, x) -> None:
        """DivergenceError unless the true residual ‖b − A x‖ / ‖b‖ is within ``RESIDUAL_SLACK`` times the
        Krylov tolerance in force (or ``RESIDUAL_FLOOR``): a solver.petsc_options override (``ksp_type:
        preonly``, a capped iteration count) that stops early without converging must not pass as a solution."""
        if self._residual is None:
            self._residual = self.A.createVecLeft()
        r = self._residual
        self.A.mult(x, r)
        r.aypx(-1.0, b)  # r = b - A x
        b_norm = b.norm()
        relative = r.norm() / b_norm if b_norm > 0 else 0.0
        self.largest_residual = max(self.largest_residual, relative)
        allowed = max(RESIDUAL_SLACK * self.ksp.getTolerances()[0], RESIDUAL_FLOOR)
        if not relative <= allowed:
            raise DivergenceError(f"solver.type iterative: the true relative residual {relative:.2e} exceeds "
                                  f"{allowed:.1e} after {self.ksp.getIterationNumber()} iterations; check "
                                  f"solver.petsc_options")

    def counts(self) -> dict:
        """The run's linear solves (summary.json "linear_solver"): the solver, solves, factorisations and,
        for the Krylov modes, the iterations (total, mean and largest per solve)."""
        kind = (f"iterative: FGMRES, fieldsplit Schur ({self._schur_name()}), {self._primal_name()}" if self.iterative
                else "direct: MUMPS LU as GMRES preconditioner, refactorised when GMRES stalls" if self.reuse
                else "direct: MUMPS LU")
        record = solve_counts(kind, self.solves, self.factorisations,
                              None if not (self.iterative or self.reuse) else self.krylov_iterations,
                              self.max_krylov_iterations)
        if self.iterative:
            record["largest_relative_residual"] = self.largest_residual  # ‖b − A x‖ / ‖b‖ over the solves
        return record

    def _schur_name(self) -> str:
        """The Schur preconditioner in force: the code's approximation, or the PETSc type a
        ``solver.petsc_options`` override put in its place."""
        names = {"CahouetChabard": "Cahouet-Chabard", "PressureConvectionDiffusion": "PCD"}
        used = self._sub_pc_types()
        if used is None or used[1] == "python" or (used[1] == "jacobi" and self.schur_context is None):
            return names.get(type(self.schur_context).__name__, "pressure mass")
        return f"PETSc {used[1]} (solver.petsc_options)"

    def _primal_name(self) -> str:
        """The velocity block's preconditioner in force: the AMG, or the PETSc type of an override."""
        used = self._sub_pc_types()
        if used is None or used[0] == self.amg:
            return f"velocity block by AMG {self.amg}"
        return f"velocity block by PETSc {used[0]} (solver.petsc_options)"

    def _sub_pc_types(self) -> tuple[str, str] | None:
        """The fieldsplit's (velocity, Schur) PC types once configured, else None."""
        if not (self.iterative and self._configured):
            return None
        primal, schur = self.ksp.getPC().getFieldSplitSubKSP()
        return primal.getPC().getType(), schur.getPC().getType()

    def converged_reason(self) -> int:
        return self.ksp.getConvergedReason()
