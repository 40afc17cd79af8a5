"""The observables of a run (:class:`Observables`): forces on the body, point A, a file scene's named
probes, solid points, lines and flow rates, energies, flow rate, Δp, max |ω|, exact-solution errors.

Every value is parallel-correct: integrals are summed over ranks, probes are evaluated by the rank that
owns the point.
"""

from __future__ import annotations

import numpy as np
from mpi4py import MPI

from .. import compat
from ..exact import EXACT_BENCHMARKS
from ..physics import materials
from ..physics.solid import elastic_energy_density
from ..physics.stress import cauchy_stress
from ..points.location import probe
from ..tags import SOLID
from . import named as own
from .forces import force_columns, force_forms

import dolfinx
import ufl

# Schäfer–Turek pressure probes: front and back of the cylinder (shared/reference/benchmarks.yaml; 3D:
# geometry/builtin/schaefer_turek_3d.py's a1, a2)
DP_POINTS = np.array([[0.15, 0.2, 0.0], [0.25, 0.2, 0.0]])
BODY = ("cylinder", "interface")
POINT_A = {"turek_hron": (0.6, 0.2), "flag": None, "turek_hron_3d": None}  # flag: (length, thickness/2), from
# the mesh; turek_hron_3d: the middle of the flag's tip (its describe())


class Observables:
    """Evaluates the observables of a scene from the current state of a :class:`~cosserat_fsi.simulation.Simulation`."""

    def __init__(self, sim, point_A: np.ndarray | None = None, solid_points: dict | None = None):
        """``point_A``: where point A is now (after a remesh, the mesh's reference is no longer the
        material's: see :meth:`point_A_now`); default the scene's. ``solid_points``: likewise, where the named
        solid points (``observables.solid_points``) are now (:meth:`solid_points_now`); default as named."""
        self.sim = sim
        self.comm = sim.comm
        scene = sim.scene
        mesh = sim.mesh
        ft = sim.facet_tags
        problem = sim.problem
        u, p, omega = sim.split_solution()
        T = cauchy_stress(u, p, problem.mu, problem.mu_r, omega)
        n = ufl.FacetNormal(mesh)
        ds = ufl.Measure("ds", domain=mesh, subdomain_data=ft)
        ids = problem.facet_ids
        named = scene.observables
        body = BODY if named is None else (*named.forces, *(("interface",) if named.wetted_solid else ()))
        body_tags = tuple(ids[b] for b in body
                          if b in ids and self.comm.allreduce(int(np.any(ft.values == ids[b])), op=MPI.MAX))
        self._adaptive = getattr(scene.time, "tolerance", None) is not None
        self.columns = ["dt"] if self._adaptive else []  # the step's δt, chosen by time.tolerance
        dim = mesh.geometry.dim
        self._force_forms = None
        if body_tags and scene.has_fluid:
            self._force_forms = force_forms(sim, u, T, n, ds, body_tags)
            self.columns += force_columns(dim)
        self._node_A = None
        if sim.model.solid and scene.geometry.name in POINT_A:
            self._node_A = _owned_node(sim, _point_A(sim) if point_A is None else point_A)
            self._space_A = sim.velocity.function_space
            self.columns += ["ux_A", "uy_A"] + (["uz_A"] if mesh.geometry.dim == 3 else [])
        self._points = self._solid_points = None
        micro = sim.model.micro_rotation
        if named is not None and named.points:
            keys = [f"observables.points.{name}" for name in named.points]
            points = np.array([own.point3(key, xy, dim) for key, xy in zip(keys, named.points.values())])
            for key, x in zip(keys, points):
                own.check_inside(sim, key, x[None, :])
            self._points = (list(named.points), points)
            self.columns += [f"{c}_{name}" for name in named.points for c in own.probe_columns(dim, micro)]
        if named is not None and named.solid_points:
            for name, x in named.solid_points.items():
                own.point3(f"observables.solid_points.{name}", x, dim)
            where = {**named.solid_points, **(solid_points or {})}
            self._solid_points = {name: own.nearest_solid_node(sim, np.asarray(where[name], dtype=float)) for name
                                  in named.solid_points}
            self._space_points = sim.velocity.function_space  # kept: after a remesh sim's is the new mesh's
            self.columns += [f"{c}_{name}" for name in named.solid_points for c in own.solid_point_columns(dim)]
        self.lines = {}  # name -> (column names, arc lengths, points (N, 3))
        for name, line in ((named.lines or {}).items() if named is not None else ()):
            key = f"observables.lines.{name}"
            for end, x in (("from", line.start), ("to", line.to)):
                own.point3(f"{key}.{end}", x, dim)
            arc, xy = line.samples()
            points = np.column_stack([xy, np.zeros((len(xy), 3 - xy.shape[1]))])
            own.check_inside(sim, key, points)
            self.lines[name] = (self._line_columns(), arc, points)
        self._energy_forms = None
        if sim.model.solid:
            dx = ufl.dx(domain=mesh, subdomain_data=sim.cell_tags)
            kinetic = 0.5 * problem.rho * ufl.inner(u, u) * dx
            if scene.solid.compressible:  # the stored energy per current volume, ψ/J
                elastic = (materials.energy_density(scene.solid.law, sim.displacement, problem.mu_s,
                                                    problem.lambda_s) * problem.dx_solid_law)
            else:
                elastic = elastic_energy_density(sim.displacement, problem.mu_s) * dx(SOLID)
            self._energy_forms = [compat.form(kinetic), compat.form(elastic)]
            self.columns += ["energy_kinetic", "energy_elastic"]
            if scene.solid.gravity:  # the weight's potential −∫_s f·d (f the body force, ramp included)
                self._energy_forms.append(compat.form(-ufl.inner(problem.body_force, sim.displacement) * dx(SOLID)))
                self.columns.append("energy_potential")
            self.columns.append("energy_total")
        self._flow_rate = None
        outlet = ids.get("outlet")
        if (scene.has_fluid and outlet is not None
                and self.comm.allreduce(int(np.any(ft.values == outlet)), op=MPI.MAX)):
            self._flow_rate = compat.form(ufl.inner(u, n) * ds(outlet))  # ∫_outlet u·n ds
            self.columns.append("flow_rate")
        self._flow_rates = own.flow_rate_forms(sim, u, n, ds, named.flow_rates if named is not None else ())
        self.columns += [f"flow_rate_{name}" for name in self._flow_rates]
        self._dp = scene.geometry.name in ("schaefer_turek", "schaefer_turek_3d")
        self._dp_points = (np.array([scene.geometry.describe()["points"][a] for a in ("a1", "a2")])
                           if scene.geometry.name == "schaefer_turek_3d" else DP_POINTS)
        if self._dp:
            self.columns.append("dp")
        if sim.model.micro_rotation:
            self.columns.append("omega_max")
        self._exact = None
        if scene.benchmark in EXACT_BENCHMARKS and sim.exact is not None:
            self._exact = _exact_error_forms(sim)
            self.columns += [f"{name}_error" for name in self._exact]

    def _line_columns(self) -> list[str]:
        return own.line_columns(self.sim.mesh.geometry.dim, self.sim.model.micro_rotation)

    def profiles(self) -> dict:
        """{line name: (N, columns) array} of the ``observables.lines`` at the current state. Collective."""
        fields = [self.sim.velocity, self.sim.pressure] + ([self.sim.micro_rotation] if self.sim.model.micro_rotation
                                                            else [])
        dim = self.sim.mesh.geometry.dim
        out = {}
        for name, (_, arc, points) in self.lines.items():
            values = probe(self.sim.locator, fields, points, self.comm)
            out[name] = np.column_stack([arc, points[:, :dim], *values])
        return out

    def locations(self) -> list[str]:
        """Where each named probe landed, for run.log: a point's cell (global index, fluid or solid); a solid
        point's node (reference position, distance from the asked position). Collective."""
        named = self.sim.scene.observables
        out = []
        if named is None:
            return out
        mesh, comm = self.sim.mesh, self.comm
        dim = mesh.geometry.dim
        for name, x in zip(*self._points) if self._points is not None else ():
            cell = int(self.sim.locator.locate(x[None, :], owned_only=True)[0])
            imap = mesh.topology.index_map(mesh.topology.dim)
            local = (imap.local_range[0] + cell, own.cell_tag(self.sim, cell)) if cell >= 0 else (-1, "")
            index, kind = max(comm.allgather(local))
            out.append(f"probe {name} at {own.text(x, dim)}: inside the mesh, {kind} cell {index}")
        for name, node in (self._solid_points or {}).items():
            x = self._space_points.tabulate_dof_coordinates()[node, :dim] if node >= 0 else np.zeros(dim)
            x = comm.allreduce(x, op=MPI.SUM)
            asked = np.asarray(named.solid_points[name], dtype=float)
            out.append(f"solid point {name} asked at {own.text(asked, dim)}: solid node at {own.text(x, dim)}, "
                       f"{np.linalg.norm(x - asked):.3g} from it")
        for name, line in (named.lines or {}).items():
            out.append(f"line {name}: {line.points} points from {tuple(line.start)} to {tuple(line.to)}, all inside "
                       f"the mesh -> line_{name}.csv")
        for name in self._flow_rates:
            out.append(f"flow rate {name}: u·n over the facet group {name!r}, n outward -> flow_rate_{name}")
        return out

    def point_A_now(self) -> np.ndarray | None:
        """The current position of point A (the node it was found at, on that mesh as it is now)."""
        if self._node_A is None:
            return None
        dim = self.sim.mesh.geometry.dim
        x = self._space_A.tabulate_dof_coordinates()[self._node_A, :dim] if self._node_A >= 0 else np.zeros(dim)
        return self.comm.allreduce(x, op=MPI.SUM)

    def solid_points_now(self) -> dict | None:
        """The current positions of the named solid points (their nodes, on the mesh as it is now)."""
        if self._solid_points is None:
            return None
        coordinates, dim = self._space_points.tabulate_dof_coordinates(), self.sim.mesh.geometry.dim
        return {name: self.comm.allreduce(coordinates[node, :dim] if node >= 0 else np.zeros(dim),
                                          op=MPI.SUM).tolist() for name, node in self._solid_points.items()}

    def evaluate(self) -> dict:
        out = {"dt": self.sim.state.steps.last} if self._adaptive else {}
        dim = self.sim.mesh.geometry.dim
        if self._force_forms is not None:
            forces = [self.comm.allreduce(dolfinx.fem.assemble_scalar(f), op=MPI.SUM) for f in self._force_forms]
            out.update(zip(force_columns(dim), forces))
        if self._node_A is not None:
            d = self.sim.displacement.x.array.reshape(-1, dim)
            local = d[self._node_A] if self._node_A >= 0 else np.zeros(dim)
            out.update(zip(("ux_A", "uy_A", "uz_A"), self.comm.allreduce(local, op=MPI.SUM)))
        if self._points is not None:
            names, points = self._points
            micro = self.sim.model.micro_rotation
            fields = [self.sim.velocity, self.sim.pressure] + ([self.sim.micro_rotation] if micro else [])
            values = probe(self.sim.locator, fields, points, self.comm)
            columns = own.probe_columns(dim, micro)
            for k, name in enumerate(names):
                out.update({f"{c}_{name}": v for c, v in zip(columns, own.probe_values(values, k, dim))})
        if self._solid_points is not None:
            d = self.sim.displacement.x.array.reshape(-1, dim)
            columns = own.solid_point_columns(dim)
            for name, node in self._solid_points.items():
                local = d[node] if node >= 0 else np.zeros(dim)
                out.update({f"{c}_{name}": float(v) for c, v in zip(columns, self.comm.allreduce(local, op=MPI.SUM))})
        if self._energy_forms is not None:
            energies = [self.comm.allreduce(dolfinx.fem.assemble_scalar(f), op=MPI.SUM) for f in self._energy_forms]
            out.update(zip(("energy_kinetic", "energy_elastic", "energy_potential"), energies),
                       energy_total=sum(energies))
        if self._flow_rate is not None:
            out["flow_rate"] = self.comm.allreduce(dolfinx.fem.assemble_scalar(self._flow_rate), op=MPI.SUM)
        for name, form in self._flow_rates.items():
            out[f"flow_rate_{name}"] = self.comm.allreduce(dolfinx.fem.assemble_scalar(form), op=MPI.SUM)
        if self._dp:
            p = probe(self.sim.locator, [self.sim.pressure], self._dp_points, self.comm)[0][:, 0]
            out["dp"] = float(p[0] - p[1])
        if self.sim.model.micro_rotation:
            local = np.abs(self.sim.micro_rotation.x.array).max(initial=0.0)
            out["omega_max"] = self.comm.allreduce(local, op=MPI.MAX)
        if self._exact is not None:
            t = self.sim.t
            for name, (field, interpolate, error, norm) in self._exact.items():
                field.interpolate(interpolate(t))
                e, n = (self.comm.allreduce(dolfinx.fem.assemble_scalar(f), op=MPI.SUM) for f in (error, norm))
                out[f"{name}_error"] = float(np.sqrt(e / n)) if n > 0 else float(np.sqrt(e))
        return out


def _exact_error_forms(sim) -> dict:
    """{name: (P4 field, t -> interpolation callable, form ‖f_h − f‖², form ‖f‖²)} for the relative L²
    errors against the scene's exact solution (the exact field interpolated in P4: its own error is
    O(h⁵), far below the P2 solution's O(h³))."""
    mesh, exact = sim.mesh, sim.exact
    gdim = mesh.geometry.dim
    pairs = [("velocity", sim.velocity, (gdim,), exact.velocity)]
    if sim.model.micro_rotation:
        pairs.append(("micro_rotation", sim.micro_rotation, (3,) if gdim == 3 else None, exact.micro_rotation))
    out = {}
    for name, numerical, shape, formula in pairs:
        field = dolfinx.fem.Function(compat.function_space(mesh, "Lagrange", 4, shape=shape))
        diff = numerical - field
        out[name] = (field, lambda t, formula=formula: (lambda x: formula(x, t)),
                     compat.form(ufl.inner(diff, diff) * ufl.dx), compat.form(ufl.inner(field, field) * ufl.dx))
    return out


def _point_A(sim):
    """Point A: the flag's tip (0.6, 0.2) for Turek–Hron; (length, thickness/2) for the flag alone."""
    if sim.scene.geometry.name == "turek_hron":
        return np.array(POINT_A["turek_hron"])
    if sim.scene.geometry.name == "turek_hron_3d":
        return np.array(sim.scene.geometry.describe()["points"]["A"])
    x = sim.mesh.geometry.x
    xmax = sim.comm.allreduce(x[:, 0].max(), op=MPI.MAX)
    ymax = sim.comm.allreduce(x[:, 1].max(), op=MPI.MAX)
    return np.array([xmax, 0.5 * ymax])


def _owned_node(sim, point):
    """Local index of the owned velocity node at ``point`` (a mesh vertex), or −1 on other ranks."""
    V = sim.velocity.function_space
    n_owned = V.dofmap.index_map.size_local
    x = V.tabulate_dof_coordinates()[:n_owned, :len(point)]
    dist = np.linalg.norm(x - point, axis=1) if n_owned else np.array([np.inf])
    i = int(np.argmin(dist))
    found = bool(dist[i] < 1e-10)
    if sim.comm.allreduce(int(found), op=MPI.SUM) != 1:
        raise RuntimeError(f"point A {tuple(point)} is not a vertex of the mesh")
    return i if found else -1
