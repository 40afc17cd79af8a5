"""Reference values: the packaged copy of the published file, periodic parsing, per-benchmark lookups."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from cosserat_fsi.config import GEOMETRY_OF_BENCHMARK
from cosserat_fsi.references import load_references, parse_periodic, reference_for

SHARED = Path("/work/shared/reference/benchmarks.yaml")
PACKAGED = Path(__file__).resolve().parents[1] / "cosserat_fsi" / "data" / "benchmarks.yaml"


@pytest.mark.skipif(not SHARED.exists(), reason="no shared reference directory on this machine")
def test_packaged_copy_is_verbatim():
    assert PACKAGED.read_bytes() == SHARED.read_bytes()


def _periodic_strings(node, path=""):
    """(path, text) of every 'mean +- amplitude [frequency]' string in the reference file."""
    if isinstance(node, dict):
        for key, value in node.items():
            yield from _periodic_strings(value, f"{path}.{key}" if path else str(key))
    elif isinstance(node, str) and "+-" in node and "[" in node:
        yield path, node


PERIODIC = list(_periodic_strings(load_references()))


def test_file_has_the_periodic_entries():
    assert len(PERIODIC) == 12  # CFD3: 2, CSM3: 2, FSI3: 2 sources x 4


@pytest.mark.parametrize("path, text", PERIODIC, ids=[p for p, _ in PERIODIC])
def test_parse_periodic_every_entry(path, text):
    value = parse_periodic(text)
    assert set(value) == {"mean", "amplitude", "frequency"}
    assert all(math.isfinite(v) for v in value.values())
    assert value["amplitude"] > 0 and value["frequency"] > 0


def test_parse_periodic_values():
    assert parse_periodic("439.45 +- 5.6183 [4.3956]") == {"mean": 439.45, "amplitude": 5.6183, "frequency": 4.3956}
    assert parse_periodic("-2.69e-3 +- 2.53e-3 [10.9]") == {"mean": -2.69e-3, "amplitude": 2.53e-3, "frequency": 10.9}
    with pytest.raises(ValueError):
        parse_periodic("439.45 +- 5.6183")


def test_numbers_are_floats():
    csm1 = load_references()["turek_hron"]["cases"]["CSM1"]
    assert csm1["mu_s"] == 0.5e6  # YAML 1.1 would read "0.5e6" as a string


@pytest.mark.parametrize("benchmark", list(GEOMETRY_OF_BENCHMARK))
def test_every_schema_benchmark_has_an_entry(benchmark):
    ref = reference_for(benchmark)
    for value in ref.values():
        assert isinstance(value, float) or set(value) <= {"mean", "amplitude", "frequency", "min", "max"}
    assert bool(ref) == (benchmark != "turek_hron_fsi2")


def test_selected_values():
    assert reference_for("schaefer_turek_2d1") == pytest.approx(
        {"c_D": 5.57953523384, "c_L": 0.010618948146, "dp": 0.11752016697})
    assert reference_for("schaefer_turek_3d1z") == pytest.approx({"c_D": 6.18533, "c_L": 0.009401, "dp": 0.170827})
    assert reference_for("turek_hron_cfd2") == {"drag": 136.70, "lift": 10.534}
    assert reference_for("turek_hron_cfd3")["lift"] == {"mean": -11.893, "amplitude": 437.81, "frequency": 4.3956}
    assert set(reference_for("turek_hron_fsi1")) == {"ux_A", "uy_A", "drag", "lift"}
    assert reference_for("turek_hron_csm1") == {"ux_A": -7.187e-3, "uy_A": -66.10e-3}
    assert reference_for("turek_hron_fsi3")["uy_A"]["frequency"] == 5.46  # the refined values
    assert reference_for("turek_hron_fsi3", source="paper_2006")["uy_A"]["frequency"] == 5.3
    assert reference_for("seed_fsi3") == {"uy_A": {"amplitude": 0.03, "frequency": 4.5}}
    assert reference_for("schaefer_turek_2d2")["St"] == {"min": 0.295, "max": 0.305}
    with pytest.raises(ValueError):
        reference_for("turek_hron_cfd9")
