"""Every number is a number, every file is read within limits: bad scenes, YAML and arguments are one line
``error: <key or file>: <problem>``, exit 2, before anything is written (in-process: the CLI's ``main``)."""

from __future__ import annotations


import pytest

from faultlib import TINY as TINY_TEXT, check, cli as run_cli, in_process_main


@pytest.fixture
def main(capsys, tmp_path):
    """``cli.main(argv)`` -> (exit code, stderr); signal handlers restored; the --out folder is checked
    to stay as it was (faultlib.in_process_main)."""
    yield from in_process_main(capsys, tmp_path)


def _one_line(code, err, expected):
    lines = err.splitlines()
    assert code == 2 and len(lines) == 1 and "Traceback" not in err, (code, err)
    assert lines[0].startswith("error: "), err
    assert expected in lines[0], err


NOT_NUMBERS = {  # --set overrides that must be refused at validation, with the key named
    "mu_inf": ("fluid.mu=.inf", "fluid.mu: must be a finite number"),
    "rho_nan": ("fluid.rho=.nan", "fluid.rho: must be a finite number"),
    "mu_overflow": ("fluid.mu=1e999", "fluid.mu: must be a finite number"),
    "body_force_nan": ("fluid.body_force=[.nan, 0]", "fluid.body_force[0]: must be a finite number"),
    "mu_r_inf": ("micropolar.mu_r=.inf", "micropolar.mu_r: must be a finite number"),
    "inertia_inf": ("micropolar.inertia=-.inf", "micropolar.inertia: must be a finite number"),
    "body_couple_nan": ("micropolar.body_couple=.nan", "micropolar.body_couple: must be a finite number"),
    "u_mean_inf": ("inflow.u_mean=.inf", "inflow.u_mean: must be a finite number"),
    "penalty_inf": ("solver.penalty=.inf", "solver.penalty: must be a finite number"),
    "krylov_rtol_nan": ("solver.krylov_rtol=.nan", "solver.krylov_rtol: must be a finite number"),
    "t_end_inf": ("time.t_end=.inf", "time.t_end: must be a finite number"),
    "dt_denormal": ("time.dt=5e-324", "time.dt: time.t_end / time.dt must be at most"),
    "dt_nan": ("time.dt=.nan", "time.dt: must be a finite number"),
    "every_huge": ("output.every=10000000000000", "output.every: must be <="),
    "every_long_int": ("output.every=" + "9" * 5000, "output.every: could not parse value"),
    "krylov_iterations_huge": ("solver.max_krylov_iterations=1000000000", "solver.max_krylov_iterations: must be <="),
    "quadrature_huge": ("time.quadrature_degree=99", "time.quadrature_degree: must be <="),
    "level_huge": ("geometry.level=" + "1" * 30, "geometry.level: must be an integer 0..6"),
    "petsc_option_capital": ("solver.petsc_options.Ksp_type=gmres", "solver.petsc_options.Ksp_type"),
    "petsc_option_nested": ("solver.petsc_options.ksp_type.x=1", "solver.petsc_options.ksp_type: is a value"),
    "petsc_option_list": ("solver.petsc_options.ksp_type=[1, 2]", "solver.petsc_options.ksp_type"),
    "petsc_option_inf": ("solver.petsc_options.ksp_rtol=.inf", "solver.petsc_options.ksp_rtol"),
    "amg_unknown": ("solver.amg=ml", "solver.amg: must be one of auto, gamg, hypre"),
}


@pytest.mark.parametrize("override, expected", NOT_NUMBERS.values(), ids=NOT_NUMBERS)
def test_non_numbers_are_refused_at_validation(main, tiny_config, override, expected):
    code, err = main("run", tiny_config, "--out", main.out, "--set", override)
    _one_line(code, err, expected)


FSI = ("configs/turek_hron_fsi3.yaml", "configs/micropolar_poiseuille.yaml")
GEOMETRY = {  # sizes refused before gmsh runs, naming the keys
    "channel_length_huge": (FSI[1], ["geometry.length=1e300"], "geometry.length: must be between"),
    "channel_height_tiny": (FSI[1], ["geometry.height=1e-12"], "geometry.height: must be between"),
    "channel_length_inf": (FSI[1], ["geometry.length=.inf"], "geometry.length: must be a finite number"),
    "channel_elongated": (FSI[1], ["geometry.length=1e5", "geometry.height=1e-3", "geometry.level=2"],
                          "error: geometry: geometry.level, geometry.length, geometry.height give about"),
    "solid_c2_inf": (FSI[0], ["solid.c2=.inf"], "solid.c2: must be a finite number"),
    "solid_gravity_nan": (FSI[0], ["solid.gravity=.nan"], "solid.gravity: must be a finite number"),
    "solid_velocity_inf": (FSI[0], ["solid.initial_velocity=[0, .inf]"],
                           "solid.initial_velocity[1]: must be a finite number"),
}


@pytest.mark.parametrize("config, overrides, expected", GEOMETRY.values(), ids=GEOMETRY)
def test_sizes_and_solid_numbers_are_refused_before_meshing(main, repo_root, config, overrides, expected):
    argv = ["run", repo_root / config, "--out", main.out]
    for item in overrides:
        argv += ["--set", item]
    code, err = main(*argv)
    _one_line(code, err, expected)


YAML = {  # scene files the loader must refuse in one line naming the file
    "deep_nesting": (b"a: " + b"[" * 3000 + b"]" * 3000 + b"\n", "nested deeper than"),
    "unhashable_key": (b"? [1, 2]\n: 3\n", "a key must be a plain value"),
    "mapping_key": (b"{{a: 1}: 2}\n", "a key must be a plain value"),
    "huge_integer": (b"output: {every: " + b"7" * 5000 + b"}\n", "integer with more than"),
    "latin1": (TINY_TEXT.encode() + b"name: caf\xe9\n", "not UTF-8 text (byte 0xe9"),
    "binary": (b"\x7fELF\x02\x01\x01\x00" + bytes(range(256)), "binary data"),
    "too_large": (b"# " + b"x" * (2 << 20) + b"\n", "larger than"),
    "billion_laughs": (b"a: &a [1, 1, 1, 1, 1, 1, 1, 1, 1, 1]\n" + b"".join(
        b"%c: &%c [%s]\n" % (c, c, b", ".join([b"*%c" % (c - 1)] * 10)) for c in range(ord("b"), ord("h"))),
        "more than 100000 values"),
    "top_level_list": (b"- 1\n- 2\n", "top level must be a mapping"),
    "empty": (b"", "top level must be a mapping of sections (got empty file)"),
    "control_character": (b"name: a\x07b\n", "could not parse YAML"),
    "bad_merge": (b"<<: 3\n", "'<<' needs a mapping"),
    "recursive_alias": (b"geometry: &a [1, *a]\n", "an alias refers to a value that contains it"),
    "recursive_merge": (b"a: &a {b: 1, <<: *a}\n", "could not parse YAML"),
}


@pytest.mark.parametrize("content, expected", YAML.values(), ids=YAML)
def test_yaml_limits(main, tmp_path, content, expected):
    path = tmp_path / "scene.yaml"
    path.write_bytes(content)
    code, err = main("run", path, "--out", main.out)
    _one_line(code, err, expected)


def test_yaml_merge_keys_are_accepted(tmp_path):
    from cosserat_fsi.config import load_scene

    path = tmp_path / "scene.yaml"
    path.write_text("x-water: &water {rho: 1.0, mu: 0.001}\n"
                    "geometry: {name: schaefer_turek, level: 0}\n"
                    "fluid: {<<: *water, mu: 0.002}\n"
                    "inflow: {u_mean: 1.0}\ntime: {scheme: characteristics1, dt: 0.05, t_end: 0.1}\n")
    scene = load_scene(path)
    assert (scene.fluid.rho, scene.fluid.mu) == (1.0, 0.002)


ARGUMENTS = {
    "config_is_a_folder": (lambda t: ["run", t], "is a folder, not a scene file"),
    "empty_restart": (lambda t: ["run", "{tiny}", "--restart", ""], "--restart: needs the folder"),
    "empty_out": (lambda t: ["run", "{tiny}", "--out", ""], "--out: needs a folder"),
    "overwrite_and_restart": (lambda t: ["run", "{tiny}", "--restart", t, "--overwrite"], "--overwrite: not with"),
    "plot_time_nan": (lambda t: ["plot", t, "--time", "nan"], "--time: invalid finite number value"),
    "study_jobs_zero": (lambda t: ["study", "{tiny}", "--jobs", "0"], "--jobs: must be 1..64"),
}


@pytest.mark.parametrize("argv, expected", ARGUMENTS.values(), ids=ARGUMENTS)
def test_bad_arguments(main, tiny_config, tmp_path, argv, expected):
    args = [str(a).replace("{tiny}", str(tiny_config)) for a in argv(tmp_path)]
    code, err = main(*args)
    _one_line(code, err, expected)


@pytest.mark.parametrize("argv", [
    [b"run", b"conf\xffig.yaml"],
    [b"run", b"{tiny}", b"--set", b"name=caf\xe9"],
    [b"run", b"{tiny}", b"--out", b"runs/\xff\xfe"],
], ids=["config_path", "set_value", "out_path"])
def test_non_utf8_arguments_never_reach_a_traceback(tiny_config, tmp_path, argv):
    args = [a.replace(b"{tiny}", str(tiny_config).encode()) for a in argv]
    result = run_cli(*args, cwd=tmp_path)
    check(result, 2, "error: argument", "not valid UTF-8")
    assert list(tmp_path.iterdir()) == []


def test_config_that_is_a_fifo_does_not_block(main, tmp_path):
    import os

    fifo = tmp_path / "scene.yaml"
    os.mkfifo(fifo)
    code, err = main("run", fifo, "--out", main.out)
    _one_line(code, err, "not a regular file")


# --------------------------------------------------------------- a user's own scene (geometry: file)
_SQUARE = """Point(1) = {0,0,0,0.25}; Point(2) = {1,0,0,0.25}; Point(3) = {1,1,0,0.25}; Point(4) = {0,1,0,0.25};
Line(1) = {1,2}; Line(2) = {2,3}; Line(3) = {3,4}; Line(4) = {4,1};
Curve Loop(1) = {1,2,3,4}; Plane Surface(1) = {1};
"""
_BLOCK = """Point(1) = {0,0,0,0.2}; Point(2) = {0.4,0,0,0.2}; Point(3) = {0.6,0,0,0.2}; Point(4) = {1,0,0,0.2};
Point(5) = {1,1,0,0.2}; Point(6) = {0,1,0,0.2}; Point(7) = {0.6,0.3,0,0.2}; Point(8) = {0.4,0.3,0,0.2};
Line(1) = {1,2}; Line(2) = {2,3}; Line(3) = {3,4}; Line(4) = {4,5}; Line(5) = {5,6}; Line(6) = {6,1};
Line(7) = {3,7}; Line(8) = {7,8}; Line(9) = {8,2};
Curve Loop(1) = {1,-9,-8,-7,3,4,5,6}; Plane Surface(1) = {1}; Curve Loop(2) = {2,7,8,9}; Plane Surface(2) = {2};
"""  # a unit square with a 0.2 x 0.3 block standing on its floor (surface 2)
_TWO_NAMES = ('Physical Surface("fluid") = {1}; Physical Curve("walls") = {1,3,4}; '
              'Physical Curve("outlet") = {2};\n')
_BLOCK_NAMED = 'Physical Surface("fluid") = {1}; Physical Surface("solid") = {2};\n'
_NAMED = 'Physical Surface("fluid") = {1}; Physical Curve("walls") = {1,2,3,4};\n'
_BOX3D = "SetFactory(\"OpenCASCADE\"); Box(1) = {0,0,0,1,1,1};\nPhysical Volume(\"fluid\") = {1};\n" \
         "Physical Surface(\"walls\") = {1,2,3,4,5,6};\n"
_SCENE = ("fluid: {rho: 1.0, mu: 0.01}\ntime: {scheme: characteristics1, dt: 0.1, t_end: 0.1}\n"
          "output: {progress: false}\n")
FILE_SCENES = {  # (files {name: content}, geometry section, extra YAML, expected message)
    "missing_file": ({}, "{name: file, path: nowhere.geo}", "", "geometry.path: no such file: "),
    "not_gmsh_suffix": ({"m.txt": _SQUARE}, "{name: file, path: m.txt}", "",
                        "geometry.path: must be a gmsh .geo or .msh file"),
    "msh_not_gmsh": ({"m.msh": "hello\n"}, "{name: file, path: m.msh}", "", "geometry.path: not a gmsh mesh file"),
    "geo_binary": ({"m.geo": "\0\1\2binary"}, "{name: file, path: m.geo}", "", "geometry.path: not a gmsh .geo"),
    "geo_syntax": ({"m.geo": "Point(1) = {0,0,0,0.1};\nLine(1) = {1, 2};\n"}, "{name: file, path: m.geo}", "",
                   "geometry.path: gmsh cannot read m.geo"),
    "no_physical_names": ({"m.geo": _SQUARE}, "{name: file, path: m.geo}", "", "has no physical names"),
    "unnamed_group": ({"m.geo": _SQUARE + 'Physical Surface("fluid") = {1}; Physical Curve(7) = {1};\n'},
                      "{name: file, path: m.geo}", "", "physical group 7 of dimension 1 in m.geo has no name"),
    "mesh_3d_without_volumes": ({"m.geo": _BOX3D.replace('Physical Volume("fluid") = {1};', "")},
                                "{name: file, path: m.geo}", "", "m.geo is a 3D mesh without physical volumes"),
    "unmapped_cells": ({"m.geo": _SQUARE + 'Physical Surface("water") = {1};\n'}, "{name: file, path: m.geo}", "",
                       "geometry.cells: cell group 'water' of m.geo is neither fluid nor solid"),
    "no_cell_groups": ({"m.geo": _SQUARE + 'Physical Curve("walls") = {1,2,3,4};\n'},
                       "{name: file, path: m.geo}", "", "m.geo has no cell group named fluid or solid"),
    "solid_without_fluid": ({"m.geo": _SQUARE + 'Physical Surface("solid") = {1};\n'},
                            "{name: file, path: m.geo}", "solid: {rho: 1.0, mu_s: 100.0}\n",
                            "geometry.path: m.geo has no fluid cells"),
    "solid_cells_no_section": ({"m.geo": _BLOCK + _BLOCK_NAMED},
                               "{name: file, path: m.geo}", "", "solid: missing section (m.geo has"),
    "solid_section_no_cells": ({"m.geo": _SQUARE + _NAMED}, "{name: file, path: m.geo}",
                               "solid: {rho: 1.0, mu_s: 100.0}\n", "solid: m.geo has no solid cells"),
    "inflow_without_inlet": ({"m.geo": _SQUARE + _NAMED}, "{name: file, path: m.geo}",
                             "inflow: {u_mean: 1.0}\n", "inflow: m.geo has no facet group 'inlet' (it has: walls)"),
    "interface_not_interface": ({"m.geo": _BLOCK + _BLOCK_NAMED + 'Physical Curve("interface") = {8};\n'},
                                "{name: file, path: m.geo}",
                                "solid: {rho: 1.0, mu_s: 100.0}\n", "facet group 'interface' of m.geo is not the"),
    "bnd_unknown_name": ({"m.geo": _SQUARE + _NAMED}, "{name: file, path: m.geo}",
                         "boundaries: {walls: {type: no_slip}, inflow_x: {type: do_nothing}}\n",
                         "boundaries.inflow_x: m.geo has no facet group 'inflow_x' (it has: walls)"),
    "bnd_without_condition": ({"m.geo": _SQUARE + _TWO_NAMES}, "{name: file, path: m.geo}",
                              "boundaries: {walls: {type: no_slip}}\n",
                              "boundaries: facet group 'outlet' of m.geo has no condition"),
    "bnd_on_interface": ({"m.geo": _BLOCK + _BLOCK_NAMED + 'Physical Curve("walls") = {1,2,3,4,5,6};\n'},
                         "{name: file, path: m.geo}", "solid: {rho: 1.0, mu_s: 100.0}\n"
                         "boundaries: {walls: {type: no_slip}, interface: {type: no_slip}}\n",
                         "boundaries.interface: the fluid-solid interface is inside the domain"),
    "bnd_builtin_geometry": ({}, "{name: channel}", "boundaries: {walls: {type: no_slip}}\n",
                             "boundaries: only for geometry file (geometry channel sets its own)"),
    "bnd_with_inflow": ({"m.geo": _SQUARE + _TWO_NAMES}, "{name: file, path: m.geo}",
                        "inflow: {u_mean: 1.0}\nboundaries: {walls: {type: no_slip}, outlet: {type: do_nothing}}\n",
                        "inflow: not used with a boundaries section"),
    "bnd_unknown_symbol": ({"m.geo": _SQUARE + _TWO_NAMES}, "{name: file, path: m.geo}",
                           "boundaries: {walls: {type: velocity, value: ['2*q', 0]}, outlet: {type: do_nothing}}\n",
                           "boundaries.walls.value[0]: unknown symbol 'q' in '2*q' (allowed: x, y, z, t, pi"),
    "bnd_syntax": ({"m.geo": _SQUARE + _TWO_NAMES}, "{name: file, path: m.geo}",
                   "boundaries: {walls: {type: velocity, value: [0, 'sin(x']}, outlet: {type: do_nothing}}\n",
                   "boundaries.walls.value[1]: syntax error in 'sin(x'"),
    "bnd_components": ({"m.geo": _SQUARE + _TWO_NAMES}, "{name: file, path: m.geo}",
                       "boundaries: {walls: {type: traction, value: [1, 0, 0]}, outlet: {type: do_nothing}}\n",
                       "boundaries.walls.value: must have 2 components for a 2D mesh (got 3)"),
    "bnd_import": ({"m.geo": _SQUARE + _TWO_NAMES}, "{name: file, path: m.geo}",
                   "boundaries: {walls: {type: velocity, value: [\"__import__('os').system('touch X')\", 0]},"
                   " outlet: {type: do_nothing}}\n", "boundaries.walls.value[0]: only the functions"),
    "bnd_attribute": ({"m.geo": _SQUARE + _TWO_NAMES}, "{name: file, path: m.geo}",
                      "boundaries: {walls: {type: velocity, value: ['x.__class__', 0]}, outlet: {type: do_nothing}}\n",
                      "boundaries.walls.value[0]: an attribute is not allowed"),
    "bnd_missing_value": ({"m.geo": _SQUARE + _TWO_NAMES}, "{name: file, path: m.geo}",
                          "boundaries: {walls: {type: velocity}, outlet: {type: do_nothing}}\n",
                          "boundaries.walls.value: missing key (type velocity needs value: [EXPR, EXPR])"),
    "bnd_value_not_used": ({"m.geo": _SQUARE + _TWO_NAMES}, "{name: file, path: m.geo}",
                           "boundaries: {walls: {type: no_slip, value: [0, 0]}, outlet: {type: do_nothing}}\n",
                           "boundaries.walls.value: not used for type no_slip"),
    "bnd_bad_type": ({"m.geo": _SQUARE + _TWO_NAMES}, "{name: file, path: m.geo}",
                     "boundaries: {walls: {type: wall}, outlet: {type: do_nothing}}\n",
                     "boundaries.walls.type: must be one of no_slip, velocity, do_nothing, traction, pressure, slip"),
    "bnd_micro_without_micropolar": ({"m.geo": _SQUARE + _TWO_NAMES}, "{name: file, path: m.geo}",
                                     "boundaries: {walls: {type: no_slip, micro_rotation: zero}, "
                                     "outlet: {type: do_nothing}}\n",
                                     "boundaries.walls.micro_rotation: only with micropolar terms"),
    "obs_unknown_force": ({"m.geo": _SQUARE + _NAMED}, "{name: file, path: m.geo}",
                          "observables: {forces: [cylinder]}\n",
                          "observables.forces[0]: m.geo has no boundary 'cylinder' (it has: walls"),
    "obs_wetted_without_solid": ({"m.geo": _SQUARE + _NAMED}, "{name: file, path: m.geo}",
                                 "observables: {wetted_solid: true}\n",
                                 "observables.wetted_solid: m.geo has no fluid-solid interface"),
    "obs_solid_points_without_solid": ({"m.geo": _SQUARE + _NAMED}, "{name: file, path: m.geo}",
                                       "observables: {solid_points: {tip: [0.5, 0.5]}}\n",
                                       "observables.solid_points: the scene has no solid section"),
    "obs_builtin_geometry": ({}, "{name: channel}", "observables: {forces: [walls]}\n",
                             "observables: only for geometry file"),
    "obs_point_components": ({"m.geo": _SQUARE + _NAMED}, "{name: file, path: m.geo}",
                             "observables: {points: {a: [0.5]}}\n",
                             "observables.points.a: must have 2 or 3 coordinates"),
    "second_order": ({"m.geo": _SQUARE + _NAMED + "Mesh.ElementOrder = 2;\n"}, "{name: file, path: m.geo}", "",
                     "only first-order triangles and quadrangles"),
    "fluid_and_solid_name": ({"m.geo": _SQUARE + _NAMED}, "{name: file, path: m.geo, cells: {solid: [fluid]}}", "",
                             "geometry.cells: 'fluid' is both fluid and solid"),
    "seed_level": ({"m.geo": _SQUARE + _NAMED}, "{name: file, path: m.geo, level: seed}", "",
                   "geometry.level: must be an integer 0..6"),
    "unknown_key": ({"m.geo": _SQUARE + _NAMED}, "{name: file, path: m.geo, flag: solid}", "",
                    "geometry.flag: only for geometry turek_hron"),
}


@pytest.mark.parametrize("files, geometry, extra, expected", FILE_SCENES.values(), ids=FILE_SCENES)
def test_file_scene_bad_input(main, tmp_path, monkeypatch, files, geometry, extra, expected):
    monkeypatch.setenv("COSSERAT_FSI_MESH_CACHE", str(tmp_path / "cache"))
    for name, content in files.items():
        (tmp_path / name).write_text(content)
    scene = tmp_path / "scene.yaml"
    scene.write_text(f"geometry: {geometry}\n{_SCENE}{extra}")
    monkeypatch.chdir(tmp_path)  # a "touch X" that ran would leave X here
    code, err = main("run", scene, "--out", main.out)
    _one_line(code, err, expected)
    assert not (tmp_path / "X").exists()


def test_file_scene_gmsh_failure(main, tmp_path, monkeypatch):
    """gmsh failing while it meshes a .geo (the fault suite's failpoint in the gmsh child) names the file."""
    monkeypatch.setenv("COSSERAT_FSI_MESH_CACHE", str(tmp_path / "cache"))
    monkeypatch.setenv("COSSERAT_FSI_FAILPOINT", "gmsh@0:error")
    (tmp_path / "m.geo").write_text(_SQUARE + _NAMED)
    scene = tmp_path / "scene.yaml"
    scene.write_text(f"geometry: {{name: file, path: m.geo}}\n{_SCENE}")
    code, err = main("run", scene, "--out", main.out)
    _one_line(code, err, "geometry.path: gmsh could not mesh m.geo")


@pytest.mark.slow
def test_file_scene_gmsh_timeout(main, tmp_path, monkeypatch):
    """gmsh that never finishes a .geo (the failpoint sleeps in the gmsh child) is stopped after
    COSSERAT_FSI_GMSH_TIMEOUT seconds: exit 2, one line naming the file, nothing cached."""
    import time

    monkeypatch.setenv("COSSERAT_FSI_MESH_CACHE", str(tmp_path / "cache"))
    monkeypatch.setenv("COSSERAT_FSI_FAILPOINT", "gmsh@0:hang")
    monkeypatch.setenv("COSSERAT_FSI_GMSH_TIMEOUT", "3")
    (tmp_path / "m.geo").write_text(_SQUARE + _NAMED)
    scene = tmp_path / "scene.yaml"
    scene.write_text(f"geometry: {{name: file, path: m.geo}}\n{_SCENE}")
    start = time.monotonic()
    code, err = main("run", scene, "--out", main.out)
    _one_line(code, err, "geometry.path: gmsh did not finish meshing m.geo within 3 s")
    assert time.monotonic() - start < 60
    assert not list((tmp_path / "cache").glob("*.msh"))
