"""Stability at the extremes (the cheap cases of `make extremes`): each run completes with finite,
bounded energy or stops with exit 3 and a message — never a silent NaN in the output."""

from __future__ import annotations


import pytest

from extremes import run_case, verdict


@pytest.mark.parametrize("case", ["dt-x10", pytest.param("light-solid", marks=pytest.mark.slow),
                                  pytest.param("mu_r-1000", marks=pytest.mark.slow)])
def test_extreme_case_is_bounded_or_stops_cleanly(tmp_path, case):
    out = run_case(case, tmp_path, extra={"time.t_end": 0.4})
    v = verdict(out)
    assert v["ok"], v
    assert v["finite"] or v["exit"] == 3, v
