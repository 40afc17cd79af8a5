"""The `cosserat-fsi run` contract: files, columns, summary, exit codes (0 done, 3 diverged)."""

from __future__ import annotations

import json
import xml.etree.ElementTree as ET

import numpy as np
import pytest

from cosserat_fsi.config import load_scene
from cosserat_fsi.io import read_timeseries


def _run(run_cli, repo_root, tmp_path, *sets):
    out = tmp_path / "run"
    proc = run_cli("run", repo_root / "configs/schaefer_turek_2d1.yaml", "--out", out, "--no-progress",
                   *[a for s in ["geometry.level=0", "time.scheme=characteristics1", *sets] for a in ("--set", s)],
                   cwd=tmp_path)
    return proc, out


def test_run_writes_the_contract_files(run_cli, repo_root, tmp_path):
    proc, out = _run(run_cli, repo_root, tmp_path, "time.dt=0.05", "time.t_end=0.5", "output.every=5")
    assert proc.returncode == 0, proc.stderr
    # config.yaml is the fully resolved scene and loads back to the same scene
    resolved = load_scene(out / "config.yaml")
    assert resolved.time.t_end == 0.5 and resolved.geometry.level == 0 and resolved.solver.penalty >= 0
    # timeseries.csv: t first, then the observables, one row per step, times = k δt
    ts = read_timeseries(out / "timeseries.csv")
    assert list(ts)[:4] == ["t", "drag", "lift", "drag_surface"] and "dp" in ts
    np.testing.assert_allclose(ts["t"], 0.05 * np.arange(1, 11), rtol=1e-12)
    assert np.all(ts["drag"] > 0)
    # summary.json: versions, dofs, steps, timings, comparison with the reference
    s = json.loads((out / "summary.json").read_text())
    assert s["status"] == "completed" and s["time"]["steps"] == 10
    assert s["dofs"]["total"] == s["dofs"]["velocity"] + s["dofs"]["pressure"]
    assert "micro_rotation" not in s["dofs"]  # no micropolar terms in this scene: no ω field
    assert {"dolfinx", "petsc", "mpi"} <= set(s["versions"])
    assert {"backtrack", "assemble_vector", "solve"} <= set(s["wall_time"]["phases"])
    assert s["benchmark"]["c_D"]["reference"] == pytest.approx(5.57953523384)
    # the linear solves: one LU of the fixed mesh's constant matrix serves the 10 steps
    memory = {key: s["linear_solver"].pop(key) for key in ("peak_rss_mib_max_rank", "peak_rss_kib_per_unknown")}
    assert s["linear_solver"] == {"type": "direct: MUMPS LU", "solves": 10, "factorisations": 1}
    assert memory["peak_rss_mib_max_rank"] == s["memory"]["peak_rss_mib_max_rank"]
    assert memory["peak_rss_kib_per_unknown"] == pytest.approx(1024 * s["memory"]["peak_rss_mib_sum"]
                                                               / s["dofs"]["total"])
    # fields.xdmf: t = 0 and every 5th step, each with its own geometry and the fields
    grids = ET.parse(out / "fields.xdmf").getroot().iter("Grid")
    times = [float(g.find("Time").get("Value")) for g in grids if g.find("Time") is not None]
    np.testing.assert_allclose(times, [0.0, 0.25, 0.5], atol=1e-12)
    log_text = (out / "run.log").read_text()
    assert (out / "fields.h5").stat().st_size > 0 and log_text.count("model:") == 1
    assert "solver.type auto: direct (MUMPS)" in log_text and "at every size in 2D" in log_text  # the choice, said


def test_diverging_run_exits_3_and_keeps_output(run_cli, repo_root, tmp_path):
    """A body force of 1e308 N/m³ overflows the first solve: exit 3, one line, files kept."""
    proc, out = _run(run_cli, repo_root, tmp_path, "time.dt=0.05", "time.t_end=0.5",
                     "fluid.body_force=[1.0e308, 1.0e308]")
    assert proc.returncode == 3, proc.stderr
    lines = [line for line in proc.stderr.splitlines() if line.startswith("diverged:")]
    assert len(lines) == 1 and "t = 0.05" in lines[0] and "Traceback" not in proc.stderr
    s = json.loads((out / "summary.json").read_text())
    assert s["status"] == "diverged" and "non-finite" in s["message"]
    assert (out / "timeseries.csv").read_text().startswith("t,") and (out / "config.yaml").exists()
