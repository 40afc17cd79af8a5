"""campaigns/fsi3_table.py and reanalyse.py: a run's table as if it had ended earlier (``--at``)."""

from __future__ import annotations

import json
import shutil

import numpy as np

from fsi3_table import row
from reanalyse import reanalyse

from cosserat_fsi.references import reference_for


def _cfd3_run(folder, repo_root):
    """A CFD3 run folder whose lift amplitude is 10 % over the reference up to t = 10 and exact after."""
    folder.mkdir()
    shutil.copy(repo_root / "configs" / "turek_hron_cfd3.yaml", folder / "config.yaml")
    ref = reference_for("turek_hron_cfd3")
    t = np.arange(1, 7001) * 0.002  # to t = 14
    phase = 2 * np.pi * ref["lift"]["frequency"] * t
    lift = ref["lift"]["mean"] + np.where(t <= 10.0, 1.1, 1.0) * ref["lift"]["amplitude"] * np.sin(phase)
    drag = ref["drag"]["mean"] + ref["drag"]["amplitude"] * np.sin(phase)
    rows = ["t,dt,drag,lift"] + [f"{a:.12e},0.002,{b:.12e},{c:.12e}" for a, b, c in zip(t, drag, lift)]
    (folder / "timeseries.csv").write_text("\n".join(rows) + "\n")
    summary = {"time": {"steps": len(t), "t_final": 14.0, "rejected_steps": 3}, "wall_time": {"total": 1.0},
               "final": {"drag": drag[-1], "lift": lift[-1]}}
    (folder / "summary.json").write_text(json.dumps(summary))
    return folder


def test_a_run_judged_as_if_it_had_ended_earlier(tmp_path, repo_root):
    run = _cfd3_run(tmp_path / "cfd3", repo_root)
    early, late = reanalyse(run, until=10.0), reanalyse(run)
    assert early["time"]["t_final"] <= 10.0 and "rejected_steps" not in early["time"]
    assert abs(early["benchmark"]["lift"]["amplitude"]["error"] - 0.10) < 2e-3
    assert abs(late["benchmark"]["lift"]["amplitude"]["error"]) < 2e-3
    cells = row(run, 10.0).split("|")
    assert cells[1].strip() == "cfd3, t ≤ 10" and len(cells) == 6 + 4 + 2  # CFD3's six quantities
    assert cells[8].strip() == "+10.00" and row(run).split("|")[8].strip() in ("+0.00", "-0.00")
