"""The values of a ``boundaries`` section's expressions on the mesh: one evaluation for every condition.

A velocity, a micro-rotation value, a pressure or a traction gets its values the same way: the expressions
(config/expressions.py) are evaluated by numpy with IEEE semantics at the interpolation points of a finite
element space and interpolated into a Function of it (``BoundaryData.fill``). The values of the Function on
the boundary's dofs are then checked to be finite; they are the values the condition uses: a Dirichlet
condition takes them at those dofs, a traction or a pressure integrates the Function over the boundary (its
trace depends on those dofs only; the others are set to 0, so that a value that is not finite away from the
boundary, e.g. 1/x on x = 1, never enters). A value that is not finite is an error naming the key: an
InputError at setup (exit 2), a DivergenceError when a time-dependent value turns non-finite during the run
(exit 3), raised on every rank together (parallel.raise_if_any).
"""

from __future__ import annotations

import numpy as np

from ..errors import DivergenceError, InputError
from ..parallel import raise_if_any

import dolfinx


class BoundaryData:
    """The expressions of one condition (``{key: Expression}``, one per component of ``V``, keys in full such
    as ``boundaries.inlet.value[0]``) as a Function ``g`` of ``V``, nonzero only on the dofs of ``facets``."""

    def __init__(self, V, facets, expressions: dict, comm):
        self.V, self.comm = V, comm
        self.keys, self.expressions = list(expressions), list(expressions.values())
        self.g = dolfinx.fem.Function(V)
        fdim = V.mesh.topology.dim - 1
        self.dofs = dolfinx.fem.locate_dofs_topological(V, fdim, facets)
        self.block = V.dofmap.index_map_bs
        if self.block != len(self.expressions):
            raise ValueError(f"{len(self.expressions)} expressions for a space of {self.block} components")
        self._away = np.ones(len(self.g.x.array) // self.block, dtype=bool)
        self._away[self.dofs] = False
        self.time_dependent = any(e.time_dependent for e in self.expressions)
        self.t: float | None = None

    def fill(self, t: float, error=DivergenceError) -> None:
        """Evaluate the expressions at time ``t`` into ``g``; ``error`` (collective) naming the first key whose
        value on a boundary dof is not finite."""
        expressions = self.expressions

        def values(x):
            if len(expressions) == 1:
                return expressions[0].evaluate(x, t)
            return np.vstack([e.evaluate(x, t) for e in expressions])

        self.g.interpolate(values)
        array = self.g.x.array.reshape(-1, self.block)
        bad = [not np.all(np.isfinite(array[self.dofs, i])) for i in range(self.block)]
        first = next((i for i, b in enumerate(bad) if b), len(bad))
        first = self.comm.allreduce(first, op=_min())
        if first < len(bad):
            text = self.expressions[first].text
            raise_if_any(self.comm, True, error(f"{self.keys[first]}: {text!r} is not finite on the boundary at "
                                                f"t = {float(t)!r} (an overflow, a division by zero or a value "
                                                "outside a function's domain)"))
        array[self._away] = 0.0
        self.g.x.scatter_forward()
        self.t = t

    def update(self, t: float) -> None:
        """:meth:`fill` at ``t`` if the expressions use t (DivergenceError if not finite)."""
        if self.time_dependent or self.t is None:
            self.fill(t)


def weak_data(problem, name: str) -> BoundaryData:
    """The values of the traction or pressure boundary ``name`` of ``problem`` (its velocity's P2 space, a
    component of it for a pressure), made once and kept by the problem, which refreshes them at the time of
    its sources (Problem.update_sources: generalised-α's t_{n+α_f})."""
    if name not in problem._weak_data:
        from .. import compat

        bc = problem.conditions()[name]
        V = problem.space.space("velocity")
        if bc.type == "pressure":
            V = compat.collapse(problem.space.sub("velocity").sub(0))[0]
        values = {f"boundaries.{name}.{k}": e for k, e in bc.all_expressions().items()
                  if k == "value" or k.startswith("value[")}
        data = BoundaryData(V, problem.facets(name), values, problem.mesh.comm)
        data.fill(float(problem.time.value), InputError)
        problem._weak_data[name] = data
    return problem._weak_data[name]


def _min():
    from mpi4py import MPI

    return MPI.MIN
