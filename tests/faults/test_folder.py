"""The run folder is owned: two runs into one folder, a finished run in --out, --overwrite, a stale lock,
output names taken by folders, a disk that fills mid-run (simulated), a failing summary, an internal
error, signals at start-up and during meshing, the mesh and compiler caches."""

from __future__ import annotations

import fcntl
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import h5py
import pytest

from faultlib import TIMEOUT, check, cli, env, snapshot


def _status(folder: Path) -> str:
    return json.loads((folder / "summary.json").read_text())["status"]


def _start(config, out, *extra, **environ) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "cosserat_fsi", "run", str(config), "--out", str(out),
                             "--no-progress", *map(str, extra)], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            env=env(**environ))


def _wait_for(predicate, seconds=60.0):
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        if predicate():
            return True
        time.sleep(0.05)
    return False


@pytest.mark.slow
def test_two_runs_into_one_folder(tiny_config, tmp_path):
    """The second run is refused naming the first's PID and touches nothing; the first ends normally."""
    out = tmp_path / "run"
    first = _start(tiny_config, out, "--set", "time.t_end=30")  # 600 steps: still running when the 2nd comes
    try:
        assert _wait_for(lambda: (out / "timeseries.csv").exists() and
                         (out / "timeseries.csv").read_text().count("\n") >= 3)
        second = cli("run", tiny_config, "--out", out, "--no-progress")
        check(second, 2, "error: --out:", f"is in use by process {first.pid}")
        again = cli("run", tiny_config, "--out", out, "--overwrite", "--no-progress")
        check(again, 2, "error: --out:", f"process {first.pid}")
        restart = cli("run", tiny_config, "--restart", out, "--no-progress")
        check(restart, 2, "error: --out:", f"process {first.pid}")
        first.send_signal(signal.SIGTERM)
        _, err = first.communicate(timeout=TIMEOUT)
    finally:
        first.kill()
    assert first.returncode == 143, err
    assert err.decode().startswith("interrupted: signal 15") and len(err.splitlines()) == 1
    assert _status(out) == "interrupted" and not (out / ".lock").exists()
    rows = (out / "timeseries.csv").read_text().splitlines()
    assert all(len(r.split(",")) == len(rows[0].split(",")) for r in rows) and "\0" not in "".join(rows)


def test_a_finished_run_is_not_replaced(tiny_config, run_copy):
    before = snapshot(run_copy)
    check(cli("run", tiny_config, "--out", run_copy, "--no-progress"), 2, "error: --out:",
          "already holds a run (completed)")
    assert snapshot(run_copy) == before


@pytest.mark.slow
def test_overwrite_replaces_only_once_set_up(tiny_config, run_copy):
    """A failing --overwrite (here at the mesh, on rank 0) leaves the old run; a working one replaces it."""
    before = snapshot(run_copy)
    failed = cli("run", tiny_config, "--out", run_copy, "--overwrite", "--no-progress",
                 COSSERAT_FSI_FAILPOINT="mesh@0:enospc")
    check(failed, 2, "error: output: cannot write (No space left on device)")
    assert snapshot(run_copy) == before
    done = cli("run", tiny_config, "--out", run_copy, "--overwrite", "--no-progress", "--set", "time.t_end=0.1")
    assert done.returncode == 0, done
    assert _status(run_copy) == "completed"  # the new run's checkpoint (its last step), not the old one's (3)
    assert json.loads((run_copy / "checkpoint" / "meta.json").read_text())["step"] == 2
    assert len((run_copy / "timeseries.csv").read_text().splitlines()) == 3


@pytest.mark.slow
def test_stale_lock_is_taken_over_with_a_warning(tiny_config, tmp_path):
    out = tmp_path / "run"
    out.mkdir()
    dead = subprocess.Popen(["true"])
    dead.wait()
    (out / ".lock").write_text(json.dumps({"pid": dead.pid, "host": os.uname().nodename}))
    result = cli("run", tiny_config, "--out", out, "--no-progress")
    assert result.returncode == 0, result
    assert f"took over the lock of process {dead.pid}" in result.stderr and len(result.stderr.splitlines()) <= 3
    assert not (out / ".lock").exists() and _status(out) == "completed"


def test_a_live_lock_names_its_pid(tiny_config, tmp_path):
    out = tmp_path / "run"
    out.mkdir()
    with open(out / ".lock", "w") as f:
        f.write(json.dumps({"pid": os.getpid(), "host": os.uname().nodename}))
        f.flush()
        fcntl.flock(f, fcntl.LOCK_EX)
        before = snapshot(out)
        check(cli("run", tiny_config, "--out", out), 2, "error: --out:", f"in use by process {os.getpid()}")
        assert snapshot(out) == before


@pytest.mark.parametrize("name", ["timeseries.csv", "fields.h5", "summary.json", "checkpoint"])
def test_output_name_taken(tiny_config, tmp_path, name):
    out = tmp_path / "run"
    (out / name).mkdir(parents=True) if name != "checkpoint" else None
    if name == "checkpoint":
        out.mkdir()
        (out / name).write_text("a file where the checkpoint folder goes")
    before = snapshot(out)
    for extra in ([], ["--overwrite"]):
        check(cli("run", tiny_config, "--out", out, *extra), 2, "error: --out:", str(out / name))
    assert snapshot(out) == before


def test_out_is_a_file(tiny_config, tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    check(cli("run", tiny_config, "--out", blocker), 2, "error: --out:", "is not a folder")
    check(cli("run", tiny_config, "--out", blocker / "sub"), 2, "error: --out: cannot write to")
    assert blocker.read_text() == "not a folder"


@pytest.mark.parametrize("failpoint, expected", [
    ("timeseries.write@0:enospc:2", "timeseries.csv: cannot write (No space left on device)"),
    ("fields.write@0:enospc:3", "fields.h5: cannot write (No space left on device)"),
    ("checkpoint.rank@0:enospc", "rank0000.npz: cannot write (No space left on device)"),
], ids=["rows", "fields", "checkpoint"])
@pytest.mark.slow
def test_disk_fills_mid_run(tiny_config, tmp_path, failpoint, expected):
    """Exit 2 naming the file; summary.json (complete, not 0 bytes) says failed; the rows before are kept."""
    out = tmp_path / "run"
    result = cli("run", tiny_config, "--out", out, "--no-progress", COSSERAT_FSI_FAILPOINT=failpoint)
    check(result, 2, "error: ", expected)
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "failed" and "No space left" in summary["message"]
    rows = (out / "timeseries.csv").read_text().splitlines()
    assert rows[0].startswith("t,") and len(rows) >= 2 and not (out / "checkpoint.tmp").exists()
    assert not (out / ".lock").exists()


@pytest.mark.slow
def test_summary_that_cannot_be_written_leaves_no_partial_file(tiny_config, tmp_path):
    out = tmp_path / "run"
    result = cli("run", tiny_config, "--out", out, "--no-progress", COSSERAT_FSI_FAILPOINT="summary@0:enospc")
    check(result, 2, "error: output: cannot write")
    assert not (out / "summary.json").exists() and not list(out.glob(".summary.json*"))


def test_internal_error_is_one_line_with_the_traceback_in_run_log(tiny_config, tmp_path):
    out = tmp_path / "run"
    result = cli("run", tiny_config, "--out", out, "--no-progress", COSSERAT_FSI_FAILPOINT="fields.open@0")
    line = check(result, 1, "internal error: RuntimeError: injected fault at fields.open (traceback in ")
    assert line.endswith(f"{out / 'run.log'})")
    assert "Traceback (most recent call last)" in (out / "run.log").read_text()
    assert _status(out) == "failed"


def test_internal_error_before_the_folder_is_owned_keeps_the_folder(tiny_config, run_copy):
    before = snapshot(run_copy)
    result = cli("run", tiny_config, "--out", run_copy, "--overwrite", COSSERAT_FSI_FAILPOINT="commit@0")
    line = check(result, 1, "internal error: RuntimeError: injected fault at commit (traceback in ")
    assert "Traceback" in Path(line.rsplit("(traceback in ", 1)[1][:-1]).read_text()
    assert snapshot(run_copy) == before


@pytest.mark.parametrize("kind, code", [("sigterm", 143), ("sigint", 130)])
@pytest.mark.parametrize("step", ["lock", "mesh", "commit"])
def test_signal_at_start_up(tiny_config, tmp_path, kind, code, step):
    out = tmp_path / "run"
    result = cli("run", tiny_config, "--out", out, "--no-progress", COSSERAT_FSI_FAILPOINT=f"{step}@0:{kind}")
    check(result, code, "interrupted: ")
    assert not (out / ".lock").exists()


def _children(pid: int) -> list[int]:
    try:
        text = Path(f"/proc/{pid}/task/{pid}/children").read_text()
    except OSError:
        return []
    return [int(c) for c in text.split()]


@pytest.mark.parametrize("how, code", [("SIGTERM", 143), ("SIGINT", 130)])
def test_signal_during_meshing(repo_root, tmp_path, how, code):
    """A signal while gmsh meshes (a level-5 Turek-Hron mesh takes a while): one line, 130/143, the child
    is gone and the cache holds no partial file."""
    cache = tmp_path / "cache"
    proc = subprocess.Popen([sys.executable, "-m", "cosserat_fsi", "mesh",
                             str(repo_root / "configs/turek_hron_fsi3.yaml"), "--set", "geometry.level=5"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            env=env(COSSERAT_FSI_MESH_CACHE=cache), start_new_session=True)
    try:
        assert _wait_for(lambda: _children(proc.pid), 60), "gmsh never started"
        time.sleep(0.5)
        child = _children(proc.pid)[0]
        if how == "SIGINT":  # Ctrl-C reaches the whole foreground process group
            os.killpg(proc.pid, signal.SIGINT)
        else:
            proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=30)
    finally:
        proc.kill()
    err = err.decode()
    assert proc.returncode == code and err.startswith("interrupted: ") and len(err.splitlines()) == 1, err
    assert not Path(f"/proc/{child}").exists() or "zombie" in Path(f"/proc/{child}/status").read_text()
    assert [p.name for p in cache.iterdir()] == []


def test_stale_mesh_temporaries_are_cleaned(repo_root, tmp_path):
    cache = tmp_path / "cache"
    cache.mkdir()
    dead = subprocess.Popen(["true"])
    dead.wait()
    stale = cache / f".square-L0-0123456789.{dead.pid}.tmp.msh"
    stale.write_text("partial")
    config = tmp_path / "cavity.yaml"
    config.write_text("geometry: {name: square, level: 0}\nfluid: {rho: 1, mu: 0.01}\n"
                      "time: {scheme: characteristics1, dt: 0.1, t_end: 1}\n")
    result = cli("mesh", config, COSSERAT_FSI_MESH_CACHE=cache)
    assert result.returncode == 0, result
    assert not stale.exists() and len(list(cache.glob("*.msh"))) == 1


@pytest.mark.parametrize("kind, expected", [("error", "RuntimeError: injected fault at gmsh"),
                                            ("abort", "killed by signal 6")])
def test_gmsh_that_fails_or_dies(tmp_path, kind, expected):
    cache = tmp_path / "cache"
    config = tmp_path / "cavity.yaml"
    config.write_text("geometry: {name: square, level: 1}\nfluid: {rho: 1, mu: 0.01}\n"
                      "time: {scheme: characteristics1, dt: 0.1, t_end: 1}\n")
    result = cli("mesh", config, COSSERAT_FSI_MESH_CACHE=cache, COSSERAT_FSI_FAILPOINT=f"gmsh@0:{kind}")
    check(result, 2, "error: geometry: gmsh could not mesh square level 1", expected)
    assert not cache.exists() or [p.name for p in cache.iterdir()] == []


@pytest.mark.parametrize("variable", ["COSSERAT_FSI_MESH_CACHE", "COSSERAT_FSI_JIT_CACHE"])
def test_unwritable_cache_named_by_its_variable(tiny_config, tmp_path, variable):
    blocker = tmp_path / "file"
    blocker.write_text("")
    out = tmp_path / "run"
    result = cli("run", tiny_config, "--out", out, **{variable: blocker / "cache"})
    check(result, 2, f"error: {variable}: cannot write to {blocker / 'cache'}")
    assert not out.exists()


def test_unwritable_home_falls_back(tmp_path):
    """HOME and XDG_CACHE_HOME unusable: the mesh cache falls back to the temporary directory."""
    config = tmp_path / "cavity.yaml"
    config.write_text("geometry: {name: square, level: 0}\nfluid: {rho: 1, mu: 0.01}\n"
                      "time: {scheme: characteristics1, dt: 0.1, t_end: 1}\n")
    blocker = tmp_path / "file"
    blocker.write_text("")
    result = cli("mesh", config, HOME=blocker / "home", XDG_CACHE_HOME=blocker / "cache",
                 COSSERAT_FSI_MESH_CACHE="", TMPDIR=tmp_path)
    assert result.returncode == 0 and "Traceback" not in result.stderr, result
    assert result.stdout.strip().split(":")[0].endswith(".msh")


@pytest.mark.slow
def test_a_reader_holding_fields_h5_does_not_stop_an_overwrite(tiny_config, run_copy):
    """ParaView/plot holding the old fields.h5 keeps its copy; --overwrite writes a new file."""
    with h5py.File(run_copy / "fields.h5", "r") as held:
        old_steps = len(held["mesh/geometry"])
        result = cli("run", tiny_config, "--out", run_copy, "--overwrite", "--no-progress",
                     "--set", "time.t_end=0.05")
        assert result.returncode == 0, result
        assert len(held["mesh/geometry"]) == old_steps  # the reader's file is intact
    with h5py.File(run_copy / "fields.h5", "r") as new:
        assert len(new["mesh/geometry"]) == 2
