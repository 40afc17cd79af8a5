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
from ..errors import DivergenceError, InputError
from ..physics import lagrangian
from ..tags import FLUID, SOLID
from ..problem.boundary import BoundaryConditions
from ..problem.spaces import MixedSpace
from .steady import SteadyStepper

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


class SteadySolid(SteadyStepper):
    """Static solid, or steady FSI, by Newton on the reference mesh (continuation in the load if needed)."""

    @classmethod
    def create(cls, problem, state, boundary, motion, timers, comm):
        if problem.scene.has_fluid and problem.model.micro_rotation:
            raise InputError("time.scheme: steady is not available for a solid in a micropolar fluid (the "
                             "steady solid solve has no micro-rotation); use a time-stepping scheme")
        slip = problem.slip_boundaries()
        if slip:
            raise InputError(f"boundaries.{slip[0]}: type slip is not available with time.scheme: steady for a "
                             "scene with a solid (its Lagrangian solve has no slip terms); use a time-stepping scheme")
        log.info("steady: one Newton solve for velocity, displacement and pressure on the reference mesh "
                 "(static solid%s)", ", ALE fluid" if problem.scene.has_fluid else "")
        return cls(problem, state, boundary, motion, timers, comm)

    def __init__(self, problem, state, boundary, motion, timers, comm):
        super().__init__(problem, state, boundary, motion, timers, comm)
        mesh, pr = self.mesh, problem
        self.space = sp = displacement_space(mesh)
        self.solution = dolfinx.fem.Function(sp.W, name="state")
        # the boundary data of the scene on this space (velocity: inflow, no-slip), d = 0 on the fixed walls
        self.boundary = BoundaryConditions(pr, comm, space=sp)
        Vd = sp.space("displacement")
        present = [name for name in FIXED if name in pr.facet_ids
                   and comm.allreduce(int(np.any(pr.facet_tags.values == pr.facet_ids[name])), op=MPI.SUM)]
        dofs = dolfinx.fem.locate_dofs_topological((sp.sub("displacement"), Vd), mesh.topology.dim - 1,
                                                   pr.facets(*present))
        self.boundary.bcs.append(dolfinx.fem.dirichletbc(dolfinx.fem.Function(Vd), dofs, sp.sub("displacement")))
        u, d, p = ufl.split(self.solution)
        phi, psi, q = ufl.TestFunctions(sp.W)
        dx = ufl.dx(domain=mesh, subdomain_data=pr.cell_tags)
        self.load = self.constant(1.0)  # continuation parameter: fraction of the body force and convection
        law = pr.scene.solid.law
        dx_solid = pr.dx_solid_law if pr.pressure_in_fluid else dx(SOLID)
        F = lagrangian.solid_statics(d, p, phi, q, mu_s=pr.mu_s, body_force=self.load * pr.body_force,
                                     dx_solid=dx_solid, law=law, lambda_s=pr.lambda_s)
        F = F + lagrangian.rest_and_extension(u, d, psi, dx_solid=dx(SOLID), dx_fluid=dx(FLUID))
        self.has_fluid_cells = bool(comm.allreduce(int(np.any(pr.cell_tags.values == FLUID)), op=MPI.SUM))
        if self.has_fluid_cells:
            F = F + lagrangian.ale_navier_stokes(u, p, d, phi, q, rho=pr.rho, mu=pr.mu, body_force=pr.body_force,
                                                 penalty=pr.penalty, dx_fluid=dx(FLUID), convection=self.load)
        self.residual = F
        self.compiled = compat.form(F)

    def acceleration(self, u):
        """The steady material acceleration (u·∇)u (observables: the residual forces on the moved mesh)."""
        return ufl.grad(u) * u

    def _solve(self, t):
        """Solve the steady problem from rest, then move the mesh to the deformed configuration."""
        newton = self._newton()
        w, sp, state = self.solution, self.space, self.state
        w.x.array[:] = 0.0
        newton.apply_bcs()
        initial = w.x.array.copy()
        with self.timers("newton"):
            report = newton.continuation(self.load, self.scene.time.newton_continuation, initial)
        # the state's fields live on the problem's spaces: same elements, so the interpolation is a copy
        for name, f in (("velocity", state.velocity), ("displacement", state.displacement),
                        ("pressure", state.pressure)):
            part = dolfinx.fem.Function(sp.space(name))
            part.x.array[:] = w.x.array[sp.dofs(name)]
            f.interpolate(part)
        with self.timers("mesh_motion"):
            m = self.motion
            vertex = dolfinx.fem.Function(m.M)
            vertex.interpolate(state.displacement)
            m.displacement.x.array[:] = vertex.x.array
            try:
                m.place(vertex.x.array, t)
            except DivergenceError as exc:  # the moving mesh's advice is for a time step, which is not here
                raise DivergenceError(steady_advice(str(exc))) from None
            self.locator.update()
        return report


TIME_STEP_ADVICE = "; try a smaller time.dt, or the deformation is too large for a moving mesh"


def steady_advice(message: str) -> str:
    """A moving mesh's failure (mesh/motion.py) with advice for a steady scene, which has no time step."""
    head = message.split(TIME_STEP_ADVICE)[0]
    return (f"{head}: the steady deformation is too large for a moving mesh (a smaller load, a stiffer solid "
            "or a time-dependent scheme)")
