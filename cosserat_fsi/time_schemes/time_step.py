"""What every time-stepping scheme shares: the step's forms, their assembly, the solve and its check.

A scheme (characteristics.py, ale_bdf.py, generalized_alpha.py; steady.py for the steady solvers) is one
class behind the interface the loop (Simulation) calls:

- ``create(problem, state, boundary, motion, timers, comm)``: the scheme of a scene, with its histories and
  linear solver; ``levels(time)`` and ``RATES``: the earlier levels and the rates the State keeps (and so
  checkpoints);
- ``advance(observe)``: one step t^n → t^{n+1}, ``observe()`` called after the solve on the mesh solved on
  (a scheme implements ``_attempt()``, the solve of a step of size ``dt`` that leaves the state as it was,
  and ``_commit(observe)``; with ``time.tolerance`` an attempt the error control rejects is tried again
  with a smaller step, time_control.py);
- ``acceleration(u)``: the scheme's material acceleration (the residual forces of the observables),
  ``dx_inertia``, ``split_solution()``, ``solution``, ``space``, ``locator``;
- ``restored()`` after a restore or a remesh, ``check()`` after the run, ``report`` (Newton's, steady).

Each scheme tells the physics only its time-discrete inertia: the forms are Problem.residual (seed eqs.
31–32) with the acceleration (α u − α h)/δt, plus the solid terms linearised by eq. (28) around d*.
"""

from __future__ import annotations

import numpy as np
from mpi4py import MPI

from .. import compat
from ..errors import DivergenceError
from ..timers import Timers
from ..solvers.linear_solver import LinearSolver
from .time_control import TimeControl

import dolfinx
import dolfinx.fem.petsc as fem_petsc
import ufl
from petsc4py import PETSc


def bdf_rate(f, history, alpha, inv_dt):
    """(α f − α h)/δt: the time derivative of ``f`` with the history α h (``history``)."""
    return (alpha * f - history) * inv_dt


class TimeStep:
    """The shared part of a time-stepping scheme (module docstring). Subclasses set ``histories`` (α h and
    the inertia measure), build ``a_form``/``L_form`` with :meth:`_forms` and implement ``advance``."""

    RATES = False  # the State keeps u̇, ω̇, ḋ (generalised-α)
    ORDER = 0  # the order of accuracy in δt (0: that of ``levels``)
    NODAL_CONVECTION = False  # the convection is in the matrix (the matrix changes every step)
    report = None  # a Newton report (steady solvers)

    @staticmethod
    def levels(time) -> int:
        """How many time levels of u the State keeps (2: u^n and u^{n−1} are both used)."""
        return 2

    @classmethod
    def histories_for(cls, problem, motion, comm):
        raise NotImplementedError

    @classmethod
    def create(cls, problem, state, boundary, motion, timers, comm):
        """The scheme of ``problem.scene`` with its histories and linear solver."""
        scene = problem.scene
        solver = LinearSolver(scene.solver, comm, problem=problem,
                              reuse_factorization=scene.solver.reuses_factorization(motion is not None,
                                                                                    cls.NODAL_CONVECTION),
                              refactorised=motion is not None or cls.NODAL_CONVECTION)
        return cls(problem, state, boundary, cls.histories_for(problem, motion, comm), solver, motion, timers,
                   comm)

    def __init__(self, problem, state, boundary, histories, solver, motion=None, timers: Timers | None = None,
                 comm=MPI.COMM_WORLD):
        scene = problem.scene
        self.problem, self.state, self.boundary, self.histories = problem, state, boundary, histories
        self.solver, self.motion, self.comm = solver, motion, comm
        self.timers = timers if timers is not None else Timers()
        self.dt = float(scene.time.dt)  # the size of the step being taken
        self.control = TimeControl.of(scene.time, self.ORDER if self.ORDER else self.levels(scene.time), comm)
        self.fixed_step = self.control is None  # every step time.dt (t^n = nδt)
        self.correction_time = (None if self.control is None
                                else dolfinx.fem.Constant(problem.mesh, PETSc.ScalarType(self.dt)))
        mesh = problem.mesh
        self.alpha = dolfinx.fem.Constant(mesh, PETSc.ScalarType(1.0))
        self.inv_dt = dolfinx.fem.Constant(mesh, PETSc.ScalarType(1.0 / self.dt))
        self.solid_dt = dolfinx.fem.Constant(mesh, PETSc.ScalarType(self.dt))  # k of d = d* + k u (eq. 28)
        # the solid terms are linearised around d* (eq. 28)
        self.d_star = dolfinx.fem.Function(state.displacement.function_space) if problem.model.solid else None
        self.solution = dolfinx.fem.Function(problem.space.W, name="state")
        self.A = None
        self.u_old = self.omega_old = None  # u^n, ω^n of the step where the stresses are evaluated between levels

    # ------------------------------------------------------------------------ the interface
    def advance(self, observe=None, dt: float | None = None) -> None:
        """One step t^n → t^{n+1} (module docstring): of size ``dt`` if given (the controller is not asked),
        else with ``time.tolerance`` the step size the controller proposes, attempted until its error estimate
        is accepted (a non-finite solution, or a mesh motion that fails, counts as a rejection), else
        ``time.dt``; ``observe()`` after the solve, on the mesh solved on."""
        control = self.control
        if dt is not None:
            self.dt, self.fixed_step = float(dt), False
        if control is None or dt is not None:
            self._attempt()
            self._commit(observe)
            return
        while True:
            self.dt = control.proposal(self.state)
            try:
                self._attempt()
                error = control.error(self)
                if self.control.accepts(error):  # to be accepted: can the mesh follow it?
                    self.check_motion()
            except DivergenceError as exc:
                error, failure = np.inf, exc
            else:
                failure = None
            if control.judge(self.state, self.dt, error, failure):
                break
            self._rejected()
        self._commit(observe)

    def check_motion(self) -> None:
        """Before an attempted step is accepted: DivergenceError (a rejection) if the mesh cannot follow it
        (the solid at a wall, a cell inverted); the BDF steps check it, generalised-α moves the mesh only
        once the step is accepted (such a step then stops the run)."""

    def _time_after_step(self) -> float:
        """t^{n+1}: (n + 1)δt with a fixed step (no accumulated rounding), else t^n + δt."""
        if self.fixed_step:
            return (self.state.step_count + 1) * self.dt
        if self.control is None:
            return self.state.t + self.dt
        return self.control.time_after(self.state, self.dt)

    def _rejected(self) -> None:
        """After a rejected attempt: the mesh back at Ω^n (the next attempt places it where it solves)."""
        if self.motion is not None:
            m = self.motion
            m.planned = None
            m.place(m.displacement.x.array, self.state.t)
            self.histories.mesh_moved(rebuild=False)

    @property
    def space(self):
        return self.problem.space

    def split_solution(self) -> tuple:
        """(u, p, ω or None) of the solution, as UFL expressions."""
        return self.problem.split(self.solution)

    @property
    def dx_inertia(self):
        return self.histories.dx_inertia

    @property
    def locator(self):
        """The point locator of the current mesh."""
        return self.histories.locator

    def check(self) -> None:
        """Nothing to report after the run: a time step that fails raises at once."""

    def acceleration(self, u):
        """The material acceleration of u (the step's, with u the solution: residual forces)."""
        return self._convected(self._at(u, self.u_old),
                               bdf_rate(u, self.histories.velocity, self.alpha, self.inv_dt))

    def restored(self) -> None:
        """After ``state.restore`` (or a remesh): the mixed solution (the Krylov initial guess), the mesh, the
        locators, and a fresh matrix."""
        self.state.to_mixed(self.solution, self.problem.space)
        if self.motion is not None:  # the mesh: reference + displacement
            m = self.motion
            self.problem.mesh.geometry.x[:, :m.dim] = m.X0 + m.displacement.x.array.reshape(-1, m.dim)[m.node_dof]
            self.histories.relocate(m, self.state)
        self.A = None
        self.solver.reset()

    # ------------------------------------------------------------------ what a scheme varies
    def _at(self, f, old):
        """Where the stresses are evaluated (generalised-α: between ``old`` = f^n and f); here at f."""
        return f

    def _convected(self, f, rate):
        """The material derivative from the rate of the histories (the nodal schemes add a convection)."""
        return rate

    def _evaluation(self, u, omega_at, d_predicted):
        """(the (u, ω) of the stresses or None, the continuity equation's divergence or None)."""
        return None, None

    def _volume_correction_step(self):
        """The time over which the solid's volume correction acts (None: ``solid_dt``; with ``time.tolerance``
        the first step's ``time.dt``, fixed: a correction undone in each step moves the solid by its area
        drift/δt, which does not fall with δt, and no step would meet the tolerance)."""
        return self.correction_time

    # --------------------------------------------------------------------------- the forms
    def _forms(self, d_predicted=None):
        """(matrix form, right-hand side form) of the step; ``d_predicted``: a corrector pass's forms."""
        pr, h = self.problem, self.histories
        trial, test = ufl.TrialFunctions(pr.space.W), ufl.TestFunctions(pr.space.W)
        u, _, omega = pr.split(trial)
        micro = omega_at = None
        if omega is not None:
            omega_at = self._at(omega, self.omega_old)
            micro = self._convected(omega_at, bdf_rate(omega, h.micro_rotation, self.alpha, self.inv_dt))
        at, divergence = self._evaluation(u, omega_at, d_predicted)
        F = pr.residual(trial, test, acceleration=self.acceleration(u), micro_acceleration=micro,
                        dx_inertia=h.dx_inertia, at=at, divergence=divergence)
        if pr.model.solid:
            F = F + pr.solid_residual(trial, test, self.d_star, self.solid_dt, d_predicted,
                                      step=self._volume_correction_step())
        return compat.form(ufl.lhs(F)), compat.form(ufl.rhs(F))

    # ------------------------------------------------------------------ assembly and solve
    def _reassemble(self, a_form):
        """Assemble ``a_form`` into the matrix (created at the first call) and hand it to the solver."""
        with self.timers("assemble_matrix"):
            bcs = self.boundary.bcs
            if self.A is None:
                self.A = fem_petsc.assemble_matrix(a_form, bcs=bcs)
            else:
                self.A.zeroEntries()
                fem_petsc.assemble_matrix(self.A, a_form, bcs=bcs)
            self.A.assemble()
            if self.problem.scene.fluid is not None:  # ρα/δt: the iterative solver's Schur preconditioner
                self.solver.reaction = (float(self.problem.scene.fluid.rho) * float(self.alpha.value)
                                        * float(self.inv_dt.value))
            self.solver.set_operator(self.A)

    def _vector(self, L_form=None, a_form=None):
        """Assemble the right-hand side (the step's, or ``L_form`` lifted with ``a_form``) into ``self.b``."""
        b, bcs = self.b, self.boundary.bcs
        with b.localForm() as loc:
            loc.set(0.0)
        fem_petsc.assemble_vector(b, self.L_form if L_form is None else L_form)
        fem_petsc.apply_lifting(b, [self.a_form if a_form is None else a_form], bcs=[bcs])
        b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        fem_petsc.set_bc(b, bcs)

    def _solve(self, t_new: float):
        """Solve for the step's solution (``self.b`` assembled); DivergenceError if it is not finite."""
        with self.timers("solve"):
            self.solver.solve(self.b, compat.petsc_vec(self.solution))
            self.solution.x.scatter_forward()
        bad = not np.isfinite(self.solution.x.array).all()
        reason = self.solver.converged_reason()
        if self.comm.allreduce(bad or reason < 0, op=MPI.LOR):
            raise DivergenceError(f"step {self.state.step_count + 1} (t = {t_new:.6g}): non-finite solution "
                                  f"(linear solver reason {reason}); try a smaller time.dt or a finer mesh")

    def _new_velocity(self) -> np.ndarray:
        """The velocity part of the solution, as an array of the velocity space."""
        return np.ravel(self.solution.x.array[self.problem.space.dofs("velocity")])
