"""The normal of a slip boundary between its facets: the polygon's facet normals averaged at the vertices.

On a curved wall the mesh's facets are chords, and u·n_h = 0 on each of them locks the flow along the wall
towards no-slip (the velocity error falls only as O(h)). The vertex average of the adjacent facets' normals,
weighted by 1/|facet| (second order on a smooth curve: the chord normals sit at the chords' mid-angles),
interpolated linearly along each facet, is O(h²) from the curve's normal, and a rigid rotation of a circle
has u·ñ = 0 on every chord. Where the facets meet at an angle (a corner: the average's length below
``SHARP`` of the weights' sum) the cells around keep the facet normal. On a straight wall ñ = n_h.
"""

from __future__ import annotations

import numpy as np

from .. import compat

import dolfinx
import dolfinx.fem.petsc as fem_petsc
import ufl
from petsc4py import PETSc

SHARP = 0.97  # |Σ w n| / Σ w below this at a vertex: a corner (facets meeting at more than about 28°)


def _assembled(form, V):
    """The vector of ``form`` on V, summed over the ranks and with its ghosts (a Function)."""
    f = dolfinx.fem.Function(V)
    vec = compat.petsc_vec(f)
    fem_petsc.assemble_vector(vec, compat.form(form))
    vec.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
    vec.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
    return f


def smoothed_normal(mesh, ds):
    """ñ on the facets of ``ds`` (a UFL vector: the vertex-averaged normal, or n_h in the corner cells)."""
    gdim = mesh.geometry.dim
    n, area = ufl.FacetNormal(mesh), ufl.FacetArea(mesh)
    V = compat.function_space(mesh, "Lagrange", 1, shape=(gdim,))
    Q = compat.function_space(mesh, "Lagrange", 1)
    N = _assembled(ufl.inner(n, ufl.TestFunction(V)) / area**2 * ds, V)
    W = _assembled(ufl.TestFunction(Q) / area**2 * ds, Q)
    values, weights = N.x.array.reshape(-1, gdim), W.x.array
    length = np.linalg.norm(values, axis=1)
    on = weights > 0
    corner = on & (length < SHARP * np.where(on, weights, 1.0))
    values[on] /= length[on, None]
    theta = dolfinx.fem.Function(compat.function_space(mesh, "DG", 0))
    cells = compat.cell_dofs(theta.function_space)[:, 0]
    theta.x.array[cells] = ~corner[compat.cell_dofs(Q)].any(axis=1)
    smooth = N / ufl.sqrt(ufl.dot(N, N) + 1e-300)
    return theta * smooth + (1 - theta) * n
