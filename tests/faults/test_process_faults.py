"""Faults around a run rather than in its scene: an environment variable that is not a number of seconds, the
Python API given a plain dict, a geometry.path too long for the file system, a steady scene whose mesh
inverts, a study report over summaries with non-numbers, a run folder holding FIFOs, a study run named
``..``, and a run killed by SIGKILL while gmsh meshes (the meshing child dies with it)."""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import time

import pytest

from faultlib import REPO, check, cli, env, in_process_main, snapshot

_SQUARE = """Point(1) = {0,0,0,0.5}; Point(2) = {1,0,0,0.5}; Point(3) = {1,1,0,0.5}; Point(4) = {0,1,0,0.5};
Line(1) = {1,2}; Line(2) = {2,3}; Line(3) = {3,4}; Line(4) = {4,1};
Curve Loop(1) = {1,2,3,4}; Plane Surface(1) = {1};
Physical Surface("fluid") = {1}; Physical Curve("inlet") = {4}; Physical Curve("outlet") = {2};
Physical Curve("walls") = {1,3};
"""
_SCENE = ("fluid: {rho: 1.0, mu: 0.01}\ntime: {scheme: characteristics1, dt: 0.1, t_end: 0.1}\n"
          "boundaries: {inlet: {type: pressure, value: 1}, outlet: {type: do_nothing}, walls: {type: no_slip}}\n"
          "output: {progress: false, fields: false}\n")


@pytest.fixture
def main(capsys, tmp_path):
    yield from in_process_main(capsys, tmp_path)


def _square_scene(folder, path: str = "m.geo"):
    (folder / "m.geo").write_text(_SQUARE)
    scene = folder / "scene.yaml"
    scene.write_text(f"geometry: {{name: file, path: {path}}}\n" + _SCENE)
    return scene


@pytest.mark.parametrize("value", ["inf", "nan", "-1", "1e400", "", "soon"])
def test_gmsh_timeout_that_is_no_number_of_seconds(main, tmp_path, monkeypatch, value):
    monkeypatch.setenv("COSSERAT_FSI_GMSH_TIMEOUT", value)
    monkeypatch.setenv("COSSERAT_FSI_MESH_CACHE", str(tmp_path / "cache"))
    code, err = main("run", _square_scene(tmp_path), "--out", main.out)
    lines = err.splitlines()
    assert code == 2 and len(lines) == 1 and "Traceback" not in err, (code, err)
    assert lines[0].startswith("error: COSSERAT_FSI_GMSH_TIMEOUT: must be a finite number of seconds > 0"), err


def test_run_scene_takes_a_dict(tmp_path, monkeypatch):
    """The Python API: a dict is validated as a scene file's content (a bad one: InputError naming the key);
    anything else that is no Scene: a TypeError that says what it takes."""
    import yaml

    import cosserat_fsi
    from cosserat_fsi.errors import InputError

    monkeypatch.setenv("COSSERAT_FSI_MESH_CACHE", str(tmp_path / "cache"))
    data = yaml.safe_load(_square_scene(tmp_path).read_text())
    data["geometry"]["path"] = str(tmp_path / "m.geo")
    summary = cosserat_fsi.run_scene(data, tmp_path / "out", progress=False)
    assert summary["status"] == "completed"
    with pytest.raises(InputError, match=r"^fluid\.mu: "):
        cosserat_fsi.run_scene({**data, "fluid": {"rho": 1.0, "mu": "x"}}, tmp_path / "bad", progress=False)
    with pytest.raises(TypeError, match="must be a Scene .* or a dict, not str"):
        cosserat_fsi.run_scene(str(tmp_path / "scene.yaml"), tmp_path / "bad", progress=False)
    assert not (tmp_path / "bad").exists()


def test_geometry_path_too_long_names_the_key(main, tmp_path):
    scene = _square_scene(tmp_path, "a" * 300 + ".geo")
    code, err = main("run", scene, "--out", main.out)
    lines = err.splitlines()
    assert code == 2 and len(lines) == 1 and "Traceback" not in err, (code, err)
    assert lines[0].startswith("error: geometry.path: file name too long (a name of 304 bytes, at most 255"), err


def test_steady_scene_whose_mesh_inverts_gets_advice_without_a_time_step(tmp_path):
    """CSM1 on level 0 with 1000 times the gravity: the moving mesh would invert; the steady scene has no
    time.dt (it refuses one), so the advice names what a steady scene can change."""
    result = cli("run", REPO / "configs" / "turek_hron_csm1.yaml", "--out", tmp_path / "out", "--no-progress",
                 "--set", "geometry.level=0", "--set", "solid.gravity=2000", "--set", "solid.mu_s=0.5e4",
                 COSSERAT_FSI_MESH_CACHE=tmp_path / "cache")
    line = check(result, 3, "diverged: ", "the mesh motion would make a cell inverted")
    assert "time.dt" not in line and "the steady deformation is too large" in line, line
    assert json.loads((tmp_path / "out" / "summary.json").read_text())["status"] == "diverged"


STUDY = "name: s\nconfig: {config}\nobservables: [c_D]\nladder: {{time.dt: [0.05]}}\n"


@pytest.mark.parametrize("edit, code", [
    (lambda s: s["memory"].update(peak_rss_mib_sum="lots"), 2),
    (lambda s: s["mesh"].update(vertices=float("inf")), 2),
    (lambda s: s["time"].update(steps=float("inf")), 2),
    (lambda s: s["wall_time"].update(total=float("nan")), 0),
    (lambda s: s.update(benchmark={"c_D": {"error": float("inf")}}), 0),
], ids=["memory_text", "vertices_inf", "steps_inf", "wall_nan", "error_inf"])
def test_study_report_over_non_numbers(tmp_path, benchmark_run, edit, code):
    """``--report-only`` over a summary.json with a non-number where a number belongs: one line naming it, or
    (a nan or an inf measurement) the report shows it and keeps it off the Pareto front."""
    config, finished = benchmark_run
    study = tmp_path / "s.yaml"
    study.write_text(STUDY.format(config=config))
    run = tmp_path / "out" / "runs" / "study-s" / "dt0.05"
    shutil.copytree(finished, run)
    summary = json.loads((run / "summary.json").read_text())
    edit(summary)
    (run / "summary.json").write_text(json.dumps(summary))
    before = snapshot(run)
    result = cli("study", study, "--out", tmp_path / "out", "--report-only")
    if code == 2:
        check(result, 2, "error: ", f"{run / 'summary.json'}: not the summary of a cosserat-fsi run")
    else:
        assert result.returncode == 0 and "Traceback" not in result.stderr, result
        report = (tmp_path / "out" / "study_s.md").read_text()
        assert "| dt0.05 |" in report and ("nan" in report or "inf" in report) and "Pareto front" not in report
    assert snapshot(run) == before


@pytest.mark.parametrize("name", ["summary.json", "timeseries.csv"])
def test_plot_never_waits_on_a_fifo(run_copy, tmp_path, name):
    """A FIFO in place of a run's file: refused or passed over at once (the timeout fails a hang)."""
    (run_copy / name).unlink()
    os.mkfifo(run_copy / name)
    result = cli("plot", run_copy, "--out", tmp_path / "plots", timeout=60)
    if name == "summary.json":  # plotted without the reference band
        assert result.returncode == 0 and "Traceback" not in result.stderr, result
    else:
        check(result, 2, "error: ", "not a regular file")


@pytest.mark.parametrize("name", ["..", "."])
def test_study_run_named_dot_dot_is_refused(tmp_path, tiny_config, name):
    study = tmp_path / "s.yaml"
    study.write_text(STUDY.format(config=tiny_config) + f"extra: {{'{name}': {{time.t_end: 0.1}}}}\n")
    result = cli("study", study, "--out", tmp_path / "out")
    check(result, 2, f"error: {study}: extra.{name}: a name of letters, digits")
    assert not (tmp_path / "out" / "runs").exists()


def _children(pid: int) -> list[int]:
    """The pids whose parent is ``pid`` (from /proc)."""
    found = []
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            try:
                status = open(f"/proc/{entry}/status").read()
            except OSError:
                continue
            if f"\nPPid:\t{pid}\n" in status:
                found.append(int(entry))
    return found


def _alive(pid: int) -> bool:
    try:
        state = open(f"/proc/{pid}/status").read().split("\nState:\t")[1][0]
    except (OSError, IndexError):
        return False
    return state != "Z"


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="/proc and PR_SET_PDEATHSIG are Linux's")
def test_gmsh_child_dies_with_a_killed_run(tmp_path):
    """A run meshing a .geo (the gmsh child held by the failpoint) killed by SIGKILL: the child is gone within
    5 s, not left meshing for its timeout."""
    scene = _square_scene(tmp_path)
    proc = subprocess.Popen([sys.executable, "-m", "cosserat_fsi", "run", str(scene), "--out", str(tmp_path / "out")],
                            env=env(COSSERAT_FSI_FAILPOINT="gmsh@0:hang", COSSERAT_FSI_MESH_CACHE=tmp_path / "cache"),
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        deadline, child = time.monotonic() + 60, None
        while child is None and time.monotonic() < deadline and proc.poll() is None:
            for pid in _children(proc.pid):
                try:
                    if b"cosserat_fsi.geometry" in open(f"/proc/{pid}/cmdline", "rb").read():
                        child = pid
                except OSError:
                    pass
            time.sleep(0.1)
        assert child is not None, "no gmsh child started"
        time.sleep(0.5)  # past the child's start (its death signal is set first thing)
        proc.send_signal(signal.SIGKILL)
        proc.wait(timeout=10)
        deadline = time.monotonic() + 5
        while _alive(child) and time.monotonic() < deadline:
            time.sleep(0.1)
        assert not _alive(child), "the gmsh child outlived the killed run"
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
