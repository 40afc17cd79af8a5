"""Slip (u·n = 0, zero tangential traction) by Nitsche's method on oblique and curved boundaries.

Straight walls at 30°: plug flow and half-Poiseuille lie in P2 × P1, so the discrete solution is the exact
one (1e-9: Newton's tolerance) for both viscous forms, with micro-rotation, on the steady path and in every
time scheme (a plug accelerating as u = t t̂). Curved: an annulus with a rotating inner cylinder and slip on
the outer circle (closed forms), the measured convergence over three meshes. 3D: the Nitsche terms on an
oblique box. Bad slip scenes: tests/faults/test_scene_slip.py."""

from __future__ import annotations

import math

import numpy as np
import pytest
from mpi4py import MPI

from cosserat_fsi import compat
from cosserat_fsi.physics import fluid

import dolfinx
import ufl

C, S = math.cos(math.pi / 6), math.sin(math.pi / 6)  # the channel's direction t̂ = (C, S), 30°
# a 2 x 1 channel along t̂ (bottom wall through the origin), structured triangles
CHANNEL = f"""Point(1) = {{0, 0, 0}}; Point(2) = {{{2 * C}, {2 * S}, 0}};
Point(3) = {{{2 * C - S}, {2 * S + C}, 0}}; Point(4) = {{{-S}, {C}, 0}};
Line(1) = {{1, 2}}; Line(2) = {{2, 3}}; Line(3) = {{3, 4}}; Line(4) = {{4, 1}};
Curve Loop(1) = {{1, 2, 3, 4}}; Plane Surface(1) = {{1}};
Transfinite Curve{{1, 3}} = 9; Transfinite Curve{{2, 4}} = 5; Transfinite Surface{{1}};
Physical Surface("fluid") = {{1}};
Physical Curve("inlet") = {{4}}; Physical Curve("outlet") = {{2}};
Physical Curve("bottom") = {{1}}; Physical Curve("top") = {{3}};
"""
R1, R2 = 0.5, 1.0  # the annulus: inner cylinder turning at Ω = 1, slip on the outer circle
ANNULUS = f"""SetFactory("OpenCASCADE");
Disk(1) = {{0, 0, 0, {R2}}}; Disk(2) = {{0, 0, 0, {R1}}};
BooleanDifference(3) = {{Surface{{1}}; Delete;}}{{Surface{{2}}; Delete;}};
Mesh.MeshSizeMax = 0.2;
Physical Surface("fluid") = {{3}};
Physical Curve("outer") = {{1}}; Physical Curve("inner") = {{2}};
"""


def _run(tmp_path, geo: str, body: str, steps: int = 1, level: int = 0):
    from cosserat_fsi.app.runner import load_mesh
    from cosserat_fsi.config import load_scene
    from cosserat_fsi.simulation import Simulation

    comm = MPI.COMM_WORLD  # every rank its own tmp_path (under mpirun each rank runs pytest)
    (tmp_path / "m.geo").write_text(geo)
    (tmp_path / "scene.yaml").write_text(f"geometry: {{name: file, path: m.geo, level: {level}}}\n{body}")
    scene = load_scene(tmp_path / "scene.yaml")
    mesh, ct, ft, _ = load_mesh(scene, comm)
    sim = Simulation(scene, mesh, ct, ft, comm)
    sim.run(steps)
    return sim


def _l2(mesh, f) -> float:
    value = dolfinx.fem.assemble_scalar(compat.form(ufl.inner(f, f) * ufl.dx(domain=mesh)))
    return math.sqrt(mesh.comm.allreduce(value, op=MPI.SUM))


def _max_error(sim, exact_u) -> float:
    """max |u − exact| over the velocity dofs (all ranks)."""
    V = sim.velocity.function_space
    x = V.tabulate_dof_coordinates()
    values = sim.velocity.x.array.reshape(-1, 2) - np.array([exact_u(p) for p in x])
    return sim.mesh.comm.allreduce(float(np.abs(values).max(initial=0.0)), op=MPI.MAX)


PLUG = {"laplacian": "fluid: {rho: 1.0, mu: 1.0}\n",
        "symmetric": "fluid: {rho: 1.0, mu: 1.0, viscous_form: symmetric}\n",
        "micropolar": "fluid: {rho: 1.0, mu: 1.0}\nmicropolar: {mu_r: 0.5, lambda1: 0.1}\n"}


@pytest.mark.mpi
@pytest.mark.parametrize("fluid_section", PLUG.values(), ids=PLUG)
def test_plug_flow_in_an_oblique_channel(tmp_path, fluid_section):
    """Slip on both walls of a channel at 30°, u = t̂ at inlet and outlet, a body force n̂ = (−sin 30°, cos 30°)
    across it: u = t̂ and the hydrostatic p = η + const (η = x·n̂), ω = 0. The walls
    carry the normal stress −p: with the natural condition instead of slip the flow would turn."""
    body = fluid_section.replace("mu: 1.0", f"mu: 1.0, body_force: [{-S}, {C}]")
    micro = ", micro_rotation: free" if "micropolar" in fluid_section else ""  # ω = 0 solves it either way
    sim = _run(tmp_path, CHANNEL, body + "time: {scheme: steady}\n"
               f"boundaries: {{inlet: {{type: velocity, value: [{C}, {S}]{micro}}}, "
               f"outlet: {{type: velocity, value: [{C}, {S}]{micro}}}, bottom: {{type: slip}}, top: {{type: slip}}}}\n")
    assert _max_error(sim, lambda p: (C, S)) < 1e-9
    Q = sim.pressure.function_space
    eta = Q.tabulate_dof_coordinates() @ np.array([-S, C, 0.0])
    diff, comm = sim.pressure.x.array - eta, sim.mesh.comm  # p − η: a constant (the penalty's, ~1e-5)
    spread = comm.allreduce(float(diff.max(initial=-np.inf)), op=MPI.MAX) - comm.allreduce(
        float(diff.min(initial=np.inf)), op=MPI.MIN)
    assert spread < 1e-8
    if sim.micro_rotation is not None:
        assert sim.mesh.comm.allreduce(float(np.abs(sim.micro_rotation.x.array).max()), op=MPI.MAX) < 1e-9


def _half_poiseuille(p):
    """u = ½ η(2 − η) t̂, η = the distance from the bottom wall (no-slip; slip on the top, η = 1)."""
    eta = -S * p[0] + C * p[1]
    speed = 0.5 * eta * (2 - eta)
    return speed * C, speed * S


def test_half_poiseuille_in_an_oblique_channel_laplacian(tmp_path):
    """Traction 2 t̂ at the inlet (p = 2), do-nothing outlet, μ = 1, no-slip bottom, slip top: the pressure
    gradient 1 along t̂ gives u = ½ η(2 − η) t̂ (test_boundaries.py's channel turned by 30°): 1e-9."""
    sim = _run(tmp_path, CHANNEL, PLUG["laplacian"] + "time: {scheme: steady}\n"
               f"boundaries: {{inlet: {{type: traction, value: [{2 * C}, {2 * S}]}}, outlet: {{type: do_nothing}}, "
               "bottom: {type: no_slip}, top: {type: slip}}\n")
    assert _max_error(sim, _half_poiseuille) < 1e-9


def test_half_poiseuille_in_an_oblique_channel_symmetric(tmp_path):
    """The same flow with the symmetric form (its natural traction ν Du n: slip's tangential part is
    ν(∂u_t/∂n + ∂u_n/∂t), zero on the straight top wall), the exact profile at both ends: 1e-9."""
    profile = [f"0.5*(-{S}*x + {C}*y)*(2 - (-{S}*x + {C}*y))*{c}" for c in (C, S)]
    sim = _run(tmp_path, CHANNEL, PLUG["symmetric"] + "time: {scheme: steady}\n"
               f"boundaries: {{inlet: {{type: velocity, value: {profile}}}, "
               f"outlet: {{type: velocity, value: {profile}}}, bottom: {{type: no_slip}}, top: {{type: slip}}}}\n")
    assert _max_error(sim, _half_poiseuille) < 1e-9


@pytest.mark.mpi
@pytest.mark.parametrize("scheme", ["characteristics1", "characteristics2", "ale_bdf2", "generalized_alpha"])
def test_accelerating_plug_in_every_time_scheme(tmp_path, scheme):
    """u = t t̂ at the inlet, slip walls, from rest: the plug u = t t̂ with p = ρ(2 − s) (s along t̂) solves
    the Navier–Stokes equations and is linear in t and x: every scheme holds it exactly (two steps)."""
    sim = _run(tmp_path, CHANNEL, PLUG["laplacian"] + f"time: {{scheme: {scheme}, dt: 0.1, t_end: 0.2}}\n"
               "output: {progress: false}\n"
               f"boundaries: {{inlet: {{type: velocity, value: ['{C}*t', '{S}*t']}}, outlet: {{type: do_nothing}}, "
               "bottom: {type: slip}, top: {type: slip}}\n", steps=2)
    assert sim.state.t == pytest.approx(0.2)
    assert _max_error(sim, lambda p: (0.2 * C, 0.2 * S)) < 1e-9


@pytest.mark.mpi
@pytest.mark.parametrize("viscous_form, bounds, rates", [("laplacian", (1.3e-2, 3.5e-3, 1.0e-3), (1.7, 2.3)),
                                                         ("symmetric", (1e-4, 5e-6, 5e-7), (2.0, 6.0))])
def test_couette_with_a_slip_outer_circle_converges(tmp_path, viscous_form, bounds, rates):
    """Inner cylinder r = 1/2 turning at Ω = 1 (u = Ω × x), slip on the circle r = 1. Its tangential traction
    is the weak form's: laplacian μ ∂u_θ/∂r = 0 gives u_θ = A r + B/r with A = B = 0.2 (A − B = 0 at r = 1,
    A/2 + 2B = 1/2); symmetric μ r ∂(u_θ/r)/∂r = 0 gives the rigid rotation u_θ = r.

    The mesh's circles are polygons: with the facet normals the error fell only as O(h) (laplacian 6.3e-2,
    3.7e-2, 1.9e-2); with the vertex-averaged normal (problem/slip_normal.py) measured over h = 0.2, 0.1, 0.05:
    laplacian 1.14e-2, 3.0e-3, 8.0e-4 (rate 1.9, the inner polygon's O(h²)), symmetric 3.7e-5, 1.5e-6,
    1.4e-7 (the rigid rotation is tangent to the averaged normal on every chord). u·n_h on the outer polygon
    (the chords' own normals) goes to 0 as h."""
    body = (f"fluid: {{rho: 1.0, mu: 1.0, viscous_form: {viscous_form}}}\ntime: {{scheme: steady}}\n"
            "boundaries: {inner: {type: velocity, value: ['-y', 'x']}, outer: {type: slip}}\n")
    A, B = (0.2, 0.2) if viscous_form == "laplacian" else (1.0, 0.0)
    errors, normal = [], []
    for level in range(3):
        folder = tmp_path / str(level)
        folder.mkdir()
        sim = _run(folder, ANNULUS, body, level=level)
        x = ufl.SpatialCoordinate(sim.mesh)
        r = ufl.sqrt(ufl.dot(x, x))
        speed = A * r + B / r
        errors.append(_l2(sim.mesh, sim.velocity - ufl.as_vector((-speed * x[1] / r, speed * x[0] / r))))
        ds = ufl.Measure("ds", domain=sim.mesh, subdomain_data=sim.problem.facet_tags)
        flux = ufl.dot(sim.velocity, ufl.FacetNormal(sim.mesh)) ** 2 * ds(sim.problem.facet_ids["outer"])
        normal.append(math.sqrt(sim.mesh.comm.allreduce(dolfinx.fem.assemble_scalar(compat.form(flux)), op=MPI.SUM)))
    measured = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert all(e < b for e, b in zip(errors, bounds)), errors
    assert rates[0] < measured[0] < rates[1] and rates[0] < measured[1] < rates[1], (errors, measured)
    assert normal[2] < normal[1] < normal[0] and normal[2] < 0.05, normal


def _oblique_box(comm, n=(4, 2, 2)):
    """A 2 x 1 x 1 box turned by 30° about z, then 20° about x; facets tagged by their reference plane:
    1 inlet, 2 outlet, 3 bottom, 4 top, 5 the sides. Returns (mesh, facet tags, t̂, ∇η)."""
    mesh = dolfinx.mesh.create_box(comm, [np.zeros(3), np.array([2.0, 1.0, 1.0])], list(n),
                                   dolfinx.mesh.CellType.tetrahedron)
    fdim = mesh.topology.dim - 1
    planes = [(1, lambda x: np.isclose(x[0], 0)), (2, lambda x: np.isclose(x[0], 2)),
              (3, lambda x: np.isclose(x[1], 0)), (4, lambda x: np.isclose(x[1], 1)),
              (5, lambda x: np.isclose(x[2], 0) | np.isclose(x[2], 1))]
    found = {tag: dolfinx.mesh.locate_entities_boundary(mesh, fdim, where) for tag, where in planes}
    for tag in (3, 4, 5):  # the walls win over inlet/outlet at edges only through their own facets
        found[tag] = np.setdiff1d(found[tag], np.concatenate([found[1], found[2]]))
    indices = np.concatenate(list(found.values()))
    values = np.concatenate([np.full(len(v), t, dtype=np.int32) for t, v in found.items()])
    order = np.argsort(indices)
    tags = dolfinx.mesh.meshtags(mesh, fdim, indices[order].astype(np.int32), values[order])
    a, b = math.radians(30), math.radians(20)
    Rz = np.array([[math.cos(a), -math.sin(a), 0], [math.sin(a), math.cos(a), 0], [0, 0, 1]])
    Rx = np.array([[1, 0, 0], [0, math.cos(b), -math.sin(b)], [0, math.sin(b), math.cos(b)]])
    R = Rx @ Rz
    mesh.geometry.x[:] = mesh.geometry.x @ R.T
    return mesh, tags, R[:, 0], R[:, 1]


@pytest.mark.mpi
@pytest.mark.parametrize("viscous_form", ["laplacian", "symmetric"])
def test_half_poiseuille_in_an_oblique_box_3d(viscous_form):
    """Stokes in a box turned about two axes: no-slip bottom, slip (Nitsche) on the top and both sides, the
    exact u = ½ η(2 − η) t̂ on inlet and outlet, μ = 1 and the force t̂ per volume: it is the solution (u·n = 0
    and zero tangential traction on the top and the sides), and it lies in P2: 1e-10."""
    from cosserat_fsi.solvers.newton import Newton
    from cosserat_fsi.problem.spaces import mixed_space

    comm = MPI.COMM_WORLD
    mesh, tags, t, g = _oblique_box(comm)
    space = mixed_space(mesh, False)
    w = dolfinx.fem.Function(space.W)
    u, p = ufl.split(w)
    v, q = ufl.TestFunctions(space.W)
    one = dolfinx.fem.Constant(mesh, 1.0)
    force = dolfinx.fem.Constant(mesh, np.ascontiguousarray(t, dtype=float))
    dx, ds = ufl.dx(domain=mesh), ufl.Measure("ds", domain=mesh, subdomain_data=tags)
    F = (fluid.momentum_residual(u, p, v, rho=one, acceleration=ufl.zero(3), mu=one, body_force=force, dx=dx,
                                 viscous_form=viscous_form)
         + fluid.continuity_residual(u, p, q, penalty=dolfinx.fem.Constant(mesh, 1e-10), dx=dx)
         + fluid.nitsche_slip(u, p, v, q, viscosity=one, viscous_form=viscous_form, ds=ds((4, 5)), mesh=mesh))

    def exact(x):
        eta = g @ x
        return np.outer(t, 0.5 * eta * (2 - eta))

    V = space.space("velocity")
    data = dolfinx.fem.Function(V)
    data.interpolate(exact)
    dofs = dolfinx.fem.locate_dofs_topological((space.sub("velocity"), V), 2, tags.indices[tags.values <= 3])
    bc = dolfinx.fem.dirichletbc(data, dofs, space.sub("velocity"))
    report = Newton(F, w, [bc], comm).solve()
    assert report.converged
    uh = dolfinx.fem.Function(V)
    uh.x.array[:] = w.x.array[space.dofs("velocity")]
    error = comm.allreduce(float(np.abs(uh.x.array - data.x.array).max()), op=MPI.MAX)
    assert error < 1e-10, error
