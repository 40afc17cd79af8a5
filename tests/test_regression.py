"""Behaviour regression: short runs of the shipped scenes give the recorded time series to 1e-10.

The records (tests/data/regression/dolfinx-<version>/) were made with campaigns/regression.py on the code
before a redesign; a refactoring must leave them unchanged. A deliberate change of the
numbers re-records them (``python campaigns/regression.py record``) in the same commit, with the reason.
"""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "campaigns"))
import regression  # noqa: E402

pytestmark = pytest.mark.slow


@pytest.mark.parametrize("case", list(regression.CASES))
def test_same_time_series_as_recorded(case, tmp_path, mpi_comm):
    if mpi_comm.size > 1:
        pytest.skip("runs its own subprocesses")
    recorded = regression.data_dir() / f"{case}.csv"
    if not recorded.is_file():
        pytest.skip(f"no record for this stack ({recorded})")
    series = regression.run_case(case, tmp_path)
    problems = regression.compare(regression.read(series), regression.read(recorded))
    assert not problems, "\n".join(problems)
