"""Output writers: CSV time series and the moving-mesh XDMF/HDF5 writer (serial and 2 ranks)."""

import os
import shutil
import signal
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import h5py
import numpy as np
import pytest

from cosserat_fsi import compat
import dolfinx.fem
import dolfinx.mesh
from mpi4py import MPI

from cosserat_fsi.io import MovingMeshXDMF, TimeSeriesWriter, read_timeseries

ROOT = Path(__file__).resolve().parents[1]
NX, NY, STEPS = 4, 3, 3


# ------------------------------------------------------------------------------------ time series
def test_timeseries_roundtrip(tmp_path):
    path = tmp_path / "ts.csv"
    with TimeSeriesWriter(path, ["drag", "lift"], MPI.COMM_SELF) as w:
        w.write(0.0, {"drag": 1.0, "lift": -2.5})
        w.write(0.1, {"drag": np.float64(1 / 3)})  # missing column -> nan
        assert len(path.read_text().splitlines()) == 3  # flushed before close
    assert path.read_text().splitlines()[0] == "t,drag,lift"
    d = read_timeseries(path)
    assert list(d) == ["t", "drag", "lift"]
    np.testing.assert_allclose(d["t"], [0.0, 0.1])
    assert d["drag"][1] == pytest.approx(1 / 3, rel=1e-10)
    assert np.isnan(d["lift"][1])


def test_timeseries_errors_and_truncated_row(tmp_path):
    with pytest.raises(ValueError):
        TimeSeriesWriter(tmp_path / "x.csv", ["t"], MPI.COMM_SELF)
    path = tmp_path / "ts.csv"
    with TimeSeriesWriter(path, ["a"], MPI.COMM_SELF) as w:
        w.write(0.0, {"a": 1.0})
        with pytest.raises(ValueError):
            w.write(0.1, {"b": 1.0})
    with open(path, "a") as f:
        f.write("1.0000000000e-01,2.5")  # a run killed mid-row
    d = read_timeseries(path)
    assert len(d["t"]) == 1 and d["a"][0] == 1.0
    empty = tmp_path / "empty.csv"
    TimeSeriesWriter(empty, ["a"], MPI.COMM_SELF).close()
    assert read_timeseries(empty)["a"].shape == (0,)


# ------------------------------------------------------------------------------------------ XDMF
def _moved(X: np.ndarray, k: int) -> np.ndarray:
    """Geometry of step k as a function of the reference coordinates (n, 2)."""
    return X + 0.05 * k * np.column_stack([np.sin(np.pi * X[:, 1]), X[:, 0] * X[:, 1]])


def _scalar(x):
    return x[0] ** 2 + x[1]


def _vector(x):
    return np.vstack([x[1], -x[0] ** 2])


def write_case(path, comm=MPI.COMM_WORLD, kill=False):
    """Write STEPS steps of a moving unit-square mesh with P1/P2 scalar, P2 vector and cell fields."""
    mesh = dolfinx.mesh.create_unit_square(comm, NX, NY)
    n_cells = compat.num_owned_cells(mesh)
    geom = compat.geometry_dofmap(mesh)
    x0 = mesh.geometry.x[:, :2].copy()
    f = dolfinx.fem.Function(compat.function_space(mesh, "Lagrange", 2))
    v = dolfinx.fem.Function(compat.function_space(mesh, "Lagrange", 2, (2,)))
    p = dolfinx.fem.Function(compat.function_space(mesh, "Lagrange", 1))
    w = MovingMeshXDMF(Path(path), mesh, comm)
    for k in range(STEPS):
        mesh.geometry.x[:, :2] = _moved(x0, k)
        f.interpolate(_scalar)
        v.interpolate(_vector)
        p.interpolate(lambda x: 1 + x[0] * x[1])
        cell_id = np.asarray(mesh.topology.original_cell_index[:n_cells], dtype=float)
        centroid = mesh.geometry.x[geom[:n_cells], :2].mean(axis=1)
        w.write(0.1 * k, {"f": f, "v": v, "p": p}, {"id": cell_id, "centroid": centroid})
    if kill:
        os.kill(os.getpid(), signal.SIGKILL)
    w.close()


def check_files(path: Path):
    """The files written by write_case hold the exact data, in the original numbering."""
    h5path = path.with_suffix(".h5")
    with h5py.File(h5path, "r") as h5:
        topo = h5["mesh/topology"][...]
        assert topo.dtype == np.int64 and topo.shape == (2 * NX * NY, 3)
        X = h5["mesh/geometry/000000"][...]
        assert X.shape == ((NX + 1) * (NY + 1), 2)
        grid = np.round(X * [NX, NY])
        np.testing.assert_allclose(grid, X * [NX, NY], atol=1e-12)  # nodes of the unit square
        for k in range(STEPS):
            s = f"{k:06d}"
            x = h5[f"mesh/geometry/{s}"][...]
            np.testing.assert_allclose(x, _moved(X, k), atol=1e-14)
            np.testing.assert_allclose(h5[f"point/f/{s}"][...], _scalar(x.T), atol=1e-12)
            v = h5[f"point/v/{s}"][...]
            assert v.shape == (len(x), 3) and np.all(v[:, 2] == 0)
            np.testing.assert_allclose(v[:, :2], _vector(x.T).T, atol=1e-12)
            np.testing.assert_allclose(h5[f"point/p/{s}"][...], 1 + x[:, 0] * x[:, 1], atol=1e-12)
            np.testing.assert_array_equal(h5[f"cell/id/{s}"][...], np.arange(len(topo)))
            c = h5[f"cell/centroid/{s}"][...]
            np.testing.assert_allclose(c[:, :2], x[topo].mean(axis=1), atol=1e-14)
        datasets = set()
        h5.visit(lambda name: datasets.add("/" + name))

    root = ET.parse(path).getroot()
    series = root.find("Domain/Grid")
    assert series.get("GridType") == "Collection" and series.get("CollectionType") == "Temporal"
    grids = series.findall("Grid")
    assert [float(g.find("Time").get("Value")) for g in grids] == pytest.approx([0.0, 0.1, 0.2])
    for k, g in enumerate(grids):
        refs = {}
        for item in g.iter("DataItem"):
            fname, dset = item.text.split(":")
            assert fname == h5path.name and dset in datasets
            refs[dset] = tuple(int(n) for n in item.get("Dimensions").split())
        assert g.find("Topology/DataItem").text.endswith(":/mesh/topology")
        assert g.find("Geometry").get("GeometryType") == "XY"
        assert g.find("Geometry/DataItem").text.endswith(f"/mesh/geometry/{k:06d}")
        attrs = {a.get("Name"): (a.get("AttributeType"), a.get("Center")) for a in g.findall("Attribute")}
        assert attrs == {"f": ("Scalar", "Node"), "v": ("Vector", "Node"), "p": ("Scalar", "Node"),
                         "id": ("Scalar", "Cell"), "centroid": ("Vector", "Cell")}
        assert refs[f"/point/v/{k:06d}"] == ((NX + 1) * (NY + 1), 3)



@pytest.mark.mpi
def test_moving_mesh_xdmf(shared_tmp):
    path = shared_tmp / "fields.xdmf"
    write_case(path)
    if MPI.COMM_WORLD.rank == 0:
        check_files(path)
        assert not path.with_name("fields.xdmf.tmp").exists()


def _run(cmd, **kw):
    env = {k: v for k, v in os.environ.items()
           if not k.startswith(("OMPI_", "PMIX_", "PMI_", "HYDRA_", "MPI_LOCALNRANKS"))}
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT), str(ROOT / "tests"), env.get("PYTHONPATH", "")])
    env.setdefault("OPENBLAS_NUM_THREADS", "1")
    return subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=300, **kw)


def _mpiexec() -> list[str] | None:
    """The launcher matching this interpreter's MPI: next to the interpreter, else on PATH."""
    for name in ("mpiexec", "mpirun"):
        exe = Path(sys.executable).parent / name
        exe = str(exe) if exe.exists() else shutil.which(name)
        if exe:
            openmpi = "Open MPI" in MPI.Get_library_version()
            return [exe, *(["--allow-run-as-root", "--oversubscribe"] if openmpi else [])]
    return None


@pytest.mark.slow
def test_serial_and_parallel_files_agree(tmp_path):
    launcher = _mpiexec()
    if launcher is None or MPI.COMM_WORLD.size > 1:
        pytest.skip("needs an MPI launcher and a serial pytest")
    code = "import sys, test_io; test_io.write_case(sys.argv[1])"
    for n in (1, 2):
        r = _run([*launcher, "-n", str(n), sys.executable, "-c", code, str(tmp_path / f"n{n}.xdmf")])
        assert r.returncode == 0, r.stderr
    check_files(tmp_path / "n2.xdmf")
    with h5py.File(tmp_path / "n1.h5", "r") as a, h5py.File(tmp_path / "n2.h5", "r") as b:
        names = []
        a.visit(lambda name: names.append(name) if isinstance(a[name], h5py.Dataset) else None)
        assert len(names) == 1 + 6 * STEPS  # topology, then geometry + 5 fields per step
        for name in names:
            np.testing.assert_allclose(a[name][...], b[name][...], rtol=0, atol=1e-13, err_msg=name)
    assert (tmp_path / "n1.xdmf").read_text().replace("n1.h5", "X") == \
        (tmp_path / "n2.xdmf").read_text().replace("n2.h5", "X")


def test_killed_run_leaves_readable_files(tmp_path):
    code = "import sys, test_io; test_io.write_case(sys.argv[1], kill=True)"
    r = _run([sys.executable, "-c", code, str(tmp_path / "k.xdmf")])
    assert r.returncode == -signal.SIGKILL, r.stderr
    check_files(tmp_path / "k.xdmf")


def test_mixed_subfunctions(tmp_path):
    """Sub-functions of a mixed solution are written without collapsing them first."""
    mesh = dolfinx.mesh.create_unit_square(MPI.COMM_SELF, 3, 3)
    el = compat.mixed_element([compat.element(mesh, "Lagrange", 2, (2,)),
                               compat.element(mesh, "Lagrange", 1)])
    w = dolfinx.fem.Function(compat.function_space(mesh, el))
    w.sub(0).interpolate(_vector)
    w.sub(1).interpolate(lambda x: 1 + x[0])
    with MovingMeshXDMF(tmp_path / "m.xdmf", mesh, MPI.COMM_SELF) as xdmf:
        xdmf.write(0.0, {"u": w.sub(0), "p": w.sub(1)})
    with h5py.File(tmp_path / "m.h5", "r") as h5:
        x = h5["mesh/geometry/000000"][...]
        np.testing.assert_allclose(h5["point/u/000000"][:, :2], _vector(x.T).T, atol=1e-12)
        np.testing.assert_allclose(h5["point/p/000000"][...], 1 + x[:, 0], atol=1e-12)


def test_geometry_only_step(tmp_path):
    mesh = dolfinx.mesh.create_unit_square(MPI.COMM_SELF, 2, 2)
    with MovingMeshXDMF(tmp_path / "a.xdmf", mesh, MPI.COMM_SELF) as w:
        w.write(0.0)
    assert len(ET.parse(tmp_path / "a.xdmf").getroot().findall("Domain/Grid/Grid")) == 1
