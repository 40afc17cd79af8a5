"""A user's mesh: every boundary facet has one condition (a named group, or ``boundaries.default`` for the
facets in none), the default inflow spans the inlet, the wall gap sees every wall whatever its name, and the
mesh cache knows a file by its content. Refusals: tests/faults/test_scene_topology.py."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from mpi4py import MPI

from cosserat_fsi import compat
from cosserat_fsi.app.runner import load_mesh
from cosserat_fsi.config import validate_geometry, validate_scene
from cosserat_fsi.geometry import build_msh
from cosserat_fsi.observables import Observables
from cosserat_fsi.simulation import Simulation

import dolfinx
import ufl

DATA = Path(__file__).parent / "data" / "user_scene"
NARROW_INLET = """// a 2 x 1 channel whose inlet is the middle half of its left side (y = 0.25 .. 0.75)
Point(1) = {0, 0, 0, 0.1}; Point(2) = {2, 0, 0, 0.1}; Point(3) = {2, 1, 0, 0.1}; Point(4) = {0, 1, 0, 0.1};
Point(5) = {0, 0.75, 0, 0.1}; Point(6) = {0, 0.25, 0, 0.1};
Line(1) = {1, 2}; Line(2) = {2, 3}; Line(3) = {3, 4}; Line(4) = {4, 5}; Line(5) = {5, 6}; Line(6) = {6, 1};
Curve Loop(1) = {1, 2, 3, 4, 5, 6}; Plane Surface(1) = {1};
Physical Surface("fluid") = {1}; Physical Curve("inlet") = {5}; Physical Curve("walls") = {1, 3, 4, 6};
"""


def _run(scene, steps=1):
    comm = MPI.COMM_WORLD
    mesh, ct, ft, _ = load_mesh(scene, comm)
    sim = Simulation(scene, mesh, ct, ft, comm)
    obs = Observables(sim)
    rows = []
    sim.run(steps, observers=[lambda sim: rows.append(obs.evaluate())])
    return sim, rows


def _flux(sim, name):
    """∫ u·n ds over the facet group ``name``."""
    pr = sim.problem
    ds = ufl.Measure("ds", domain=sim.mesh, subdomain_data=sim.facet_tags)(pr.facet_ids[name])
    form = compat.form(ufl.inner(sim.state.velocity, ufl.FacetNormal(sim.mesh)) * ds)
    return sim.comm.allreduce(dolfinx.fem.assemble_scalar(form), op=MPI.SUM)


def test_default_condition_takes_the_unnamed_boundary(tmp_path):
    """The outlet side left unnamed and ``boundaries.default: do_nothing``: the unnamed facets are the group
    ``default`` (the right side of the 2 x 1 channel, length 1), the flow leaves through them with the
    inflow's flux 1."""
    geo = (DATA / "channel.geo").read_text().replace('Physical Curve("outlet") = {2};', "")
    (tmp_path / "c.geo").write_text(geo)
    scene = validate_scene({
        "geometry": {"name": "file", "path": str(tmp_path / "c.geo")}, "fluid": {"rho": 1.0, "mu": 1.0},
        "boundaries": {"inlet": {"type": "velocity", "value": ["6*y*(1 - y)", 0]}, "bottom": {"type": "no_slip"},
                       "top": {"type": "no_slip"}, "default": {"type": "do_nothing"}},
        "time": {"scheme": "steady"}, "output": {"progress": False, "fields": False}})
    sim, _ = _run(scene)
    pr = sim.problem
    assert set(pr.facet_ids) == {"inlet", "bottom", "top", "default"}
    one = dolfinx.fem.Constant(sim.mesh, 1.0)
    ds = ufl.Measure("ds", domain=sim.mesh, subdomain_data=sim.facet_tags)
    length = sim.comm.allreduce(dolfinx.fem.assemble_scalar(compat.form(one * ds(pr.facet_ids["default"]))),
                                op=MPI.SUM)
    assert length == pytest.approx(1.0, abs=1e-12)
    assert pr.pressure_determined()
    assert _flux(sim, "default") == pytest.approx(1.0, rel=1e-10)
    assert _flux(sim, "inlet") == pytest.approx(-1.0, rel=1e-10)


def test_default_inflow_profile_spans_the_inlet_not_the_mesh(tmp_path):
    """No boundaries section, ``inflow: {u_mean: 1}``: the parabola lives on the inlet y = 0.25 .. 0.75, so the
    flux is u_mean × 0.5 (the mesh-high parabola 6 y (1 − y) would give 0.6875 and jump at the walls)."""
    (tmp_path / "n.geo").write_text(NARROW_INLET.replace('Physical Curve("walls")',
                                                         'Physical Curve("outlet") = {2}; Physical Curve("walls")'))
    scene = validate_scene({
        "geometry": {"name": "file", "path": str(tmp_path / "n.geo")}, "fluid": {"rho": 1.0, "mu": 1.0},
        "inflow": {"u_mean": 1.0}, "time": {"scheme": "steady"}, "output": {"progress": False, "fields": False}})
    sim, rows = _run(scene)
    assert _flux(sim, "inlet") == pytest.approx(-0.5, rel=1e-10)
    assert rows[-1]["flow_rate"] == pytest.approx(0.5, rel=1e-8)
    value = sim.problem.conditions()["inlet"].value[0]
    assert "0.25" in value and "0.5" in value, value


def test_wall_gap_checks_every_wall_whatever_its_name(tmp_path):
    """The block scene with its channel walls called ``sides``: the wall-contact check keeps the facets of
    every boundary whose velocity is prescribed (sides, clamp and the inlet: 3.8 + 0.2 + 1 long)."""
    geo = (DATA / "block_channel.geo").read_text().replace('"walls"', '"sides"')
    (tmp_path / "b.geo").write_text(geo)
    scene = validate_scene({
        "geometry": {"name": "file", "path": str(tmp_path / "b.geo")}, "fluid": {"rho": 1.0, "mu": 0.01},
        "solid": {"rho": 1.0, "mu_s": 100.0},
        "boundaries": {"inlet": {"type": "velocity", "value": ["6*y*(1 - y)", 0]}, "outlet": {"type": "do_nothing"},
                       "sides": {"type": "no_slip"}, "clamp": {"type": "no_slip"}},
        "time": {"scheme": "characteristics1", "dt": 0.01, "t_end": 0.01},
        "output": {"progress": False, "fields": False}})
    comm = MPI.COMM_WORLD
    mesh, ct, ft, _ = load_mesh(scene, comm)
    sim = Simulation(scene, mesh, ct, ft, comm)
    assert set(sim.problem.wall_boundaries()) == {"inlet", "sides", "clamp"}
    segments = sim.motion.walls.segments
    lengths = np.unique(np.round(segments.reshape(len(segments), -1), 12), axis=0)
    total = np.linalg.norm(lengths[:, 2:] - lengths[:, :2], axis=1).sum()
    assert total == pytest.approx(3.8 + 0.2 + 1.0, abs=1e-9)


def test_mesh_cache_knows_a_file_by_its_content(tmp_path):
    """The same .geo in two folders is one cached mesh; an included file that changes is another."""
    for folder in ("a", "b"):
        (tmp_path / folder).mkdir()
        (tmp_path / folder / "pts.geo").write_text("h = 0.25;\n")
        (tmp_path / folder / "m.geo").write_text('Include "pts.geo";\n' + (DATA / "channel.geo").read_text())
    cache = tmp_path / "cache"
    a, b = (build_msh(validate_geometry({"name": "file", "path": str(tmp_path / f / "m.geo")}), cache)
            for f in ("a", "b"))
    assert a == b
    (tmp_path / "b" / "pts.geo").write_text("h = 0.5;\n")
    c = build_msh(validate_geometry({"name": "file", "path": str(tmp_path / "b" / "m.geo")}), cache)
    assert c != a
