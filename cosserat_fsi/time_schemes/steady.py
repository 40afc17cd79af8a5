"""Steady scenes solved as steady problems (``time.scheme: steady``): Newton on the equations without ∂/∂t.

Navier–Stokes and micropolar scenes: the residual of seed eqs. (31)–(32) with the convective acceleration
ρ (u·∇)u in the momentum equation and ρI (u·∇)ω in the micro-rotation equation (∂/∂t = 0), given to the
scene's :class:`~.problem.Problem` residual as its material accelerations. Newton starts from the rest
state with the boundary data; when it does not converge, a continuation in the convection (the Reynolds
number) follows: from the Stokes solution (convection 0, one linear solve) through the fractions of
``time.newton_continuation`` (a developed Poiseuille flow is its own Stokes solution: any Reynolds number).

Scenes with a solid (CSM, FSI): :mod:`.steady_solid` (Lagrangian statics, monolithic ALE for FSI); the
scheme registry (schemes.py) picks one of the two.

A steady solve is one "step" of the run loop: :meth:`SteadyStepper.advance` solves, fills the State
(so observables, outputs and checkpoints work unchanged) and calls ``observe``. A Newton that does
not converge keeps the last iterate as the state, and the runner writes it and exits with code 3.
"""

from __future__ import annotations

import logging

from .. import compat
from ..errors import DivergenceError
from ..points.location import PointLocator
from ..problem.boundary import steady_time
from ..solvers.linear_solver import LinearSolver, resolved_type
from ..solvers.newton import Newton, NewtonReport
from ..solvers.oseen_preconditioner import streamline_diffusion

import dolfinx
import ufl
from petsc4py import PETSc

log = logging.getLogger("cosserat_fsi")


class SteadyStepper:
    """The run-loop face of a steady solver (the Simulation's scheme, time_step.py's interface): one step, a
    Newton report, failure recorded for the runner. Subclasses build ``space``, ``solution``, ``residual``
    and ``_solve``."""

    failure: str | None = None
    report: NewtonReport | None = None
    ITERATIVE = False  # takes solver.type: iterative (else MUMPS whatever the scene says)
    linear_kind = "direct"  # solver.type resolved for this scene (create): "direct" or "iterative"
    RATES = False

    @staticmethod
    def levels(time) -> int:
        return 1

    @classmethod
    def create(cls, problem, state, boundary, motion, timers, comm):
        return cls(problem, state, boundary, motion, timers, comm)

    def __init__(self, problem, state, boundary, motion, timers, comm):
        self.problem, self.state, self.boundary, self.motion = problem, state, boundary, motion
        self.timers, self.comm = timers, comm
        self.scene, self.mesh = problem.scene, problem.mesh
        self.dx_inertia = ufl.dx(domain=self.mesh)  # the observables' residual forces use it too
        self.locator = PointLocator(self.mesh)
        self.newton = None

    def constant(self, value):
        return dolfinx.fem.Constant(self.mesh, PETSc.ScalarType(value))

    def split_solution(self) -> tuple:
        """(u, p, ω or None) of the solution, as UFL expressions."""
        parts = ufl.split(self.solution)
        sp = self.space
        omega = parts[sp.index("micro_rotation")] if "micro_rotation" in sp.names else None
        return parts[sp.index("velocity")], parts[sp.index("pressure")], omega

    def convecting_velocity(self):
        """The velocity that convects, for the iterative solver's Schur approximation (None: no convection)."""
        return None

    def _newton(self):
        if self.newton is None:
            with self.timers("setup_newton"):
                tm = self.scene.time
                linear = preconditioning = None
                if self.ITERATIVE and self.linear_kind == "iterative":
                    linear = LinearSolver(self.scene.solver, self.comm, problem=self.problem, steady=True)
                    linear.convecting_velocity = w = self.convecting_velocity()
                    if w is not None:  # the AMG's velocity block with a streamline diffusion
                        W = self.space.W
                        du, v = self.problem.split(ufl.TrialFunction(W))[0], self.problem.split(ufl.TestFunction(W))[0]
                        preconditioning = streamline_diffusion(self.problem, w, du, v)
                self.newton = Newton(self.residual, self.solution, self.boundary.bcs, self.comm,
                                     compiled=self.compiled, max_iterations=tm.newton_max_iterations,
                                     rtol=tm.newton_rtol, name="newton", linear_solver=linear,
                                     preconditioning=preconditioning)
        return self.newton

    def advance(self, observe=None) -> None:
        """Solve the steady equations at :func:`steady_time` and call ``observe()``."""
        t = steady_time(self.scene)
        self.boundary.update(t)
        self.problem.update_sources(t)
        report = self._solve(t)
        self.report = report
        self.state.t = t
        self.state.step_count += 1
        if observe is not None:
            observe()
        if not report.converged:
            last = report.history[-1] if report.history else {}
            residual, relative = last.get("residual", float("nan")), last.get("relative", float("nan"))
            self.failure = (f"Newton did not converge ({report.message}; last |F| = {residual:.3e}, "
                            f"relative {relative:.2e}); the last iterate and the residual history are written")

    def check(self) -> None:
        """Raise DivergenceError (exit 3) if the solve failed; called by the runner after the outputs."""
        if self.failure:
            raise DivergenceError(self.failure)

    def restored(self) -> None:
        """Nothing to rebuild: a steady solve starts from the state."""


class SteadyFluid(SteadyStepper):
    """Steady Navier–Stokes (and micropolar) flow by Newton on the mixed u (× ω) × p space."""

    ITERATIVE = True

    @classmethod
    def create(cls, problem, state, boundary, motion, timers, comm):
        kind, why = resolved_type(problem.scene.solver, problem, steady=True)
        log.info("steady: Newton on the steady equations (convection (u.grad)u%s), %s",
                 ", (u.grad)omega" if problem.model.micro_rotation else "",
                 "FGMRES" if kind == "iterative" else "MUMPS")
        if problem.scene.solver.type == "auto":
            log.info(why)
        stepper = cls(problem, state, boundary, motion, timers, comm)
        stepper.linear_kind = kind
        return stepper

    def __init__(self, problem, state, boundary, motion, timers, comm):
        super().__init__(problem, state, boundary, motion, timers, comm)
        self.space = problem.space
        self.solution = dolfinx.fem.Function(self.space.W, name="state")
        self.convection = self.constant(1.0)  # continuation parameter (the Reynolds number's fraction)
        u, _, omega = problem.split(self.solution)
        micro = None
        if omega is not None:  # (u·∇)ω: u·grad ω for the 2D scalar, grad(ω) u for the 3D vector
            micro = self.convection * (ufl.dot(u, ufl.grad(omega)) if ufl.shape(omega) == () else ufl.grad(omega) * u)
        self.residual = problem.residual(self.solution, ufl.TestFunctions(self.space.W),
                                         acceleration=self.acceleration(u), micro_acceleration=micro)
        self.compiled = compat.form(self.residual)

    def convecting_velocity(self):
        """w of the steady (w·∇)u at the Newton iterate (the iterative solver's PCD Schur approximation)."""
        return self.convection * self.problem.split(self.solution)[0]

    def acceleration(self, u):
        """The steady material acceleration (u·∇)u = grad(u) u, times the continuation parameter."""
        return self.convection * ufl.grad(u) * u

    def _solve(self, t) -> NewtonReport:
        """Newton from the state (continuation if needed); the state takes the result."""
        newton = self._newton()
        self.state.to_mixed(self.solution, self.space)
        newton.apply_bcs()
        initial = self.solution.x.array.copy()
        with self.timers("newton"):
            report = newton.continuation(self.convection, self.scene.time.newton_continuation, initial,
                                         stokes_first=newton.linear_solver is not None)
        self.state.from_mixed(self.solution, self.space)
        return report
