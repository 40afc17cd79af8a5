"""Point location and the vectorised P2 evaluation used by the characteristics."""

import numpy as np
import pytest
from mpi4py import MPI

from cosserat_fsi import compat
from cosserat_fsi.geometry import SchaeferTurek, build_msh
from cosserat_fsi.points import _kernels, location
from cosserat_fsi.time_schemes.variable_step import BdfWeights
from cosserat_fsi.points.back_tracking_nodes import BackTrackingNodes
from cosserat_fsi.points.location import PointLocator, eval_at, evaluate, neighbour_table, probe

import dolfinx


def _mesh(tmp_path):
    path = build_msh(SchaeferTurek(), cache_dir=tmp_path) if MPI.COMM_WORLD.rank == 0 else None
    mesh, _, _ = compat.read_msh(MPI.COMM_WORLD.bcast(path), MPI.COMM_WORLD)
    return mesh


def test_vectorised_p2_evaluation_equals_function_eval(tmp_path):
    """eval_at (barycentric P2 basis) = dolfinx's Function.eval to round-off, scalar and vector."""
    mesh = _mesh(tmp_path)
    locator = PointLocator(mesh)
    rng = np.random.default_rng(0)
    points = np.zeros((400, 3))
    points[:, 0], points[:, 1] = rng.uniform(0, 2.2, 400), rng.uniform(0, 0.41, 400)
    cells = locator.locate(points)
    found = cells >= 0
    assert found.sum() > 0
    for shape, expr in (((2,), lambda x: np.vstack([np.sin(3 * x[0]) * x[1], x[0] ** 2 - x[1]])),
                        (None, lambda x: np.cos(2 * x[0] + x[1]))):
        f = dolfinx.fem.Function(compat.function_space(mesh, "Lagrange", 2, shape=shape))
        f.interpolate(expr)
        ours = eval_at(locator, f, points[found], cells[found])
        theirs = f.eval(points[found], cells[found]).reshape(found.sum(), -1)
        assert np.abs(ours - theirs).max() < 1e-12


def test_tree_shared_by_nearby_configurations(tmp_path):
    """PointLocator.tree is built once per mesh and serves configurations within its slack (padded
    boxes): located through it (no hint, so the tree path), each point of a moved configuration is in the
    cell found, and a point is found exactly when some cell contains it (brute force over all cells).
    A configuration beyond the slack gets a new tree, and locates as well."""
    mesh = _mesh(tmp_path)
    locator = PointLocator(mesh)
    first = locator.tree
    slack = location._TREES[mesh][1]
    X = mesh.geometry.x[:, :2].copy()
    rng = np.random.default_rng(1)
    points = np.zeros((400, 3))
    points[:, 0], points[:, 1] = rng.uniform(-0.05, 2.25, 400), rng.uniform(-0.05, 0.46, 400)
    all_cells = np.arange(len(locator.x0), dtype=np.int32)
    for scale, shared in ((0.9, True), (3.0, False)):
        wobble = scale * slack * np.column_stack([np.sin(40 * X[:, 1]), np.cos(30 * X[:, 0])])
        locator.update(X + wobble)
        assert (locator.tree is first) == shared
        cells = locator.locate(points)
        lam = np.array([location.barycentric(locator, np.repeat(p[None], len(all_cells), 0), all_cells)
                        for p in points])  # (points, 2, cells)
        inside = np.minimum(np.minimum(lam[:, 0], lam[:, 1]), 1 - lam[:, 0] - lam[:, 1]) >= -location._TOL
        found = cells >= 0
        assert found.sum() > 300
        assert np.array_equal(found, inside.any(axis=1))
        assert inside[np.flatnonzero(found), cells[found]].all()


def test_neighbour_table():
    """Two triangles sharing the edge (1, 2): each is the other's neighbour across it, opposite node 0 of
    the first and node 3 (local 1) of the second; the other edges are boundary (−1)."""
    table = neighbour_table(np.array([[0, 1, 2], [1, 3, 2], [4, 5, 6]], dtype=np.int32))
    assert table.tolist() == [[1, -1, -1], [-1, 0, -1], [-1, -1, -1]]


@pytest.mark.mpi
def test_compiled_backtracking_equals_numpy(tmp_path, monkeypatch):
    """The numba kernels locate the same cells and give the same values as the numpy reference, on the
    feet of a BDF2-like step (hint cells, feet in other cells, on other ranks, outside the domain and
    pulled back), at the P2 nodes (on edges and vertices: ties between cells) and for probes: cells identical,
    values equal to round-off (the kernels repeat the numpy operations in the same order, so in practice bit
    for bit). Serial and under 2 ranks."""
    if not _kernels.ENABLED:
        pytest.skip("numba not importable (or COSSERAT_FSI_NO_NUMBA=1): no compiled path to compare")
    comm = MPI.COMM_WORLD
    mesh = _mesh(tmp_path)
    V = compat.function_space(mesh, "Lagrange", 2, shape=(2,))
    S = compat.function_space(mesh, "Lagrange", 2)
    u, p = dolfinx.fem.Function(V), dolfinx.fem.Function(S)
    u.interpolate(lambda x: np.vstack([4 * x[1] * (0.41 - x[1]) / 0.41**2 + 0.3 * np.sin(7 * x[0]),
                                       0.5 * np.cos(5 * x[0] + 3 * x[1])]))
    p.interpolate(lambda x: np.exp(x[0]) * np.sin(4 * x[1]))
    chars = BackTrackingNodes(V, comm=comm)
    x, hint = chars.quadrature_nodes(4)
    h = 0.41 / 8  # ~ the cell size of level 0
    rng = np.random.default_rng(comm.rank)
    feet = x - 0.03 * np.hstack([chars.at_quadrature_nodes(u, 4), np.zeros((len(x), 1))])  # mostly near
    jump = rng.random(len(x)) < 0.1  # and 10 % anywhere within 3 cells, many across the walls
    feet[jump, :2] += rng.uniform(-3 * h, 3 * h, (jump.sum(), 2))
    fixed = np.array([[0.2, 0.2, 0.0], [1.0, 0.1, 0.0], [2.1, 0.4, 0.0], [0.2, 0.45, 0.0]])

    def run(compiled):
        monkeypatch.setattr(location, "COMPILED", compiled)
        loc = chars.locator
        return dict(cells=loc.locate(feet), nodes=loc.locate(chars.nodes()), hinted=loc.locate(feet, hint=hint),
                    owned=loc.locate(feet, owned_only=True, hint=hint),
                    values=evaluate(loc, [u, p], feet, x, comm, hint=hint),
                    probes=probe(loc, [u, p], fixed, comm))

    ref, ours = run(False), run(True)
    for key in ("cells", "nodes", "hinted", "owned"):
        assert np.array_equal(ref[key], ours[key]), key
    moved = ref["hinted"] != hint
    assert (ref["cells"] < 0).any() and moved.any()  # the cases are exercised
    walked = _kernels.walk(feet, hint, chars.locator.x0, chars.locator.Jinv_flat, chars.locator.neighbours,
                           1e-10, np.iinfo(np.int32).max, 64)
    assert (walked[moved] >= 0).mean() > 0.5  # most feet that left their cell are found by the walk
    for a, b in zip(ref["values"] + ref["probes"], ours["values"] + ours["probes"]):
        assert a.shape == b.shape and np.array_equal(np.isnan(a), np.isnan(b))
        assert np.nanmax(np.abs(a - b)) <= 1e-14 * np.nanmax(np.abs(a))


def _wobble(X, t):
    """An interior mesh motion of the unit square, zero on its boundary (as in test_fsi)."""
    bump = np.sin(np.pi * X[:, 0]) * np.sin(np.pi * X[:, 1])
    return 0.08 * np.sin(2 * np.pi * t / 0.2)[None] * np.column_stack([bump, -bump * X[:, 0]])


@pytest.mark.mpi
@pytest.mark.parametrize("ratio", [1.0, 0.6, 1.7])
@pytest.mark.parametrize("moving", [False, True], ids=["fixed", "moving"])
def test_fused_bdf2_history_equals_numpy(monkeypatch, moving, ratio):
    """The fused BDF2 kernel (histories.py → _kernels.bdf2_quadrature: u*, feet, both evaluations and
    a₁v₁ − a₂v₂ written into the quadrature functions) gives the numpy path's α h of u and ω to round-off
    (in practice bit for bit), on a fixed and on a moving mesh, at constant steps and at a step ratio
    ω = δt_n/δt_{n−1} ≠ 1 (u* = (1 + ω)u^n − ωu^{n−1}, the second foot δt_n + δt_{n−1}), with feet beyond the
    inflow (pulled back), and under 2 ranks on other ranks: the points the kernel's walks cannot finish take
    the general path."""
    if not _kernels.ENABLED:
        pytest.skip("numba not importable (or COSSERAT_FSI_NO_NUMBA=1): no compiled path to compare")
    from cosserat_fsi.app.runner import load_mesh
    from cosserat_fsi.config import validate_scene
    from cosserat_fsi.simulation import Simulation

    comm = MPI.COMM_WORLD
    scene = validate_scene({"geometry": {"name": "square", "level": 0}, "fluid": {"rho": 1.0, "mu": 0.01},
                            "inflow": {"u_mean": 1.0}, "micropolar": {"mu_r": 0.1, "lambda1": 0.01},
                            "time": {"dt": 0.05, "t_end": 0.2, "scheme": "characteristics2"}})
    sim = Simulation(scene, *load_mesh(scene, comm)[:3], comm, prescribed_motion=_wobble if moving else None)
    sim.run(3)
    stepper, h = sim.stepper, sim.stepper.histories
    statuses = []
    kernel = _kernels.bdf2_quadrature
    monkeypatch.setattr(_kernels, "bdf2_quadrature", lambda *a: statuses.append(kernel(*a)[0]) or kernel(*a))

    def history(compiled):
        monkeypatch.setattr(location, "COMPILED", compiled)
        for f in (h.velocity, h.micro_rotation):
            f.x.array[:] = np.nan
        h.update(BdfWeights(2, ratio * stepper.dt, ratio), stepper.state, stepper.solve_displacement)
        return [f.x.array.copy() for f in (h.velocity, h.micro_rotation)]

    ref, ours = history(False), history(True)
    assert len(statuses) == 1 and h.micro_rotation.function_space.dofmap.index_map_bs == 1  # fused, with ω
    status = statuses[0]
    assert comm.allreduce(int((status == 0).sum())) > 0.9 * comm.allreduce(len(status))
    assert comm.allreduce(int((status == 1).sum())) > 0  # feet that leave the local mesh: general path
    for a, b in zip(ref, ours):
        assert np.isfinite(a).all() and np.isfinite(b).all()
        assert np.abs(a - b).max() <= 1e-14 * np.abs(a).max()


@pytest.mark.parametrize("compiled", [False, True], ids=["numpy", "compiled"])
def test_feet_on_a_rotation(monkeypatch, compiled):
    """Solid-body rotation u = Ω(−(y − ½), x − ½) (steady, linear: P2 holds it exactly, so α h carries the
    feet without interpolation error): the exact feet are x rotated by −Ωδt and −2Ωδt about the centre.
    The feet are read back through the BDF2 history of ω: with ω^n = x (or y) and ω^{n−1} = 0 the history
    is 2X¹ₓ, with ω^n = 0 and ω^{n−1} = x it is −½X²ₓ. Over the points within 0.3 of the centre, for δt =
    0.04, 0.02, 0.01: the straight feet's error falls as δt² (the trajectory error per unit time, error/δt,
    as δt: first order); rates within ±0.1. (Midpoint feet, third order here, measured no better in CFD3
    and were removed: docs/perf_time_schemes.md, "Options removed (findings)".)"""
    if compiled and not _kernels.ENABLED:
        pytest.skip("numba not importable (or COSSERAT_FSI_NO_NUMBA=1)")
    from cosserat_fsi.app.runner import load_mesh
    from cosserat_fsi.config import validate_scene
    from cosserat_fsi.simulation import Simulation

    monkeypatch.setattr(location, "COMPILED", compiled)
    comm = MPI.COMM_WORLD
    scene = validate_scene({"geometry": {"name": "square", "level": 0}, "fluid": {"rho": 1.0, "mu": 0.01},
                            "inflow": {"u_mean": 1.0}, "micropolar": {"mu_r": 0.1, "lambda1": 0.01},
                            "time": {"dt": 0.01, "t_end": 0.2, "scheme": "characteristics2"}})
    sim = Simulation(scene, *load_mesh(scene, comm)[:3], comm)
    state, h = sim.stepper.state, sim.stepper.histories
    rate = 2.0  # Ω
    for f in (state.velocity, state.velocity_prev):
        f.interpolate(lambda X: np.vstack([-rate * (X[1] - 0.5), rate * (X[0] - 0.5)]))
    x = h.chars.quadrature_nodes(h.degree)[0][:, :2]
    inner = np.hypot(x[:, 0] - 0.5, x[:, 1] - 0.5) <= 0.3
    qdofs = h._quadrature_dofs(h.micro_rotation)

    def foot_errors(dt):
        bdf = BdfWeights(2, dt)
        feet = np.zeros((len(x), 2, 2))  # point, foot k = 1, 2, component
        for comp in (0, 1):
            for k, (now, before) in enumerate(((state.micro_rotation, state.micro_rotation_prev),
                                               (state.micro_rotation_prev, state.micro_rotation))):
                now.interpolate(lambda X, comp=comp: X[comp])
                before.x.array[:] = 0.0
                h.update(bdf, state)
                feet[:, k, comp] = h.micro_rotation.x.array[qdofs] / (2.0 if k == 0 else -0.5)
        errors = []
        for k in (1, 2):
            c, s = np.cos(-k * rate * dt), np.sin(-k * rate * dt)
            r = x - 0.5
            exact = 0.5 + np.column_stack([c * r[:, 0] - s * r[:, 1], s * r[:, 0] + c * r[:, 1]])
            errors.append(np.abs(feet[inner, k - 1] - exact[inner]).max(initial=0.0))
        return comm.allreduce(max(errors), op=MPI.MAX)

    dts = (0.04, 0.02, 0.01)
    e = [foot_errors(dt) for dt in dts]
    rates = np.log2(np.array(e[:-1]) / np.array(e[1:]))
    assert np.all(np.abs(rates - 2.0) <= 0.1), (e, rates)


def test_values_at_quadrature_nodes_compiled_equals_numpy(tmp_path, monkeypatch):
    """BackTrackingNodes.at_quadrature_nodes: the compiled kernel = the numpy sum (bit for bit), vector and
    scalar, and both = Function.eval at the quadrature points to round-off."""
    mesh = _mesh(tmp_path)
    V = compat.function_space(mesh, "Lagrange", 2, shape=(2,))
    S = compat.function_space(mesh, "Lagrange", 2)
    u, p = dolfinx.fem.Function(V), dolfinx.fem.Function(S)
    u.interpolate(lambda x: np.vstack([np.sin(3 * x[0]) * x[1], x[0] ** 2 - x[1]]))
    p.interpolate(lambda x: np.cos(2 * x[0] + x[1]))
    chars = BackTrackingNodes(V)
    x, cells = chars.quadrature_nodes(6)
    for f in (u, p):
        values = {}
        for compiled in ([False, True] if _kernels.ENABLED else [False]):
            monkeypatch.setattr(location, "COMPILED", compiled)
            values[compiled] = chars.at_quadrature_nodes(f, 6)
        assert all(np.array_equal(values[False], v) for v in values.values())
        assert np.abs(values[False] - f.eval(x, cells).reshape(len(x), -1)).max() < 1e-12
