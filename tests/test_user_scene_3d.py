"""A user's own 3D gmsh file (``geometry: {name: file, path: m.geo}`` with physical volumes and surfaces): its
dimension read from the file's names, developed plane Poiseuille flow in a box channel (exact in P2 × P1: the
flow rate and the fields at every vertex against the closed form, on 1 and 2 ranks), the fluid–solid interface
of a block found from the cells, a facet group inside the domain. Refusals: tests/faults/test_scene_3d_files.py."""

from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np
import pytest
from mpi4py import MPI

from cosserat_fsi import compat
from cosserat_fsi.app.runner import _build_checked
from cosserat_fsi.config import validate_geometry, validate_scene
from cosserat_fsi.geometry import build_msh
from cosserat_fsi.geometry.file import read_names
from cosserat_fsi.problem.model import Problem

import dolfinx
import ufl

DATA = Path(__file__).parent / "data" / "user_scene"
H, W, MU = 0.4, 0.4, 1.0
SCENE = """geometry: {name: file, path: box_channel.geo}
fluid: {rho: 1.0, mu: 1.0}
boundaries:
  inlet: {type: velocity, value: ['y*(0.4 - y)/0.04', 0, 0]}
  outlet: {type: do_nothing}
  plates: {type: no_slip}
  sides: {type: slip}
time: {scheme: steady}
output: {progress: false}
"""
"""Plane Poiseuille flow between the no-slip plates y = 0, 0.4 (u = 4 y (H − y)/H² along x, 1 on the mid-plane),
slip on the sides z = 0, 0.4, Navier–Stokes steady: u, p = 8 μ (1 − x)/H² are in P2 × P1, so the discrete
solution is the exact one."""
FLOW_RATE = W * 2.0 / 3.0 * H  # ∫∫ u dy dz: the mean 2/3 of the peak 1 over the section H × W


def _run(run_cli, tmp_path, out, launcher=()):
    (tmp_path / "box_channel.geo").write_text((DATA / "box_channel.geo").read_text())
    (tmp_path / "scene.yaml").write_text(SCENE)
    result = run_cli("run", tmp_path / "scene.yaml", "--out", tmp_path / out, launcher=launcher)
    assert result.returncode == 0, result.stderr
    series = np.genfromtxt(tmp_path / out / "timeseries.csv", delimiter=",", names=True)
    with h5py.File(tmp_path / out / "fields.h5", "r") as f:
        x, u, p = (f[k][:] for k in ("mesh/geometry/000000", "point/velocity/000000", "point/pressure/000000"))
    order = np.lexsort(np.round(x, 9).T)  # vertices by position: the same order on any number of ranks
    return float(series["flow_rate"]), x[order], u[order], p[order]


def _check_poiseuille(flow_rate, x, u, p):
    exact = np.zeros_like(u)
    exact[:, 0] = 4.0 * x[:, 1] * (H - x[:, 1]) / H**2
    assert flow_rate == pytest.approx(FLOW_RATE, rel=1e-8)
    assert np.abs(u - exact).max() < 1e-8
    assert np.abs(p - 8.0 * MU * (1.0 - x[:, 0]) / H**2).max() < 1e-8 * 50.0
    assert len(x) > 200 and np.ptp(x[:, 2]) == pytest.approx(W)  # a 3D mesh: the vertices span z too


def test_box_channel_poiseuille(run_cli, tmp_path):
    """`cosserat-fsi run` on the box channel: flow rate 0.4 × 2/3 × 0.4 through the outlet, the velocity at every
    vertex 4 y (H − y)/H² e_x and the pressure 8 μ (1 − x)/H² (measured: errors 1e-15, 1e-13)."""
    _check_poiseuille(*_run(run_cli, tmp_path, "one"))


@pytest.mark.slow
def test_box_channel_two_ranks(run_cli, mpirun, tmp_path):
    """The same run on 2 ranks: the same numbers to 1e-8 (the exact ones)."""
    one = _run(run_cli, tmp_path, "one")
    two = _run(run_cli, tmp_path, "two", launcher=mpirun(2))
    _check_poiseuille(*two)
    assert two[0] == pytest.approx(one[0], rel=1e-8)
    for a, b in zip(one[1:], two[1:]):
        assert a.shape == b.shape and np.abs(a - b).max() < 1e-8


def _measure(mesh, tags, kind, tag):
    one = dolfinx.fem.Constant(mesh, 1.0)
    form = compat.form((one("+") if kind == "dS" else one) * ufl.Measure(kind, domain=mesh, subdomain_data=tags)(tag))
    return mesh.comm.allreduce(dolfinx.fem.assemble_scalar(form), op=MPI.SUM)


def _mesh(geometry, cache):
    comm = MPI.COMM_WORLD
    path = comm.bcast(build_msh(geometry, cache) if comm.rank == 0 else None)
    names = comm.bcast(read_names(path) if comm.rank == 0 else None)
    return (*compat.read_msh(path, comm, gdim=geometry.DIM), names)


def _fluid_solid_faces(mesh, cells) -> int:
    """Faces between a fluid and a solid cell, from dolfinx's own topology (owned faces, over all ranks)."""
    mesh.topology.create_connectivity(2, 3)
    faces, owned = mesh.topology.connectivity(2, 3), mesh.topology.index_map(2).size_local
    tag = np.zeros(mesh.topology.index_map(3).size_local + mesh.topology.index_map(3).num_ghosts, dtype=int)
    tag[cells.indices] = cells.values
    count = sum(1 for f in range(owned) if len(faces.links(f)) == 2 and len(set(tag[faces.links(f)])) == 2)
    return mesh.comm.allreduce(count, op=MPI.SUM)


@pytest.mark.mpi
def test_block_interface_found_from_the_cells(tmp_path):
    """A 0.2 cube of solid cells inside the channel: the interface is the faces between fluid and solid
    tetrahedra (as many as dolfinx's topology finds), of area 6 × 0.04; volumes 0.152 and 0.008."""
    geometry = validate_geometry({"name": "file", "path": str(DATA / "block_box.geo")})
    assert geometry.DIM == 3
    mesh, cells, facets, names = _mesh(geometry, tmp_path)
    assert mesh.geometry.dim == 3 and mesh.topology.dim == 3
    assert names["dim"] == 3 and names["interior"] == [] and "unnamed" not in names
    assert set(names["facets"]) == {"inlet", "outlet", "walls", "interface"}
    ids = names["facets"]
    tagged = facets.indices[facets.values == ids["interface"]]
    found = mesh.comm.allreduce(int(np.sum(tagged < mesh.topology.index_map(2).size_local)), op=MPI.SUM)
    assert found == _fluid_solid_faces(mesh, cells) >= 12  # at least two triangles on each face of the cube
    assert _measure(mesh, facets, "dS", ids["interface"]) == pytest.approx(0.24, abs=1e-12)
    areas = {name: _measure(mesh, facets, "ds", ids[name]) for name in ("inlet", "outlet", "walls")}
    assert areas == pytest.approx({"inlet": 0.16, "outlet": 0.16, "walls": 1.6}, abs=1e-12)
    volumes = [_measure(mesh, cells, "dx", k) for k in (1, 2)]
    assert volumes == pytest.approx([0.16 - 0.008, 0.008], abs=1e-12)
    assert names["cells"]["solid"] == mesh.comm.allreduce(int(np.sum(
        cells.indices[cells.values == 2] < mesh.topology.index_map(3).size_local)), op=MPI.SUM)


SPLIT = (DATA / "split_channel.geo").read_text()  # the channel in two halves, the face group "mid" inside


@pytest.mark.mpi
def test_facet_group_inside_the_domain(tmp_path):
    """A named surface inside the domain is listed as interior (its faces are those of two cells: dS gives
    its area 0.16, ds nothing) and needs no condition; without a boundaries section it gets none by name."""
    (tmp_path / "m.geo").write_text(SPLIT)
    scene = validate_scene({
        "geometry": {"name": "file", "path": str(tmp_path / "m.geo")}, "fluid": {"rho": 1.0, "mu": 1.0},
        "boundaries": {"inlet": {"type": "velocity", "value": ["1", 0, 0]}, "outlet": {"type": "do_nothing"},
                       "walls": {"type": "no_slip"}},
        "time": {"scheme": "steady"}})
    comm = MPI.COMM_WORLD
    path = comm.bcast(_build_checked(scene) if comm.rank == 0 else None)  # no condition asked for "mid"
    names = comm.bcast(read_names(path) if comm.rank == 0 else None)
    assert names["dim"] == 3 and names["interior"] == ["mid"]
    mesh, _, facets = compat.read_msh(path, comm, gdim=3)
    assert _measure(mesh, facets, "dS", names["facets"]["mid"]) == pytest.approx(0.16, abs=1e-12)
    assert _measure(mesh, facets, "ds", names["facets"]["mid"]) == 0.0
    assert _measure(mesh, facets, "ds", names["facets"]["walls"]) == pytest.approx(1.6, abs=1e-12)
    data = scene.model_dump(mode="json")
    data.update(boundaries=None, inflow={"u_mean": 1.0})  # conditions by name: none for "mid"
    cells = dolfinx.mesh.meshtags(mesh, 3, np.arange(mesh.topology.index_map(3).size_local, dtype=np.int32),
                                  np.ones(mesh.topology.index_map(3).size_local, dtype=np.int32))
    problem = Problem(validate_scene(data), mesh, cells, facets, facet_ids=names["facets"])
    assert set(problem.conditions()) == {"inlet", "outlet", "walls"}
    assert problem.conditions()["inlet"].type == "velocity"


MSH3 = "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$PhysicalNames\n2\n2 1 \"walls\"\n3 2 \"fluid\"\n$EndPhysicalNames\n"
MSH2 = "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$PhysicalNames\n2\n1 1 \"walls\"\n2 2 \"fluid\"\n$EndPhysicalNames\n"


@pytest.mark.parametrize("files, dim", [
    ({"m.geo": (DATA / "box_channel.geo").read_text()}, 3),
    ({"m.geo": (DATA / "channel.geo").read_text()}, 2),
    ({"m.geo": (DATA / "channel.geo").read_text() + '// Physical Volume("fluid") = {1};\n'}, 2),
    ({"m.geo": (DATA / "channel.geo").read_text() + 's = "Physical Volume";\n'}, 2),
    ({"m.geo": 'Include "v.geo";\n', "v.geo": 'Physical Volume("fluid") = {1};\n'}, 3),
    ({"m.geo": 'Merge "m3.msh";\n', "m3.msh": MSH3}, 3),
    ({"m.geo": 'Merge "m2.msh";\n', "m2.msh": MSH2}, 2),
    ({"m.msh": MSH3}, 3),
    ({"m.msh": MSH2}, 2),
], ids=["box", "square", "comment", "string", "include", "merge_3d", "merge_2d", "msh_3d", "msh_2d"])
def test_dimension_is_read_from_the_names(tmp_path, files, dim):
    """FileGeometry.DIM from the file's text, without meshing: a Physical Volume (in the file or one it
    Includes) or a dimension-3 entry of a .msh's $PhysicalNames (the file or one a .geo Merges)."""
    for name, text in files.items():
        (tmp_path / name).write_text(text)
    main = "m.msh" if "m.msh" in files else "m.geo"
    assert validate_geometry({"name": "file", "path": str(tmp_path / main)}).DIM == dim
