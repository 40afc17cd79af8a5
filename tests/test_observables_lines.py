"""A scene's own observables: ``observables.lines`` profiles (line_NAME.csv), ``observables.flow_rates``,
where the probes landed (run.log), a ``reference`` section's verdict, the scene's columns in ``plot`` and in
the ``result:`` line.

The channel of tests/data/user_scene/channel.geo (2 x 1, structured triangles) with a parabolic inflow
u = 4 y (1 − y), a do-nothing outlet and μ = 1: steady Stokes–Navier–Stokes flow is exactly that parabola
with a linear pressure p = 8 (2 − x), both in the P2/P1 spaces, so a profile across the channel equals the
parabola to round-off, on 1 and 2 ranks, and the flow rate out of the outlet is ∫ 4y(1 − y) dy = 2/3 (into
the inlet: −2/3 along its outward normal).
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from cosserat_fsi.io import read_timeseries

DATA = Path(__file__).parent / "data" / "user_scene"


def _scene(folder: Path, extra: str = "", time: str = "{scheme: steady}") -> Path:
    path = folder / "scene.yaml"
    micro = ", micro_rotation: free" if "micropolar" in extra else ""  # ω at the inflow: natural
    path.write_text(f"geometry: {{name: file, path: {DATA}/channel.geo}}\n"
                    "fluid: {rho: 1.0, mu: 1.0}\n"
                    f"time: {time}\n"
                    f"boundaries: {{inlet: {{type: velocity, value: ['4*y*(1 - y)', 0]{micro}}}, "
                    "outlet: {type: do_nothing},\n"
                    "             top: {type: no_slip}, bottom: {type: no_slip}}\n"
                    "observables: {points: {C: [1.0, 0.5]}, lines: {across: {from: [1.3, 0.0], to: [1.3, 1.0], "
                    "points: 11}}, flow_rates: [inlet, outlet]}\n"
                    "output: {progress: false, fields: false}\n" + extra)
    return path


def _read(path: Path) -> tuple[list[str], np.ndarray]:
    """(header, rows) of a line_NAME.csv (what pandas.read_csv reads)."""
    with open(path) as f:
        header = f.readline().strip().split(",")
    return header, np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)


def _exact_check(header, rows):
    frame = dict(zip(header, rows.T))
    y = frame["y"]
    assert np.allclose(frame["s"], np.linspace(0, 1, 11), atol=1e-15)
    assert np.allclose(frame["x"], 1.3, atol=1e-15)
    assert np.abs(frame["u"] - 4 * y * (1 - y)).max() < 1e-10
    assert np.abs(frame["v"]).max() < 1e-10
    assert np.abs(frame["p"] - 8 * (2 - 1.3)).max() < 1e-9


def test_poiseuille_profile_is_the_exact_parabola_on_one_and_two_ranks(run_cli, mpirun, tmp_path):
    scene = _scene(tmp_path)
    one = run_cli("run", scene, "--out", tmp_path / "one")
    assert one.returncode == 0, one.stderr
    two = run_cli("run", scene, "--out", tmp_path / "two", launcher=mpirun(2))
    assert two.returncode == 0, two.stderr
    (header, a), (_, b) = (_read(tmp_path / run / "line_across.csv") for run in ("one", "two"))
    assert header == ["t", "s", "x", "y", "u", "v", "p"] and a.shape == (11, 7)  # steady: one block
    _exact_check(header, a)
    assert np.abs(a - b).max() < 1e-12
    for run in ("one", "two"):
        series = read_timeseries(tmp_path / run / "timeseries.csv")
        assert abs(series["flow_rate_outlet"][-1] - 2 / 3) < 1e-10, run
        assert abs(series["flow_rate_inlet"][-1] + 2 / 3) < 1e-10, run
    log = (tmp_path / "one" / "run.log").read_text()
    assert "probe C at (1, 0.5): inside the mesh, fluid cell" in log
    assert "line across: 11 points from (1.3, 0.0) to (1.3, 1.0)" in log


def test_lines_every_output_step_and_restart_continues_the_file(run_cli, tmp_path):
    """Time-dependent: a block at t = 0 and every output.every steps; a restart from the checkpoint of step
    2 keeps the blocks up to it and gives the file of an uninterrupted run."""
    time = "{scheme: characteristics1, dt: 0.1, t_end: 0.4}"
    extra = "micropolar: {mu_r: 0.5, lambda1: 0.1}\n"
    scene = _scene(tmp_path, extra, time)
    text = scene.read_text().replace("fields: false}", "fields: false, every: 2, checkpoint_every: 2}")
    scene.write_text(text)
    full = run_cli("run", scene, "--out", tmp_path / "full")
    assert full.returncode == 0, full.stderr
    header, frame = _read(tmp_path / "full" / "line_across.csv")
    assert header == ["t", "s", "x", "y", "u", "v", "p", "omega"]
    assert np.unique(frame[:, 0]) == pytest.approx([0.0, 0.2, 0.4]) and len(frame) == 33
    short = scene.read_text().replace("t_end: 0.4", "t_end: 0.2")  # its checkpoint: the full run's of step 2
    (tmp_path / "short.yaml").write_text(short)
    assert run_cli("run", tmp_path / "short.yaml", "--out", tmp_path / "short").returncode == 0
    cut = tmp_path / "cut"  # the full run "killed" after step 2 (with its later blocks written)
    shutil.copytree(tmp_path / "full", cut)
    shutil.rmtree(cut / "checkpoint")
    shutil.copytree(tmp_path / "short" / "checkpoint", cut / "checkpoint")
    assert json.loads((cut / "checkpoint" / "meta.json").read_text())["step"] == 2
    (cut / "line_across.csv").write_text((cut / "line_across.csv").read_text() + "0.5,1,2")  # a torn block
    again = run_cli("run", scene, "--restart", cut)
    assert again.returncode == 0, again.stderr
    _, restarted = _read(tmp_path / "cut" / "line_across.csv")
    assert restarted.shape == frame.shape and np.abs(restarted - frame).max() < 1e-12


@pytest.mark.parametrize("reference, verdict", [
    ("{u_C: {value: 1.0, tolerance: 1.0e-6}}", "PASS (1/1"),
    ("{u_C: {value: 1.1, tolerance: 0.01}}", "FAIL (0/1"),
    ("{v_C: {value: 0, abs_tolerance: 1.0e-8}, p_C: {value: 8.0, tolerance: 1.0e-6}}", "PASS (2/2"),
    ("{flow_rate_outlet: {value: 0.6666666666666666, tolerance: 1.0e-9}, u_C: {value: 1.0, tolerance: 1.0e-6}}",
     "PASS (2/2"),
    ("{flow_rate_inlet: {value: 0.6666666666666666, tolerance: 1.0e-3}, u_C: {value: 1.0, tolerance: 1.0e-6}}",
     "FAIL (1/2"),
])
def test_reference_section_gives_a_verdict(run_cli, tmp_path, reference, verdict):
    """u at the centre of the channel is exactly 1, p at x = 1 exactly 8: the verdict table of the run."""
    result = run_cli("run", _scene(tmp_path, f"reference: {reference}\n"), "--out", tmp_path / "run")
    assert result.returncode == 0, result.stderr
    out = result.stdout + result.stderr
    assert f"reference: {verdict} within tolerance)" in out, out
    summary = json.loads((tmp_path / "run" / "summary.json").read_text())
    assert summary["reference"]["u_C" if "u_C" in reference else "v_C"]["reference"] in (1.0, 1.1, 0.0)
    assert "u_C = 1" in out  # the scene's own probe in the result line
    assert "flow_rate_outlet = 0.666667" in out


def test_plot_draws_the_scene_probes(run_cli, tmp_path):
    scene = _scene(tmp_path, time="{scheme: characteristics1, dt: 0.1, t_end: 0.2}")
    assert run_cli("run", scene, "--out", tmp_path / "run").returncode == 0
    result = run_cli("plot", tmp_path / "run", "--out", tmp_path / "plots")
    assert result.returncode == 0, result.stderr
    assert (tmp_path / "plots" / "probes.png").is_file() and (tmp_path / "plots" / "flow_rates.png").is_file()


def test_resolved_config_with_lines_and_reference_loads_again(tmp_path):
    from cosserat_fsi.config import dump_resolved, load_scene

    scene = load_scene(_scene(tmp_path, "reference: {u_C: {mean: 1.0, frequency: 2.0, tolerance: 0.1}}\n",
                              "{scheme: characteristics1, dt: 0.1, t_end: 0.2}"))
    (tmp_path / "resolved.yaml").write_text(dump_resolved(scene))
    again = load_scene(tmp_path / "resolved.yaml")
    assert again == scene and "from:" in dump_resolved(scene)


def _strip(rows: int, columns: int = 6) -> np.ndarray:
    """The corners (n, 3, 2) of a structured strip of ``rows`` x ``columns`` squares, two triangles each."""
    out = []
    for i in range(columns):
        for j in range(rows):
            a, b, c, d = (i, j), (i + 1, j), (i + 1, j + 1), (i, j + 1)
            out += [[a, b, c], [a, c, d]]
    return np.array(out, dtype=float) * 0.1


@pytest.mark.parametrize("rows, across", [(1, 1), (2, 2), (3, 2), (4, 4), (5, 4)])
def test_cells_across_a_strip(rows, across):
    """2·(largest vertex depth from the boundary), at least 1: never more than the strip's rows."""
    from cosserat_fsi.mesh.report import _regions

    assert _regions(_strip(rows)) == [{"cells": 12 * rows, "across": across}]


def test_two_solid_regions_are_counted_apart():
    from cosserat_fsi.mesh.report import _regions

    far = _strip(1) + np.array([5.0, 0.0])  # a thin strip beside a thick one
    assert _regions(np.concatenate([_strip(4), far])) == [{"cells": 48, "across": 4}, {"cells": 12, "across": 1}]


def test_run_log_names_conditions_probes_and_the_solid(run_cli, tmp_path):
    """A file scene with a solid block and no boundaries section for 'clamp' and 'walls' (their defaults by
    name): run.log lists every boundary's condition, where the probe and the solid point landed, the block's
    cells across; config.yaml lists the conditions and loads again as the same scene."""
    from cosserat_fsi.config import load_scene

    (tmp_path / "block.geo").write_text((DATA / "block_channel.geo").read_text())
    scene = tmp_path / "scene.yaml"
    scene.write_text("geometry: {name: file, path: block.geo}\nfluid: {rho: 1.0, mu: 0.01}\n"
                     "solid: {rho: 1.0, mu_s: 100.0}\ninflow: {u_mean: 1.0}\n"
                     "observables: {points: {B: [1.5, 0.5]}, solid_points: {top: [0.93, 0.41]}}\n"
                     "time: {scheme: characteristics1, dt: 0.01, t_end: 0.01}\noutput: {progress: false}\n")
    result = run_cli("run", scene, "--out", tmp_path / "run")
    assert result.returncode == 0, result.stderr
    log = (tmp_path / "run" / "run.log").read_text()
    assert "boundaries:\n  walls: no_slip\n" in log and "  clamp: no_slip\n" in log
    assert "  inlet: velocity ['(6.0*1.0*y*(1.0 - y)/1.0**2)', '0']\n" in log
    assert "probe B at (1.5, 0.5): inside the mesh, fluid cell" in log
    assert "solid point top asked at (0.93, 0.41): solid node at (" in log
    assert "solid region 1: " in log and "cells across" in log
    config = (tmp_path / "run" / "config.yaml").read_text()
    assert "#   walls: no_slip\n" in config
    assert load_scene(tmp_path / "run" / "config.yaml") == load_scene(scene)


def test_periodic_reference_parts_and_a_column_not_periodic_yet():
    """mean/amplitude/frequency against summary.json's periodic analysis (relative errors); a column that is
    not periodic by the end FAILs with its state named; the verdict line counts both."""
    from cosserat_fsi.app.verdict import compare_with_scene_reference, verdict_lines
    from cosserat_fsi.config.sections import Reference

    summary = {"final": {"uy_tip": 0.01, "drag": 2.0}, "signals": {"uy_tip": "periodic", "drag": "not periodic yet"},
               "periodic": {"uy_tip": {"mean": 0.001, "amplitude": 0.0202, "frequency": 2.0}}}
    reference = {"uy_tip": Reference(amplitude=0.02, frequency=2.0, tolerance=0.02),
                 "drag": Reference(mean=2.0, abs_tolerance=0.1)}
    summary["reference"] = compare_with_scene_reference(reference, summary)
    assert summary["reference"]["uy_tip.amplitude"]["error"] == pytest.approx(0.01, rel=1e-12)
    assert summary["reference"]["uy_tip.frequency"]["verdict"] == "pass"
    assert summary["reference"]["drag.mean (not periodic yet)"]["verdict"] == "FAIL"
    lines = verdict_lines(summary)
    assert "reference: FAIL (2/3 within tolerance)" in lines
    assert any(line.startswith("uy_tip.amplitude") and line.rstrip().endswith("pass") for line in lines)
    summary.update(status="diverged", time={"t_final": 0.0261784})  # the same values, a run that stopped
    summary["reference"] = compare_with_scene_reference(reference, summary)
    assert {entry["verdict"] for entry in summary["reference"].values()} == {"n/a"}
    lines = verdict_lines(summary)
    assert "reference: not judged: the run diverged at t = 0.0261784 (a verdict is given for a completed run)" in lines
    assert not any(word in "\n".join(lines) for word in ("PASS", "FAIL", " pass")), lines


def test_flow_rate_through_an_interior_group_is_refused(tmp_path):
    """The fluid-solid interface of the block channel is inside the mesh (no outward normal): a scene built in
    Python that asks its flow rate is refused naming the key (a scene file is refused earlier, by the file's
    names: tests/faults/test_scene_observables.py)."""
    from mpi4py import MPI

    from cosserat_fsi.app.runner import load_mesh
    from cosserat_fsi.config import load_scene
    from cosserat_fsi.config.sections import ObservableSet
    from cosserat_fsi.errors import InputError
    from cosserat_fsi.observables import Observables
    from cosserat_fsi.simulation import Simulation

    (tmp_path / "block.geo").write_text((DATA / "block_channel.geo").read_text())
    (tmp_path / "scene.yaml").write_text(
        "geometry: {name: file, path: block.geo}\nfluid: {rho: 1.0, mu: 0.01}\nsolid: {rho: 1.0, mu_s: 100.0}\n"
        "inflow: {u_mean: 1.0}\ntime: {scheme: characteristics1, dt: 0.01, t_end: 0.01}\n")
    scene = load_scene(tmp_path / "scene.yaml")
    mesh, ct, ft, _ = load_mesh(scene, MPI.COMM_WORLD)  # (which would check the names against the file's)
    scene.observables = ObservableSet(flow_rates=["outlet", "interface"])
    sim = Simulation(scene, mesh, ct, ft, MPI.COMM_WORLD)
    with pytest.raises(InputError) as caught:
        Observables(sim)
    assert str(caught.value) == ("observables.flow_rates[1]: facet group 'interface' is inside the mesh (a flow rate "
                                 "is through a boundary, along its outward normal)")
    scene.observables = ObservableSet(flow_rates=["outlet"])
    assert "flow_rate_outlet" in Observables(sim).columns
