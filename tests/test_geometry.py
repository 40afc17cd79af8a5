"""geometry.build_msh: tags, areas, lengths, vertex counts, determinism, cache, input errors."""

import math
import subprocess
import sys

import numpy as np
import pytest

from cosserat_fsi import errors, geometry
from cosserat_fsi.geometry import turek_hron

R, A_HALF = 0.05, 0.01  # cylinder radius, flag half thickness
X0 = turek_hron.FLAG_START
FLAG_AREA = (0.6 - X0) * 2 * A_HALF - R**2 * math.asin(A_HALF / R) + A_HALF * math.sqrt(R**2 - A_HALF**2)
ARC = 2 * R * math.asin(A_HALF / R)  # clamped arc of the circle
INTERFACE = 2 * (0.6 - X0) + 2 * A_HALF
# measures integrated by _measures, in this order
NAMES = ("fluid", "solid", "inlet", "outlet", "walls", "cylinder", "interface", "lid", "boundary", "interior5")


def _measures(path):
    """{name: area or length} of the mesh read by dolfinx, plus vertex count and coordinates."""
    compat = pytest.importorskip("cosserat_fsi.compat")
    import dolfinx.fem
    import ufl
    from mpi4py import MPI

    mesh, cells, facets = compat.read_msh(path, MPI.COMM_WORLD)
    dx = ufl.Measure("dx", domain=mesh, subdomain_data=cells)
    ds = ufl.Measure("ds", domain=mesh, subdomain_data=facets)
    dS = ufl.Measure("dS", domain=mesh, subdomain_data=facets)
    c = dolfinx.fem.Constant(mesh, np.zeros(len(NAMES)))
    parts = [dx(1), dx(2), ds(1), ds(2), ds(3), ds(4), ds(5), ds(6), ds, dS(5)]
    form = compat.form(sum((c[i] * m for i, m in enumerate(parts[1:], 1)), c[0] * parts[0]))
    out = {}
    for i, name in enumerate(NAMES):
        c.value = np.eye(len(NAMES))[i]
        out[name] = mesh.comm.allreduce(dolfinx.fem.assemble_scalar(form), op=MPI.SUM)
    out["vertices"] = mesh.topology.index_map(0).size_global
    out["x"] = np.vstack(mesh.comm.allgather(mesh.geometry.x[:, :2]))
    return out


def _is_vertex(x, point):
    return np.min(np.linalg.norm(x - np.asarray(point), axis=1)) < 1e-12


@pytest.mark.parametrize("level,flag", [(0, "solid"), (1, "solid"), ("seed", "rigid")])
def test_turek_hron_measures(tmp_path, level, flag):
    m = _measures(geometry.build_msh("turek_hron", level, {"flag": flag}, tmp_path))
    hole = math.pi * R**2 + (0 if flag == "solid" else FLAG_AREA)
    assert m["fluid"] + m["solid"] == pytest.approx(2.5 * 0.41 - hole, rel=1e-3)
    assert m["solid"] == (pytest.approx(FLAG_AREA, rel=1e-3) if flag == "solid" else 0)
    assert m["inlet"] == pytest.approx(0.41, rel=1e-12) and m["outlet"] == pytest.approx(0.41, rel=1e-12)
    assert m["walls"] == pytest.approx(5.0, rel=1e-12)
    circle = 2 * math.pi * R - (0 if flag == "solid" else ARC)
    assert m["cylinder"] == pytest.approx(circle, rel=5e-3 if level == 0 else 1.5e-3)  # inscribed polygon
    interface = (m["interior5"], m["interface"]) if flag == "solid" else (m["interface"], m["interior5"])
    assert interface == (pytest.approx(INTERFACE, rel=1e-12), 0)
    assert m["boundary"] == pytest.approx(sum(m[k] for k in ("inlet", "outlet", "walls", "cylinder", "interface")))
    assert m["lid"] == 0
    assert _is_vertex(m["x"], (0.6, 0.2)) and _is_vertex(m["x"], (0.15, 0.2))


def test_schaefer_turek_measures(tmp_path):
    m = _measures(geometry.build_msh("schaefer_turek", 0, None, tmp_path))
    assert m["fluid"] == pytest.approx(2.2 * 0.41 - math.pi * R**2, rel=1e-3) and m["solid"] == 0
    assert (m["inlet"], m["outlet"], m["walls"]) == pytest.approx((0.41, 0.41, 4.4), rel=1e-12)
    assert m["cylinder"] == pytest.approx(2 * math.pi * R, rel=5e-3) and m["interface"] == 0
    assert m["boundary"] == pytest.approx(0.41 * 2 + 4.4 + m["cylinder"])
    assert _is_vertex(m["x"], (0.15, 0.2)) and _is_vertex(m["x"], (0.25, 0.2))


def test_channel_and_square_measures(tmp_path):
    m = _measures(geometry.build_msh("channel", 1, {"length": 2.0, "height": 0.5}, tmp_path))
    assert m["vertices"] == (64 + 1) * (16 + 1)
    assert (m["fluid"], m["inlet"], m["outlet"], m["walls"]) == pytest.approx((1.0, 0.5, 0.5, 4.0), rel=1e-12)
    m = _measures(geometry.build_msh("square", 0, {"size": 2.0}, tmp_path))
    assert m["vertices"] == 81
    assert (m["fluid"], m["walls"], m["lid"], m["inlet"]) == pytest.approx((4.0, 6.0, 2.0, 0.0), abs=1e-12)


def _gmsh_vertices(path):
    """Number of mesh nodes in the file, counted by gmsh (no dolfinx needed)."""
    import gmsh

    gmsh.initialize(["gmsh", "-nopopup"], readConfigFiles=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.open(str(path))
        return len(gmsh.model.mesh.getNodes()[0])
    finally:
        gmsh.finalize()


@pytest.mark.parametrize("name,flag", [("turek_hron", "solid"), ("turek_hron", "rigid"),
                                       ("schaefer_turek", None)])
def test_vertex_counts_per_level(tmp_path, name, flag):
    params = {"flag": flag} if flag else None
    n0, n1 = (_gmsh_vertices(geometry.build_msh(name, level, params, tmp_path)) for level in (0, 1))
    assert 600 <= n0 <= 900
    assert 3.3 <= n1 / n0 <= 4.2


def test_seed_level(tmp_path):
    assert _gmsh_vertices(geometry.build_msh("turek_hron", "seed", None, tmp_path)) == pytest.approx(2199, rel=0.05)


def test_deterministic_and_cached(tmp_path, monkeypatch):
    a = geometry.build_msh("turek_hron", 0, None, tmp_path / "a")
    b = geometry.build_msh("turek_hron", 0, {"flag": "solid"}, tmp_path / "b")
    assert a.name == b.name and a.read_bytes() == b.read_bytes()
    assert [p.name for p in (tmp_path / "a").iterdir()] == [a.name]  # no temporary file left
    assert a.read_text().startswith("$MeshFormat\n4.1 0 8\n")
    assert geometry.build_msh("turek_hron", 0, {"flag": "rigid"}, tmp_path / "a") != a

    def fail(*args):
        raise AssertionError("rebuilt a cached mesh")

    monkeypatch.setattr(turek_hron, "build", fail)
    assert geometry.build_msh("turek_hron", 0, None, tmp_path / "a") == a


@pytest.mark.parametrize("name,level,params,key", [
    ("cylinder", 0, None, "geometry.name"),
    ("turek_hron", 7, None, "geometry.level"),
    ("turek_hron", -1, None, "geometry.level"),
    ("turek_hron", True, None, "geometry.level"),
    ("turek_hron", "2", None, "geometry.level"),
    ("channel", "seed", None, "geometry.level"),
    ("turek_hron", 0, {"flag": "soft"}, "geometry.flag"),
    ("channel", 0, {"length": -1.0}, "geometry.length"),
    ("channel", 0, {"height": "1"}, "geometry.height"),
    ("channel", 0, {"size": 1.0}, "geometry.size"),
])
def test_bad_input(tmp_path, name, level, params, key):
    with pytest.raises(errors.InputError, match=rf"^{key}: "):
        geometry.build_msh(name, level, params, tmp_path)
    assert not any(tmp_path.iterdir())


def test_describe_and_levels():
    d = geometry.describe("turek_hron")
    assert d["points"]["A"] == (0.6, 0.2) and d["cell_tags"] == {"fluid": 1, "solid": 2}
    assert d["facet_tags"] == {"inlet": 1, "outlet": 2, "walls": 3, "cylinder": 4, "interface": 5}
    assert geometry.describe("square")["facet_tags"] == {"walls": 3, "lid": 6}
    assert geometry.describe("channel", {"height": 0.41})["height"] == 0.41
    assert "seed" in geometry.LEVELS["turek_hron"] and "seed" not in geometry.LEVELS["channel"]
    assert set(geometry.LEVELS) == set(geometry.GEOMETRIES)


def test_import_is_light():
    code = "import sys, cosserat_fsi.geometry; assert not {'gmsh', 'dolfinx'} & set(sys.modules)"
    subprocess.run([sys.executable, "-c", code], check=True, cwd=geometry.__file__.rsplit("/cosserat_fsi/", 1)[0])
