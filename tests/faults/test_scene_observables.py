"""A file scene's own observables and references misused: ``observables.lines`` (outside the mesh, too few or
too many points, wrong dimensions, a segment of length 0), probes and solid points with a coordinate count
that is not the scene's (2 in 2D, 3 in 3D) or not finite, probes outside the mesh, ``observables.flow_rates``
naming a facet group the file lacks or one twice, a ``reference`` to a column the scene does not have or with
a bad tolerance; forces on a facet group the file lacks or one inside the domain; a restart whose line_NAME.csv
is missing, foreign or damaged. Each is one line
``error: <key>: ...``, exit 2, no traceback, the --out folder byte for byte as it was (in-process: the CLI's
``main``; the mesh is the 2 x 1 channel of tests/data/user_scene, level 0: setup-time cases cost one mesh
read; the 3D cases: a real 3D file, tests/data/user_scene/halves_box.geo: wrong coordinate counts are refused by
the scene checks before the mesh is read, positions outside the mesh and unknown or inside facet groups at
setup)."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from faultlib import in_process_main, snapshot

CHANNEL = Path(__file__).resolve().parents[1] / "data" / "user_scene" / "channel.geo"
SCENE = """\
geometry: {name: file, path: channel.geo}
fluid: {rho: 1.0, mu: 1.0}
time: {scheme: characteristics1, dt: 0.1, t_end: 0.1}
boundaries: {inlet: {type: velocity, value: ['4*y*(1 - y)', 0]}, outlet: {type: do_nothing},
             top: {type: no_slip}, bottom: {type: no_slip}}
observables: {points: {C: [1.0, 0.5]}, lines: {L: {from: [1.0, 0.0], to: [1.0, 1.0], points: 5}}}
output: {progress: false, fields: false}
"""

CASES = {  # --set -> the expected message (after "error: ")
    "line_outside": ("observables.lines.L.to=[1.0, 1.5]", "observables.lines.L: point (1, 1.125) is outside the mesh"),
    "line_far_outside": ("observables.lines.L.from=[-5.0, 0.0]", "observables.lines.L: point (-5, 0) is outside"),
    "line_points_0": ("observables.lines.L.points=0", "observables.lines.L.points: must be >= 2 (got 0)"),
    "line_points_1": ("observables.lines.L.points=1", "observables.lines.L.points: must be >= 2 (got 1)"),
    "line_points_negative": ("observables.lines.L.points=-3", "observables.lines.L.points: must be >= 2"),
    "line_points_huge": ("observables.lines.L.points=10001", "observables.lines.L.points: must be <= 10000"),
    "line_points_overflow": ("observables.lines.L.points=" + "9" * 40, "observables.lines.L.points: must be <="),
    "line_points_float": ("observables.lines.L.points=2.5", "observables.lines.L.points: must be an integer"),
    "line_points_text": ("observables.lines.L.points=many", "observables.lines.L.points: must be an integer"),
    "line_from_3d": ("observables.lines.L.from=[1.0, 0.0, 0.0]",
                     "observables.lines.L.from: must have 2 coordinates [x, y] in a 2D scene (got 3)"),
    "line_to_1d": ("observables.lines.L.to=[1.0]", "observables.lines.L.to: must have 2 or 3 coordinates"),
    "line_from_nan": ("observables.lines.L.from=[.nan, 0.0]", "observables.lines.L.from[0]: must be a finite number"),
    "line_from_text": ("observables.lines.L.from=[a, 0.0]", "observables.lines.L.from[0]: must be a number"),
    "line_zero_length": ("observables.lines.L.to=[1.0, 0.0]", "observables.lines.L.to: must differ from 'from'"),
    "line_no_from": ("observables.lines.L={to: [1.0, 1.0], points: 3}", "observables.lines.L.from: missing key"),
    "line_no_points": ("observables.lines.L={from: [1.0, 0.0], to: [1.0, 1.0]}",
                       "observables.lines.L.points: missing key"),
    "line_unknown_key": ("observables.lines.L.step=3", "observables.lines.L.step: unknown key"),
    "line_bad_name": ("observables.lines={a-b: {from: [0, 0], to: [1, 1], points: 3}}",
                      "observables.lines: 'a-b': names are 1 to 40 letters"),
    "line_not_mapping": ("observables.lines.L=3", "observables.lines.L: must be a mapping"),
    "probe_outside": ("observables.points={C: [2.5, 0.5]}",
                      "observables.points.C: point (2.5, 0.5) is outside the mesh"),
    "probe_3d_in_2d": ("observables.points={C: [1.0, 0.5, 0.0]}",
                       "observables.points.C: must have 2 coordinates [x, y] in a 2D scene (got 3)"),
    "probe_4_coordinates": ("observables.points={C: [1.0, 0.5, 0.0, 0.0]}",
                            "observables.points.C: must have 2 or 3 coordinates ([x, y] in a 2D scene, [x, y, z] in "
                            "3D; got 4)"),
    "probe_1_coordinate": ("observables.points={C: [1.0]}", "observables.points.C: must have 2 or 3 coordinates"),
    "probe_no_coordinates": ("observables.points={C: []}", "observables.points.C: must have 2 or 3 coordinates"),
    "probe_nan": ("observables.points={C: [.nan, 0.5]}", "observables.points.C[0]: must be a finite number"),
    "probe_inf_z": ("observables.points={C: [1.0, 0.5, .inf]}", "observables.points.C[2]: must be a finite number"),
    "probe_text": ("observables.points={C: [1.0, up]}", "observables.points.C[1]: must be a number"),
    "solid_point_4_coordinates": ("observables.solid_points={tip: [1.0, 0.5, 0.0, 0.0]}",
                                  "observables.solid_points.tip: must have 2 or 3 coordinates"),
    "solid_point_nan": ("observables.solid_points={tip: [1.0, .nan]}",
                        "observables.solid_points.tip[1]: must be a finite number"),
    "flow_rate_unknown": ("observables.flow_rates=[inlet, wall]",
                          "observables.flow_rates[1]: channel.geo has no boundary facet group 'wall' (it has: bottom, "
                          "inlet, outlet, top)"),
    "flow_rate_interface": ("observables.flow_rates=[interface]",
                            "observables.flow_rates[0]: channel.geo has no boundary facet group 'interface'"),
    "flow_rate_twice": ("observables.flow_rates=[outlet, inlet, outlet]",
                        'observables.flow_rates: "outlet" listed twice'),
    "flow_rate_bad_name": ("observables.flow_rates=[out-let]",
                           "observables.flow_rates: 'out-let': names are 1 to 40 letters"),
    "flow_rate_not_list": ("observables.flow_rates=outlet", "observables.flow_rates: must be a list"),
    "ref_unknown_column": ("reference={drag: {value: 1.0, tolerance: 0.1}}",
                           "reference.drag: not a column of this scene's timeseries.csv"),
    "ref_time_column": ("reference={t: {value: 1.0, tolerance: 0.1}}",
                        "reference.t: the time and the step size are not observables"),
    "ref_negative_tolerance": ("reference={u_C: {value: 1.0, tolerance: -0.1}}",
                               "reference.u_C.tolerance: must be > 0"),
    "ref_zero_tolerance": ("reference={u_C: {value: 1.0, tolerance: 0}}", "reference.u_C.tolerance: must be > 0"),
    "ref_inf_tolerance": ("reference={u_C: {value: 1.0, tolerance: .inf}}",
                          "reference.u_C.tolerance: must be a finite number"),
    "ref_no_tolerance": ("reference={u_C: {value: 1.0}}", "reference.u_C: give exactly one of tolerance"),
    "ref_two_tolerances": ("reference={u_C: {value: 1.0, tolerance: 0.1, abs_tolerance: 0.1}}",
                           "reference.u_C: give exactly one of tolerance"),
    "ref_nothing": ("reference={u_C: {tolerance: 0.1}}", "reference.u_C: missing key (value, or mean"),
    "ref_value_and_frequency": ("reference={u_C: {value: 1.0, frequency: 2.0, tolerance: 0.1}}",
                                "reference.u_C: frequency: not with value"),
    "ref_relative_to_zero": ("reference={v_C: {value: 0.0, tolerance: 0.1}}",
                             "reference.v_C: tolerance: relative to a reference of 0; give abs_tolerance"),
    "ref_negative_frequency": ("reference={u_C: {frequency: -2.0, tolerance: 0.1}}",
                               "reference.u_C.frequency: must be > 0"),
    "ref_negative_amplitude": ("reference={u_C: {amplitude: -1.0, tolerance: 0.1}}",
                               "reference.u_C.amplitude: must be >= 0"),
    "ref_unknown_part": ("reference={u_C: {period: 1.0, tolerance: 0.1}}", "reference.u_C.period: unknown key"),
    "ref_not_mapping": ("reference=[u_C]", "reference: must be a mapping"),
}


@pytest.fixture
def main(capsys, tmp_path, monkeypatch):
    """``cli.main(argv)`` -> (exit code, stderr) in a folder holding the scene; the --out folder is checked to
    stay byte for byte as it was."""
    shutil.copy(CHANNEL, tmp_path / "channel.geo")
    (tmp_path / "scene.yaml").write_text(SCENE)
    monkeypatch.chdir(tmp_path)
    yield from in_process_main(capsys, tmp_path)


@pytest.mark.parametrize("setting, expected", CASES.values(), ids=CASES)
def test_scene_observable_fault(main, setting, expected):
    code, err = main("run", "scene.yaml", "--out", main.out, "--overwrite", "--set", setting)
    lines = err.splitlines()
    assert code == 2 and len(lines) == 1 and "Traceback" not in err, (code, err)
    assert lines[0].startswith("error: " + expected.split(":")[0] + ":"), err  # names the key
    assert expected in lines[0], err


HALVES = Path(__file__).resolve().parents[1] / "data" / "user_scene" / "halves_box.geo"
SCENE_3D = """\
geometry: {name: file, path: halves_box.geo}
fluid: {rho: 1.0, mu: 1.0}
time: {scheme: characteristics1, dt: 0.1, t_end: 0.1}
boundaries: {inlet: {type: velocity, value: ['y*(0.4 - y)/0.04', 0, 0]}, outlet: {type: do_nothing},
             plates: {type: no_slip}, sides: {type: slip}}
observables: {points: {C: [0.25, 0.2, 0.2]}, lines: {L: {from: [0.25, 0.0, 0.2], to: [0.25, 0.4, 0.2], points: 5}},
              flow_rates: [outlet], forces: [plates]}
output: {progress: false, fields: false}
"""
"""A real 3D file scene: halves_box.geo, the 1 x 0.4 x 0.4 channel in tetrahedra (physical volume fluid; surfaces
inlet, outlet, plates, sides, and mid: the face x = 0.5 inside the domain)."""

CASES_3D = {  # --set ... -> the expected message (after "error: ")
    "probe_2d_in_3d": (["observables.points={C: [0.25, 0.2]}"],
                       "observables.points.C: must have 3 coordinates [x, y, z] in a 3D scene (got 2)"),
    "line_from_2d_in_3d": (["observables.lines.L.from=[0.25, 0.0]"],
                           "observables.lines.L.from: must have 3 coordinates [x, y, z] in a 3D scene (got 2)"),
    "line_to_2d_in_3d": (["observables.lines.L.to=[0.25, 0.4]"],
                         "observables.lines.L.to: must have 3 coordinates [x, y, z] in a 3D scene (got 2)"),
    "solid_point_2d_in_3d": (["solid={rho: 1.0, mu_s: 1.0}", "observables.solid_points={tip: [0.25, 0.2]}"],
                             "observables.solid_points.tip: must have 3 coordinates [x, y, z] in a 3D scene (got 2)"),
    "probe_4_in_3d": (["observables.points={C: [0.25, 0.2, 0.2, 0.2]}"],
                      "observables.points.C: must have 2 or 3 coordinates ([x, y] in a 2D scene, [x, y, z] in 3D; "
                      "got 4)"),
    "line_to_4_in_3d": (["observables.lines.L.to=[0.25, 0.4, 0.2, 0.0]"],
                        "observables.lines.L.to: must have 2 or 3 coordinates"),
    "probe_outside_3d": (["observables.points={C: [0.25, 0.2, 0.5]}"],
                         "observables.points.C: point (0.25, 0.2, 0.5) is outside the mesh"),
    "line_leaves_3d": (["observables.lines.L.to=[0.25, 0.6, 0.2]"],
                       "observables.lines.L: point (0.25, 0.45, 0.2) is outside the mesh"),
    "flow_rate_unknown_3d": (["observables.flow_rates=[outlet, walls]"],
                             "observables.flow_rates[1]: halves_box.geo has no boundary facet group 'walls' (it has: "
                             "inlet, outlet, plates, sides)"),
    "flow_rate_inside_3d": (["observables.flow_rates=[mid]"],
                            "observables.flow_rates[0]: halves_box.geo has no boundary facet group 'mid'"),
    "force_unknown_3d": (["observables.forces=[walls]"],
                         "observables.forces[0]: halves_box.geo has no boundary 'walls' (it has: inlet, outlet, "
                         "plates, sides; the interface: observables.wetted_solid)"),
    "force_inside_3d": (["observables.forces=[plates, mid]"],
                        "observables.forces[1]: halves_box.geo has no boundary 'mid'"),
}


@pytest.fixture
def main3d(capsys, tmp_path, monkeypatch):
    """``cli.main(argv)`` -> (exit code, stderr) in a folder holding the 3D scene and its .geo; the --out folder is
    checked to stay byte for byte as it was."""
    shutil.copy(HALVES, tmp_path / "halves_box.geo")
    (tmp_path / "scene.yaml").write_text(SCENE_3D)
    monkeypatch.chdir(tmp_path)
    yield from in_process_main(capsys, tmp_path)


@pytest.mark.parametrize("settings, expected", CASES_3D.values(), ids=CASES_3D)
def test_scene_observable_fault_3d(main3d, settings, expected):
    sets = [a for setting in settings for a in ("--set", setting)]
    code, err = main3d("run", "scene.yaml", "--out", main3d.out, "--overwrite", *sets)
    lines = err.splitlines()
    assert code == 2 and len(lines) == 1 and "Traceback" not in err, (code, err)
    assert lines[0].startswith("error: " + expected.split(":")[0] + ":") and expected in lines[0], err


def test_3d_scene_of_the_cases_runs(tmp_path):
    """The 3D scene of ``main3d`` itself is a 3D scene that runs (one step), with its positions, flow rate and
    force: the cases above fail on their setting alone."""
    from cosserat_fsi import load_scene, read_timeseries, run_scene

    shutil.copy(HALVES, tmp_path / "halves_box.geo")
    (tmp_path / "scene.yaml").write_text(SCENE_3D)
    scene = load_scene(tmp_path / "scene.yaml")
    assert scene.geometry.DIM == 3 and scene.observables.points["C"] == [0.25, 0.2, 0.2]
    assert scene.observables.lines["L"].samples()[1].shape == (5, 3)
    from mpi4py import MPI

    assert run_scene(scene, tmp_path / "run", MPI.COMM_SELF, progress=False)["status"] == "completed"
    series = read_timeseries(tmp_path / "run" / "timeseries.csv")
    assert {"u_C", "w_C", "flow_rate_outlet", "drag", "lift", "side"} <= set(series)
    assert read_timeseries(tmp_path / "run" / "line_L.csv")["z"].tolist() == [0.2] * 5


def test_steady_scene_has_no_periodic_reference(main):
    code, err = main("run", "scene.yaml", "--out", main.out, "--overwrite", "--set", "time={scheme: steady}",
                     "--set", "reference={u_C: {mean: 1.0, tolerance: 0.1}}")
    assert code == 2 and err.startswith("error: reference.u_C: a steady scene has one state"), err


@pytest.fixture(scope="module")
def lined_run(tmp_path_factory):
    """A finished 2-step run of the channel with a line (its checkpoint at step 2)."""
    from faultlib import cli as run_cli

    folder = tmp_path_factory.mktemp("lined")
    shutil.copy(CHANNEL, folder / "channel.geo")
    (folder / "scene.yaml").write_text(SCENE.replace("t_end: 0.1", "t_end: 0.2").replace(
        "fields: false}", "fields: false, every: 1, checkpoint_every: 1}"))
    result = run_cli("run", folder / "scene.yaml", "--out", folder / "run", "--no-progress")
    assert result.returncode == 0, result
    return folder


@pytest.mark.parametrize("damage, expected", [
    (lambda p: p.unlink(), "line_L.csv is missing"),
    (lambda p: p.write_text("t,s,x,y,u,v\n"), "line_L.csv has other columns than this scene's line"),
    (lambda p: p.write_text(p.read_text().replace("e-", "x-", 3)),
     "line_L.csv: line 3 is not a row of 7 numbers (damaged file)"),
], ids=["line_file_missing", "line_file_other_columns", "line_file_damaged"])
def test_restart_checks_the_line_files(lined_run, tmp_path, damage, expected):
    from faultlib import check, cli as run_cli

    run = tmp_path / "run"
    shutil.copytree(lined_run / "run", run)
    damage(run / "line_L.csv")
    before = snapshot(run)
    result = run_cli("run", lined_run / "scene.yaml", "--restart", run, "--no-progress", "--set", "time.t_end=0.3")
    check(result, 2, "error: --restart: ", expected)
    assert snapshot(run) == before
