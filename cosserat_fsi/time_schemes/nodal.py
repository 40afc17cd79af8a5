"""What the schemes on the nodal values share (``ale_bdf2``, ale_bdf.py; ``generalized_alpha``,
generalized_alpha.py): the histories of the nodal values and the convection relative to the moving mesh.

The BDF of the nodal values is the time derivative along the mesh's motion w; the material derivative adds
((u* − w*)·∇)f in fluid cells, with u* extrapolated and w* the mesh velocity u* gives. In solid cells the
mesh is the material and the nodal BDF is already the material derivative: no convection there.
"""

from __future__ import annotations

from ..mesh.motion import PrescribedMotion
from ..points.location import PointLocator

import dolfinx
import ufl


class NodalHistories:
    """α·h for u (``velocity``) and ω (``micro_rotation`` or None) at the nodes, the inertia measure
    ``dx_inertia`` and the point locator of the current mesh (``locator``)."""

    def __init__(self, problem):
        sp, mesh = problem.space, problem.mesh
        self.velocity = dolfinx.fem.Function(sp.space("velocity"))
        self.micro_rotation = (dolfinx.fem.Function(sp.space("micro_rotation")) if problem.model.micro_rotation
                               else None)
        self.dx_inertia = ufl.dx(domain=mesh)
        self.locator = PointLocator(mesh)

    def update(self, bdf, state, solve_displacement=None) -> None:
        """α h = u^n (first order) or a₁u^n − a₂u^{n−1} (``bdf``: BdfWeights; 2u^n − ½u^{n−1} at constant
        steps) node by node: the values the mesh's nodes carried at t^n and t^{n−1}."""
        for target, now, before in ((self.velocity, state.velocity, state.velocity_prev),
                                    (self.micro_rotation, state.micro_rotation, state.micro_rotation_prev)):
            if target is not None:
                target.x.array[:] = bdf.history(now.x.array, before.x.array)

    def mesh_moved(self, rebuild: bool = False) -> None:
        """The mesh moved: the locator follows (no earlier configurations are needed)."""
        self.locator.update()

    def remember_configuration(self) -> None:
        """Nothing: the nodal values need no earlier configuration."""

    def relocate(self, motion, state) -> None:
        """After a restore: the locator on the restored mesh."""
        self.locator.update()


class MeshConvection:
    """The convecting velocity c = u* − w* of ((u* − w*)·∇)f (``velocity``), none in solid cells."""

    def __init__(self, problem, motion):
        V = problem.space.space("velocity")
        self.motion = motion
        self.velocity = dolfinx.fem.Function(V, name="convecting_velocity")
        self.fluid_cells = problem.fluid_cells
        if motion is not None:
            self._w_P1, self._w = dolfinx.fem.Function(motion.M), dolfinx.fem.Function(V)
        self._u_star = None

    def material_derivative(self, f, rate):
        """``rate`` + ((u* − w*)·∇)f in fluid cells."""
        c = self.velocity
        convection = ufl.grad(f) * c if ufl.shape(f) != () else ufl.dot(ufl.grad(f), c)
        return rate + (convection if self.fluid_cells is None else self.fluid_cells * convection)

    def set(self, u_star, t: float) -> None:
        """c = u* − w*, w* the mesh velocity u* gives: the extension of u* from the solid's vertices (the
        solid vertices move with the velocity and the extension is linear, so the mesh velocity at t is the
        extension of u(t); an extrapolated u* makes it O(δt²)); a prescribed motion's, its rate at t."""
        c, m = self.velocity, self.motion
        c.x.array[:] = u_star
        self._u_star = c.x.array.copy()
        if m is not None:
            self._w_P1.x.array[:] = m.velocity_of(c, t) if isinstance(m, PrescribedMotion) else m.velocity_of(c)
            self._w.interpolate(self._w_P1)
            c.x.array[:] -= self._w.x.array
        c.x.scatter_forward()

    def relinearise(self, u_new) -> None:
        """One Picard iteration: c = u_new − w* (the mesh, its velocity and the histories stay)."""
        c = self.velocity
        c.x.array[:] += u_new - self._u_star
        self._u_star = u_new.copy()
        c.x.scatter_forward()
