"""Steady scenes solved as steady problems (``time.scheme: steady``): Newton on the equations without ∂/∂t.

Navier–Stokes and micropolar scenes: the residual of seed eqs. (31)–(32) with the convective acceleration
ρ (u·∇)u in the momentum equation and ρI (u·∇)ω in the micro-rotation equation (∂/∂t = 0), given to the
scene's :class:`~.problem.Problem` residual as its material accelerations. Newton starts from the rest
state with the boundary data, so its first iterate is the Stokes solution; when it does not converge, a
continuation in the convection (the Reynolds number) follows (``time.newton_continuation``).

Scenes with a solid (CSM, FSI): :mod:`.steady_solid` (Lagrangian statics, monolithic ALE for FSI).

A steady solve is one "step" of the run loop: :meth:`SteadyFluid.advance` solves, fills u^n, ω^n, p^n
(so observables, outputs and checkpoints work unchanged) and calls ``before_move``. A Newton that does
not converge keeps the last iterate as the state, and the runner writes it and exits with code 3.
"""

from __future__ import annotations

import logging

from .. import compat
from ..errors import DivergenceError
from .newton import Newton, NewtonReport
from .stepper import Stepper

import ufl

log = logging.getLogger("cosserat_fsi")


def make_stepper(scene, mesh, cell_tags, facet_tags, comm, exact=None):
    """The stepper of a scene: time stepping, or the steady solver of its kind."""
    if scene.time.scheme != "steady":
        return Stepper(scene, mesh, cell_tags, facet_tags, comm, exact=exact)
    if scene.has_solid:
        from .steady_solid import SteadySolid

        return SteadySolid(scene, mesh, cell_tags, facet_tags, comm, exact=exact)
    return SteadyFluid(scene, mesh, cell_tags, facet_tags, comm, exact=exact)


def steady_time(scene) -> float:
    """The time at which the boundary data and sources are evaluated: after every ramp."""
    ramps = [scene.time.t_end]
    if scene.inflow is not None:
        ramps.append(scene.inflow.ramp_time)
    if scene.solid is not None:
        ramps.append(scene.solid.gravity_ramp_time)
    return max(ramps)


class SteadyMixin:
    """The run-loop face of a steady solver: one step, a Newton report, failure recorded for the runner."""

    steady = True  # observables: the momentum residual's inertia is the convective acceleration
    failure: str | None = None
    report: NewtonReport | None = None

    def _finish(self, report: NewtonReport, before_move):
        self.report = report
        self.t = steady_time(self.scene)
        self.step_count += 1
        if before_move is not None:
            before_move()
        if not report.converged:
            last = report.history[-1] if report.history else {}
            self.failure = (f"Newton did not converge ({report.message}; last |F| = "
                            f"{last.get('residual', float('nan')):.3e}, relative {last.get('relative', float('nan')):.2e}); "
                            f"the last iterate and the residual history are written")

    def check(self):
        """Raise DivergenceError (exit 3) if the solve failed; called by the runner after the outputs."""
        if self.failure:
            raise DivergenceError(self.failure)


class SteadyFluid(SteadyMixin, Stepper):
    """Steady Navier–Stokes (and micropolar) flow by Newton on the mixed u (× ω) × p space."""

    def acceleration(self, u):
        """The steady material acceleration (u·∇)u = grad(u) u, times the continuation parameter."""
        return self.convection * ufl.grad(u) * u

    def _forms(self):
        """F(w; test) = the problem's residual with the accelerations (u·∇)u and (u·∇)ω (seed eqs. 31–32)."""
        pr, w = self.problem, self.w
        self.convection = self._const(1.0)  # continuation parameter (the Reynolds number's fraction)
        self.dx_inertia = ufl.dx(domain=self.mesh)  # the observables' residual forces use it too
        u, _, omega = pr.split(w)
        micro = self.convection * ufl.dot(u, ufl.grad(omega)) if omega is not None else None
        self.residual = pr.residual(w, ufl.TestFunctions(pr.space.W), acceleration=self.acceleration(u),
                                    micro_acceleration=micro)
        self.newton = None
        self.a_form, self.L_form = None, compat.form(self.residual)

    def _make_solver(self):
        return None

    def advance(self, before_move=None):
        """Solve the steady equations (Newton from the initial state, continuation if needed)."""
        t = steady_time(self.scene)
        for update in self._updates:
            update(t)
        self.problem.update_sources(t)
        sp, w = self.space, self.w
        if self.newton is None:
            with self.timers("setup_newton"):
                tm = self.scene.time
                self.newton = Newton(self.residual, w, self.bcs, self.comm, compiled=self.L_form, max_iterations=tm.newton_max_iterations,
                                     rtol=tm.newton_rtol, name="newton")
        w.x.array[sp.dofs("velocity")] = self.u_n.x.array
        w.x.array[sp.dofs("pressure")] = self.p_n.x.array
        if self.model.micro_rotation:
            w.x.array[sp.dofs("micro_rotation")] = self.omega_n.x.array
        self.newton.apply_bcs()
        initial = w.x.array.copy()
        with self.timers("newton"):
            report = self.newton.continuation(self.convection, self.scene.time.newton_continuation, initial)
        self.u_n.x.array[:] = w.x.array[sp.dofs("velocity")]
        self.p_n.x.array[:] = w.x.array[sp.dofs("pressure")]
        if self.model.micro_rotation:
            self.omega_n.x.array[:] = w.x.array[sp.dofs("micro_rotation")]
        self._finish(report, before_move)
