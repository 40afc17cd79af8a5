"""A user's mesh whose boundary is not exactly partitioned into named groups, and names given twice: one line
``error: <key or file>: ...``, exit 2, nothing written (in-process: the CLI's ``main``). The numbers behind
these refusals (the ``default`` condition, the inlet's profile, the wall gap): tests/test_user_mesh_topology.py."""

from __future__ import annotations

import shutil

import pytest

from cosserat_fsi.app import cli
from faultlib import in_process_main, snapshot

SQUARE = """Point(1) = {0,0,0,0.25}; Point(2) = {1,0,0,0.25}; Point(3) = {1,1,0,0.25}; Point(4) = {0,1,0,0.25};
Line(1) = {1,2}; Line(2) = {2,3}; Line(3) = {3,4}; Line(4) = {4,1};
Curve Loop(1) = {1,2,3,4}; Plane Surface(1) = {1};
"""  # a unit square meshed with 4 segments a side; bottom 1, right 2, top 3, left 4
BLOCK = """Point(1) = {0,0,0,0.2}; Point(2) = {0.4,0,0,0.2}; Point(3) = {0.6,0,0,0.2}; Point(4) = {1,0,0,0.2};
Point(5) = {1,1,0,0.2}; Point(6) = {0,1,0,0.2}; Point(7) = {0.6,0.3,0,0.2}; Point(8) = {0.4,0.3,0,0.2};
Line(1) = {1,2}; Line(2) = {2,3}; Line(3) = {3,4}; Line(4) = {4,5}; Line(5) = {5,6}; Line(6) = {6,1};
Line(7) = {3,7}; Line(8) = {7,8}; Line(9) = {8,2};
Curve Loop(1) = {1,-9,-8,-7,3,4,5,6}; Plane Surface(1) = {1}; Curve Loop(2) = {2,7,8,9}; Plane Surface(2) = {2};
Physical Surface("fluid") = {1}; Physical Surface("solid") = {2};
"""  # a block (surface 2) standing on the floor of a unit square; line 2 is the block's foot
FLUID = 'Physical Surface("fluid") = {1};\n'
WALLS_OUTLET = FLUID + 'Physical Curve("walls") = {1,3,4}; Physical Curve("outlet") = {2};\n'
THREE_SIDES = FLUID + 'Physical Curve("walls") = {1,3,4};\n'  # the right side (x = 1) in no group
BND = "boundaries: {walls: {type: no_slip}, outlet: {type: do_nothing}}\n"
SCENE = ("fluid: {rho: 1.0, mu: 0.01}\ntime: {scheme: characteristics1, dt: 0.1, t_end: 0.1}\n"
         "output: {progress: false, fields: false}\n")
SOLID = "solid: {rho: 1.0, mu_s: 100.0}\n"

MSH = """$MeshFormat
2.2 0 8
$EndMeshFormat
$PhysicalNames
3
1 3 "walls"
1 7 "{second}"
2 1 "fluid"
$EndPhysicalNames
$Nodes
4
1 0 0 0
2 1 0 0
3 1 1 0
4 0 1 0
$EndNodes
$Elements
6
1 1 2 3 1 1 2
2 1 2 3 3 3 4
3 1 2 7 2 2 3
4 1 2 7 4 4 1
5 2 2 1 1 1 2 3
6 2 2 1 1 1 3 4
$EndElements
"""  # two triangles of a unit square (MSH 2.2, as other tools write it): bottom and top in group 3, the sides in 7


TWO_FLUIDS = (MSH.replace("{second}", "sides").replace('2 1 "fluid"', '2 1 "fluid"\n2 2 "fluid"')
              .replace("3\n1 3", "4\n1 3").replace("6 2 2 1 1", "6 2 2 2 1"))  # each triangle a group "fluid"


CASES = {  # (.geo text, extra YAML, the message's start after "error: ", a part of it)
    "unnamed_side": (SQUARE + THREE_SIDES, "boundaries: {walls: {type: no_slip}}\n",
                     "m.geo: 4 boundary facets are in no physical group", "name them or give boundaries.default"),
    "unnamed_side_where": (SQUARE + THREE_SIDES, "boundaries: {walls: {type: no_slip}}\n",
                           "m.geo: 4 boundary facets", "(the first near (1, "),
    "unnamed_side_defaults_by_name": (SQUARE + THREE_SIDES, "", "m.geo: 4 boundary facets are in no physical group",
                                      None),
    "unnamed_side_with_inflow": (SQUARE + FLUID + 'Physical Curve("inlet") = {4}; Physical Curve("walls") = {1,3};\n',
                                 "inflow: {u_mean: 1.0}\n", "m.geo: 4 boundary facets are in no physical group",
                                 None),
    "unnamed_all_sides": (SQUARE + FLUID + 'Physical Point("corner") = {1};\n', "",
                          "m.geo: 16 boundary facets are in no physical group", None),
    "unnamed_block_foot": (BLOCK + 'Physical Curve("walls") = {1,3,4,5,6};\n', SOLID,
                           "m.geo: 1 boundary facets are in no physical group", "near (0.5, 0)"),
    "same_name_two_curve_groups": (("m.msh", MSH.replace("{second}", "walls")),
                                   "boundaries: {walls: {type: no_slip}}\n",
                                   "geometry.path: m.msh: physical name \"walls\" is used by 2 groups (tags 3 and 7)",
                                   None),
    "same_name_two_cell_groups": (("m.msh", TWO_FLUIDS), "",
                                  "geometry.path: m.msh: physical name \"fluid\" is used by 2 groups (tags 1 and 2)",
                                  None),
    "msh_sides_and_walls_fine_but_forces_twice": (("m.msh", MSH.replace("{second}", "sides")),
                                                  "boundaries: {walls: {type: no_slip}, sides: {type: do_nothing}}\n"
                                                  "observables: {forces: [sides, walls, sides]}\n",
                                                  "observables.forces: \"sides\" listed twice", None),
    "facet_in_two_groups": (SQUARE + FLUID + 'Physical Curve("walls") = {1,2,3,4}; Physical Curve("outlet") = {2};\n',
                            BND, "geometry.path: m.geo: a facet near (1, ",
                            "is in two physical groups, \"outlet\" and \"walls\""),
    "facet_in_two_groups_one_shared_curve": (SQUARE + FLUID + 'Physical Curve("a") = {1,2}; Physical Curve("b") = '
                                             '{2,3,4};\n', "", "geometry.path: m.geo: a facet near (1, ",
                                             "\"a\" and \"b\""),
    "default_named_in_file": (SQUARE + FLUID + 'Physical Curve("default") = {1,2,3,4};\n', "",
                              "geometry.path: m.geo: physical name \"default\" is reserved", None),
    "default_without_unnamed_facets": (SQUARE + WALLS_OUTLET, BND.replace("}}\n", "}, default: {type: no_slip}}\n"),
                                       "boundaries.default: every boundary facet of m.geo is in a named group", None),
    "default_but_named_group_lacks_condition": (SQUARE + THREE_SIDES, "boundaries: {default: {type: do_nothing}}\n",
                                                "boundaries: facet group 'walls' of m.geo has no condition", None),
    "default_bad_type": (SQUARE + THREE_SIDES, "boundaries: {walls: {type: no_slip}, default: {type: outflow}}\n",
                         "boundaries.default.type: must be one of", None),
    "default_on_builtin_geometry": (None, "boundaries: {default: {type: no_slip}}\n",
                                    "boundaries: only for geometry file", None),
    "forces_listed_twice": (SQUARE + WALLS_OUTLET, BND + "observables: {forces: [walls, walls]}\n",
                            "observables.forces: \"walls\" listed twice", None),
    "forces_listed_twice_among_others": (SQUARE + WALLS_OUTLET, BND + "observables: {forces: [walls, outlet, walls]}\n",
                                         "observables.forces: \"walls\" listed twice", None),
    "forces_unknown_boundary": (SQUARE + WALLS_OUTLET, BND + "observables: {forces: [cylinder]}\n",
                                "observables.forces[0]: m.geo has no boundary 'cylinder'", "(it has: outlet, walls"),
    "forces_default_without_unnamed": (SQUARE + WALLS_OUTLET, BND + "observables: {forces: [default]}\n",
                                       "observables.forces[0]: m.geo has no boundary 'default'", None),
    "boundaries_key_names_no_group": (SQUARE + WALLS_OUTLET,
                                      BND.replace("}}\n", "}, wall: {type: no_slip}}\n"),
                                      "boundaries.wall: m.geo has no facet group 'wall'", "(it has: outlet, walls)"),
    "boundaries_key_twice": (SQUARE + WALLS_OUTLET,
                             "boundaries: {walls: {type: no_slip}, walls: {type: slip}, outlet: {type: do_nothing}}\n",
                             "", "duplicate key 'walls'"),
    "boundaries_interface_twice_named": (BLOCK + 'Physical Curve("walls") = {1,2,3,4,5,6}; Physical Curve("foot") = '
                                         '{2};\n', SOLID, "geometry.path: m.geo: a facet near (0.5, 0)",
                                         "\"foot\" and \"walls\""),
}


@pytest.fixture
def main(capsys, tmp_path, monkeypatch):
    """``cli.main(argv)`` -> (exit code, stderr); the --out folder stays byte for byte as it was."""
    monkeypatch.setenv("COSSERAT_FSI_MESH_CACHE", str(tmp_path / "cache"))
    monkeypatch.chdir(tmp_path)
    yield from in_process_main(capsys, tmp_path)


def _one_line(code, err, start, part):
    lines = err.splitlines()
    assert code == 2 and len(lines) == 1 and "Traceback" not in err, (code, err)
    assert lines[0].startswith("error: " + start), err
    assert part is None or part in lines[0], err


@pytest.mark.parametrize("geo, extra, start, part", CASES.values(), ids=CASES)
def test_scene_topology_refused(main, tmp_path, geo, extra, start, part):
    if geo is None:
        geometry = "{name: channel, level: 0}"
    else:
        name, text = geo if isinstance(geo, tuple) else ("m.geo", geo)
        (tmp_path / name).write_text(text)
        geometry = f"{{name: file, path: {name}}}"
    scene = tmp_path / "scene.yaml"
    scene.write_text(f"geometry: {geometry}\n{SCENE}{extra}")
    code, err = main("run", scene, "--out", main.out)
    _one_line(code, err, start, part)


def _finished_run(main, tmp_path, geo_files):
    """A 1-step run of a file scene (its .geo Includes points.geo) whose checkpoint a restart reads."""
    case = tmp_path / "case"
    case.mkdir()
    for name, text in geo_files.items():
        (case / name).write_text(text)
    scene = case / "scene.yaml"
    scene.write_text("geometry: {name: file, path: m.geo}\nfluid: {rho: 1.0, mu: 0.01}\n"
                     "time: {scheme: characteristics1, dt: 0.1, t_end: 0.2}\n"
                     "output: {progress: false, fields: false, checkpoint_every: 1}\n" + BND)
    run = tmp_path / "run"
    assert cli.main(["run", str(scene), "--out", str(run)]) == 0
    return case, scene, run


POINTS = "Point(1) = {0,0,0,0.25}; Point(2) = {1,0,0,0.25}; Point(3) = {1,1,0,0.25}; Point(4) = {0,1,0,0.25};\n"
MAIN = 'Include "points.geo";\n' + SQUARE.split("\n", 1)[1] + WALLS_OUTLET


@pytest.mark.parametrize("changed", ["m.geo", "points.geo"])
def test_restart_after_the_geo_changed_is_refused(main, capsys, tmp_path, changed):
    """The checkpoint's scene fingerprint holds the mesh file's content and that of the files it Includes:
    a changed .geo (or included file) is another scene; the run folder stays as it was."""
    case, scene, run = _finished_run(main, tmp_path, {"m.geo": MAIN, "points.geo": POINTS})
    capsys.readouterr()
    text = (case / changed).read_text()
    (case / changed).write_text(text.replace("{1,1,0,0.25}", "{1,1.2,0,0.25}") if changed == "points.geo"
                                else text + "Mesh.MeshSizeFactor = 0.8;\n")
    before = snapshot(run)
    code = cli.main(["run", str(scene), "--restart", str(run), "--set", "time.t_end=0.3"])
    _one_line(code, capsys.readouterr().err, "--restart: the checkpoint is from another scene", None)
    assert snapshot(run) == before


def test_copied_case_folder_restarts(main, capsys, tmp_path):
    """The same files in another folder are the same scene: the restart is accepted (and the mesh cache reused)."""
    case, scene, run = _finished_run(main, tmp_path, {"m.geo": MAIN, "points.geo": POINTS})
    capsys.readouterr()
    copy = tmp_path / "copy"
    shutil.copytree(case, copy)
    shutil.rmtree(case)
    meshes = sorted(p.name for p in (tmp_path / "cache").glob("*.msh"))
    assert cli.main(["run", str(copy / "scene.yaml"), "--restart", str(run), "--set", "time.t_end=0.3"]) == 0
    assert sorted(p.name for p in (tmp_path / "cache").glob("*.msh")) == meshes
