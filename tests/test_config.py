"""Scene validation: example configs, one-line error messages naming the key, overrides, round trip."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

from cosserat_fsi.config import NODAL_CONVECTION, TIME_SCHEMES, Scene, Solver, dump_resolved, load_scene, yaml_load
from cosserat_fsi.errors import InputError

REPO = Path(__file__).resolve().parents[1]
CONFIGS = sorted((REPO / "configs").glob("*.yaml"))
EXAMPLES = sorted((REPO / "examples").rglob("*.yaml"))
BASE = """\
geometry: {name: turek_hron, level: 1, flag: rigid}
fluid: {rho: 1000.0, mu: 1.0}
inflow: {u_mean: 0.2}
time: {scheme: characteristics1, dt: 0.01, t_end: 1.0}
"""


CSM = """\
geometry: {name: flag, level: 0}
solid: {law: saint_venant_kirchhoff, rho: 1000.0, mu_s: 0.5e6, lambda_s: 2.0e6, gravity: 2.0}
time: {scheme: steady}
"""


def write(tmp_path: Path, text: str, name: str = "config.yaml") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


def test_there_are_example_configs():
    assert len(CONFIGS) >= 5


@pytest.mark.parametrize("path", CONFIGS, ids=[p.stem for p in CONFIGS])
def test_example_config_validates(path):
    scene = load_scene(path)
    assert scene.name == path.stem
    assert path.read_text().startswith("#"), "every config starts with a header comment"


# (text or None for BASE, overrides, expected message start)
BAD = [
    ("unknown_key", BASE.replace("mu: 1.0", "muu: 1.0"), [], "fluid.muu: unknown key (did you mean 'mu'?)"),
    ("unknown_section", BASE + "fluidd: {}\n", [], "fluidd: unknown key (did you mean 'fluid'?)"),
    ("string_for_float", BASE.replace("rho: 1000.0", "rho: '1000'"), [], "fluid.rho: must be a number"),
    ("bool_for_float", None, ["fluid.mu=true"], "fluid.mu: must be a number"),
    ("negative_rho", None, ["fluid.rho=-1"], "fluid.rho: must be > 0 (got -1)"),
    ("dt_zero", None, ["time.dt=0"], "time.dt: must be > 0 (got 0)"),
    ("dt_negative", None, ["time.dt=-0.1"], "time.dt: must be > 0 (got -0.1)"),
    ("t_end_below_dt", None, ["time.t_end=0.001"], "time.t_end: must be >= time.dt"),
    ("corrector_without_solid", None, ["time.scheme=characteristics2", "time.corrector_passes=1"],
     "time.corrector_passes: needs a solid with scheme characteristics2"),
    ("rho_infinity_above_one", None, ["time.scheme=generalized_alpha", "time.rho_infinity=1.5"],
     "time.rho_infinity: must be <= 1"),
    ("bad_geometry", None, ["geometry.name=foo"],
     "geometry.name: must be one of turek_hron, schaefer_turek, channel, square, flag, box, file, cube, duct, "
     "schaefer_turek_3d, turek_hron_3d (got 'foo')"),
    ("initial_velocity_2_in_3d", None,
     ["geometry={name: turek_hron_3d}", "solid={rho: 1, mu_s: 1, initial_velocity: [0, 1]}"],
     "solid.initial_velocity: needs 3 components for the 3D geometry turek_hron_3d"),
    ("flag_wider_than_duct", None, ["geometry={name: turek_hron_3d, width: 0.2, flag_width: 0.3}"],
     "geometry.flag_width: must be < width"),
    ("level_7", None, ["geometry.level=7"], "geometry.level: must be an integer 0..6 or 'seed' (got 7)"),
    ("level_float", None, ["geometry.level=1.0"], "geometry.level: must be an integer"),
    ("seed_on_channel", None, ["geometry.name=channel", "geometry.flag=null", "geometry.level=seed"],
     "geometry.level: 'seed' only for geometry turek_hron"),
    ("flag_on_channel", None, ["geometry.name=channel"], "geometry.flag: only for geometry turek_hron"),
    ("bad_scheme", None, ["time.scheme=euler"], "time.scheme: must be one of characteristics1, characteristics2, "
     "ale_bdf2, generalized_alpha, steady (got 'euler')"),
    ("time_stepping_without_dt", None, ["time.dt=null"], "time.dt: missing key"),
    ("bad_yaml", "fluid: {rho: 1,\ntime: [\n", [], "config.yaml: line 3: could not parse YAML"),
    ("duplicate_key", BASE + "time: {dt: 1}\n", [], "config.yaml: line 5: could not parse YAML (duplicate key 'time')"),
    ("top_level_list", "- 1\n- 2\n", [], "config.yaml: top level must be a mapping"),
    ("empty_file", "", [], "config.yaml: top level must be a mapping"),
    ("missing_section", BASE.replace("fluid: {rho: 1000.0, mu: 1.0}\n", ""), [], "fluid: missing section"),
    ("missing_key", BASE.replace("rho: 1000.0, ", ""), [], "fluid.rho: missing key"),
    ("set_without_value", None, ["time.dt"], "--set time.dt: expected dotted.key=value"),
    ("set_unknown_key", None, ["time.dtt=1"], "time.dtt: unknown key (did you mean 'dt'?)"),
    ("set_into_value", None, ["time.dt.x=1"], "time.dt: is a value, not a section"),
    ("benchmark_geometry", None, ["benchmark=schaefer_turek_2d1"],
     "benchmark: schaefer_turek_2d1 needs geometry.name schaefer_turek"),
    ("benchmark_flag", None, ["benchmark=turek_hron_fsi3", "solid={rho: 1000, mu_s: 2e6}"],
     "benchmark: turek_hron_fsi3 needs geometry.flag solid"),
    ("unknown_benchmark", None, ["benchmark=cfd9"], "benchmark: must be one of"),
    ("solid_flag_without_solid", None, ["geometry.flag=solid"], "solid: missing section"),
    ("no_inflow", None, ["inflow=null"], "inflow: missing section"),
    ("length_on_turek_hron", None, ["geometry.length=2"], "geometry.length: not used for geometry 'turek_hron'"),
    # the geometry union: one model per geometry, chosen by name
    ("geometry_without_name", BASE.replace("name: turek_hron, ", ""), [], "geometry.name: missing key"),
    ("height_on_square", None, ["geometry.name=square", "geometry.flag=null", "geometry.height=2"],
     "geometry.height: not used for geometry 'square' (only for channel, flag, duct)"),
    ("radius_on_channel", None, ["geometry={name: channel, radius: 0.1}"], "geometry.radius: only for geometry box"),
    ("misspelt_geometry_key", None, ["geometry.lenght=2"], "geometry.lenght: unknown key (did you mean 'length'?)"),
    ("box_radius_too_large", None, ["geometry={name: box, radius: 0.5}", "solid={rho: 1, mu_s: 1}"],
     "geometry.radius: must be < 0.5 (got 0.5)"),
    ("flag_height_negative", None, ["geometry={name: flag, height: -1}"], "geometry.height: must be > 0 (got -1)"),
    ("seed_on_flag", None, ["geometry={name: flag, level: seed}"],
     "geometry.level: 'seed' only for geometry turek_hron"),
    ("geometry_not_a_mapping", None, ["geometry=3"], "geometry: must be a mapping of keys (got 3)"),
    # the time union: one model per scheme, chosen by scheme
    ("time_without_scheme", BASE.replace("scheme: characteristics1, ", ""), [],
     "time.scheme: missing key (one of characteristics1, characteristics2, ale_bdf2, generalized_alpha, steady)"),
    ("dt_on_steady", None, ["time.scheme=steady"],
     "time.dt: not used by scheme steady (only for characteristics1, characteristics2, ale_bdf2, generalized_alpha)"),
    ("rho_infinity_on_characteristics2", None, ["time.scheme=characteristics2", "time.rho_infinity=0.5"],
     "time.rho_infinity: only for scheme generalized_alpha (got scheme 'characteristics2')"),
    ("quadrature_on_ale_bdf2", None, ["time.scheme=ale_bdf2", "time.quadrature_degree=6"],
     "time.quadrature_degree: not used by scheme ale_bdf2 (only for characteristics1, characteristics2)"),
    ("corrector_on_first_order", None, ["time.corrector_passes=1"],
     "time.corrector_passes: not used by scheme characteristics1 (only for characteristics2, ale_bdf2, "
     "generalized_alpha)"),
    ("newton_rtol_on_ale_bdf2", None, ["time.scheme=ale_bdf2", "time.newton_rtol=1e-8"],
     "time.newton_rtol: only for scheme steady (got scheme 'ale_bdf2')"),
    ("dt_on_steady_yaml", BASE.replace("time: {scheme: characteristics1, dt: 0.01, t_end: 1.0}",
                                       "time: {scheme: steady, dt: 0.01}"), [], "time.dt: not used by scheme steady"),
    ("convection_removed", BASE.replace("t_end: 1.0}", "t_end: 1.0, convection: ale}"), [],
     "time.convection: unknown key (removed: the scheme sets it, e.g. scheme ale_bdf2 for convection ale)"),
    ("convection_removed_set", None, ["time.convection=ale"], "time.convection: unknown key (removed"),
    *[(f"{key}_removed", BASE.replace("t_end: 1.0}", f"t_end: 1.0, {key}: {value}}}"), [f"time.scheme={scheme}"],
       f"time.{key}: unknown key") for key, value, scheme in (
        ("foot", "midpoint", "characteristics2"), ("solid_linearisation", "consistent", "characteristics2"),
        ("solve_configuration", "extrapolated", "characteristics2"), ("characteristics", "nodes", "characteristics1"))],
    ("body_force_length", None, ["fluid.body_force=[1]"], "fluid.body_force: must have 2 entries"),
    ("body_force_item", None, ["fluid.body_force=[1, x]"], "fluid.body_force[1]: must be a number"),
    ("body_force_3_in_2d", None, ["fluid.body_force=[0, 1, 0]"], "fluid.body_force: needs 2 components"),
    ("body_force_2_in_3d", None, ["geometry={name: cube}", "time={scheme: steady}", "fluid.body_force=[0, 1]"],
     "fluid.body_force: needs 3 components for the 3D geometry cube"),
    ("body_couple_vector_in_2d", None, ["micropolar.body_couple=[0, 0, 1]"], "micropolar.body_couple: a number in 2D"),
    ("every_zero", None, ["output.every=0"], "output.every: must be >= 1"),
    ("bad_name", None, ["name=../x"], "name: must use only letters"),
    ("two_errors", None, ["fluid.rho=-1", "time.dt=-1"], "fluid.rho: must be > 0 (got -1) (+1 more)"),
    # the solid's law and its parameters
    ("law_without_parameters", CSM, ["solid.mu_s=null", "solid.lambda_s=null"],
     "solid.law: saint_venant_kirchhoff takes one pair of parameters, E and nu, or mu_s and lambda_s (got none)"),
    ("law_with_mixed_pair", CSM, ["solid.lambda_s=null", "solid.nu=0.4"],
     "solid.law: saint_venant_kirchhoff takes one pair of parameters, E and nu, or mu_s and lambda_s (got mu_s, nu)"),
    ("law_with_three_parameters", CSM, ["solid.E=1.4e6"], "solid.law: saint_venant_kirchhoff takes one pair"),
    ("nu_half", CSM, ["solid.mu_s=null", "solid.lambda_s=null", "solid.E=1.4e6", "solid.nu=0.5"],
     "solid.nu: must be < 0.5 (got 0.5)"),
    ("nu_zero", CSM, ["solid.mu_s=null", "solid.lambda_s=null", "solid.E=1.4e6", "solid.nu=0"],
     "solid.nu: must be > 0 (got 0)"),
    ("incompressible_with_lambda", CSM, ["solid.law=mooney_rivlin_incompressible"],
     "solid.lambda_s: not used by solid.law mooney_rivlin_incompressible (it takes mu_s)"),
    ("incompressible_without_mu", CSM, ["solid.law=mooney_rivlin_incompressible", "solid.lambda_s=null",
                                        "solid.mu_s=null"], "solid.mu_s: missing key"),
    ("compressible_c2", CSM, ["solid.c2=1.0"], "solid.c2: only for solid.law mooney_rivlin_incompressible"),
    ("linear_displacement_steady", CSM, ["solid.displacement=linear"],
     "solid.displacement: linear is for the BDF schemes (characteristics1, characteristics2, ale_bdf2; got "
     "time.scheme steady)"),
    ("linear_displacement_generalized_alpha", CSM, ["solid.displacement=linear", "time.scheme=generalized_alpha",
                                                    "time.dt=0.01", "time.t_end=1.0"],
     "solid.displacement: linear is for the BDF schemes"),
    ("bad_displacement", CSM, ["solid.displacement=cubic"], "solid.displacement: must be one of quadratic, linear"),
    ("compressible_volume_correction", CSM, ["solid.volume_correction=true"],
     "solid.volume_correction: only for solid.law mooney_rivlin_incompressible"),
    ("compressible_volume_correction_time", CSM, ["solid.volume_correction_time=0.002"],
     "solid.volume_correction_time: only for solid.law mooney_rivlin_incompressible"),
    ("bad_clamp", CSM, ["geometry.clamp=round"], "geometry.clamp: must be one of straight, arc"),
    ("bad_flag_mesh", None, ["geometry.name=turek_hron", "geometry.flag_mesh=quads"],
     "geometry.flag_mesh: must be one of unstructured, structured"),
    ("structured_rigid_flag", None, ["geometry.name=turek_hron", "geometry.flag=rigid",
                                     "geometry.flag_mesh=structured"],
     "geometry.flag_mesh: structured needs geometry.flag solid"),
    ("flag_cells_across_unstructured", None, ["geometry.name=turek_hron", "geometry.flag_cells_across=8"],
     "geometry.flag_cells_across: only with geometry.flag_mesh structured"),
    ("flag_cells_across_odd", (REPO / "configs/turek_hron_fsi3.yaml").read_text(),
     ["geometry.flag_mesh=structured", "geometry.flag_cells_across=7"],
     "geometry.flag_cells_across: must be even, 2 to 128 (level 6's flag; got 7)"),
    ("flag_cells_across_too_many", (REPO / "configs/turek_hron_fsi3.yaml").read_text(),
     ["geometry.flag_mesh=structured", "geometry.flag_cells_across=130"],
     "geometry.flag_cells_across: must be even, 2 to 128 (level 6's flag; got 130)"),
    ("clamp_on_another_geometry", None, ["geometry.clamp=arc"], "geometry.clamp: only for geometry flag"),
    ("unknown_law", CSM, ["solid.law=hooke"], "solid.law: must be one of mooney_rivlin_incompressible, "
     "saint_venant_kirchhoff, neo_hookean"),
]


@pytest.mark.parametrize("text, overrides, expected", [b[1:] for b in BAD], ids=[b[0] for b in BAD])
def test_bad_input_is_one_line_naming_the_key(tmp_path, text, overrides, expected):
    path = write(tmp_path, BASE if text is None else text)
    with pytest.raises(InputError) as info:
        load_scene(path, overrides)
    message = str(info.value).replace(str(tmp_path) + "/", "")
    assert "\n" not in message
    assert message.startswith(expected), message


@pytest.mark.parametrize("path", EXAMPLES, ids=[p.stem for p in EXAMPLES])
def test_example_scenes_validate(path):
    assert load_scene(path).time.scheme in TIME_SCHEMES


def test_set_null_removes_a_key_to_switch_scheme(tmp_path):
    """``--set KEY=null`` removes the key (its default applies): the way to a scheme without that key."""
    path = write(tmp_path, BASE.replace("scheme: characteristics1,", "scheme: ale_bdf2, corrector_passes: 2,"))
    assert load_scene(path).time.corrector_passes == 2
    scene = load_scene(path, ["time.scheme=characteristics1", "time.corrector_passes=null"])
    assert scene.time.scheme == "characteristics1" and not hasattr(scene.time, "corrector_passes")
    assert load_scene(path, ["time.scheme=characteristics2", "time.corrector_passes=null"]).time.corrector_passes == 0
    steady = load_scene(path, ["time.scheme=steady", "time.dt=null", "time.t_end=null", "time.corrector_passes=null"])
    assert (steady.time.dt, steady.time.t_end, steady.time.newton_rtol) == (1.0, 1.0, 1e-10)
    assert "dt" not in steady.to_yaml()
    assert load_scene(path, ["solid.mesh_motion.remesh=null"]) == load_scene(path)  # nothing to remove: no-op
    with pytest.raises(InputError, match=r"^time\.corrector_passes: not used by scheme characteristics1"):
        load_scene(path, ["time.scheme=characteristics1"])


def test_time_schemes_and_reuse_default():
    assert list(TIME_SCHEMES) == ["characteristics1", "characteristics2", "ale_bdf2", "generalized_alpha", "steady"]
    assert set(NODAL_CONVECTION) == {"ale_bdf2", "generalized_alpha"}
    solver = Solver()
    assert solver.reuses_factorization(True, False) and not solver.reuses_factorization(True, True)
    assert not solver.reuses_factorization(False, False)
    forced = Solver(reuse_factorization=True)
    assert forced.reuses_factorization(False, True) and not forced.reuses_factorization(False, False)


def test_missing_file(tmp_path):
    with pytest.raises(InputError, match=r"nothere\.yaml: file not found$"):
        load_scene(tmp_path / "nothere.yaml")


def test_python_tags_are_not_evaluated(tmp_path):
    path = write(tmp_path, "name: !!python/object/apply:os.getcwd []\n" + BASE)
    with pytest.raises(InputError, match="could not parse YAML"):
        load_scene(path)


def test_defaults_and_properties(tmp_path):
    scene = load_scene(write(tmp_path, BASE, "my_case.yaml"))
    assert scene.name == "my_case"
    assert scene.micropolar.mu_r == 0.0 and scene.solver.penalty == 1e-10 and scene.output.every == 10
    assert scene.inflow.profile == "parabolic" and scene.time.scheme == "characteristics1"
    assert (scene.has_inflow, scene.has_solid, scene.has_micropolar) == (True, False, False)
    channel = load_scene(write(tmp_path, "geometry: {name: channel}\nfluid: {rho: 1, mu: 1}\n"
                                         "time: {scheme: characteristics1, dt: 0.1, t_end: 1}\n"))
    assert (channel.geometry.length, channel.geometry.height) == (1.0, 1.0) and not hasattr(channel.geometry, "flag")
    assert channel.geometry.msh_params() == {"length": 1.0, "height": 1.0}
    assert not channel.has_inflow


def test_overrides_applied_and_sections_created(tmp_path):
    scene = load_scene(write(tmp_path, BASE), [
        "time.dt=1e-3", "micropolar.mu_r=0.5", "geometry.flag=solid", "solid={rho: 1000, mu_s: 2.0E6}",
        "benchmark=turek_hron_fsi3", "fluid.body_force=[0, -9.81]", "output.fields=false"])
    assert scene.time.dt == 1e-3
    assert scene.has_micropolar and scene.has_solid
    assert scene.solid.mu_s == 2e6 and scene.fluid.body_force == [0.0, -9.81]
    assert scene.output.fields is False
    assert scene.geometry.msh_params() == {"flag": "solid"}


def test_exponent_without_dot_is_a_float(tmp_path):
    assert yaml_load("a: 1e-3\nb: 2E6\nc: +1.5e+2\nd: 1_000\ne: '1e-3'") == {
        "a": 1e-3, "b": 2e6, "c": 150.0, "d": 1000, "e": "1e-3"}
    scene = load_scene(write(tmp_path, BASE.replace("mu: 1.0", "mu: 1e-3")))
    assert isinstance(scene.fluid.mu, float) and scene.fluid.mu == 1e-3


@pytest.mark.parametrize("path", CONFIGS, ids=[p.stem for p in CONFIGS])
def test_resolved_config_round_trips(tmp_path, path):
    scene = load_scene(path, ["micropolar.lambda1=1e-4"] if "csm" not in path.stem else [])  # flag: no fluid
    text = dump_resolved(scene)
    again = load_scene(write(tmp_path, text, "other_name.yaml"))
    assert again == scene
    assert dump_resolved(again) == text == scene.to_yaml()
    assert isinstance(again, Scene)


def test_loading_a_scene_imports_no_heavy_modules(tmp_path):
    code = ("import sys; from cosserat_fsi.config import load_scene; import cosserat_fsi.app.cli; "
            f"load_scene({str(CONFIGS[0])!r}); "
            "print(sorted(m for m in ('dolfinx', 'petsc4py', 'gmsh', 'mpi4py') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


def test_set_reaches_into_named_boundaries(repo_root):
    """--set boundaries.NAME.KEY=...: a mapping of named sections takes any name, then its keys."""
    flap = repo_root / "examples" / "perpendicular_flap" / "flap.yaml"
    scene = load_scene(flap, ["boundaries.inlet.value=['5*min(t, 1)', 0]", "boundaries.outlet.type=no_slip"])
    assert scene.boundaries["inlet"].value == ["5*min(t, 1)", 0] and scene.boundaries["outlet"].type == "no_slip"
    for bad, message in (("boundaries.inlet.valu=[1, 0]", "boundaries.inlet.valu: unknown key (did you mean 'value'?)"),
                         ("boundaries.inlet.value.x=1", "boundaries.inlet.value: is a value, not a section")):
        with pytest.raises(InputError, match=re.escape(message)):
            load_scene(flap, [bad])


def test_solid_law_parameters(tmp_path):
    """E, ν give the Lamé pair (plane strain and 3D); the incompressible law is the default and keeps its
    volume correction unless switched off; a compressible law has none."""
    scene = load_scene(write(tmp_path, CSM), ["solid.mu_s=null", "solid.lambda_s=null", "solid.E=1.4e6",
                                             "solid.nu=0.4"])
    mu, lam = scene.solid.lame()
    assert abs(mu - 0.5e6) < 1e-6 and abs(lam - 2.0e6) < 1e-6
    assert scene.solid.compressible and not scene.solid.corrects_volume
    old = load_scene(write(tmp_path, CSM), ["solid.law=null", "solid.lambda_s=null"])
    assert old.solid.law == "mooney_rivlin_incompressible" and old.solid.corrects_volume
    assert not load_scene(write(tmp_path, CSM), ["solid.law=null", "solid.lambda_s=null", "time=null",
                                                  "time.scheme=ale_bdf2", "time.dt=0.01", "time.t_end=0.1",
                                                  "solid.volume_correction=false"]).solid.corrects_volume
