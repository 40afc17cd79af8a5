"""A user's own 3D gmsh file that the scene contract refuses (cell types, names, the boundary's partition, the
scene against the file's dimension), and 2D files drawn off the plane z = 0: one line ``error: <key or
file>: ...``, exit 2, no traceback, nothing written (in-process: the CLI's ``main``; one case through a
subprocess too). What works: tests/test_user_scene_3d.py."""

from __future__ import annotations

import pytest

from faultlib import REPO, check, cli, in_process_main, snapshot

REPO_DATA = REPO / "tests" / "data" / "user_scene"

BOX = """SetFactory("OpenCASCADE");
Box(1) = {0, 0, 0, 1, 0.4, 0.4};
Mesh.MeshSizeMax = 0.2;
"""  # surfaces: 1 x = 0, 2 x = 1, 3 y = 0, 4 y = 0.4, 5 z = 0, 6 z = 0.4
NAMES = ('Physical Volume("fluid") = {1}; Physical Surface("inlet") = {1}; Physical Surface("outlet") = {2};\n'
         'Physical Surface("walls") = {3, 4, 5, 6};\n')
BLOCK = """SetFactory("OpenCASCADE");
Box(1) = {0, 0, 0, 1, 0.4, 0.4};
Box(2) = {0.4, 0.1, 0.1, 0.2, 0.2, 0.2};
BooleanFragments{ Volume{1}; Delete; }{ Volume{2}; Delete; }
Mesh.MeshSizeMax = 0.2;
inlet() = Surface In BoundingBox{-0.01, -0.01, -0.01, 0.01, 0.41, 0.41};
outlet() = Surface In BoundingBox{0.99, -0.01, -0.01, 1.01, 0.41, 0.41};
walls() = Surface In BoundingBox{-0.01, -0.01, -0.01, 1.01, 0.01, 0.41};
walls() += Surface In BoundingBox{-0.01, 0.39, -0.01, 1.01, 0.41, 0.41};
walls() += Surface In BoundingBox{-0.01, -0.01, -0.01, 1.01, 0.41, 0.01};
walls() += Surface In BoundingBox{-0.01, -0.01, 0.39, 1.01, 0.41, 0.41};
Physical Surface("inlet") = {inlet()}; Physical Surface("outlet") = {outlet()};
Physical Surface("walls") = {walls()};
"""  # a 0.2 cube (volume 2) inside the channel (volume 3)
BLOCK_CELLS = 'Physical Volume("fluid") = {3}; Physical Volume("solid") = {2};\n'
SPLIT = (REPO_DATA / "split_channel.geo").read_text()  # the channel in two halves, the face group "mid" inside
PRISMS = """Point(1) = {0, 0, 0, 0.2}; Point(2) = {1, 0, 0, 0.2};
Point(3) = {1, 0.4, 0, 0.2}; Point(4) = {0, 0.4, 0, 0.2};
Line(1) = {1, 2}; Line(2) = {2, 3}; Line(3) = {3, 4}; Line(4) = {4, 1};
Curve Loop(1) = {1, 2, 3, 4}; Plane Surface(1) = {1};
out[] = Extrude {0, 0, 0.4} { Surface{1}; Layers{2}; Recombine; };
Physical Volume("fluid") = {out[1]}; Physical Surface("walls") = {1, out[0], out[2], out[3], out[4], out[5]};
"""
SQUARE = """Point(1) = {0,0,0,0.25}; Point(2) = {1,0,0,0.25}; Point(3) = {1,1,0,0.25}; Point(4) = {0,1,0,0.25};
Line(1) = {1,2}; Line(2) = {2,3}; Line(3) = {3,4}; Line(4) = {4,1};
Curve Loop(1) = {1,2,3,4}; Plane Surface(1) = {1};
Physical Surface("fluid") = {1}; Physical Curve("inlet") = {4}; Physical Curve("walls") = {1,2,3};
"""
XZ_SQUARE = SQUARE.replace("{1,1,0,", "{1,0,1,").replace("{0,1,0,", "{0,0,1,")  # the square in the x-z plane
TILTED = SQUARE.replace("{1,1,0,", "{1,1,0.5,").replace("{0,1,0,", "{0,1,0.5,")  # z = y/2
TET_MSH = """$MeshFormat
2.2 0 8
$EndMeshFormat
$PhysicalNames
3
2 1 "walls"
2 2 "walls"
3 3 "fluid"
$EndPhysicalNames
$Nodes
4
1 0 0 0
2 1 0 0
3 0 1 0
4 0 0 1
$EndNodes
$Elements
5
1 2 2 1 1 1 2 3
2 2 2 1 1 1 2 4
3 2 2 2 2 1 3 4
4 2 2 2 2 2 3 4
5 4 2 3 1 1 2 3 4
$EndElements
"""  # one tetrahedron (MSH 2.2, as other tools write it): its four faces in two groups both named "walls"
SCENE = ("fluid: {rho: 1.0, mu: 0.01}\ntime: {scheme: characteristics1, dt: 0.1, t_end: 0.1}\n"
         "output: {progress: false, fields: false}\n")
BND = "boundaries: {inlet: {type: velocity, value: [1, 0, 0]}, outlet: {type: do_nothing}, walls: {type: no_slip}}\n"
SOLID = "solid: {rho: 1.0, mu_s: 100.0}\n"
NO_SLIP = "boundaries: {walls: {type: no_slip}}\n"

CASES = {  # (file name, its text, extra YAML, the message's start after "error: ", a part of it)
    "hexahedra": ("m.geo", BOX + "Transfinite Curve{1:12} = 3; Transfinite Surface{1:6}; Recombine Surface{1:6};\n"
                  "Transfinite Volume{1};\n" + NAMES, BND, "geometry.path: m.geo has Hexahedron 8 elements",
                  "only first-order tetrahedra are supported"),
    "prisms": ("m.geo", PRISMS, NO_SLIP, "geometry.path: m.geo has Prism 6 elements",
               "only first-order tetrahedra are supported"),
    "second_order": ("m.geo", BOX + "Mesh.ElementOrder = 2;\n" + NAMES, BND,
                     "geometry.path: m.geo has Tetrahedron 10 elements", "only first-order tetrahedra"),
    "surfaces_only": ("m.geo", BOX + 'Physical Surface("walls") = {1, 2, 3, 4, 5, 6};\n', "",
                      "geometry.path: m.geo is a 3D mesh without physical volumes", "Physical Volume"),
    "plane_xz": ("m.geo", XZ_SQUARE, "boundaries: {inlet: {type: velocity, value: [1, 0]}, walls: {type: no_slip}}\n",
                 "geometry.path: m.geo is a 2D mesh outside the plane z = 0 (z from 0 to 1)", "x-y plane"),
    "plane_tilted": ("m.geo", TILTED, "", "geometry.path: m.geo is a 2D mesh outside the plane z = 0 (z from 0 to 0.5)",
                     None),
    "face_in_two_groups": ("m.geo", BOX + NAMES + 'Physical Surface("top") = {6};\n', BND,
                           "geometry.path: m.geo: a facet near (", ", 0.4) is in two physical groups, \"top\" and "
                           "\"walls\""),
    "duplicate_names_geo": ("m.geo", BOX + 'Physical Volume("fluid") = {1};\nPhysical Surface("walls", 10) = {3};\n'
                            'Physical Surface("walls", 11) = {4};\n', "", "geometry.path: gmsh cannot read m.geo",
                            "already exists"),
    "duplicate_names_msh": ("m.msh", TET_MSH, NO_SLIP,
                            "geometry.path: m.msh: physical name \"walls\" is used by 2 groups (tags 1 and 2)", None),
    "default_named": ("m.geo", BOX + 'Physical Volume("fluid") = {1}; Physical Surface("default") = {1:6};\n', "",
                      "geometry.path: m.geo: physical name \"default\" is reserved", None),
    "unnamed_volume": ("m.geo", BOX + NAMES.replace('Physical Volume("fluid")', "Physical Volume(7)"), BND,
                       "geometry.path: physical group 7 of dimension 3 in m.geo has no name", None),
    "unmapped_volume": ("m.geo", BOX + NAMES.replace('"fluid"', '"water"'), BND,
                        "geometry.cells: cell group 'water' of m.geo is neither fluid nor solid", None),
    "condition_inside": ("m.geo", SPLIT, BND.replace("}}\n", "}, mid: {type: no_slip}}\n"),
                         "boundaries.mid: facet group mid of m.geo is inside the domain (not on its boundary); it "
                         "takes no condition", None),
    "velocity_two_components": ("m.geo", BOX + NAMES, BND.replace("[1, 0, 0]", "[1, 0]"),
                                "boundaries.inlet.value: must have 3 components for a 3D mesh (got 2)", None),
    "traction_two_components": ("m.geo", BOX + NAMES, BND.replace("outlet: {type: do_nothing}",
                                                                  "outlet: {type: traction, value: [0, 0]}"),
                                "boundaries.outlet.value: must have 3 components for a 3D mesh (got 2)", None),
    "body_force_two_components": ("m.geo", BOX + NAMES, BND + "fluid: {rho: 1.0, mu: 0.01, body_force: [0, 1]}\n",
                                  "fluid.body_force: needs 3 components for the 3D geometry file", None),
    "velocity_three_components_2d": ("m.geo", SQUARE, "boundaries: {inlet: {type: velocity, value: [1, 0, 0]}, "
                                     "walls: {type: no_slip}}\n",
                                     "boundaries.inlet.value: must have 2 components for a 2D mesh (got 3)", None),
    "missing_condition": ("m.geo", BOX + NAMES, BND.replace(", walls: {type: no_slip}", ""),
                          "boundaries: facet group 'walls' of m.geo has no condition", None),
    "default_all_named": ("m.geo", BOX + NAMES, BND.replace("}}\n", "}, default: {type: no_slip}}\n"),
                          "boundaries.default: every boundary facet of m.geo is in a named group", None),
    "unnamed_faces": ("m.geo", BOX + NAMES.replace('Physical Surface("outlet") = {2};', ""),
                      BND.replace("outlet: {type: do_nothing}, ", ""),
                      "m.geo: ", "boundary facets are in no physical group (the first near (1, "),
    "solid_section_no_volumes": ("m.geo", BOX + NAMES, BND + SOLID, "solid: m.geo has no solid cells", None),
    "solid_volumes_no_section": ("m.geo", BLOCK + BLOCK_CELLS, BND, "solid: missing section (m.geo has ", None),
    "remesh_quality_1": ("m.geo", BLOCK + BLOCK_CELLS, BND + "solid: {rho: 1.0, mu_s: 100.0, mesh_motion: {remesh: "
                         "{quality: 1.0}}}\n", "solid.mesh_motion.remesh.quality: ", None),
    "fails_to_mesh": ("m.geo", """Point(1) = {0,0,0,0.2}; Point(2) = {1,0,0,0.2}; Point(3) = {1,1,0,0.2};
Point(4) = {0,1,0,0.2}; Point(5) = {0.5,0.5,1,0.2};
Line(1) = {1,2}; Line(2) = {2,3}; Line(3) = {3,4}; Line(4) = {4,1}; Line(5) = {1,5}; Line(6) = {2,5};
Curve Loop(1) = {1,2,3,4}; Plane Surface(1) = {1}; Curve Loop(2) = {1,6,-5}; Plane Surface(2) = {2};
Surface Loop(1) = {1, 2}; Volume(1) = {1};
Physical Volume("fluid") = {1}; Physical Surface("walls") = {1, 2};
""", NO_SLIP, "geometry.path: gmsh could not mesh m.geo", None),  # an open surface loop
    "group_inside_and_on_boundary": ("m.geo", SPLIT.replace('Physical Surface("mid") = {mid()};',
                                                            'Physical Surface("mid") = {mid(), outlet()};')
                                     .replace('Physical Surface("outlet") = {outlet()};', ""),
                                     "", "geometry.path: m.geo: facet group \"mid\" has ",
                                     "inside the domain (one near (0.5, "),
    "declared_3d_meshed_2d": ("m.geo", SQUARE + 'If (0)\n  Physical Volume("fluid") = {1};\nEndIf\n',
                              "boundaries: {inlet: {type: velocity, value: [1, 0, 0]}, walls: {type: no_slip}}\n",
                              "geometry.path: m.geo holds a 2D mesh but its physical names declare 3D", None),
}


@pytest.fixture
def main(capsys, tmp_path, monkeypatch):
    """``cli.main(argv)`` -> (exit code, stderr); the --out folder stays byte for byte as it was."""
    monkeypatch.setenv("COSSERAT_FSI_MESH_CACHE", str(tmp_path / "cache"))
    monkeypatch.chdir(tmp_path)
    yield from in_process_main(capsys, tmp_path)


def _scene(tmp_path, name, text, extra):
    (tmp_path / name).write_text(text)
    scene = tmp_path / "scene.yaml"
    body = SCENE if "fluid:" not in extra else SCENE.split("\n", 1)[1]
    scene.write_text(f"geometry: {{name: file, path: {name}}}\n{body}{extra}")
    return scene


@pytest.mark.parametrize("name, text, extra, start, part", CASES.values(), ids=CASES)
def test_3d_file_refused(main, tmp_path, name, text, extra, start, part):
    code, err = main("run", _scene(tmp_path, name, text, extra), "--out", main.out)
    lines = err.splitlines()
    assert code == 2 and len(lines) == 1 and "Traceback" not in err, (code, err)
    assert lines[0].startswith("error: " + start), err
    assert part is None or part in lines[0], err


@pytest.mark.slow
def test_hexahedra_refused_from_the_command_line(tmp_path):
    """The same contract through the real command line: exit 2, one line, the --out folder never made."""
    name, text, extra, start, part = CASES["hexahedra"]
    before = snapshot(tmp_path)
    result = cli("run", _scene(tmp_path, name, text, extra), "--out", tmp_path / "out", "--no-progress",
                 cwd=tmp_path, COSSERAT_FSI_MESH_CACHE=tmp_path / "cache")
    line = check(result, 2, "error: " + start, part)
    assert len(result.stderr.splitlines()) == 1, line
    assert not (tmp_path / "out").exists()
    assert {p for p in snapshot(tmp_path) if p.parts[0] != "cache"} == {p for p in before} | {
        p.relative_to(tmp_path) for p in (tmp_path / name, tmp_path / "scene.yaml")}
