"""Which scenes are their benchmark's problem (config/benchmarks.py): every shipped benchmark scene is; a scene
that differs in any defining key gets its numbers beside the reference without a verdict ("n/a", the line
``benchmark NAME: reference not applicable: KEY differs (...)``), and summary.json says ``applicable: false``
with the keys. Config and summary level only: no mesh, no solve."""

from __future__ import annotations

import copy
import json
from pathlib import Path

import pytest

from cosserat_fsi.app.verdict import applicable, benchmark_rows, verdict_lines
from cosserat_fsi.config import GEOMETRY_OF_BENCHMARK, load_scene, validate_scene, yaml_load
from cosserat_fsi.config.benchmarks import DEFINING, OneOf, applicability, differences
from cosserat_fsi.errors import InputError
from cosserat_fsi.references import reference_for

REPO = Path(__file__).resolve().parents[1]
SHIPPED = {p.name: load_scene(p) for p in sorted((REPO / "configs").glob("*.yaml"))}
SHIPPED_BENCHMARKS = [name for name, scene in SHIPPED.items() if scene.benchmark]


def _raw(name: str) -> dict:
    return yaml_load((REPO / "configs" / name).read_text(encoding="utf-8"))


def base_scene(benchmark: str) -> dict:
    """A scene of the benchmark's problem as a dict: its shipped scene (FSI2: FSI3's with FSI2's values)."""
    for name, scene in SHIPPED.items():
        if scene.benchmark == benchmark:
            return _raw(name)
    assert benchmark == "turek_hron_fsi2"
    data = _raw("turek_hron_fsi3.yaml")
    data["benchmark"] = benchmark
    data["solid"].update(rho=10000.0, mu_s=0.5e6, lambda_s=2.0e6)
    data["inflow"]["u_mean"] = 1.0
    return data


def _set(data: dict, key: str, value) -> None:
    section, _, name = key.partition(".")
    data.setdefault(section, {})[name] = value


def _changed(data: dict, key: str, expected) -> None:
    """Change ``key`` (only it, but for the parameter pair a law needs) to a value its benchmark does not
    admit."""
    if key == "solid.law":
        if "saint_venant_kirchhoff" in expected:
            _set(data, key, "neo_hookean")
        else:  # the seed's incompressible law -> a compressible one, which takes mu_s and lambda_s
            _set(data, key, "neo_hookean")
            _set(data, "solid.lambda_s", 8.0e6)
        return
    if isinstance(expected, str):
        other = {"laplacian": "symmetric", "parabolic": "uniform", "zero": "half_curl", "arc": "straight",
                 "rigid": "solid", "solid": "rigid"}.get(expected, "channel" if expected != "channel" else "square")
        _set(data, key, other)
        return
    if key in ("fluid.body_force", "solid.initial_velocity"):
        dim = 3 if data["geometry"]["name"].endswith("_3d") else 2
        _set(data, key, [0.0, -1.0, 0.0][:dim])
        return
    _set(data, key, 2.0 * expected if expected else 0.5)


CHANGES = [(bench, key) for bench, keys in DEFINING.items() for key in keys]


def _summary(scene, quantities: dict | None = None) -> dict:
    """A hand-made summary of a run of ``scene``: every reference quantity within 0.1 % of its reference,
    the benchmark block as the runner writes it."""
    bench = {"name": scene.benchmark, **applicability(scene)}
    for key, ref in (quantities or reference_for(scene.benchmark)).items():
        if isinstance(ref, dict) and "frequency" in ref:
            bench[key] = {p: {"value": 1.001 * ref[p], "reference": ref[p], "error": 0.001} for p in ref}
        elif isinstance(ref, float):
            bench[key] = {"value": 1.001 * ref if ref else 1e-6, "reference": ref, "error": 0.001 if ref else 1e-6}
    return {"status": "completed", "ranks": 1, "final": {}, "signals": {}, "periodic": {},
            "wall_time": {"total": 1.0, "setup": 0.5}, "time": {"steps": 1, "dt": 0.01, "t_final": 0.01},
            "benchmark": bench}


def test_the_geometry_table_is_the_defining_keys_geometry():
    assert set(GEOMETRY_OF_BENCHMARK) == set(DEFINING)
    for name, keys in DEFINING.items():
        assert GEOMETRY_OF_BENCHMARK[name] == (keys["geometry.name"], keys.get("geometry.flag"))


@pytest.mark.parametrize("config", SHIPPED_BENCHMARKS)
def test_every_shipped_benchmark_scene_is_its_benchmarks_problem(config):
    scene = SHIPPED[config]
    assert differences(scene) == {}, config
    summary = _summary(scene)
    assert summary["benchmark"]["applicable"] is True and "differs" not in summary["benchmark"]
    lines = verdict_lines(summary)
    if benchmark_rows(summary):  # 2D-2 (ranges) and FSI2 (no values) have no table
        assert lines[0].startswith(tuple(f"benchmark {scene.benchmark}: {w}" for w in ("PASS", "no tolerances")))
    assert "not applicable" not in "\n".join(lines)


def test_every_benchmark_has_a_scene_of_its_problem():
    for benchmark in DEFINING:
        assert differences(validate_scene(base_scene(benchmark))) == {}, benchmark


@pytest.mark.parametrize("benchmark, key", CHANGES, ids=[f"{b}-{k}" for b, k in CHANGES])
def test_a_changed_defining_key_gives_no_verdict(benchmark, key):
    data = copy.deepcopy(base_scene(benchmark))
    _changed(data, key, DEFINING[benchmark][key])
    try:
        scene = validate_scene(data)
    except InputError as exc:  # another geometry or flag: refused when the scene is read, before any run
        assert key in ("geometry.name", "geometry.flag"), exc
        return
    found = applicability(scene)
    assert found["applicable"] is False and key in found["differs"], found
    summary = _summary(scene, {"q": 1.0})  # one quantity within tolerance, for every benchmark alike
    summary["benchmark"]["q"] = {"value": 1.0, "reference": 1.0, "error": 0.0}
    lines = verdict_lines(summary)
    text = "\n".join(lines)
    assert "PASS" not in text and "FAIL" not in text and " pass" not in text, text
    assert lines[0].startswith(f"benchmark {benchmark}: reference not applicable: {found['differs'][0]} differs")
    assert all(row[5] == "n/a" for row in benchmark_rows(summary))
    assert not applicable(summary)
    json.dumps(summary)  # what summary.json holds


def test_the_not_applicable_line_names_the_first_key_and_the_count():
    data = base_scene("turek_hron_csm1")
    data["solid"].update(law="neo_hookean", mu_s=1.0e6)
    lines = verdict_lines(_summary(validate_scene(data)))
    assert lines[0] == ("benchmark turek_hron_csm1: reference not applicable: solid.law differs (neo_hookean; the "
                        "benchmark: saint_venant_kirchhoff); 2 defining keys differ: solid.law, solid.mu_s"), lines[0]
    assert [line.split()[-1] for line in lines[3:5]] == ["n/a", "n/a"]
    data = base_scene("micropolar_poiseuille")
    data["micropolar"]["wall_condition"] = "half_curl"
    line = verdict_lines(_summary(validate_scene(data)))[0]
    assert line == ("benchmark micropolar_poiseuille: reference not applicable: micropolar.wall_condition "
                    "differs (half_curl; the benchmark: zero)"), line


def test_a_quantity_without_a_value_is_no_fail_either():
    data = base_scene("turek_hron_cfd3")
    data["fluid"]["mu"] = 2.0
    summary = _summary(validate_scene(data), {})
    summary["signals"] = {"drag": "not periodic yet"}
    rows = benchmark_rows(summary)
    assert rows and {row[5] for row in rows} == {"n/a"}
    assert "FAIL" not in "\n".join(verdict_lines(summary))


@pytest.mark.parametrize("status", ["diverged", "interrupted", "failed"])
def test_a_run_that_did_not_complete_gets_its_values_without_a_verdict(status):
    """FSI3 stopped at t = 0.026 (a step rejected at dt_min): a lift of round-off "periodic" at 2.7 kHz must
    not pass, and the quantities not periodic yet must not FAIL either: values, "n/a", one line saying why."""
    scene = SHIPPED["turek_hron_fsi3.yaml"]
    summary = _summary(scene)
    summary.update(status=status, time={"t_final": 0.0261784, "steps": 217})
    rows = benchmark_rows(summary)
    assert len(rows) == 12 and {row[5] for row in rows} == {"n/a"}
    lines = verdict_lines(summary)
    assert lines[0] == (f"benchmark turek_hron_fsi3: not judged: the run {status} at t = 0.0261784 (a verdict "
                        "is given for a completed run)"), lines[0]
    assert not any(word in "\n".join(lines) for word in ("PASS", "FAIL", " pass")), lines
    summary["status"] = "completed"
    assert verdict_lines(summary)[0] == "benchmark turek_hron_fsi3: PASS (12/12 within tolerance)"


def test_numerical_choices_do_not_change_the_problem():
    data = base_scene("turek_hron_fsi3")
    data["geometry"].update(level=0, flag_mesh="structured")
    data["time"].update(scheme="characteristics2", dt=0.001, tolerance=None)
    data["solid"]["mesh_motion"] = {"method": "harmonic"}
    data["inflow"].update(ramp_time=1.0, asymmetry=0.1)
    data["solver"] = {"type": "direct"}
    assert differences(validate_scene(data)) == {}


def test_moduli_count_however_given():
    """E and nu with the benchmark's Lamé parameters (nu_s = 0.4) are the benchmark's solid."""
    data = base_scene("turek_hron_csm1")
    del data["solid"]["mu_s"], data["solid"]["lambda_s"]
    data["solid"].update(E=2 * 0.5e6 * 1.4, nu=0.4)
    assert differences(validate_scene(data)) == {}
    data["solid"]["nu"] = 0.3
    assert list(differences(validate_scene(data))) == ["solid.mu_s", "solid.lambda_s"]


def test_law_family_admits_its_laws():
    assert all(isinstance(DEFINING[b]["solid.law"], OneOf) for b in DEFINING if "solid.law" in DEFINING[b])
    data = base_scene("turek_hron_fsi3")
    data["solid"].update(law="mooney_rivlin_incompressible", lambda_s=None)
    found = differences(validate_scene(data))
    assert found["solid.law"] == {"scene": "mooney_rivlin_incompressible", "benchmark": "saint_venant_kirchhoff"}


def test_the_runner_records_applicability(tmp_path):
    """compare_with_reference (what summary.json's ``benchmark`` block is made of)."""
    from cosserat_fsi.app.verdict import compare_with_reference

    data = base_scene("turek_hron_cfd1")
    summary = {"final": {"drag": 14.29, "lift": 1.119}, "periodic": {}}
    same = compare_with_reference(validate_scene(data), summary)
    assert same["applicable"] is True and same["drag"]["error"] == 0.0
    data["fluid"]["mu"] = 2.0
    other = compare_with_reference(validate_scene(data), summary)
    assert other["applicable"] is False and other["differs"] == ["fluid.mu"]
    assert other["differences"]["fluid.mu"] == {"scene": 2.0, "benchmark": 1.0}
    assert other["drag"] == same["drag"]  # the numbers beside the reference are kept
