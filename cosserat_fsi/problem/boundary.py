"""Dirichlet data of a scene (seed §5.2: V_0h, W_0h), refreshed in time.

One path for every scene: the conditions by facet name of ``scene.conditions()`` — a file scene's
``boundaries`` section, or a built-in geometry's preset (geometry/presets.py: no-slip walls, cylinder, clamp
and a rigid flag; the inflow profile × ramp at the inlet, with the optional antisymmetric start-up tilt; the
moving lid of the cavity). With an exact solution: its values on every tagged boundary but the outlet.
Where ``micropolar.wall_condition: half_curl`` the wall value of ω is weak (Problem.residual) and has no
Dirichlet condition here; ``micro_rotation: {value: EXPR}`` is a Dirichlet condition on ω. Every expression of
a boundaries section (values, pressures, tractions, ω values) is evaluated one way (problem/data.py): numpy
into a Function, checked finite on the boundary's dofs; not finite at the start is an InputError (exit 2), at
a later update a DivergenceError (exit 3). A boundary of
type ``slip`` (Nitsche, Problem.slip) has no Dirichlet condition either; its facets are only checked here.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from mpi4py import MPI

from ..errors import InputError
from ..parallel import raise_if_any
from ..tags import SOLID
from .data import BoundaryData, weak_data
from .model import Problem

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
        self._data: dict[str, list[BoundaryData]] = {}  # the Dirichlet data of a boundaries section by name
        weak = problem.half_curl_walls()
        micro = problem.model.micro_rotation
        if exact is not None:
            boundary = [name for name in problem.facet_ids if name != "outlet"]
            self._add("velocity", boundary, exact=exact.velocity)
            if micro:
                self._add("micro_rotation", [b for b in boundary if b not in weak], exact=exact.micro_rotation)
            return
        self._named(problem.conditions(), micro)
        self._check_data(problem.conditions())
        solid_pressure = problem.solid_pressure_condition(self.space)  # a compressible solid: p = 0 inside
        if solid_pressure is not None:
            self.bcs.append(solid_pressure)

    def _named(self, boundaries, micro: bool) -> None:
        """The conditions of a ``boundaries`` section: no-slip first, then the velocities (they win at shared
        corners, as the built-in inflow does); slip is checked (weak: Problem.slip); ω = 0 where the
        micro-rotation condition is zero."""
        self._add("velocity", self.problem.no_slip_boundaries())
        for name, bc in boundaries.items():
            if bc.type == "velocity":
                self._add("velocity", (name,), data=self._data_of(name, "value", "velocity"))
        for name, bc in boundaries.items():
            if bc.type == "slip":
                self._slip(name)
        if micro:
            zero = self.problem.micro_rotation_boundaries("zero")
            if zero:
                self._add("micro_rotation", zero)
            wall = self.problem.scene.micropolar.wall_condition
            for name, bc in boundaries.items():  # (run.log lists every boundary's condition: scene.condition_lines)
                if bc.micro(wall) == "value":
                    self._add("micro_rotation", (name,),
                              data=self._data_of(name, "micro_rotation.value", "micro_rotation"))

    def _data_of(self, name: str, prefix: str, space_name: str) -> BoundaryData:
        """The BoundaryData (problem/data.py) of the expressions ``prefix`` of boundary ``name`` on the
        sub-space ``space_name``."""
        data = {f"boundaries.{name}.{k}": e for k, e in self.problem.conditions()[name].all_expressions().items()
                if k == prefix or k.startswith(prefix + "[")}
        self._data[name] = self._data.get(name, []) + [BoundaryData(self.space.space(space_name),
                                                                    self.problem.facets(name), data, self.comm)]
        return self._data[name][-1]

    def _check_data(self, boundaries) -> None:
        """Every expression of ``boundaries`` evaluated at the start into the values its condition uses
        (problem/data.py; the tractions' and pressures' are the problem's): not finite on the boundary is an
        InputError (exit 2). :meth:`update` refreshes the time-dependent ones (not finite: exit 3)."""
        scene = self.problem.scene
        start = steady_time(scene) if scene.time.scheme == "steady" else 0.0
        for name, bc in boundaries.items():
            data = list(self._data.get(name, ()))
            if bc.type in ("traction", "pressure"):
                data.append(weak_data(self.problem, name))
            for item in data:
                item.fill(start, InputError)

    def _slip(self, name: str) -> None:
        """Slip is weak (Problem.slip, Nitsche): no Dirichlet condition; its facets must be on the boundary of
        the mesh and of fluid cells (the terms carry the fluid's stress)."""
        mesh, facets = self.problem.mesh, self.problem.facets(name)
        tdim = mesh.topology.dim
        mesh.topology.create_connectivity(tdim - 1, tdim)
        facets = facets[facets < mesh.topology.index_map(tdim - 1).size_local]  # owned (exterior: the owner's)
        inside = ~np.isin(facets, dolfinx.mesh.exterior_facet_indices(mesh.topology))
        solid = False
        if self.problem.model.solid:
            ct, f2c = self.problem.cell_tags, mesh.topology.connectivity(tdim - 1, tdim)
            solid_cells = ct.indices[ct.values == SOLID]
            solid = any(np.isin(f2c.links(f), solid_cells).any() for f in facets[~inside])
        raise_if_any(self.comm, inside.any(), InputError(
            f"boundaries.{name}: type slip needs facets on the boundary of the mesh (some are inside it)"))
        raise_if_any(self.comm, solid, InputError(
            f"boundaries.{name}: type slip on a side of solid cells is not supported (the slip condition carries "
            "the fluid's stress); use no_slip there"))

    def update(self, t: float) -> None:
        """Set the time-dependent boundary values to time ``t`` (DivergenceError if they are not finite)."""
        for data in (item for items in self._data.values() for item in items):
            data.update(t)
        for update in self._updates:
            update(t)

    def _add(self, space_name, facet_names, exact=None, data: BoundaryData | None = None):
        """One condition on the sub-space ``space_name``: the ``exact(x, t)`` data, a boundaries section's
        ``data`` (its value: [EXPR, EXPR] in x, y, z, t; one for ω in 2D), or zero."""
        sp = self.space
        Vs = sp.space(space_name)
        g = data.g if data is not None else dolfinx.fem.Function(Vs)
        if exact is not None:
            self._updates.append(lambda t: g.interpolate(lambda x: exact(x, t)))
        fdim = self.problem.mesh.topology.dim - 1
        dofs = dolfinx.fem.locate_dofs_topological((sp.sub(space_name), Vs), fdim,
                                                   self.problem.facets(*facet_names))
        self.bcs.append(dolfinx.fem.dirichletbc(g, dofs, sp.sub(space_name)))


def steady_time(scene) -> float:
    """The time at which the boundary data and sources are evaluated: ``time.steady_at`` if given, else after
    every ramp."""
    if getattr(scene.time, "steady_at", None) is not None:
        return scene.time.steady_at
    ramps = [scene.time.t_end]
    if scene.inflow is not None:
        ramps.append(scene.inflow.ramp_time)
    if scene.solid is not None:
        ramps.append(scene.solid.gravity_ramp_time)
    return max(ramps)
