"""geometry.build_msh: tags, areas, lengths, vertex counts, determinism, cache, input errors."""

import math
import subprocess
import sys

import numpy as np
import pytest

from cosserat_fsi import errors, geometry
from cosserat_fsi.config import validate_geometry
from cosserat_fsi.geometry.builtin import turek_hron


def _geo(name, level=0, params=None):
    """The validated model of a ``geometry`` section."""
    return validate_geometry({"name": name, "level": level, **(params or {})})

R, A_HALF = 0.05, 0.01  # cylinder radius, flag half thickness
X0 = turek_hron.FLAG_START
FLAG_AREA = (0.6 - X0) * 2 * A_HALF - R**2 * math.asin(A_HALF / R) + A_HALF * math.sqrt(R**2 - A_HALF**2)
ARC = 2 * R * math.asin(A_HALF / R)  # clamped arc of the circle
INTERFACE = 2 * (0.6 - X0) + 2 * A_HALF
# measures integrated by _measures, in this order
NAMES = ("fluid", "solid", "inlet", "outlet", "walls", "cylinder", "interface", "lid", "clamp", "boundary",
         "interior5")


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
    parts = [dx(1), dx(2), ds(1), ds(2), ds(3), ds(4), ds(5), ds(6), ds(7), ds, dS(5)]
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
    m = _measures(geometry.build_msh(_geo("turek_hron", level, {"flag": flag}), tmp_path))
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
    m = _measures(geometry.build_msh(_geo("schaefer_turek", 0, None), tmp_path))
    assert m["fluid"] == pytest.approx(2.2 * 0.41 - math.pi * R**2, rel=1e-3) and m["solid"] == 0
    assert (m["inlet"], m["outlet"], m["walls"]) == pytest.approx((0.41, 0.41, 4.4), rel=1e-12)
    assert m["cylinder"] == pytest.approx(2 * math.pi * R, rel=5e-3) and m["interface"] == 0
    assert m["boundary"] == pytest.approx(0.41 * 2 + 4.4 + m["cylinder"])
    assert _is_vertex(m["x"], (0.15, 0.2)) and _is_vertex(m["x"], (0.25, 0.2))


def test_channel_and_square_measures(tmp_path):
    m = _measures(geometry.build_msh(_geo("channel", 1, {"length": 2.0, "height": 0.5}), tmp_path))
    assert m["vertices"] == (64 + 1) * (16 + 1)
    assert (m["fluid"], m["inlet"], m["outlet"], m["walls"]) == pytest.approx((1.0, 0.5, 0.5, 4.0), rel=1e-12)
    m = _measures(geometry.build_msh(_geo("square", 0, {"length": 2.0}), tmp_path))
    assert m["vertices"] == 81
    assert (m["fluid"], m["walls"], m["lid"], m["inlet"]) == pytest.approx((4.0, 6.0, 2.0, 0.0), abs=1e-12)


@pytest.mark.parametrize("level,params", [(0, None), (1, None), (1, {"length": 1.0, "height": 0.1})])
def test_flag_measures(tmp_path, level, params):
    length, thickness = (params or {}).get("length", 0.35), (params or {}).get("height", 0.02)
    m = _measures(geometry.build_msh(_geo("flag", level, params), tmp_path))
    assert (m["solid"], m["fluid"]) == (pytest.approx(length * thickness, rel=1e-12), 0)
    assert m["clamp"] == pytest.approx(thickness, rel=1e-12)
    assert m["interface"] == pytest.approx(2 * length + thickness, rel=1e-12) and m["interior5"] == 0
    assert m["boundary"] == pytest.approx(m["clamp"] + m["interface"], rel=1e-12)
    assert sum(m[k] for k in ("inlet", "outlet", "walls", "cylinder", "lid")) == 0
    ny = 4 * 2**level
    assert m["vertices"] == (round(4 * length / thickness) * ny // 4 + 1) * (ny + 1)  # L0 defaults: 71 x 5
    assert _is_vertex(m["x"], (length, thickness / 2))
    assert _geo("flag", level, params).describe()["points"]["A"] == (length, thickness / 2)


@pytest.mark.parametrize("level", [0, 2])
def test_flag_clamped_on_the_arc(tmp_path, level):
    """``clamp: arc``: the benchmark's flag, clamped on the cylinder (radius 0.05, centre (−0.05, 0.01) in the
    flag's frame): the area and the clamp's arc as in the Turek–Hron geometry (to the chord's polygon error,
    O(h²)), every clamp vertex on the circle, A a vertex, the cell count of the straight flag."""
    m = _measures(geometry.build_msh(_geo("flag", level, {"clamp": "arc"}), tmp_path))
    assert m["solid"] == pytest.approx(FLAG_AREA, rel=2e-4 / 4**level)
    assert m["clamp"] == pytest.approx(ARC, rel=1e-3 / 4**level)
    x = m["x"]
    on_clamp = x[:, 0] < 1e-9
    assert np.abs(np.hypot(x[on_clamp, 0] + R, x[on_clamp, 1] - A_HALF) - R).max() < 1e-9  # gmsh's arc: 1e-11
    assert _is_vertex(x, (0.35, A_HALF)) and np.min(np.linalg.norm(x - [0.0, A_HALF], axis=1)) < 1e-9
    ny = 4 * 2**level
    assert m["vertices"] == (70 * ny // 4 + 1) * (ny + 1)


@pytest.mark.parametrize("level, across", [(0, None), (1, None), (0, 6)])
def test_turek_hron_structured_flag(tmp_path, level, across):
    """``flag_mesh: structured``: the flag's cells are transfinite, 2·2^level (or ``flag_cells_across``) across
    and square along it (2 × across × along triangles), its area, clamp arc and interface those of the
    unstructured flag, A a vertex; the fluid around it unchanged in area."""
    params = {"flag_mesh": "structured", **({"flag_cells_across": across} if across else {})}
    m = _measures(geometry.build_msh(_geo("turek_hron", level, params), tmp_path))
    assert m["solid"] == pytest.approx(FLAG_AREA, rel=1e-3 / 4**level)  # the arc's chords
    assert m["fluid"] + m["solid"] == pytest.approx(2.5 * 0.41 - math.pi * R**2, rel=1e-3)
    assert m["interior5"] == pytest.approx(INTERFACE, rel=1e-9)
    assert _is_vertex(m["x"], (0.6, 0.2))
    compat = pytest.importorskip("cosserat_fsi.compat")
    from mpi4py import MPI

    mesh, cells, _ = compat.read_msh(geometry.build_msh(_geo("turek_hron", level, params), tmp_path),
                                     MPI.COMM_WORLD)
    across = across or 2 * 2**level
    along = round((0.6 - X0) / (0.02 / across))
    assert mesh.comm.allreduce(int(np.sum(cells.values == 2)), op=MPI.SUM) == 2 * across * along


def test_box_measures(tmp_path):
    r = 0.2
    errors_ = []
    for level in (0, 1):
        m = _measures(geometry.build_msh(_geo("box", level, None), tmp_path))
        assert m["fluid"] + m["solid"] == pytest.approx(1.0, rel=1e-12)
        assert m["solid"] == pytest.approx(math.pi * r**2, abs=2e-3)  # inscribed polygon
        assert m["fluid"] == pytest.approx(1 - math.pi * r**2, abs=2e-3)
        assert m["walls"] == pytest.approx(4.0, rel=1e-12) and m["boundary"] == pytest.approx(4.0, rel=1e-12)
        assert m["interior5"] == pytest.approx(2 * math.pi * r, rel=5e-3 if level == 0 else 1.5e-3)
        assert sum(m[k] for k in ("inlet", "outlet", "cylinder", "interface", "lid", "clamp")) == 0
        for point in ((0.5 - r, 0.5), (0.5 + r, 0.5), (0.5, 0.5 - r), (0.5, 0.5 + r)):
            assert _is_vertex(m["x"], point)
        errors_.append(math.pi * r**2 - m["solid"])
    assert 0 < errors_[1] < errors_[0] / 3  # O(h^2)
    m = _measures(geometry.build_msh(_geo("box", 0, {"radius": 0.1}), tmp_path))
    assert m["solid"] == pytest.approx(math.pi * 0.1**2, abs=1e-3)
    assert m["interior5"] == pytest.approx(2 * math.pi * 0.1, rel=1e-2) and m["walls"] == pytest.approx(4.0)


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


@pytest.mark.parametrize("name,flag,low,high", [("turek_hron", "solid", 600, 900), ("turek_hron", "rigid", 600, 900),
                                                ("schaefer_turek", None, 600, 900), ("box", None, 300, 500)])
def test_vertex_counts_per_level(tmp_path, name, flag, low, high):
    params = {"flag": flag} if flag else None
    n0, n1 = (_gmsh_vertices(geometry.build_msh(_geo(name, level, params), tmp_path)) for level in (0, 1))
    assert low <= n0 <= high
    assert 3.3 <= n1 / n0 <= 4.2


def test_seed_level(tmp_path):
    path = geometry.build_msh(_geo("turek_hron", "seed", None), tmp_path)
    assert _gmsh_vertices(path) == pytest.approx(2199, rel=0.05)


def test_deterministic_and_cached(tmp_path, monkeypatch):
    a = geometry.build_msh(_geo("turek_hron", 0, None), tmp_path / "a")
    b = geometry.build_msh(_geo("turek_hron", 0, {"flag": "solid"}), tmp_path / "b")
    assert a.name == b.name and a.read_bytes() == b.read_bytes()
    # no temporary file left; the .sha256 stamp guards the cache
    assert sorted(p.name for p in (tmp_path / "a").iterdir()) == [a.name, a.with_suffix(".sha256").name]
    assert a.read_text().startswith("$MeshFormat\n4.1 0 8\n")
    assert geometry.build_msh(_geo("turek_hron", 0, {"flag": "rigid"}), tmp_path / "a") != a

    def fail(*args):
        raise AssertionError("rebuilt a cached mesh")

    monkeypatch.setattr(turek_hron, "build", fail)
    assert geometry.build_msh(_geo("turek_hron", 0, None), tmp_path / "a") == a


def test_another_gmsh_builds_its_own_mesh(tmp_path, monkeypatch):
    """gmsh 4.8 (Debian) and 4.15 (the wheel) mesh the same geometry differently: the cache key holds the gmsh
    version, so two stacks sharing a cache never read each other's mesh (a run's numbers would depend on
    which stack meshed first)."""
    first = geometry.build_msh(_geo("channel", 0, None), tmp_path)
    monkeypatch.setattr(geometry, "gmsh_version", lambda: "0.0.0-another")
    other = geometry.build_msh(_geo("channel", 0, None), tmp_path)
    assert other != first and other.exists() and first.exists()


@pytest.mark.parametrize("damage", ["truncated", "garbage", "no_stamp"])
def test_damaged_cached_mesh_is_rebuilt(tmp_path, damage):
    """A cached .msh that was truncated, overwritten or has no stamp is rebuilt, never read."""
    path = geometry.build_msh(_geo("channel", 0, None), tmp_path)
    good = path.read_bytes()
    if damage == "truncated":
        path.write_bytes(good[: len(good) // 3])
    elif damage == "garbage":
        path.write_text("$MeshFormat\nnot a mesh\n")
    else:
        path.with_suffix(".sha256").unlink()
    assert geometry.build_msh(_geo("channel", 0, None), tmp_path) == path
    assert path.read_bytes() == good and path.with_suffix(".sha256").exists()


@pytest.mark.parametrize("name,defaults,other", [("flag", {"length": 0.35, "height": 0.02}, {"height": 0.03}),
                                                ("box", {"radius": 0.2}, {"radius": 0.25})])
def test_deterministic_new_geometries(tmp_path, monkeypatch, name, defaults, other):
    a = geometry.build_msh(_geo(name, 0, None), tmp_path / "a")
    b = geometry.build_msh(_geo(name, 0, defaults), tmp_path / "b")
    assert a.name == b.name and a.name.startswith(f"{name}-L0-") and a.read_bytes() == b.read_bytes()
    assert sorted(p.name for p in (tmp_path / "a").iterdir()) == [a.name, a.with_suffix(".sha256").name]
    assert a.read_text().startswith("$MeshFormat\n4.1 0 8\n")
    assert geometry.build_msh(_geo(name, 0, other), tmp_path / "a").name != a.name
    monkeypatch.setattr(geometry._MODULES[name], "build", lambda *args: pytest.fail("rebuilt a cached mesh"))
    assert geometry.build_msh(_geo(name, 0, defaults), tmp_path / "a") == a


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
    ("flag", "seed", None, "geometry.level"),
    ("flag", 0, {"height": 0.0}, "geometry.height"),
    ("flag", 0, {"length": "0.35"}, "geometry.length"),
    ("flag", 0, {"thickness": 0.02}, "geometry.thickness"),
    ("box", 7, None, "geometry.level"),
    ("box", 0, {"radius": -0.1}, "geometry.radius"),
    ("box", 0, {"radius": 0.5}, "geometry.radius"),
    ("box", 0, {"radius": True}, "geometry.radius"),
    ("box", 0, {"size": 1.0}, "geometry.size"),
])
def test_bad_input(tmp_path, name, level, params, key):
    with pytest.raises(errors.InputError, match=rf"^{key}: "):
        geometry.build_msh(_geo(name, level, params), tmp_path)
    assert not any(tmp_path.iterdir())


def test_describe_and_levels():
    d = _geo("turek_hron").describe()
    assert d["points"]["A"] == (0.6, 0.2) and d["cell_tags"] == {"fluid": 1, "solid": 2}
    assert d["facet_tags"] == {"inlet": 1, "outlet": 2, "walls": 3, "cylinder": 4, "interface": 5}
    assert _geo("square").describe()["facet_tags"] == {"walls": 3, "lid": 6}
    assert _geo("channel", 0, {"height": 0.41}).describe()["height"] == 0.41
    assert geometry.TurekHron.SEED and not any(m.SEED for n, m in geometry.MODELS.items() if n != "turek_hron")
    assert all(model.model_fields["name"].default == name for name, model in geometry.MODELS.items())
    d = _geo("flag").describe()
    assert d["points"] == {"A": (0.35, 0.01)} and d["cell_tags"] == {"solid": 2}
    assert d["facet_tags"] == {"interface": 5, "clamp": 7} and (d["length"], d["thickness"]) == (0.35, 0.02)
    d = _geo("box").describe()
    assert d["cell_tags"] == {"fluid": 1, "solid": 2} and d["facet_tags"] == {"walls": 3, "interface": 5}
    assert d["disk"] == {"centre": (0.5, 0.5), "radius": 0.2}
    assert _geo("box", 0, {"radius": 0.1}).describe()["disk"]["radius"] == 0.1


def test_import_is_light():
    code = "import sys, cosserat_fsi.geometry; assert not {'gmsh', 'dolfinx'} & set(sys.modules)"
    subprocess.run([sys.executable, "-c", code], check=True, cwd=geometry.__file__.rsplit("/cosserat_fsi/", 1)[0])
