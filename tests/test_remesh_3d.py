"""Automatic remeshing in 3D (tetrahedra): what must hold across a remesh.

The flag of ``turek_hron_3d`` (level 0) is bent up by 5 cm at its tip and twisted (the mesh follows by the
biharmonic extension; minimum fluid cell quality 0.24 → 0.12) and the fluid is meshed anew:
- every solid tetrahedron is kept (same count, same node coordinates), and so is every tagged facet (the
  same triangles per tag, the same area per tag to 1e-12): the fluid's volume is the same to 1e-12;
- the new fluid cells are better than the bent ones;
- a field linear in x (P2 velocity, P1 pressure) arrives exactly (1e-12).
A short FSI run that remeshes at steps 1 and 2 gives the same time series on 1 and 2 ranks (1e-8), and its
restart from the checkpoint after both remeshes reproduces the uninterrupted run (1e-10).
"""

from __future__ import annotations

import shutil
import tempfile
from pathlib import Path

import numpy as np
import pytest
from mpi4py import MPI

from cosserat_fsi import compat
from cosserat_fsi.app.runner import load_mesh
from cosserat_fsi.config import validate_scene
from cosserat_fsi.tags import FLUID, SOLID

import dolfinx

SCENE = {"geometry": {"name": "turek_hron_3d", "level": 0}, "fluid": {"rho": 1000.0, "mu": 1.0},
         "solid": {"rho": 1000.0, "mu_s": 5e5, "mesh_motion": {"remesh": {"quality": 0.2}}},
         "inflow": {"u_mean": 0.2}, "time": {"dt": 0.01, "t_end": 0.05, "scheme": "characteristics2"}}


def _bent(comm):
    """The scene's mesh with the flag bent up (tip +5 cm) and twisted by the mesh motion."""
    from cosserat_fsi.mesh.motion import MeshMotion

    scene = validate_scene(SCENE)
    mesh, cell_tags, facet_tags, _ = load_mesh(scene, comm)
    motion = MeshMotion(mesh, cell_tags, comm, **scene.solid.mesh_motion.options(), mesh_sizes=True)
    motion.measure_quality()
    rest = motion.min_fluid_quality
    bend = lambda x: np.clip((x[0] - 0.2485) / 0.3515, 0, 1) ** 2  # noqa: E731
    velocity = dolfinx.fem.Function(motion.M)
    velocity.interpolate(lambda x: np.vstack([-0.005 * bend(x), 0.08 * bend(x), 0.1 * bend(x) * (x[1] - 0.2)]))
    motion.move(velocity, 1.0, 0.0)
    return scene, mesh, cell_tags, facet_tags, motion, rest


def _owned(mesh, tags, value):
    n = compat.num_owned_cells(mesh)
    return tags.indices[(tags.values == value) & (tags.indices < n)]


def _sorted_points(simplices: np.ndarray) -> np.ndarray:
    """Each simplex's points in lexicographic order (of their coordinates to 1e-9: the .msh file keeps 16
    digits, so a coordinate read back may differ in its last bit), one row per simplex."""
    keys = np.round(simplices, 9)
    return np.array([p[np.lexsort(k.T[::-1])] for p, k in zip(simplices, keys)]).reshape(len(simplices), -1)


def _solid_cells(mesh, cell_tags, comm) -> np.ndarray:
    """The solid tetrahedra (all ranks) as their sorted node coordinates, in a partition-free order."""
    x = mesh.geometry.x[compat.geometry_dofmap(mesh)[_owned(mesh, cell_tags, SOLID), :4]]
    cells = _sorted_points(x)
    cells = np.concatenate(comm.allgather(cells))
    return cells[np.lexsort(np.round(cells, 9).T[::-1])]


def _facets(mesh, facet_tags, comm) -> dict[int, np.ndarray]:
    """Tag -> its triangles (all ranks, each once) as sorted node coordinates, in a partition-free order."""
    top = mesh.topology
    top.create_connectivity(2, 0)
    vertices = top.connectivity(2, 0).array.reshape(-1, 3)
    node = np.empty(top.index_map(0).size_local + top.index_map(0).num_ghosts, dtype=np.int64)
    top.create_connectivity(3, 0)
    node[top.connectivity(3, 0).array.reshape(-1, 4)] = compat.geometry_dofmap(mesh)[:, :4]
    x = mesh.geometry.x[node[vertices[facet_tags.indices]]]
    rows = _sorted_points(x)
    rows = np.concatenate(comm.allgather(rows))
    tags = np.concatenate(comm.allgather(np.asarray(facet_tags.values)))
    out = {}
    for tag in np.unique(tags):
        r = rows[tags == tag]
        r = r[np.lexsort(np.round(r, 9).T[::-1])]
        keep = np.ones(len(r), dtype=bool)
        keep[1:] = np.abs(np.diff(r, axis=0)).max(axis=1) > 1e-12  # a ghost facet: twice
        out[int(tag)] = r[keep]
    return out


def _area(triangles: np.ndarray) -> float:
    p = triangles.reshape(-1, 3, 3)
    return float(0.5 * np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1).sum())


def _fluid(mesh, cell_tags, comm) -> tuple[float, float]:
    """The fluid's volume and its cells' minimum quality (all ranks)."""
    from cosserat_fsi.mesh.motion import _signed_measures, cell_quality

    cells = _owned(mesh, cell_tags, FLUID)
    volume = comm.allreduce(float(np.abs(_signed_measures(mesh)[cells]).sum()), op=MPI.SUM)
    quality = comm.allreduce(float(np.abs(cell_quality(mesh)[cells]).min(initial=1.0)), op=MPI.MIN)
    return volume, quality


@pytest.mark.mpi
def test_3d_remesh_keeps_the_solid_and_the_boundary_and_carries_a_linear_field_exactly():
    from cosserat_fsi.geometry import facet_ids
    from cosserat_fsi.mesh.remesh import remesh_msh
    from cosserat_fsi.mesh.transfer import interpolator

    comm = MPI.COMM_WORLD
    scene, mesh, cell_tags, facet_tags, motion, rest = _bent(comm)
    volume, quality = _fluid(mesh, cell_tags, comm)
    assert quality == motion.min_fluid_quality and quality < 0.5 * rest, (rest, quality)
    folder = Path(comm.bcast(tempfile.mkdtemp() if comm.rank == 0 else None, root=0))
    try:
        remesh_msh(mesh, cell_tags, facet_tags, motion.node_sizes(), facet_ids(scene.geometry),
                   folder / "remesh.msh", comm)
        new, new_cell_tags, new_facet_tags = compat.read_msh(folder / "remesh.msh", comm, gdim=3)
    finally:
        comm.barrier()
        if comm.rank == 0:
            shutil.rmtree(folder)
    solid, kept = _solid_cells(mesh, cell_tags, comm), _solid_cells(new, new_cell_tags, comm)
    assert len(solid) == len(kept) > 0 and np.abs(solid - kept).max() < 1e-14
    old_facets, new_facets = _facets(mesh, facet_tags, comm), _facets(new, new_facet_tags, comm)
    assert sorted(old_facets) == sorted(new_facets) == [1, 2, 3, 4, 5]
    for tag, triangles in old_facets.items():
        assert triangles.shape == new_facets[tag].shape and np.abs(triangles - new_facets[tag]).max() < 1e-14, tag
        assert abs(_area(triangles) - _area(new_facets[tag])) < 1e-12, tag
    new_volume, new_quality = _fluid(new, new_cell_tags, comm)
    assert abs(new_volume - volume) < 1e-12, (volume, new_volume)
    assert new_quality > quality + 0.05, (quality, new_quality)
    # a linear field arrives exactly
    A, b = np.array([[0.3, -1.2, 0.5], [2.0, 0.1, -0.7], [-0.4, 0.9, 1.1]]), np.array([1.5, -0.25, 0.75])
    c = np.array([-2.0, 0.5, 3.0])
    spaces = [(compat.function_space(m, "Lagrange", 2, shape=(3,)), compat.function_space(m, "Lagrange", 1))
              for m in (mesh, new)]
    fields = [(lambda x: A @ x + b[:, None]), (lambda x: 3.0 - c @ x)]
    transfer = interpolator(comm)
    for k, field in enumerate(fields):
        source, target = dolfinx.fem.Function(spaces[0][k]), dolfinx.fem.Function(spaces[1][k])
        source.interpolate(field)
        transfer(target, source)
        x = target.function_space.tabulate_dof_coordinates()
        exact = field(x.T).T.ravel()
        assert comm.allreduce(float(np.abs(target.x.array - exact).max()), op=MPI.MAX) < 1e-12, k


RUN = {**SCENE, "solid": {"rho": 1000.0, "mu_s": 5e4, "mesh_motion": {"remesh": {"quality": 0.5, "max_count": 2}}},
       "inflow": {"u_mean": 1.0, "ramp_time": 0.05},  # remeshes at steps 1 and 2 (the mesh's quality is 0.24)
       "time": {"dt": 0.01, "t_end": 0.03, "scheme": "characteristics2"},
       "solver": {"reuse_factorization": False},  # a restart refactorises: exact LU on both sides
       "output": {"every": 1, "checkpoint_every": 2, "progress": False}}


def _compare(a: dict, b: dict, rtol: float) -> str | None:
    """None if the two time series agree to ``rtol`` of each column's size; a component of a vector (the
    force, the displacement of A), to ``rtol`` of the vector's size: the lift and the cross-stream motion of
    A are small differences of drag-sized terms (uy(A) ≈ 4e-6 m against ux(A) ≈ 9e-3 m)."""
    if list(a) != list(b) or len(a["t"]) != len(b["t"]):
        return f"columns {list(a)} / {list(b)}, lengths {len(a['t'])} / {len(b['t'])}"
    vectors = {"force": ["drag", "lift", "side"], "surface": ["drag_surface", "lift_surface", "side_surface"],
               "A": ["ux_A", "uy_A", "uz_A"]}
    for key in a:
        group = next((v for v in vectors.values() if key in v), [key])
        scale = max(np.sqrt(sum(a[k] ** 2 for k in group)).max(), 1e-30)
        if np.abs(a[key] - b[key]).max() > rtol * scale + 1e-15:
            return f"{key}: {np.abs(a[key] - b[key]).max():.3e} > {rtol} × {scale:.3e}"
    return None


@pytest.mark.slow
@pytest.mark.mpi
@pytest.mark.two_ranks
def test_3d_remeshing_run_serial_equals_parallel_and_restarts():
    """The run with two remeshes on COMM_WORLD (2 ranks under mpirun) = on COMM_SELF (1e-8): rank 0 meshes the
    same fluid whatever the partition; and the world run restarted from its checkpoint of step 2 (after both
    remeshes: it names meshes/remesh_002.msh) gives the uninterrupted run's time series (1e-10)."""
    import json

    from test_restart import cut_at_checkpoint, run_keeping_checkpoint

    from cosserat_fsi.app.runner import run_scene
    from cosserat_fsi.io import read_timeseries

    comm = MPI.COMM_WORLD
    root = Path(comm.bcast(tempfile.mkdtemp() if comm.rank == 0 else None, root=0))
    single, full, cut = root / "self", root / "full", root / "cut"
    scene = validate_scene(RUN)
    if comm.rank == 0:
        run_scene(scene, single, MPI.COMM_SELF, progress=False)
        full.mkdir()
    comm.barrier()
    kept = run_keeping_checkpoint(scene, full, comm, 2)
    if comm.rank == 0:
        meta, lines = cut_at_checkpoint(full, cut, kept)
        assert meta["step"] == 2 and meta["mesh"] == "meshes/remesh_002.msh" and len(meta["remeshes"]) == 2
        (cut / "timeseries.csv").write_text("".join(lines[: meta["rows"] + 1]))
    comm.barrier()
    run_scene(scene, cut, comm, progress=False, restart=True)
    problem = None  # decided on rank 0, asserted on every rank: a failure must not leave rank 1 in a barrier
    if comm.rank == 0:
        a, b, c = (read_timeseries(run / "timeseries.csv") for run in (single, full, cut))
        problem = (_compare(a, b, 1e-8) or _compare(b, c, 1e-10)) if len(a["t"]) == 3 else f"{len(a['t'])} rows"
        for run in (single, full, cut):
            summary = json.loads((run / "summary.json").read_text())
            remeshes = summary["remeshes"]
            steps = [e["step"] for e in remeshes["events"]] if run != cut else [1, 2]
            if summary["status"] != "completed" or remeshes["count"] != 2 or steps != [1, 2]:
                problem = problem or f"{run.name}: {summary['status']}, remeshes {remeshes}"
        shutil.rmtree(root)
    problem = comm.bcast(problem, root=0)
    assert problem is None, problem
