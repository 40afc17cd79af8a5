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


def test_the_roughness_of_a_record_sees_a_kick_after_a_change_of_step(tmp_path):
    """campaigns/step_change_kick.py: a smooth drag's rows lie on the line through their neighbours up to its
    curvature, A (2πf δt)²/2 on a sine; a kick of 1 N on the row after a change of step shows there."""
    from step_change_kick import roughness

    run = tmp_path / "run"
    run.mkdir()
    dt = np.r_[np.full(200, 1e-3), np.full(200, 1.2e-3)]
    t = np.cumsum(dt)
    drag = 30.0 * np.sin(2 * np.pi * 11.0 * t)
    lift, uy = 150.0 * np.sin(2 * np.pi * 5.5 * t), 0.035 * np.sin(2 * np.pi * 5.5 * t)
    kicked = drag.copy()
    kicked[200] += 1.0  # the first row of the larger step
    for name, values in (("smooth", drag), ("kicked", kicked)):
        columns = zip(*(a.tolist() for a in (t, dt, values, lift, uy)))
        rows = ["t,dt,drag,lift,uy_A"] + [",".join(map(repr, row)) for row in columns]
        (run / "timeseries.csv").write_text("\n".join(rows) + "\n")
        cells = [c.strip() for c in roughness(run, 0.0, 1.0).split("|")[1:-1]]
        assert cells[3] == "1"  # one change of step
        rms, largest = (float(v) for v in cells[4].split(" / "))
        curvature = 30.0 * (2 * np.pi * 11.0 * 1.2e-3) ** 2 / 2
        if name == "smooth":
            assert largest <= 1.01 * curvature
        else:
            assert 0.99 < largest < 1.0 + curvature and float(cells[7].split(" / ")[0]) > 0.99


def test_the_fitted_row_takes_the_spikes_out_of_the_drag_amplitude(tmp_path):
    """campaigns/step_change_kick.py fitted: a record of the reference's own sines, the drag with 1 N spikes on
    every third row (the forces after the steps' changes), reads the drag amplitude ~ +2 % high with the
    verdict's vertices and within 0.5 % with parabolas fitted over ± 0.1 period; every other column ~ 0."""
    from step_change_kick import fitted

    reference = reference_for("turek_hron_fsi3")
    t = np.arange(0.0, 2.0, 1e-3)
    columns = {"t": t}
    for key in ("ux_A", "uy_A", "drag", "lift"):
        ref = reference[key]
        columns[key] = ref["mean"] + ref["amplitude"] * np.sin(2 * np.pi * ref["frequency"] * t)
    columns["drag"] = columns["drag"] + 1.0 * (np.arange(len(t)) % 3 == 0)
    run = tmp_path / "run"
    run.mkdir()
    rows = [",".join(columns)] + [",".join(map(repr, r)) for r in zip(*(c.tolist() for c in columns.values()))]
    (run / "timeseries.csv").write_text("\n".join(rows) + "\n")
    cells = [c.strip() for c in fitted(run, 0.1).split("|")[1:-1]]
    errors = [tuple(float(v) for v in c.split(" → ")) for c in cells[1:]]
    drag_amplitude = errors[5]
    assert drag_amplitude[0] > 1.5 and abs(drag_amplitude[1]) < 0.5
    for k, (vertex, fit) in enumerate(errors):
        if k not in (4, 5):  # the drag mean carries the spikes' own mean, 1/3 N
            assert abs(vertex) < 0.1 and abs(fit) < 0.1, (k, vertex, fit)


def test_large_runs_row(tmp_path):
    """campaigns/large_runs.py: a saturated swing uy(A) = 8 cm sin(2π 1.9 t) + 0.2 cm, ux(A) = −3 cm (1 −
    cos 2ωt)/2, is read back over t ≥ 11 as −7.80 / +8.20 cm at 1.900 Hz, ux(A) min −3.00 cm; the second run,
    twice as long, at 2.00 × the first."""
    from large_runs import row

    t = np.arange(0.0, 15.0 + 1e-9, 2e-3)
    uy = 0.08 * np.sin(2 * np.pi * 1.9 * t) + 0.002
    ux = -0.03 * (1 - np.cos(4 * np.pi * 1.9 * t)) / 2
    run = tmp_path / "run"
    run.mkdir()
    lines = "".join(f"{a:.17g},{b:.17g},{c:.17g}\n" for a, b, c in zip(t, ux, uy))
    (run / "timeseries.csv").write_text("t,ux_A,uy_A\n" + lines)
    summary = {"ranks": 1, "status": "completed", "time": {"steps": len(t) - 1, "rejected_steps": 2},
               "remeshes": {"count": 0}, "mesh_quality": {"lowest": 0.4}, "wall_time": {"total": 500.0}}
    (run / "summary.json").write_text(json.dumps(summary))
    text, wall = row(run, 11.0, None)
    cells = [c.strip() for c in text.split("|")[1:-1]]
    assert cells[3:9] == ["7,500 (2)", "0", "-7.80 / +8.20", "1.900", "-3.00", "0.400"], cells
    assert row(run, 11.0, 250.0)[0].rstrip(" |").endswith("2.00")
