"""Automatic remeshing: what must hold across a remesh.

The Turek–Hron flag (L0, BDF2) is bent in pure bending to a tip deflection of 12 cm (campaigns/mesh_motion.py;
the biharmonic extension's minimum cell quality is then 0.28) and the mesh is remeshed:
- the solid cells are kept (same vertices), the new fluid cells are better (quality > 0.5);
- a translating free stream (u, u^{n−1}, d, d^{n−1} uniform, p linear) arrives to round-off (P2/P1 are exact);
- the mesh displacement levels are relative to the new mesh (zero for a mesh that did not move since);
- a smooth flow arrives to interpolation accuracy: the kinetic energy jumps by < 1e-4 (relative), the
  outlet flux (its edges are kept) by < 1e-12, ∫ div u over the fluid changes by < 1e-3 of ∫ |∇u|;
- a resting flag remeshed mid-run stays at rest (1e-12) and the run goes on.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest
from mpi4py import MPI

from cosserat_fsi.app.runner import load_mesh
from cosserat_fsi.config import validate_scene
from cosserat_fsi.simulation import Simulation

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "campaigns"))
import mesh_motion as campaign  # noqa: E402

SCENE = {"geometry": {"name": "turek_hron", "level": 0, "flag": "solid"}, "fluid": {"rho": 1000.0, "mu": 1.0},
         "solid": {"rho": 1000.0, "mu_s": 5e5, "mesh_motion": {"remesh": {"quality": 0.1}}},
         "inflow": {"u_mean": 0.0}, "time": {"dt": 0.01, "t_end": 0.1, "scheme": "characteristics2"}}


def _simulation(scene=SCENE) -> Simulation:
    comm = MPI.COMM_WORLD
    scene = validate_scene(scene)
    return Simulation(scene, *load_mesh(scene, comm)[:3], comm)


def _bend(sim, delta: float = 0.12) -> np.ndarray:
    """Bend the flag (the mesh follows by the mesh motion); the levels as if it had been bent for long."""
    m, state = sim.motion, sim.state
    points = np.zeros((len(m.displacement.x.array) // 2, 2))
    points[m.node_dof[: len(m.X0)]] = m.X0
    total = m.extend(campaign.bending(points, delta).ravel())
    m.place(total, 0.0)
    m.displacement.x.array[:] = total
    for level in (state.mesh_displacement_prev, state.configuration_n, state.configuration_nm1):
        level.x.array[:] = total
    sim.stepper.histories.relocate(m, state)
    return total


def _max(comm, a) -> float:
    return comm.allreduce(float(np.abs(a).max(initial=0.0)), op=MPI.MAX)


def _integral(sim, integrand) -> float:
    import dolfinx
    import ufl

    from cosserat_fsi import compat
    from cosserat_fsi.tags import FLUID

    dx = ufl.dx(domain=sim.mesh, subdomain_data=sim.cell_tags)
    return sim.comm.allreduce(dolfinx.fem.assemble_scalar(compat.form(integrand(dx(FLUID)))), op=MPI.SUM)


def _ds(sim, name):
    import ufl

    return ufl.ds(domain=sim.mesh, subdomain_data=sim.facet_tags)(sim.problem.facet_ids[name])


FREE_STREAM = {"u_n": (1.5, -0.25), "u_nm1": (1.25, -0.5), "d_n": (0.01, 0.02), "d_nm1": (0.015, 0.01)}


@pytest.mark.mpi
def test_remesh_keeps_the_solid_and_carries_a_free_stream_exactly():
    sim = _simulation()
    comm = sim.comm
    _bend(sim)
    before = sim.motion.min_fluid_quality
    solid_before = _solid_cells(sim)
    functions = sim.state.functions()
    for name, value in FREE_STREAM.items():
        functions[name].interpolate(lambda x, v=value: np.outer(v, np.ones(x.shape[1])))
    sim.state.pressure.interpolate(lambda x: 3.0 - 2.0 * x[0] + 0.5 * x[1])
    sim.state.t, sim.state.step_count = 0.5, 50
    record = sim.remesh("test")
    assert before < 0.3 and record["quality_before"] == before and record["quality_after"] > 0.5
    assert (sim.t, sim.step_count, len(sim.remeshes)) == (0.5, 50, 1)
    assert _solid_cells(sim) == solid_before  # the solid keeps its cells
    functions = sim.state.functions()
    for name, value in FREE_STREAM.items():
        assert _max(comm, functions[name].x.array.reshape(-1, 2) - value) < 1e-12, name
    x = sim.state.pressure.function_space.tabulate_dof_coordinates()
    assert _max(comm, sim.state.pressure.x.array - (3.0 - 2.0 * x[:, 0] + 0.5 * x[:, 1])) < 1e-12
    for name in ("mesh_displacement", "solid_displacement", "mesh_displacement_prev", "mesh_displacement_n",
                 "mesh_displacement_nm1"):
        assert _max(comm, functions[name].x.array) < 1e-12, name


def _solid_cells(sim) -> list:
    """The solid triangles as sorted vertex coordinates (all ranks), rounded to 1e-12."""
    from cosserat_fsi import compat
    from cosserat_fsi.tags import SOLID

    n = compat.num_owned_cells(sim.mesh)
    cells = sim.cell_tags.indices[(sim.cell_tags.values == SOLID) & (sim.cell_tags.indices < n)]
    x = sim.mesh.geometry.x[compat.geometry_dofmap(sim.mesh)[cells, :3], :2]
    local = [tuple(sorted(tuple(np.round(p, 12)) for p in c)) for c in x]
    return sorted(t for part in sim.comm.allgather(local) for t in part)


@pytest.mark.mpi
def test_remesh_carries_a_smooth_flow_to_interpolation_accuracy():
    import ufl

    sim = _simulation()
    _bend(sim)
    flow = lambda x: np.vstack([x[1] * (0.41 - x[1]) * (1 + np.sin(3 * x[0])), 0.1 * np.cos(2 * x[0]) * x[1]])  # noqa: E731
    sim.state.velocity.interpolate(flow)

    def measures(sim):
        u = sim.state.velocity
        kinetic = _integral(sim, lambda dx: ufl.inner(u, u) * dx)
        div = _integral(sim, lambda dx: ufl.div(u) * dx)
        grad = _integral(sim, lambda dx: ufl.sqrt(ufl.inner(ufl.grad(u), ufl.grad(u))) * dx)
        import dolfinx

        from cosserat_fsi import compat

        n = ufl.FacetNormal(sim.mesh)
        flux = sim.comm.allreduce(dolfinx.fem.assemble_scalar(compat.form(ufl.inner(u, n) * _ds(sim, "outlet"))),
                                  op=MPI.SUM)
        return kinetic, div, grad, flux

    k0, div0, grad0, flux0 = measures(sim)
    sim.remesh("test")
    k1, div1, grad1, flux1 = measures(sim)
    assert abs(k1 - k0) < 1e-4 * k0, (k0, k1)
    assert abs(flux1 - flux0) < 1e-12 * abs(flux0), (flux0, flux1)
    assert abs(div1 - div0) < 1e-3 * grad0, (div0, div1, grad0)


SVK = {**SCENE, "solid": {**SCENE["solid"], "law": "saint_venant_kirchhoff", "lambda_s": 2e6}}


@pytest.mark.mpi
@pytest.mark.parametrize("scene", [SCENE, SVK], ids=["incompressible", "saint_venant_kirchhoff"])
def test_resting_flag_remeshed_mid_run_stays_at_rest(scene):
    """A flag at rest in fluid at rest, remeshed mid-run: every field stays 0 (with a compressible solid the
    remeshed run also rebuilds its pressure condition)."""
    sim = _simulation(scene)
    sim.run(3)
    _bend(sim, 0.05)
    sim.remesh("test")
    sim.run(6)
    assert sim.step_count == 6 and len(sim.remeshes) == 1
    for name, f in sim.state.functions().items():
        if not name.startswith("mesh_displacement") and name not in ("solid_displacement", "mesh_size"):
            assert _max(sim.comm, f.x.array) < 1e-12, name


@pytest.mark.mpi
def test_a_named_solid_point_follows_the_material_across_a_remesh():
    """``observables.solid_points`` are material points: after a remesh (whose mesh's reference is the bent
    configuration) the point is found where it is now, not at its named reference coordinates."""
    from cosserat_fsi.geometry import build_msh
    from cosserat_fsi.observables import Observables

    comm = MPI.COMM_WORLD
    preset = validate_scene(SCENE)
    msh = comm.bcast(str(build_msh(preset.geometry)) if comm.rank == 0 else None, root=0)
    scene = {**SCENE, "inflow": None, "geometry": {"name": "file", "path": msh},  # the same mesh, named parts
             "boundaries": {"inlet": {"type": "no_slip"}, "outlet": {"type": "do_nothing"},
                            "walls": {"type": "no_slip"}, "cylinder": {"type": "no_slip"}},
             "observables": {"forces": ["cylinder"], "solid_points": {"tip": [0.6, 0.2]}}}
    sim = _simulation(scene)
    observables = Observables(sim)
    _bend(sim)
    sim.displacement.interpolate(sim.motion.displacement)  # the solid's displacement = its mesh's
    before = np.array(observables.solid_points_now()["tip"])
    assert before[1] - 0.2 > 0.1  # the bent tip
    sim.remesh()
    carried = Observables(sim, observables.point_A_now(), observables.solid_points_now())
    assert np.abs(np.array(carried.solid_points_now()["tip"]) - before).max() < 1e-12
    values = carried.evaluate()
    assert abs(values["uy_tip"] - (before[1] - 0.2)) < 1e-10 and abs(values["ux_tip"] - (before[0] - 0.6)) < 1e-10
    naive = Observables(sim)  # looked up at the named coordinates on the new mesh: another point
    assert np.linalg.norm(np.array(naive.solid_points_now()["tip"]) - before) > 0.02  # 4.4 cm off


RUN = {**SCENE, "solid": {"rho": 1000.0, "mu_s": 5.0e4,
                          "mesh_motion": {"remesh": {"quality": 0.95, "max_count": 2}}},  # remeshes at steps 1, 2
       "inflow": {"u_mean": 1.0, "ramp_time": 0.05}, "time": {"dt": 0.01, "t_end": 0.08, "scheme": "characteristics2"},
       "solver": {"reuse_factorization": False},  # a restart refactorises: exact LU on both sides
       "output": {"every": 1, "checkpoint_every": 4, "progress": False}}


@pytest.fixture(scope="module")
def remeshed_runs(tmp_path_factory):
    """The run above, and a copy restarted from its checkpoint of step 4 (after both remeshes)."""
    import shutil
    import tempfile

    from test_restart import cut_at_checkpoint, run_keeping_checkpoint

    from cosserat_fsi.app.runner import run_scene

    comm = MPI.COMM_WORLD
    root = Path(comm.bcast(tempfile.mkdtemp() if comm.rank == 0 else None, root=0))
    full, cut = root / "full", root / "cut"
    if comm.rank == 0:
        full.mkdir()
    comm.barrier()
    scene = validate_scene(RUN)
    kept = run_keeping_checkpoint(scene, full, comm, 4)  # the run's last checkpoint is of its last step
    if comm.rank == 0:
        meta, lines = cut_at_checkpoint(full, cut, kept)
        assert meta["step"] == 4 and meta["mesh"] == "meshes/remesh_002.msh" and len(meta["remeshes"]) == 2
        (cut / "timeseries.csv").write_text("".join(lines[: meta["rows"] + 1]))
    comm.barrier()
    run_scene(scene, cut, comm, progress=False, restart=True)
    yield full, cut
    comm.barrier()
    if comm.rank == 0:
        shutil.rmtree(root)


@pytest.mark.mpi
def test_restart_after_a_remesh_reproduces_the_uninterrupted_run(remeshed_runs):
    import json

    from cosserat_fsi.io import read_timeseries

    full, cut = remeshed_runs
    if MPI.COMM_WORLD.rank != 0:
        return
    a, b = read_timeseries(full / "timeseries.csv"), read_timeseries(cut / "timeseries.csv")
    assert list(a) == list(b) and len(a["t"]) == len(b["t"]) == 8
    for key in a:
        scale = max(np.abs(a[key]).max(), 1e-30)
        assert np.abs(a[key] - b[key]).max() <= 1e-10 * scale, key
    for run in (full, cut):
        summary = json.loads((run / "summary.json").read_text())
        assert summary["status"] == "completed" and summary["remeshes"]["count"] == 2
        event = summary["remeshes"]["events"][0]
        assert event["t"] == pytest.approx(0.01) and event["quality_after"] > 0.5 and event["seconds"] > 0


def test_the_fields_show_the_run_across_remeshes(remeshed_runs):
    """VTK's XDMF reader (what ParaView uses): 9 steps, a new mesh from step 1 on, point A where
    timeseries.csv says it is, for the uninterrupted and the restarted run."""
    import pyvista as pv

    from cosserat_fsi.io import read_timeseries

    for run in remeshed_runs:
        reader = pv.get_reader(str(run / "fields.xdmf"))
        times, points, positions = list(reader.time_values), [], []
        for t in times:
            reader.set_active_time_value(t)
            mesh = reader.read()
            mesh = mesh[0] if isinstance(mesh, pv.MultiBlock) else mesh
            x = np.asarray(mesh.points)[:, :2]
            points.append(len(x))
            ts = read_timeseries(run / "timeseries.csv")
            k = len(positions)
            a = np.array([0.6, 0.2]) + (np.array([ts["ux_A"][k - 1], ts["uy_A"][k - 1]]) if k else 0.0)
            positions.append(np.linalg.norm(x - a, axis=1).min())
            assert np.isfinite(mesh.point_data["velocity"]).all()
        np.testing.assert_allclose(times, np.arange(9) * 0.01, atol=1e-12)
        assert points[0] != points[1] != points[2] and points[2] == points[-1]  # the remeshes of steps 1, 2
        assert max(positions) < 1e-12, positions


PVSCRIPT = r"""
import json, sys
import numpy as np
from paraview.simple import OpenDataFile
from paraview import servermanager
from vtk.util.numpy_support import vtk_to_numpy
reader = OpenDataFile(sys.argv[1])
expected = json.loads(open(sys.argv[2]).read())
out = {"times": list(reader.TimestepValues), "points": [], "A": []}
for t, a in zip(out["times"], expected):
    reader.UpdatePipeline(t)
    data = servermanager.Fetch(reader)
    if data.IsA("vtkMultiBlockDataSet"):
        data = data.GetBlock(0)
    x = vtk_to_numpy(data.GetPoints().GetData())[:, :2]
    out["points"].append(len(x))
    out["A"].append(float(np.linalg.norm(x - a, axis=1).min()))
print("JSON" + json.dumps(out))
"""


@pytest.mark.slow
@pytest.mark.skipif(__import__("shutil").which("pvpython") is None, reason="pvpython (python3-paraview) missing")
def test_pvpython_shows_the_run_across_remeshes(remeshed_runs, tmp_path):
    import json
    import subprocess

    from cosserat_fsi.io import read_timeseries

    if MPI.COMM_WORLD.rank != 0:
        return
    full = remeshed_runs[0]
    ts = read_timeseries(full / "timeseries.csv")
    expected = [[0.6, 0.2]] + [[0.6 + x, 0.2 + y] for x, y in zip(ts["ux_A"], ts["uy_A"])]
    (tmp_path / "a.json").write_text(json.dumps(expected))
    (tmp_path / "read.py").write_text(PVSCRIPT)
    proc = subprocess.run(["pvpython", "--force-offscreen-rendering", str(tmp_path / "read.py"),
                           str(full / "fields.xdmf"), str(tmp_path / "a.json")],
                          capture_output=True, text=True, timeout=300)
    line = [x for x in proc.stdout.splitlines() if x.startswith("JSON")]
    assert proc.returncode == 0 and line, proc.stdout + proc.stderr
    out = json.loads(line[0][4:])
    np.testing.assert_allclose(out["times"], np.arange(9) * 0.01, atol=1e-12)
    points = out["points"]
    assert points[0] != points[1] != points[2] and points[2] == points[-1]
    assert max(out["A"]) < 1e-12, out["A"]


@pytest.mark.mpi
@pytest.mark.two_ranks
def test_remeshing_run_serial_equals_parallel(tmp_path_factory):
    """The run with two remeshes on COMM_WORLD (2 ranks under mpirun) = on COMM_SELF: rank 0 meshes the same
    fluid whatever the partition, so the time series agree to round-off."""
    import shutil
    import tempfile

    from cosserat_fsi.app.runner import run_scene
    from cosserat_fsi.io import read_timeseries

    comm = MPI.COMM_WORLD
    root = Path(comm.bcast(tempfile.mkdtemp() if comm.rank == 0 else None, root=0))
    scene = validate_scene({**RUN, "time": {**RUN["time"], "t_end": 0.04}})
    if comm.rank == 0:
        (root / "world").mkdir()
        (root / "self").mkdir()
        run_scene(scene, root / "self", MPI.COMM_SELF, progress=False)
    comm.barrier()
    run_scene(scene, root / "world", comm, progress=False)
    problem = None  # decided on rank 0, asserted on every rank: a failure must not leave rank 1 in a barrier
    if comm.rank == 0:
        a, b = read_timeseries(root / "self" / "timeseries.csv"), read_timeseries(root / "world" / "timeseries.csv")
        if not len(a["t"]) == len(b["t"]) == 4:
            problem = f"lengths {len(a['t'])}, {len(b['t'])}"
        for key in a if problem is None else ():
            # forces: relative to the force's size (lift is a small difference of drag-sized traction sums,
            # so its round-off between partitions is ~1e-10 of the drag, ~1e-7 of the lift itself)
            forces = key.startswith(("drag", "lift")) and "drag" in a and "lift" in a
            scale = max(np.hypot(a["drag"], a["lift"]).max() if forces else np.abs(a[key]).max(), 1e-30)
            if np.abs(a[key] - b[key]).max() > 1e-8 * scale + 1e-12:  # + round-off floor (tip motion ~1e-5 m)
                problem = f"{key}: {np.abs(a[key] - b[key]).max():.3e} > 1e-8 × {scale:.3e} + 1e-12"
                break
        shutil.rmtree(root)
    problem = comm.bcast(problem, root=0)
    assert problem is None, problem
