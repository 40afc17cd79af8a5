"""A file scene's mesh converted to XDMF/HDF5 (``cosserat-fsi mesh SCENE --format xdmf``) and read distributed
(``geometry: {name: file, path: NAME.xdmf}``): the same mesh, so the same numbers as the .geo it came from. dolfinx
numbers the cells of the two reads differently: what is compared is integrated or probed (the groups' areas and
volumes, the time series, summary.json's final values). 2D: an elastic block in a channel (the interface found
from the cells, a probe, a solid point, the wetted force); 3D: plane Poiseuille flow in a box channel and a
solid block's interface. Refusals: tests/faults/test_scene_xdmf.py."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np
import pytest
from mpi4py import MPI

from cosserat_fsi import compat
from cosserat_fsi.config import validate_scene
from cosserat_fsi.geometry import build_msh
from cosserat_fsi.geometry.file import read_names
from cosserat_fsi.app.xdmf_mesh import convert, load
from cosserat_fsi.geometry.xdmf_file import table

import dolfinx
import ufl

DATA = Path(__file__).parent / "data" / "user_scene"
BLOCK_2D = """geometry: {name: file, path: block.geo}
fluid: {rho: 1.0, mu: 0.01}
solid: {rho: 1.0, mu_s: 100.0}
boundaries: {inlet: {type: velocity, value: ['6*y*(1 - y)*min(t/0.05, 1)', 0]},
             outlet: {type: do_nothing}, walls: {type: no_slip}, clamp: {type: no_slip}}
observables: {wetted_solid: true, points: {B: [1.5, 0.5]}, solid_points: {top: [0.9, 0.4]}}
time: {scheme: characteristics1, dt: 0.01, t_end: 0.03}
output: {progress: false, fields: false}
"""
BOX_3D = """geometry: {name: file, path: block.geo}
fluid: {rho: 1.0, mu: 1.0}
boundaries:
  inlet: {type: velocity, value: ['y*(0.4 - y)/0.04', 0, 0]}
  outlet: {type: do_nothing}
  plates: {type: no_slip}
  sides: {type: slip}
observables: {points: {C: [0.5, 0.2, 0.2]}}
time: {scheme: steady}
output: {progress: false, fields: false}
"""
BLOCK_3D = {"fluid": {"rho": 1.0, "mu": 1.0}, "solid": {"rho": 1.0, "mu_s": 100.0},
            "boundaries": {"inlet": {"type": "velocity", "value": [1, 0, 0]}, "outlet": {"type": "do_nothing"},
                           "walls": {"type": "no_slip"}}, "time": {"scheme": "steady"}}
BLOCK_2D_DICT = {"fluid": {"rho": 1.0, "mu": 1.0}, "solid": {"rho": 1.0, "mu_s": 100.0},
                 "boundaries": {"inlet": {"type": "velocity", "value": [1, 0]}, "outlet": {"type": "do_nothing"},
                                "walls": {"type": "no_slip"}, "clamp": {"type": "no_slip"}},
                 "time": {"scheme": "steady"}}


def _measure(mesh, tags, kind, tag):
    one = dolfinx.fem.Constant(mesh, 1.0)
    form = compat.form((one("+") if kind == "dS" else one) * ufl.Measure(kind, domain=mesh, subdomain_data=tags)(tag))
    return mesh.comm.allreduce(dolfinx.fem.assemble_scalar(form), op=MPI.SUM)


@pytest.mark.mpi
@pytest.mark.parametrize("geo, extra", [("block_channel.geo", BLOCK_2D_DICT), ("block_box.geo", BLOCK_3D)],
                         ids=["2d", "3d"])
def test_xdmf_reads_the_same_groups_distributed(tmp_path, geo, extra):
    """The converted pair read on every rank: the same volumes per cell tag and lengths/areas per facet group
    (the interface with dS) as the .geo's mesh read on rank 0 and distributed, shared-facet ghost cells, and
    each rank holding a part of the cells only."""
    comm = MPI.COMM_WORLD
    folder = Path(comm.bcast(str(tmp_path) if comm.rank == 0 else None))
    if comm.rank == 0:
        (folder / "block.geo").write_text((DATA / geo).read_text())
    comm.barrier()
    scene = validate_scene({"geometry": {"name": "file", "path": str(folder / "block.geo")}, **extra})
    path = comm.bcast(str(convert(scene, folder)) if comm.rank == 0 else None)
    msh = comm.bcast(str(build_msh(scene.geometry)) if comm.rank == 0 else None)
    names = comm.bcast(read_names(msh) if comm.rank == 0 else None)
    assert table(path) == names and Path(path).with_suffix(".h5").is_file()
    xdmf_scene = validate_scene({"geometry": {"name": "file", "path": path}, **extra})
    assert xdmf_scene.geometry.DIM == names["dim"] == scene.geometry.DIM
    mesh_x, cells_x, facets_x = load(xdmf_scene, comm)
    mesh_m, cells_m, facets_m = compat.read_msh(msh, comm, gdim=names["dim"])
    cells = mesh_x.topology.index_map(mesh_x.topology.dim)
    assert cells.size_global == names["cells"]["fluid"] + names["cells"]["solid"]
    if comm.size > 1:
        assert 0 < cells.size_local < cells.size_global and cells.num_ghosts > 0
    for tag in (1, 2):
        assert _measure(mesh_x, cells_x, "dx", tag) == pytest.approx(_measure(mesh_m, cells_m, "dx", tag),
                                                                      rel=1e-12, abs=1e-14)
    for name, tag in names["facets"].items():
        kind = "dS" if name == "interface" else "ds"
        expected = _measure(mesh_m, facets_m, kind, tag)
        assert expected > 0 and _measure(mesh_x, facets_x, kind, tag) == pytest.approx(expected, rel=1e-12), name


def _csv(path):
    with open(path) as f:
        rows = list(csv.DictReader(f))
    return {k: np.array([float(r[k]) for r in rows]) for k in rows[0]}


def _runs(run_cli, mpirun, folder: Path, scene: str, geo: str, two_ranks: bool):
    """The .geo scene on one rank, its XDMF twin on one rank (and on 2): (time series, summary) of each."""
    (folder / "block.geo").write_text((DATA / geo).read_text())
    (folder / "geo.yaml").write_text(scene)
    (folder / "xdmf.yaml").write_text(scene.replace("block.geo", "block.xdmf"))
    converted = run_cli("mesh", folder / "geo.yaml", "--format", "xdmf")
    assert converted.returncode == 0 and (folder / "block.h5").is_file(), converted.stderr
    runs = [("geo.yaml", "geo", ()), ("xdmf.yaml", "xdmf", ())] + ([("xdmf.yaml", "xdmf2", mpirun(2))] if two_ranks
                                                                   else [])
    out = []
    for config, name, launcher in runs:
        result = run_cli("run", folder / config, "--out", folder / name, launcher=launcher)
        assert result.returncode == 0, result.stderr
        summary = json.loads((folder / name / "summary.json").read_text())
        assert len(summary["memory"]["peak_rss_mib_per_rank"]) == (2 if launcher else 1)
        out.append((_csv(folder / name / "timeseries.csv"), summary["final"]))
    return out


def _same(a, b):
    """The same series (CSV: 11 significant digits) and final values (summary.json: full precision) to 1e-10."""
    assert set(a[0]) == set(b[0]) and set(a[1]) == set(b[1])
    for key in a[0]:
        assert np.allclose(a[0][key], b[0][key], rtol=1e-10, atol=1e-12), key
    for key in a[1]:
        assert b[1][key] == pytest.approx(a[1][key], rel=1e-10, abs=1e-13), key


@pytest.mark.slow
def test_block_2d_from_xdmf_equals_geo(run_cli, mpirun, tmp_path):
    """The 2D elastic block over 3 steps from the .geo (1 rank) and from its .xdmf on 1 and 2 ranks: the same
    drag, lift, wetted force, probe and solid point to 1e-10."""
    geo, xdmf, xdmf2 = _runs(run_cli, mpirun, tmp_path, BLOCK_2D, "block_channel.geo", two_ranks=True)
    assert len(geo[0]["t"]) == 3 and np.abs(geo[0]["ux_top"]).max() > 0 and np.abs(geo[0]["drag"]).max() > 0
    _same(geo, xdmf)
    _same(geo, xdmf2)


@pytest.mark.slow
def test_box_3d_from_xdmf_equals_geo(run_cli, mpirun, tmp_path):
    """Steady plane Poiseuille flow in the 3D box channel from the .geo and from its .xdmf on 1 and 2 ranks:
    the same flow rate and probe to 1e-10 (the exact 0.4 × 2/3 × 0.4)."""
    geo, xdmf, xdmf2 = _runs(run_cli, mpirun, tmp_path, BOX_3D, "box_channel.geo", two_ranks=True)
    assert geo[1]["flow_rate"] == pytest.approx(0.4 * 2.0 / 3.0 * 0.4, rel=1e-8)
    _same(geo, xdmf)
    _same(geo, xdmf2)
