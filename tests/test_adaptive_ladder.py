"""campaigns/adaptive_ladder.py: the slope fits, and the --one mode's count of the controller's attempts."""

from __future__ import annotations

import math

import pytest

from adaptive_ladder import analyse, extrapolated, run_case, slope


def _row(tol, amplitude, reference=100.0):
    return {"case": f"t{tol}", "tolerance": tol, "status": "completed", "amplitude": amplitude,
            "amplitude_error": amplitude / reference - 1.0}


def test_slope_of_errors_proportional_to_the_tolerance():
    rows = [_row(tol, 100.0 * (1.0 + 3.0 * tol)) for tol in (1e-1, 1e-2, 1e-3)]
    rows.append({"case": "fixed", "tolerance": None, "status": "completed", "amplitude": 50.0,
                 "amplitude_error": -0.5})  # the fixed-δt row is not part of the fit
    assert slope(rows) == pytest.approx(1.0, rel=1e-12)
    # against the finest tolerance: 3 (tol - 1e-3)/(1 + 3e-3), over 1e-2 … 1e-1: log10(0.297/0.027) = log10(11)
    assert slope(rows, against_finest=True) == pytest.approx(math.log10(11.0), rel=1e-12)
    assert slope(rows[:1]) is None


def test_the_time_error_model_finds_the_floor_and_the_slope():
    """Q(tol) = Q* + C tol^s with Q* off the reference by the mesh's floor (+2 %): s, Q*, the floor and the
    time errors |Q − Q*|/Q* come back; a sign change of C is found as well; fewer than four rows: None."""
    for s, c in ((1.1, 30.0), (0.8, -5.0)):
        rows = [_row(tol, 102.0 + c * tol ** s) for tol in (3e-1, 1e-1, 3e-2, 1e-2, 3e-3)]
        fit = extrapolated(rows)
        assert fit["slope"] == pytest.approx(s, abs=0.006) and fit["value"] == pytest.approx(102.0, rel=1e-3)
        assert fit["floor"] == pytest.approx(0.02, abs=1e-3)
        assert fit["time_errors"][0] == pytest.approx(abs(c) * 3e-3 ** s / 102.0, rel=0.05)
    assert extrapolated(rows[:3]) is None


def test_one_mode_counts_the_rejected_steps(tmp_path):
    """From rest on level 0 at tolerance 1e-3 the third step (the first with an estimate) is rejected twice."""
    sets = {"geometry.level": 0, "time.t_end": 0.006}
    out = run_case("cfd3", 1e-3, sets, tmp_path)
    row = analyse(out, "cfd3", 1e-3)
    assert (row["exit"], row["status"], row["rejected"], row["attempts"]) == (0, "completed", 2, row["steps"] + 2)
    lines = (out / "attempts.csv").read_text().splitlines()
    assert lines[0] == "t,dt,E,accepted,top1pct_share,E_u,x_max,y_max"
    t, dt, e, accepted = lines[3].split(",")[:4]
    assert (float(t), float(dt), accepted) == (0.004, 0.002, "0")
    assert float(e) == pytest.approx(21.4970, rel=1e-4)  # the node-weighted estimate
