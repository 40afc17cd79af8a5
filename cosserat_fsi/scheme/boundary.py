"""Dirichlet data of a scene (seed §5.2: V_0h, W_0h), refreshed in time.

No-slip (and ω = 0) on walls, cylinder, clamp and a rigid flag; the inflow profile × ramp at the inlet,
with an optional antisymmetric kick during the ramp; the moving lid of the cavity. With an exact solution:
its values on every tagged boundary but the outlet. Where ``micropolar.wall_condition: half_curl`` the
wall value of ω is weak (Problem.residual) and has no Dirichlet condition here.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from mpi4py import MPI

from .. import compat
from ..errors import InputError
from .problem import Problem, ramp

import dolfinx


class BoundaryConditions:
    """The list ``bcs`` of dolfinx Dirichlet conditions on the mixed space and :meth:`update` (t).

    ``space``: another mixed space with the same field names (default: the problem's).
    """

    def __init__(self, problem: Problem, comm=MPI.COMM_WORLD, exact=None, space=None):
        self.problem, self.comm = problem, comm
        self.space = space if space is not None else problem.space
        self.bcs: list = []
        self._updates: list[Callable[[float], None]] = []
        weak = problem.half_curl_walls()
        micro = problem.model.micro_rotation
        if exact is not None:
            boundary = [name for name in problem.facet_ids if name != "outlet"]
            self._add("velocity", boundary, exact=exact.velocity)
            if micro:
                self._add("micro_rotation", [b for b in boundary if b not in weak], exact=exact.micro_rotation)
            return
        scene = problem.scene
        if scene.boundaries is not None:
            self._named(scene.boundaries, micro)
            return
        inflow = scene.inflow
        moving_lid = inflow is not None and scene.geometry.name in ("square", "cube")
        no_slip = problem.no_slip_boundaries()
        self._add("velocity", no_slip + (() if moving_lid else ("lid",)))
        if inflow is not None:
            self._inflow(inflow, moving_lid)
        if micro and not weak:
            self._add("micro_rotation", no_slip + ("lid",))

    def _named(self, boundaries, micro: bool) -> None:
        """The conditions of a ``boundaries`` section: no-slip first, then the velocities (they win at shared
        corners, as the built-in inflow does), slip; ω = 0 where the micro-rotation condition is zero."""
        self._add("velocity", self.problem.no_slip_boundaries())
        for name, bc in boundaries.items():
            if bc.type == "velocity":
                self._add("velocity", (name,), expressions=bc.expressions())
        for name, bc in boundaries.items():
            if bc.type == "slip":
                self._slip(name)
        if micro:
            zero = self.problem.micro_rotation_boundaries("zero")
            if zero:
                self._add("micro_rotation", zero)

    def _slip(self, name: str) -> None:
        """u·n = 0 on a straight boundary along x or y: the normal component is zero."""
        mesh = self.problem.mesh
        facets = self.problem.facets(name)
        fdim = mesh.topology.dim - 1
        sp = self.space
        V0, _ = compat.collapse(sp.sub("velocity").sub(0))
        local = dolfinx.fem.locate_dofs_topological((sp.sub("velocity").sub(0), V0), fdim, facets)[1]
        x = V0.tabulate_dof_coordinates()[local][:, :2]
        lo = self.comm.allreduce(x.min(axis=0) if len(x) else np.full(2, np.inf), op=MPI.MIN)
        hi = self.comm.allreduce(x.max(axis=0) if len(x) else np.full(2, -np.inf), op=MPI.MAX)
        extent = hi - lo
        size = max(float(np.max(extent)), 1e-300)
        flat = [i for i in range(2) if extent[i] <= 1e-10 * size]
        if len(flat) != 1:
            raise InputError(f"boundaries.{name}: type slip needs a straight boundary along x or y "
                             "(u.n = 0 is imposed on one velocity component)")
        Vi, _ = compat.collapse(sp.sub("velocity").sub(flat[0]))
        dofs = dolfinx.fem.locate_dofs_topological((sp.sub("velocity").sub(flat[0]), Vi), fdim, facets)
        self.bcs.append(dolfinx.fem.dirichletbc(dolfinx.fem.Function(Vi), dofs, sp.sub("velocity").sub(flat[0])))

    def update(self, t: float) -> None:
        """Set the time-dependent boundary values to time ``t``."""
        for update in self._updates:
            update(t)

    def _inflow(self, inflow, moving_lid: bool):
        """Parabolic or uniform inflow (or the lid's velocity) × ramp, + ε sin(π t/T) × a tilted profile."""
        x = self.problem.mesh.geometry.x
        zeros = [np.zeros_like] * (self.problem.mesh.geometry.dim - 1)  # the other velocity components
        ramp_time = inflow.ramp_time
        y0 = self.comm.allreduce(x[:, 1].min(), op=MPI.MIN)
        H = self.comm.allreduce(x[:, 1].max(), op=MPI.MAX) - y0

        if len(zeros) == 2:  # 3D duct: the parabola in z too (mean u_mean over the inlet)
            z0 = self.comm.allreduce(x[:, 2].min(), op=MPI.MIN)
            W = self.comm.allreduce(x[:, 2].max(), op=MPI.MAX) - z0

        def profile(x):
            y = x[1] - y0
            ux = (6.0 * inflow.u_mean * y * (H - y) / H**2 if inflow.profile == "parabolic"
                  else np.full_like(y, inflow.u_mean))
            if len(zeros) == 2 and inflow.profile == "parabolic":
                ux = ux * 6.0 * (x[2] - z0) * (W - (x[2] - z0)) / W**2
            return np.vstack([ux] + [z(ux) for z in zeros])

        def lid(x):
            return np.vstack([np.full_like(x[0], inflow.u_mean)] + [z(x[0]) for z in zeros])

        def tilt(x):  # antisymmetric about mid-height: breaks the symmetry of the start-up
            return profile(x) * (2.0 * (x[1] - y0) / H - 1.0)

        def bump(t):  # ε sin(π t / T) during the ramp, then 0
            return inflow.asymmetry * np.sin(np.pi * t / ramp_time) if 0 < t < ramp_time else 0.0

        kick = (tilt, bump) if inflow.asymmetry and not moving_lid else None
        self._add("velocity", ("lid",) if moving_lid else ("inlet",), values=lid if moving_lid else profile,
                  scale=lambda t: ramp(t, ramp_time), kick=kick)

    def _add(self, space_name, facet_names, values=None, scale=None, exact=None, kick=None, expressions=None):
        """One condition on the sub-space ``space_name``: fixed ``values`` (× ``scale(t)``, plus
        ``kick = (values2, scale2)`` × scale2(t)), the ``exact(x, t)`` data, or zero."""
        sp = self.space
        Vs = sp.space(space_name)
        g = dolfinx.fem.Function(Vs)
        if values is not None:
            g.interpolate(values)
            if scale is not None:
                g0 = g.x.array.copy()
                g1, scale1 = np.zeros_like(g0), (lambda t: 0.0)
                if kick is not None:
                    g.interpolate(kick[0])
                    g1, scale1 = g.x.array.copy(), kick[1]
                self._updates.append(lambda t: g.x.array.__setitem__(slice(None), scale(t) * g0 + scale1(t) * g1))
        if exact is not None:
            self._updates.append(lambda t: g.interpolate(lambda x: exact(x, t)))
        if expressions is not None:  # a boundaries section's value: [EXPR, EXPR] in x, y, z, t

            def fill(t, g=g, expressions=expressions):
                g.interpolate(lambda x: np.vstack([e.evaluate(x, t) for e in expressions]))

            fill(0.0)
            if any(e.time_dependent for e in expressions):
                self._updates.append(fill)
        fdim = self.problem.mesh.topology.dim - 1
        dofs = dolfinx.fem.locate_dofs_topological((sp.sub(space_name), Vs), fdim,
                                                   self.problem.facets(*facet_names))
        self.bcs.append(dolfinx.fem.dirichletbc(g, dofs, sp.sub(space_name)))
