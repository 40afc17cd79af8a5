"""A 3D file scene's conditions and data misused: vectors with the wrong number of components for a 3D mesh
(velocity, traction, the micro-rotation's value, body_force, solid.initial_velocity), a pressure given as a list,
expressions that are not finite on a face of the 3D boundary, ω not named on a velocity boundary, t in a steady
scene, ``slip`` on a face of solid cells, a .msh with a node at nan or inf, a .msh whose nodes all lie in one
plane but that names its cells a volume, a restart after the .geo changed. Each is one line ``error: <key or
file>: ...``, exit 2, no traceback, the --out folder byte for byte as it was (in-process: the CLI's ``main``).

The scene: tests/data/user_scene/halves_box.geo (the 1 x 0.4 x 0.4 channel in tetrahedra: inlet x = 0, outlet
x = 1, plates y = 0, 0.4, sides z = 0, 0.4) with a micropolar fluid; FOOT: a solid block standing on the face
y = 0 (its group ``bottom`` holds faces of fluid and of solid cells)."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from faultlib import in_process_main, snapshot

HALVES = Path(__file__).resolve().parents[1] / "data" / "user_scene" / "halves_box.geo"
SCENE = """\
geometry: {name: file, path: halves_box.geo}
fluid: {rho: 1.0, mu: 1.0}
micropolar: {mu_r: 0.5, lambda1: 0.1}
time: {scheme: characteristics1, dt: 0.1, t_end: 0.1}
boundaries: {inlet: {type: velocity, value: ['y*(0.4 - y)/0.04', 0, 0], micro_rotation: zero},
             outlet: {type: do_nothing}, plates: {type: no_slip}, sides: {type: slip}}
output: {progress: false, fields: false, checkpoint_every: 1}
"""
FOOT = """SetFactory("OpenCASCADE");
Box(1) = {0, 0, 0, 1, 0.4, 0.4};
Box(2) = {0.4, 0, 0.1, 0.2, 0.2, 0.2};
BooleanFragments{ Volume{1}; Delete; }{ Volume{2}; Delete; }
MeshSize{ PointsOf{ Volume{:}; } } = 0.2;
Physical Volume("fluid") = {3};
Physical Volume("solid") = {2};
Physical Surface("inlet") = {Surface In BoundingBox{-0.01, -0.01, -0.01, 0.01, 0.41, 0.41}};
Physical Surface("outlet") = {Surface In BoundingBox{0.99, -0.01, -0.01, 1.01, 0.41, 0.41}};
Physical Surface("bottom") = {Surface In BoundingBox{-0.01, -0.01, -0.01, 1.01, 0.01, 0.41}};
walls() = Surface In BoundingBox{-0.01, 0.39, -0.01, 1.01, 0.41, 0.41};
walls() += Surface In BoundingBox{-0.01, -0.01, -0.01, 1.01, 0.41, 0.01};
walls() += Surface In BoundingBox{-0.01, -0.01, 0.39, 1.01, 0.41, 0.41};
Physical Surface("walls") = {walls()};
"""  # a 0.2 cube of solid (volume 2) on the face y = 0 of the channel (volume 3)
FOOT_SCENE = """\
geometry: {name: file, path: foot.geo}
fluid: {rho: 1.0, mu: 1.0}
solid: {rho: 1.0, mu_s: 100.0}
time: {scheme: characteristics1, dt: 0.1, t_end: 0.1}
boundaries: {inlet: {type: velocity, value: ['1', 0, 0]}, outlet: {type: do_nothing}, bottom: {type: no_slip},
             walls: {type: no_slip}}
output: {progress: false, fields: false}
"""
TET = """$MeshFormat
2.2 0 8
$EndMeshFormat
$PhysicalNames
2
2 1 "walls"
3 2 "fluid"
$EndPhysicalNames
$Nodes
4
1 0 0 0
2 1 0 0
3 0 1 0
4 {node4}
$EndNodes
$Elements
5
1 2 2 1 1 1 2 3
2 2 2 1 2 1 2 4
3 2 2 1 3 1 3 4
4 2 2 1 4 2 3 4
5 4 2 2 1 1 2 3 4
$EndElements
"""  # one tetrahedron named a volume (MSH 2.2), its fourth node as given
TET_SCENE = """\
geometry: {name: file, path: m.msh}
fluid: {rho: 1.0, mu: 1.0}
time: {scheme: steady}
boundaries: {walls: {type: no_slip}}
output: {progress: false, fields: false}
"""

CASES = {  # --set ... on SCENE -> the expected message (after "error: ")
    "velocity_2_components": (["boundaries.inlet.value=[1, 0]"],
                              "boundaries.inlet.value: must have 3 components for a 3D mesh (got 2)"),
    "traction_2_components": (["boundaries.sides={type: traction, value: [0, 0]}"],
                              "boundaries.sides.value: must have 3 components for a 3D mesh (got 2)"),
    "traction_4_components": (["boundaries.sides={type: traction, value: [0, 0, 0, 0]}"],
                              "boundaries.sides.value: must have 2 components, x and y (3 in 3D; got 4)"),
    "micro_value_2_components": (["boundaries.plates.micro_rotation={value: [0, 0]}"],
                                 "boundaries.plates.micro_rotation.value: must be 3 components [EXPR, EXPR, EXPR] "
                                 "for a 3D mesh (got 2)"),
    "micro_value_1_component": (["boundaries.plates.micro_rotation={value: [0]}"],
                                "boundaries.plates.micro_rotation.value: must be 3 components [EXPR, EXPR, EXPR] "
                                "for a 3D mesh (got 1)"),
    "micro_value_scalar": (["boundaries.plates.micro_rotation={value: '0.5'}"],
                           "boundaries.plates.micro_rotation.value: must be 3 components [EXPR, EXPR, EXPR] for a "
                           "3D mesh"),
    "body_force_2_components": (["fluid.body_force=[0, 1]"],
                                "fluid.body_force: needs 3 components for the 3D geometry file (got 2)"),
    "pressure_list": (["boundaries.outlet={type: pressure, value: [0, 0, 0]}"],
                      "boundaries.outlet.value: must be one expression, the pressure p (got a list of 3)"),
    "velocity_not_finite_on_face": (["boundaries.inlet.value=['1/(z-0.4)', 0, 0]"],
                                    "boundaries.inlet.value[0]: '1/(z-0.4)' is not finite on the boundary at t = 0.0"),
    "traction_not_finite_on_face": (["boundaries.sides={type: traction, value: ['0', 'log(z)', '0']}"],
                                    "boundaries.sides.value[1]: 'log(z)' is not finite on the boundary at t = 0.0"),
    "micro_value_not_finite_on_face": (["boundaries.plates.micro_rotation={value: ['0', '0', '1/(y-0.4)']}"],
                                       "boundaries.plates.micro_rotation.value[2]: '1/(y-0.4)' is not finite on the "
                                       "boundary"),
    "pressure_not_finite_on_face": (["boundaries.outlet={type: pressure, value: 'sqrt(0.9 - x)'}"],
                                    "boundaries.outlet.value: 'sqrt(0.9 - x)' is not finite on the boundary"),
    "velocity_without_micro": (["boundaries.inlet={type: velocity, value: [1, 0, 0]}"],
                               "boundaries.inlet.micro_rotation: required on a velocity boundary of a micropolar "
                               "scene"),
    "t_in_steady_scene": (["time={scheme: steady}", "boundaries.inlet.value=['t', 0, 0]"],
                          "boundaries.inlet.value[0]: uses t in a steady scene: give the time as time.steady_at"),
}
FOOT_CASES = {  # --set ... on FOOT_SCENE
    "slip_on_solid_face": (["boundaries.bottom={type: slip}"],
                           "boundaries.bottom: type slip on a side of solid cells is not supported"),
    "initial_velocity_2_components": (["solid.initial_velocity=[0, 1]"],
                                      "solid.initial_velocity: needs 3 components for the 3D geometry file (got 2)"),
}
MSH_CASES = {  # the fourth node of TET -> the expected message
    "msh_node_nan": ("0 0 nan", "geometry.path: m.msh: node 4 has a coordinate that is not a finite number "
                                "(0, 0, nan)"),
    "msh_node_inf": ("0 inf 1", "geometry.path: m.msh: node 4 has a coordinate that is not a finite number "
                                "(0, inf, 1)"),
    "msh_coplanar_volume": ("1 1 0", "geometry.path: m.msh: 1 of 1 tetrahedra have no volume (the first near (0.5, "
                                     "0.5, 0)): their nodes lie in one plane"),
}


@pytest.fixture(scope="module")
def mesh_cache(tmp_path_factory) -> Path:
    """One mesh cache for the cases of this module (each file is meshed once)."""
    return tmp_path_factory.mktemp("meshes")


@pytest.fixture
def main(capsys, tmp_path, monkeypatch, mesh_cache):
    """``cli.main(argv)`` -> (exit code, stderr) in a folder holding the scenes and their files; the --out folder
    is checked to stay byte for byte as it was."""
    shutil.copy(HALVES, tmp_path / "halves_box.geo")
    (tmp_path / "scene.yaml").write_text(SCENE)
    (tmp_path / "foot.geo").write_text(FOOT)
    (tmp_path / "foot.yaml").write_text(FOOT_SCENE)
    monkeypatch.setenv("COSSERAT_FSI_MESH_CACHE", str(mesh_cache))
    monkeypatch.chdir(tmp_path)
    yield from in_process_main(capsys, tmp_path)


def _one_line(code, err, expected):
    lines = err.splitlines()
    assert code == 2 and len(lines) == 1 and "Traceback" not in err, (code, err)
    assert lines[0].startswith("error: " + expected.split(":")[0] + ":") and expected in lines[0], err


@pytest.mark.parametrize("scene, settings, expected", [("scene.yaml", *c) for c in CASES.values()]
                         + [("foot.yaml", *c) for c in FOOT_CASES.values()], ids=[*CASES, *FOOT_CASES])
def test_3d_condition_fault(main, scene, settings, expected):
    sets = [a for setting in settings for a in ("--set", setting)]
    _one_line(*main("run", scene, "--out", main.out, "--overwrite", *sets), expected)


@pytest.mark.parametrize("node4, expected", MSH_CASES.values(), ids=MSH_CASES)
def test_3d_msh_fault(main, tmp_path, node4, expected):
    (tmp_path / "m.msh").write_text(TET.format(node4=node4))
    (tmp_path / "m.yaml").write_text(TET_SCENE)
    _one_line(*main("run", "m.yaml", "--out", main.out, "--overwrite"), expected)


def test_the_scenes_of_the_cases_pass(main, tmp_path):
    """The cases fail on their setting alone: the tetrahedron with its fourth node off the plane and the
    channel scene run (one step)."""
    (tmp_path / "m.msh").write_text(TET.format(node4="0 0 1"))
    (tmp_path / "m.yaml").write_text(TET_SCENE)
    for scene in ("m.yaml", "scene.yaml"):
        code, err = main("run", scene, "--out", tmp_path / f"run_{scene[0]}")
        assert code == 0, err


def test_restart_after_the_geo_changed(main, tmp_path):
    """The checkpoint keeps the .geo's content fingerprint: a restart with the file unchanged continues the
    run; after the file changed (a finer mesh) it is refused, the run folder as it was."""
    run = tmp_path / "run"
    code, err = main("run", "scene.yaml", "--out", run)
    assert code == 0, err
    same = tmp_path / "same"
    shutil.copytree(run, same)
    code, err = main("run", "scene.yaml", "--restart", same, "--set", "time.t_end=0.2")
    assert code == 0, err
    geo = tmp_path / "halves_box.geo"
    geo.write_text(geo.read_text().replace("= 0.2;", "= 0.15;"))
    before = snapshot(run)
    code, err = main("run", "scene.yaml", "--restart", run, "--set", "time.t_end=0.2")
    _one_line(code, err, "--restart: the checkpoint is from another scene (only time.t_end and output may change")
    assert snapshot(run) == before
