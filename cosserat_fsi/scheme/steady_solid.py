"""Steady scenes with a solid: the flag alone (CSM1/2) and steady fluid–structure interaction (FSI1).

One monolithic Newton solve on the *reference* mesh for velocity u (P2) × displacement d (P2) × pressure p (P1)
(physics/lagrangian.py): static equilibrium of the incompressible solid (Lagrangian, F = I + ∇d) on the solid
cells, steady Navier–Stokes pulled back to the cells moved by d on the fluid cells (ALE), u = 0 on the solid
and the harmonic extension of d on the fluid cells. The momentum test function is continuous across the
interface, so the fluid's traction loads the solid without an interface term; the geometry (the fluid
domain bent by the flag) is part of the Newton unknowns, so no fixed point over the geometry is needed.

Why monolithic rather than the seed's scheme marched to a steady state: the characteristics scheme's steady
state carries an O(δt) error and needs thousands of steps (FSI1: 1,500 steps, 331 s); a fixed point over
the geometry (fluid on a frozen mesh ↔ solid under the fluid's traction) needs a handful of fluid and solid
solves; the monolithic Newton converges quadratically in 5–7 factorisations.

After the solve the mesh is moved to X + d (the P1 vertex values of d), so observables, fields and energies
are evaluated on the deformed configuration as in a time-stepping run.
"""

from __future__ import annotations

import logging

from .. import compat
from ..physics import lagrangian
from .newton import Newton
from .spaces import MixedSpace
from .steady import SteadyMixin, steady_time
from .stepper import FLUID, SOLID, TAGS, Stepper

import dolfinx
import numpy as np
import ufl
from mpi4py import MPI

log = logging.getLogger("cosserat_fsi")

FIXED = ("inlet", "outlet", "walls", "cylinder", "clamp", "lid")  # d = 0 there (the channel and the clamp)


def displacement_space(mesh) -> MixedSpace:
    """velocity P2 × displacement P2 × pressure P1."""
    elements = {"velocity": compat.element(mesh, "Lagrange", 2, shape=(2,)),
                "displacement": compat.element(mesh, "Lagrange", 2, shape=(2,)),
                "pressure": compat.element(mesh, "Lagrange", 1)}
    W = compat.function_space(mesh, compat.mixed_element(elements.values()))
    names = tuple(elements)
    return MixedSpace(W=W, names=names, collapsed={n: compat.collapse(W.sub(i)) for i, n in enumerate(names)})


class SteadySolid(SteadyMixin, Stepper):
    """Static solid, or steady FSI, by Newton on the reference mesh (continuation in the load if needed)."""

    def acceleration(self, u):
        """The steady material acceleration (u·∇)u (observables: the residual forces on the moved mesh)."""
        return ufl.grad(u) * u

    def _forms(self):
        self.dx_inertia = ufl.dx(domain=self.mesh)
        self.space = sp = displacement_space(self.mesh)
        self.w = dolfinx.fem.Function(sp.W, name="state")
        # the state the run loop reads, on the collapsed spaces of this mixed space
        self.u_n = dolfinx.fem.Function(sp.space("velocity"), name="velocity")
        self.d_n = dolfinx.fem.Function(sp.space("displacement"), name="displacement")
        self.p_n = dolfinx.fem.Function(sp.space("pressure"), name="pressure")
        u, d, p = ufl.split(self.w)
        phi, psi, q = ufl.TestFunctions(sp.W)
        dx = ufl.dx(domain=self.mesh, subdomain_data=self.cell_tags)
        self.load = self._const(1.0)  # continuation parameter: fraction of the body force and convection
        F = lagrangian.solid_statics(d, p, phi, q, mu_s=self.mu_s, body_force=self.load * self.f, dx_solid=dx(SOLID))
        F = F + lagrangian.rest_and_extension(u, d, psi, dx_solid=dx(SOLID), dx_fluid=dx(FLUID))
        self.has_fluid_cells = bool(self.comm.allreduce(int(np.any(self.cell_tags.values == FLUID)), op=MPI.SUM))
        if self.has_fluid_cells:
            F = F + lagrangian.ale_navier_stokes(u, p, d, phi, q, rho=self.rho, mu=self.mu, body_force=self.f,
                                                 penalty=self.problem.penalty, dx_fluid=dx(FLUID), convection=self.load)
        self.residual = F
        self.newton = None
        self.a_form, self.L_form = None, compat.form(F)

    def _boundary_conditions(self):
        super()._boundary_conditions()  # velocity: inflow, no-slip (on this space: see _forms)
        sp = self.space
        Vd = sp.space("displacement")
        zero = dolfinx.fem.Function(Vd)
        present = [name for name in FIXED
                   if self.comm.allreduce(int(np.any(self.facet_tags.values == TAGS[name])), op=MPI.SUM)]
        facets = self.facets(*present)
        dofs = dolfinx.fem.locate_dofs_topological((sp.sub("displacement"), Vd), self.mesh.topology.dim - 1, facets)
        self.bcs.append(dolfinx.fem.dirichletbc(zero, dofs, sp.sub("displacement")))

    def _make_solver(self):
        return None

    def advance(self, before_move=None):
        """Solve the steady problem, then move the mesh to the deformed configuration and observe."""
        t = steady_time(self.scene)
        for update in self._updates:
            update(t)
        self.problem.update_sources(t)
        sp, w = self.space, self.w
        if self.newton is None:
            with self.timers("setup_newton"):
                tm = self.scene.time
                self.newton = Newton(self.residual, w, self.bcs, self.comm, compiled=self.L_form,
                                     max_iterations=tm.newton_max_iterations, rtol=tm.newton_rtol, name="newton")
        w.x.array[:] = 0.0
        self.newton.apply_bcs()
        initial = w.x.array.copy()
        with self.timers("newton"):
            report = self.newton.continuation(self.load, self.scene.time.newton_continuation, initial)
        for name, f in (("velocity", self.u_n), ("displacement", self.d_n), ("pressure", self.p_n)):
            f.x.array[:] = w.x.array[sp.dofs(name)]
        with self.timers("mesh_motion"):
            m = self.motion
            vertex = dolfinx.fem.Function(m.M)
            vertex.interpolate(self.d_n)
            m.displacement.x.array[:] = vertex.x.array
            m.place(vertex.x.array, t)
            self.chars.locator.update()
        self._finish(report, before_move)

