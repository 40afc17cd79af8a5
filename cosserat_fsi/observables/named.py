"""A file scene's named observables (``observables`` section): probes fixed in space, points that move with
the solid, line profiles and flow rates through named facet groups, in 2D and 3D.

Probe columns ``u_P, v_P, p_P`` (2D, with micropolar terms ``omega_P``) or ``u_P, v_P, w_P, p_P`` (3D, with
``omega_x_P, omega_y_P, omega_z_P``: ω is a vector in 3D); solid points ``ux_P, uy_P`` (3D: ``uz_P``); lines
``s, x, y[, z], u, v[, w], p`` (+ ``omega`` or ``omega_x, omega_y, omega_z``); ``flow_rate_NAME`` = ∫ u·n ds
over a boundary facet group, n the outward normal.
"""

from __future__ import annotations

import numpy as np
from mpi4py import MPI

from .. import compat
from ..config.sections import coordinate_problem
from ..errors import InputError
from ..parallel import raise_if_any
from ..tags import SOLID

import dolfinx
import ufl


def probe_columns(dim: int, micro: bool) -> tuple[str, ...]:
    """The quantities of one probe, in the order of :func:`probe_values`."""
    velocity = ("u", "v", "w")[:dim]
    omega = (("omega",) if dim == 2 else ("omega_x", "omega_y", "omega_z")) if micro else ()
    return (*velocity, "p", *omega)


def probe_values(values: list, k: int, dim: int) -> list[float]:
    """The values of probe ``k`` from :func:`~cosserat_fsi.points.location.probe`'s (velocity, pressure[, ω])
    arrays, in the order of :func:`probe_columns`."""
    row = [*values[0][k, :dim], values[1][k, 0]]
    if len(values) > 2:
        row += list(values[2][k])  # 2D: the scalar ω; 3D: its three components
    return [float(v) for v in row]


def solid_point_columns(dim: int) -> tuple[str, ...]:
    return ("ux", "uy", "uz")[:dim]


def line_columns(dim: int, micro: bool) -> list[str]:
    """The columns of ``line_NAME.csv`` after ``t``."""
    return ["s", *"xyz"[:dim], *probe_columns(dim, micro)]


def point3(key: str, xy, dim: int) -> np.ndarray:
    """The point ``xy`` of the scene as a 3-vector (z = 0 in 2D); InputError naming ``key`` if it has not
    ``dim`` coordinates (the scene validator says so first; this guards a scene built in Python)."""
    problem = coordinate_problem(key, len(xy), dim)
    if problem is not None:
        raise InputError(problem)
    return np.array([*map(float, xy), *[0.0] * (3 - len(xy))])


def text(x, dim: int) -> str:
    """``(x, y)`` or ``(x, y, z)``, 6 significant digits."""
    return "(" + ", ".join(f"{v:.6g}" for v in np.asarray(x, dtype=float)[:dim]) + ")"


def check_inside(sim, key: str, points: np.ndarray) -> None:
    """InputError naming ``key`` if a point is in no cell of any rank (outside the mesh). Collective."""
    found = (sim.locator.locate(points, owned_only=True) >= 0).astype(np.int64)
    hits = sim.comm.allreduce(found, op=MPI.SUM)
    if not hits.all():
        x = points[int(np.argmin(hits))]
        raise InputError(f"{key}: point {text(x, sim.mesh.geometry.dim)} is outside the mesh")


def cell_tag(sim, cell: int) -> str:
    """'fluid' or 'solid': the subdomain of a local cell."""
    tags = sim.cell_tags
    if tags is None:
        return "fluid"
    where = np.flatnonzero(tags.indices == cell)
    return "solid" if len(where) and tags.values[where[0]] == SOLID else "fluid"


def nearest_solid_node(sim, point: np.ndarray) -> int:
    """Local index of the owned solid velocity node nearest to ``point`` on the reference mesh (the one of
    the lowest rank on a tie), −1 on the other ranks."""
    V = sim.velocity.function_space
    n_owned = V.dofmap.index_map.size_local
    nodes = np.asarray(sim.problem.solid_velocity_dofs, dtype=np.int64)
    nodes = nodes[nodes < n_owned]
    x = V.tabulate_dof_coordinates()[nodes, :len(point)]
    dist = np.linalg.norm(x - point, axis=1)
    i = int(np.argmin(dist)) if len(nodes) else -1
    mine = float(dist[i]) if len(nodes) else np.inf
    best = sim.comm.allgather(mine)
    owner = int(np.argmin(best))
    return int(nodes[i]) if sim.comm.rank == owner else -1


def flow_rate_forms(sim, u, n, ds, names) -> dict:
    """{name: form of ∫ u·n ds over the facet group ``name``}, n the outward normal of the domain. A group
    with facets inside the mesh (between two cells: no outward side) is refused naming its key. Collective."""
    mesh, ids = sim.mesh, sim.problem.facet_ids
    tdim = mesh.topology.dim
    mesh.topology.create_connectivity(tdim - 1, tdim)
    exterior = dolfinx.mesh.exterior_facet_indices(mesh.topology)
    owned = mesh.topology.index_map(tdim - 1).size_local
    out = {}
    for i, name in enumerate(names):
        key = f"observables.flow_rates[{i}]"
        facets = sim.problem.facets(name)
        if name not in ids or not sim.comm.allreduce(len(facets), op=MPI.SUM):
            raise InputError(f"{key}: the mesh has no facet group {name!r}")
        facets = facets[facets < owned]  # owned: an exterior facet is its owner's
        raise_if_any(sim.comm, bool((~np.isin(facets, exterior)).any()), InputError(
            f"{key}: facet group {name!r} is inside the mesh (a flow rate is through a boundary, along its "
            "outward normal)"))
        out[name] = compat.form(ufl.inner(u, n) * ds(ids[name]))
    return out
