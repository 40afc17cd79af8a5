"""Every quantity a benchmark publishes gets a verdict (app/verdict.py TOLERANCES), and a periodic mean about
zero (FSI3's and CFD3's lift, uy(A)) is judged relative to its amplitude."""

from __future__ import annotations

from pathlib import Path

import pytest

from cosserat_fsi.app.verdict import TOLERANCES, benchmark_rows, compare_with_reference, periodic_error
from cosserat_fsi.config import load_scene
from cosserat_fsi.references import reference_for

REPO = Path(__file__).resolve().parents[1]
PUBLISHED = ["schaefer_turek_2d1", "schaefer_turek_3d1z", "turek_hron_cfd1", "turek_hron_cfd2", "turek_hron_cfd3",
             "turek_hron_csm1", "turek_hron_csm2", "turek_hron_csm3", "turek_hron_fsi1", "turek_hron_fsi3"]


def _labels(benchmark: str) -> set[str]:
    labels = set()
    for key, ref in reference_for(benchmark).items():
        labels |= {f"{key}.{part}" for part in ref} if isinstance(ref, dict) else {key}
    return labels


@pytest.mark.parametrize("benchmark", PUBLISHED)
def test_every_published_quantity_has_a_tolerance(benchmark):
    assert _labels(benchmark) == set(TOLERANCES[benchmark])


@pytest.mark.parametrize("benchmark, limit", [("turek_hron_fsi3", 0.02), ("turek_hron_csm3", 0.01),
                                              ("turek_hron_fsi1", 0.01), ("turek_hron_csm1", 0.01)])
def test_the_issue_bands(benchmark, limit):
    assert max(TOLERANCES[benchmark].values()) <= limit


def test_a_mean_about_zero_is_relative_to_the_amplitude():
    lift = reference_for("turek_hron_fsi3")["lift"]  # 2.5 ± 153.91
    error, scale = periodic_error(lift["mean"] + 1.5, lift, "mean")
    assert scale == "amplitude" and error == pytest.approx(1.5 / lift["amplitude"])
    ux = reference_for("turek_hron_fsi3")["ux_A"]  # -2.88e-3 ± 2.72e-3: the mean is the larger
    error, scale = periodic_error(1.01 * ux["mean"], ux, "mean")
    assert scale == "mean" and error == pytest.approx(-0.01)  # |value| larger: signed by value − reference
    error, scale = periodic_error(1.01 * lift["amplitude"], lift, "amplitude")
    assert scale == "amplitude" and error == pytest.approx(0.01)


def test_the_fsi3_table_judges_twelve_quantities():
    scene = load_scene(REPO / "configs" / "turek_hron_fsi3.yaml")
    refs = reference_for("turek_hron_fsi3")
    periodic = {key: {"method": "maxima", "mean": ref["mean"] + 0.015 * ref["amplitude"],
                      "amplitude": 1.03 * ref["amplitude"], "frequency": ref["frequency"]}
                for key, ref in refs.items()}
    summary = {"final": {key: 0.0 for key in refs}, "periodic": periodic}
    summary["benchmark"] = compare_with_reference(scene, summary)
    rows = {r[0]: r for r in benchmark_rows(summary)}
    assert len(rows) == 12 and all(r[5] in ("pass", "FAIL") for r in rows.values())
    assert rows["lift.mean"][3] == "+1.500 % of amplitude" and rows["lift.mean"][5] == "pass"
    assert rows["uy_A.mean"][5] == "pass"
    assert rows["ux_A.mean"][3] == "+1.417 %" and rows["ux_A.mean"][5] == "pass"  # relative to the mean
    assert rows["drag.amplitude"][5] == "FAIL" and rows["drag.frequency"][5] == "pass"
