"""A key the user sets is used or refused (cosserat_fsi/config/usage.py): a key whose effect depends on another
key's value, set where that value makes it meaningless, is one line ``error: <key>: <why>``, exit 2, no
traceback, nothing written (in-process: the CLI's ``main``). The output cadence keys are the one exception:
warned in run.log. The walk over every key of the scene reference: tests/test_keys_walk.py."""

from __future__ import annotations

import pytest

from faultlib import REPO, check, cli, in_process_main

REPO_DATA = REPO / "tests" / "data" / "user_scene"


@pytest.fixture
def main(capsys, tmp_path):
    yield from in_process_main(capsys, tmp_path)


TINY = "tiny"  # faultlib.TINY: schaefer_turek level 0, characteristics1, direct solver
FSI3 = "configs/turek_hron_fsi3.yaml"  # ale_bdf2, moving mesh
FSI1 = "configs/turek_hron_fsi1.yaml"  # steady, with a solid
CSM1 = "configs/turek_hron_csm1.yaml"  # steady, flag alone
CSM3 = "configs/turek_hron_csm3.yaml"  # ale_bdf2, flag alone
CFD1 = "configs/turek_hron_cfd1.yaml"  # steady, flag rigid
CFD3 = "configs/turek_hron_cfd3.yaml"  # ale_bdf2, flag rigid
POISEUILLE = "configs/micropolar_poiseuille.yaml"  # steady channel, micropolar
TAYLOR_GREEN = "configs/micropolar_taylor_green.yaml"  # square with a lid, micropolar
INCOMPRESSIBLE = ["solid.law=mooney_rivlin_incompressible", "solid.lambda_s=null"]

CASES = {  # scene, overrides, the start of the message line
    "amg_with_direct": (TINY, ["solver.type=direct", "solver.amg=gamg"], "solver.amg: only for the iterative solver"),
    "amg_auto_2d": (TINY, ["solver.amg=hypre"], "solver.amg: only for the iterative solver; solver.type auto takes "
                                                "MUMPS at every size in 2D"),
    "max_iterations_direct": (TINY, ["solver.type=direct", "solver.max_iterations=50"], "solver.max_iterations: only"),
    "reuse_with_iterative": (FSI3, ["solver.type=iterative", "solver.reuse_factorization=true"],
                             "solver.reuse_factorization: not with solver.type iterative"),
    "reuse_fixed_mesh": (TINY, ["solver.reuse_factorization=true"],
                         "solver.reuse_factorization: not used: the matrix of scheme characteristics1 on a fixed mesh"),
    "reuse_steady": (FSI1, ["solver.reuse_factorization=true"], "solver.reuse_factorization: not used by a steady"),
    "iterative_steady_solid": (FSI1, ["solver.type=iterative"], "solver.type: iterative: not available for the "
                                                                "steady solid solve"),
    "max_krylov_without_reuse": (TINY, ["solver.max_krylov_iterations=20"],
                                 "solver.max_krylov_iterations: only with a kept factorisation"),
    "krylov_rtol_direct": (TINY, ["solver.type=direct", "solver.krylov_rtol=1e-8"], "solver.krylov_rtol: only for"),
    "mumps_ordering_iterative": (TINY, ["solver.type=iterative", "solver.mumps_ordering=metis"],
                                 "solver.mumps_ordering: not with solver.type iterative"),
    "initial_velocity_steady": (FSI1, ["solid.initial_velocity=[0.1, 0.0]"],
                                "solid.initial_velocity: not used by a steady scene"),
    "solid_on_rigid_flag": (CFD3, ["solid={rho: 1000.0, mu_s: 2.0e6}"],
                            "solid: not used: geometry turek_hron with flag rigid has no solid cells"),
    "solid_on_schaefer_turek": (TINY, ["solid={rho: 1000.0, mu_s: 2.0e6}"],
                                "solid: not used: geometry schaefer_turek has no solid cells"),
    "solid_on_channel": (POISEUILLE, ["solid={rho: 1000.0, mu_s: 2.0e6}"],
                         "solid: not used: geometry channel has no solid cells"),
    "gravity_ramp_without_gravity": (FSI3, ["solid.gravity_ramp_time=1.0"],
                                     "solid.gravity_ramp_time: needs solid.gravity"),
    "volume_correction_steady": (CSM1, ["solid.volume_correction=false"],
                                 "solid.volume_correction: not used by a steady scene"),
    "volume_correction_time_off": (FSI3, INCOMPRESSIBLE + ["solid.volume_correction=false",
                                                           "solid.volume_correction_time=0.1"],
                                   "solid.volume_correction_time: needs the volume correction"),
    "mesh_motion_steady": (FSI1, ["solid.mesh_motion.method=elastic"],
                           "solid.mesh_motion.method: not used by a steady scene"),
    "mesh_motion_without_fluid": (CSM3, ["solid.mesh_motion.method=elastic"],
                                  "solid.mesh_motion.method: not used: geometry flag has no fluid mesh"),
    "wall_gap_steady": (FSI1, ["solid.mesh_motion.wall_gap=0.001"], "solid.mesh_motion.wall_gap: not used by a steady"),
    "poisson_ratio_biharmonic": (FSI3, ["solid.mesh_motion.poisson_ratio=0.3"],
                                 "solid.mesh_motion.poisson_ratio: only for solid.mesh_motion.method elastic"),
    "remesh_steady": (FSI1, ["solid.mesh_motion.remesh={quality: 0.3}"], "solid.mesh_motion.remesh: not used by a "
                                                                         "steady scene"),
    "inertia_newtonian": (TINY, ["micropolar.inertia=0.1"], "micropolar.inertia: only with micropolar terms"),
    "body_couple_newtonian": (TINY, ["micropolar.body_couple=1.0"], "micropolar.body_couple: only with micropolar"),
    "wall_condition_newtonian": (TINY, ["micropolar.wall_condition=half_curl"], "micropolar.wall_condition: only with"),
    "lambda2_in_2d": (TINY, ["micropolar.lambda2=0.1"], "micropolar.lambda2: acts in 3D only"),
    "nodal_characteristics_ale": (FSI3, ["micropolar.mu_r=0.1", "micropolar.nodal_characteristics=true"],
                                  "micropolar.nodal_characteristics: only for the characteristics schemes"),
    "micropolar_without_fluid": (CSM1, ["micropolar.mu_r=0.1"], "micropolar.mu_r: not used: geometry flag has no "
                                                                "fluid"),
    "inflow_without_inlet": (CSM3, ["inflow={u_mean: 1.0}"], "inflow: not used: geometry flag has no inlet"),
    "profile_of_a_lid": (TAYLOR_GREEN, ["benchmark=null", "inflow={u_mean: 1.0, profile: uniform}"],
                         "inflow.profile: not used: the lid of geometry square moves as a whole"),
    "asymmetry_without_ramp": (TINY, ["inflow.ramp_time=0", "inflow.asymmetry=0.1"],
                               "inflow.asymmetry: acts during the ramp only (inflow.ramp_time is 0)"),
    "penalty_with_an_outlet": (TINY, ["solver.penalty=1e-8"], "solver.penalty: not used: a boundary of type "
                                                              "do_nothing determines the pressure"),
    "c2_not_modelled": ("configs/turek_hron_3d_fsi.yaml", ["solid.c2=1000.0"], "solid.c2: not used: the solid's "
                                                                             "stress has no c₂ term"),
    "inflow_of_an_exact_solution": (POISEUILLE, ["inflow={u_mean: 1.0}"], "inflow: not used: benchmark "
                                                                          "micropolar_poiseuille takes its boundary"),
    "inflow_ramp_steady": (CFD1, ["inflow.ramp_time=0.5"],
                           "inflow.ramp_time: not used: this steady scene is solved at the end of every ramp"),
    "gravity_ramp_steady": (CSM1, ["solid.gravity_ramp_time=0.5"],
                            "solid.gravity_ramp_time: not used: this steady scene is solved at the end of every ramp"),
}


@pytest.mark.parametrize("scene, overrides, start", CASES.values(), ids=CASES)
def test_a_set_key_the_run_would_not_use_is_refused(main, tiny_config, scene, overrides, start):
    argv = ["run", tiny_config if scene == TINY else REPO / scene, "--out", main.out]
    for item in overrides:
        argv += ["--set", item]
    code, err = main(*argv)
    lines = err.splitlines()
    assert code == 2 and len(lines) == 1 and "Traceback" not in err, (code, err)
    assert lines[0].startswith("error: " + start), err


def test_a_wall_gap_that_would_check_no_vertex_is_refused_at_setup(main):
    """solid.mesh_motion.wall_gap: 1e300 leaves every solid vertex "attached" (within the gap at rest), so the
    contact check would check nothing: refused when the mesh is read, before anything is written."""
    code, err = main("run", REPO / FSI3, "--out", main.out, "--set", "geometry.level=0",
                     "--set", "solid.mesh_motion.wall_gap=1e300")
    lines = err.splitlines()
    assert code == 2 and len(lines) == 1 and "Traceback" not in err, (code, err)
    assert lines[0].startswith("error: solid.mesh_motion.wall_gap: 1e+300 m reaches every solid vertex"), err
    assert "off to turn the check off" in lines[0]


def test_wall_gap_off_is_the_way_to_turn_the_check_off():
    from cosserat_fsi.config import load_scene

    scene = load_scene(REPO / FSI3, ["solid.mesh_motion.wall_gap=off"])
    assert scene.solid.mesh_motion.options()["wall_gap"] == "off"
    with pytest.raises(Exception, match="solid.mesh_motion.wall_gap"):
        load_scene(REPO / FSI3, ["solid.mesh_motion.wall_gap=none"])


SPLIT = (REPO_DATA / "split_channel.geo").read_text()  # the channel in two halves, the face group "mid" inside


def test_a_traction_on_an_interior_facet_group_is_refused(main, tmp_path):
    (tmp_path / "m.geo").write_text(SPLIT)
    scene = tmp_path / "scene.yaml"
    scene.write_text("geometry: {name: file, path: m.geo}\nfluid: {rho: 1.0, mu: 1.0}\n"
                     "boundaries: {inlet: {type: velocity, value: [1, 0, 0]}, outlet: {type: do_nothing}, "
                     "walls: {type: no_slip}, mid: {type: traction, value: [0, 0, 1]}}\n"
                     "time: {scheme: characteristics1, dt: 0.1, t_end: 0.1}\n")
    code, err = main("run", scene, "--out", main.out)
    lines = err.splitlines()
    assert code == 2 and len(lines) == 1 and "Traceback" not in err, (code, err)
    assert lines[0].startswith("error: boundaries.mid: facet group mid of m.geo is inside the domain"), err


STUDY = "name: s\nconfig: {config}\nobservables: {observables}\nladder: {{geometry.level: [0]}}\n"


@pytest.mark.parametrize("config, observables, expected", [
    ("configs/schaefer_turek_2d1.yaml", "[c_D, dp_typo]",
     "observables[1]: 'dp_typo' is not a column of benchmark schaefer_turek_2d1 (valid: c_D, c_L, dp)"),
    ("configs/turek_hron_cfd3.yaml", "[drag.maen]",
     "observables[0]: 'drag.maen' is not a column of benchmark turek_hron_cfd3 (valid: drag.mean, drag.amplitude, "
     "drag.frequency, lift.mean, lift.amplitude, lift.frequency)"),
], ids=["steady", "periodic"])
def test_a_misspelt_study_observable_is_refused_at_setup(tmp_path, config, observables, expected):
    study = tmp_path / "study.yaml"
    study.write_text(STUDY.format(config=REPO / config, observables=observables))
    line = check(cli("study", study, "--out", tmp_path / "out", "--report-only"), 2, "error: ", expected)
    assert not (tmp_path / "out" / "study_s.md").exists(), line


def test_an_unused_output_cadence_is_one_warning_line(tiny_config, tmp_path):
    """output.every with the fields off and nothing else written every N steps: the run goes on, and says so
    once, on the terminal and in run.log."""
    out = tmp_path / "run"
    result = cli("run", tiny_config, "--out", out, "--no-progress", "--set", "output.fields=false",
                 "--set", "output.every=2")
    assert result.returncode == 0, result
    warned = [line for line in (out / "run.log").read_text().splitlines() if "output.every: not used" in line]
    assert len(warned) == 1, warned
    assert "output.every: not used: output.fields is false" in result.stderr + result.stdout


CHANNEL = (REPO_DATA / "channel.geo").read_text().replace(
    'Physical Curve("bottom") = {1}; Physical Curve("top") = {3};', 'Physical Curve("walls") = {1, 3};')
BOX = (REPO_DATA / "channel.geo").read_text().split("Physical Curve")[0] + 'Physical Curve("walls") = {1, 2, 3, 4};\n'
NO_BOUNDARIES = ("geometry: {{name: file, path: m.geo}}\nfluid: {{rho: 1.0, mu: 1.0}}\n{inflow}"
                 "solver: {{penalty: 1.0e-8}}\ntime: {{scheme: steady}}\n")


def test_a_penalty_where_the_mesh_names_an_outlet_is_refused(main, tmp_path):
    """A file scene without a boundaries section takes its conditions by name from the mesh: the outlet is
    do_nothing, which fixes the pressure, so the penalty set does nothing — refused once the names are read."""
    assert 'Physical Curve("walls")' in CHANNEL
    (tmp_path / "m.geo").write_text(CHANNEL)
    scene = tmp_path / "scene.yaml"
    scene.write_text(NO_BOUNDARIES.format(inflow="inflow: {u_mean: 1.0}\n"))
    code, err = main("run", scene, "--out", main.out)
    lines = err.splitlines()
    assert code == 2 and len(lines) == 1 and "Traceback" not in err, (code, err)
    assert lines[0].startswith("error: solver.penalty: not used: a boundary of type do_nothing determines the "
                               "pressure"), err


def test_a_penalty_in_a_closed_file_box_is_kept(tmp_path):
    """The same check lets the penalty through where every named boundary is a wall (there it fixes the
    pressure's constant), and refuses it for the same scene once the mesh also names an outlet."""
    from cosserat_fsi.config import load_scene
    from cosserat_fsi.errors import InputError
    from cosserat_fsi.geometry.file import check_scene

    (tmp_path / "m.geo").write_text(BOX)
    path = tmp_path / "scene.yaml"
    path.write_text(NO_BOUNDARIES.format(inflow=""))
    scene = load_scene(path)
    check_scene(scene, {"dim": 2, "facets": {"walls": 1}, "cells": {"fluid": 64}})
    with pytest.raises(InputError, match="^solver.penalty: not used: a boundary of type do_nothing"):
        check_scene(scene, {"dim": 2, "facets": {"walls": 1, "outlet": 2}, "cells": {"fluid": 64}})
