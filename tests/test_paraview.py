"""What ParaView reads: fields.xdmf opened by VTK's XDMF reader (pyvista, both stacks) and, where
Debian's paraview is installed, by pvpython itself. The number of time steps, the motion of point A
(against timeseries.csv) and the field ranges are checked; files written by 2 ranks read the same."""

from __future__ import annotations

import json
import shutil
import subprocess

import numpy as np
import pytest

from cosserat_fsi.io import read_timeseries

A = np.array([0.6, 0.2])

PVSCRIPT = r"""
import json, sys
import numpy as np
from paraview.simple import OpenDataFile
from paraview import servermanager
from vtk.util.numpy_support import vtk_to_numpy
reader = OpenDataFile(sys.argv[1])
times = list(reader.TimestepValues)
out = {"reader": reader.GetXMLName(), "times": times, "A": [], "speed_max": [], "p_range": []}
a = None
for t in times:
    reader.UpdatePipeline(t)  # (simple.UpdatePipeline(time=0.0) ignores t = 0)
    data = servermanager.Fetch(reader)
    if data.IsA("vtkMultiBlockDataSet"):
        data = data.GetBlock(0)
    x = vtk_to_numpy(data.GetPoints().GetData())[:, :2]
    if a is None:
        a = int(np.argmin(np.linalg.norm(x - [0.6, 0.2], axis=1)))
    u = vtk_to_numpy(data.GetPointData().GetArray("velocity"))
    p = vtk_to_numpy(data.GetPointData().GetArray("pressure"))
    out["A"].append(x[a].tolist())
    out["speed_max"].append(float(np.linalg.norm(u[:, :2], axis=1).max()))
    out["p_range"].append([float(p.min()), float(p.max())])
print("JSON" + json.dumps(out))
"""


def _run(run_cli, out, repo_root, launcher=()):
    proc = run_cli("run", repo_root / "configs/turek_hron_fsi3.yaml", "--out", out, "--no-progress",
                   "--set", "geometry.level=0", "--set", "time.dt=0.01", "--set", "time.t_end=0.05",
                   "--set", "output.every=1", "--set", "solid.mu_s=2.0e4", "--set", "inflow.ramp_time=0.01",
                   "--set", "time.tolerance=null",
                   # a very soft flag that moves visibly within a few steps: the incompressible law (a
                   # compressible one this soft is squeezed flat by the sudden inflow's pressure)
                   "--set", "solid.law=mooney_rivlin_incompressible", "--set", "solid.lambda_s=null",
                   launcher=launcher)
    assert proc.returncode == 0, proc.stderr
    return out


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory, repo_root, run_cli):
    return _run(run_cli, tmp_path_factory.mktemp("pv") / "run", repo_root)


def _check(times, positions, speed_max, p_range, run):
    ts = read_timeseries(run / "timeseries.csv")
    np.testing.assert_allclose(times, np.arange(6) * 0.01, atol=1e-12)
    positions = np.asarray(positions)
    np.testing.assert_allclose(positions[0], A, atol=1e-12)
    np.testing.assert_allclose(positions[1:] - A, np.column_stack([ts["ux_A"], ts["uy_A"]]), atol=1e-12, rtol=0)
    assert np.abs(ts["uy_A"]).max() > 1e-7
    # plausible ranges: at rest at t = 0, then up to about twice the peak inflow speed (1.5 Ū = 3 m/s)
    assert speed_max[0] == 0.0 and 1.0 < max(speed_max) < 6.0, speed_max
    assert all(np.isfinite(p_range).ravel()) and all(lo <= hi for lo, hi in p_range)


def test_vtk_xdmf_reader_sees_the_moving_mesh(run_dir):
    import pyvista as pv

    reader = pv.get_reader(str(run_dir / "fields.xdmf"))
    times, positions, speed, prange = list(reader.time_values), [], [], []
    a = None
    for t in times:
        reader.set_active_time_value(t)
        mesh = reader.read()
        mesh = mesh[0] if isinstance(mesh, pv.MultiBlock) else mesh
        x = np.asarray(mesh.points)[:, :2]
        a = int(np.argmin(np.linalg.norm(x - A, axis=1))) if a is None else a
        positions.append(x[a])
        speed.append(float(np.linalg.norm(mesh.point_data["velocity"][:, :2], axis=1).max()))
        prange.append([float(mesh.point_data["pressure"].min()), float(mesh.point_data["pressure"].max())])
    _check(times, positions, speed, prange, run_dir)


def _pvpython(run, tmp_path):
    script = tmp_path / "read.py"
    script.write_text(PVSCRIPT)
    proc = subprocess.run(["pvpython", "--force-offscreen-rendering", str(script), str(run / "fields.xdmf")],
                          capture_output=True, text=True, timeout=300)
    line = [x for x in proc.stdout.splitlines() if x.startswith("JSON")]
    assert proc.returncode == 0 and line, proc.stdout + proc.stderr
    out = json.loads(line[0][4:])
    _check(out["times"], out["A"], out["speed_max"], out["p_range"], run)


NO_PVPYTHON = pytest.mark.skipif(shutil.which("pvpython") is None,
                                 reason="Debian's paraview (pvpython, package python3-paraview) is not installed")


@NO_PVPYTHON
def test_pvpython_opens_the_run(run_dir, tmp_path):
    _pvpython(run_dir, tmp_path)


@pytest.mark.slow
def test_files_written_by_two_ranks_read_the_same(run_cli, run_dir, tmp_path, repo_root, mpirun):
    """The same run under mpirun -n 2: identical mesh, topology and (to round-off) fields in the reader."""
    import h5py

    two = _run(run_cli, tmp_path / "two", repo_root, mpirun(2))
    if shutil.which("pvpython"):
        _pvpython(two, tmp_path)
    with h5py.File(run_dir / "fields.h5") as f1, h5py.File(two / "fields.h5") as f2:
        assert np.array_equal(f1["mesh/topology"][:], f2["mesh/topology"][:])
        for key in ("mesh/geometry/000005", "point/velocity/000005", "point/displacement/000005"):
            scale = max(np.abs(f1[key][:]).max(), 1e-30)
            assert np.abs(f1[key][:] - f2[key][:]).max() <= 1e-8 * scale, key
