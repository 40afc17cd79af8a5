"""Fields from one mesh to another of the same domain (remeshing): ``interpolator(comm)`` is the
``interpolate(target, source)`` that ``State.transfer_to`` takes.

dolfinx 0.11 interpolates natively between non-matching meshes; on 0.5.2 the source is evaluated at the
target's dof coordinates by the characteristics' parallel point location (local cells, then the other
ranks' owned cells). A target dof that lies in no cell of the source mesh is an error (the new mesh must
cover no more than the old one, up to round-off).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from mpi4py import MPI

from .. import compat
from ..points.location import PointLocator, values_anywhere


def interpolator(comm=MPI.COMM_WORLD) -> Callable:
    """``interpolate(target, source)``: ``target`` ← ``source`` (Functions on different meshes). Collective."""
    locators, located = {}, {}

    def point_values(source, points: np.ndarray) -> np.ndarray:
        mesh = source.function_space.mesh
        locator = locators.get(id(mesh))
        if locator is None:
            locator = locators[id(mesh)] = PointLocator(mesh)
        (values,), found = values_anywhere(locator, [source], np.asarray(points, dtype=np.float64), comm)
        missing = comm.allreduce(int((~found).sum()), op=MPI.SUM)
        if missing:
            raise ValueError(f"transfer: {missing} target nodes lie outside the source mesh")
        return values

    def interpolate(target, source) -> None:
        compat.interpolate_nonmatching(target, source, point_values, located)

    return interpolate
