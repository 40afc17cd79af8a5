"""Checkpoint/restart and SIGTERM: a run restarted from its checkpoint reproduces the uninterrupted run
(to 1e-10 relative, same rank count), a signal writes a checkpoint and exits 128 + signal, and a
restart from a missing, corrupt or foreign checkpoint is a one-line exit 2 that leaves the folder as it was."""

from __future__ import annotations

import json
import shutil
import signal
import subprocess
import time
from pathlib import Path

import numpy as np
import pytest
from mpi4py import MPI

from cosserat_fsi.config import validate_scene
from cosserat_fsi.io import read_timeseries
from cosserat_fsi.io.fields_check import xdmf_times
from cosserat_fsi.app.runner import run_scene

ST = {"geometry": {"name": "schaefer_turek", "level": 0}, "fluid": {"rho": 1.0, "mu": 0.001},
      "inflow": {"u_mean": 1.0, "ramp_time": 0.2},
      "time": {"dt": 0.05, "t_end": 0.6, "scheme": "characteristics2"},
      "output": {"every": 2, "checkpoint_every": 5, "progress": False}}
FSI = {"geometry": {"name": "turek_hron", "level": 0, "flag": "solid"}, "fluid": {"rho": 1000.0, "mu": 1.0},
       "solid": {"rho": 1000.0, "mu_s": 5.0e4}, "inflow": {"u_mean": 1.0, "ramp_time": 0.05},
       "time": {"scheme": "characteristics1", "dt": 0.01, "t_end": 0.16}, "solver": {"reuse_factorization": False},
       "output": {"every": 3, "checkpoint_every": 8, "progress": False}}
FSI_BDF2 = {**FSI, "time": {**FSI["time"], "scheme": "characteristics2"}}
FSI_ALE = {**FSI, "time": {**FSI["time"], "scheme": "ale_bdf2"}}
FSI_GA = {**FSI, "time": {**FSI["time"], "scheme": "generalized_alpha"}}
FSI_GA_CORRECTOR = {**FSI, "time": {**FSI_GA["time"], "corrector_passes": 1}}
# the benchmarks' compressible solid (its pressure condition, no volume correction), the shipped scheme
FSI_SVK = {**FSI_ALE, "solid": {"law": "saint_venant_kirchhoff", "rho": 1000.0, "mu_s": 5.0e5, "lambda_s": 2.0e6}}


def cut_at_checkpoint(full: Path, cut: Path, kept: Path) -> tuple[dict, list[str]]:
    """``cut``: a copy of the finished run ``full`` whose checkpoint is ``kept`` (as if killed after it); its
    meta.json and the lines of its timeseries.csv, for the caller to cut where the kill would have."""
    shutil.copytree(full, cut)
    shutil.rmtree(cut / "checkpoint")
    shutil.copytree(kept, cut / "checkpoint")
    meta = json.loads((cut / "checkpoint" / "meta.json").read_text())
    return meta, (cut / "timeseries.csv").read_text().splitlines(keepends=True)


def run_keeping_checkpoint(scene, out: Path, comm, step: int) -> Path:
    """Run ``scene`` into ``out`` and keep a copy of its checkpoint of ``step`` (a finished run's checkpoint
    is of its last step): the folder ``out.parent / "checkpoint_STEP"``."""
    import cosserat_fsi.app.runner as runner

    original, kept = runner.write_checkpoint, out.parent / f"checkpoint_{step}"

    def write_and_keep(run_dir, sim, comm, meta):
        original(run_dir, sim, comm, meta)
        if sim.step_count == step and comm.rank == 0:
            shutil.copytree(Path(run_dir) / "checkpoint", kept)

    runner.write_checkpoint = write_and_keep
    try:
        run_scene(scene, out, comm, progress=False)
    finally:
        runner.write_checkpoint = original
    return kept



def _fields(path: Path) -> dict:
    import h5py

    with h5py.File(path / "fields.h5", "r") as f:
        out = {}
        f.visititems(lambda name, obj: out.__setitem__(name, obj[:]) if hasattr(obj, "shape") else None)
    return out


@pytest.mark.mpi
@pytest.mark.parametrize("raw", [ST, FSI, FSI_BDF2, FSI_ALE, FSI_GA, FSI_GA_CORRECTOR, FSI_SVK],
                         ids=["navier_stokes_bdf2", "fsi_moving_mesh", "fsi_bdf2", "fsi_ale", "fsi_generalized_alpha",
                              "fsi_generalized_alpha_corrector", "fsi_saint_venant_kirchhoff"])
def test_restart_reproduces_the_uninterrupted_run(shared_tmp, raw):
    comm = MPI.COMM_WORLD
    scene = validate_scene(raw)
    full, cut = shared_tmp / "full", shared_tmp / "cut"
    if comm.rank == 0:
        full.mkdir()
    comm.barrier()
    n, every = round(scene.time.t_end / scene.time.dt), scene.output.checkpoint_every
    kept = run_keeping_checkpoint(scene, full, comm, every * ((n - 1) // every))  # the last one before the end
    if comm.rank == 0:  # a copy "killed" after the last checkpoint: later rows and field steps half-written
        meta, lines = cut_at_checkpoint(full, cut, kept)
        (cut / "timeseries.csv").write_text("".join(lines[: meta["rows"] + 2]) + lines[meta["rows"] + 2][:7])
        assert 0 < meta["step"] < len(lines) - 1
    comm.barrier()
    run_scene(scene, cut, comm, progress=False, restart=True)
    if comm.rank == 0:
        a, b = read_timeseries(full / "timeseries.csv"), read_timeseries(cut / "timeseries.csv")
        assert list(a) == list(b) and len(a["t"]) == len(b["t"]) == round(scene.time.t_end / scene.time.dt)
        for key in a:
            scale = max(np.abs(a[key]).max(), 1e-30)
            assert np.abs(a[key] - b[key]).max() <= 1e-10 * scale, key
        fa, fb = _fields(full), _fields(cut)
        assert sorted(fa) == sorted(fb)
        for key in fa:
            assert np.allclose(fa[key], fb[key], rtol=1e-10, atol=1e-12 * max(np.abs(fa[key]).max(), 1)), key
        assert json.loads((cut / "summary.json").read_text())["status"] == "completed"


def _config(tmp_path, raw=ST, **time):
    import yaml

    raw = {**raw, "time": {**raw["time"], **time}}
    path = tmp_path / "scene.yaml"
    path.write_text(yaml.safe_dump(raw))
    return path


@pytest.mark.slow
def test_sigterm_writes_a_checkpoint_and_the_restart_completes(run_cli, tmp_path):
    config = _config(tmp_path, t_end=40.0)  # 800 steps: the signal arrives mid-run
    out = tmp_path / "run"
    proc = subprocess.Popen(run_cli.command("run", config, "--out", out, "--no-progress"), env=run_cli.env,
                            stderr=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    csv = out / "timeseries.csv"
    deadline = time.time() + 120
    while time.time() < deadline and (not csv.exists() or csv.read_text().count("\n") < 12):
        time.sleep(0.2)
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 128 + signal.SIGTERM, err
    lines = [x for x in err.splitlines() if x.startswith("interrupted:")]
    assert len(lines) == 1 and "--restart" in lines[0] and "Traceback" not in err
    meta = json.loads((out / "checkpoint" / "meta.json").read_text())
    rows = read_timeseries(csv)["t"]
    assert meta["step"] == len(rows) >= 11  # the checkpoint is of the last step written
    assert json.loads((out / "summary.json").read_text())["status"] == "interrupted"
    # resume with a shorter end time (allowed to change) and compare with an uninterrupted run
    t_end = 0.05 * (meta["step"] + 6)
    done = run_cli("run", _config(tmp_path, t_end=t_end), "--restart", out, "--no-progress")
    assert done.returncode == 0, done.stderr
    ref = tmp_path / "ref"
    assert run_cli("run", _config(tmp_path, t_end=t_end), "--out", ref, "--no-progress").returncode == 0
    a, b = read_timeseries(ref / "timeseries.csv"), read_timeseries(csv)
    assert len(a["t"]) == len(b["t"]) == meta["step"] + 6
    assert np.abs(a["drag"] - b["drag"]).max() <= 1e-10 * np.abs(a["drag"]).max()


@pytest.fixture(scope="module")
def finished_run(tmp_path_factory, run_cli):
    tmp = tmp_path_factory.mktemp("finished")
    out = tmp / "run"
    assert run_cli("run", _config(tmp, t_end=0.3), "--out", out, "--no-progress",
                "--set", "output.checkpoint_every=2").returncode == 0
    return tmp, out


def _snapshot(folder: Path) -> dict:
    return {p.relative_to(folder): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


@pytest.mark.parametrize("case, expected", [
    ("no_checkpoint", "error: --restart: "),
    ("not_a_folder", "error: --restart: "),
    ("corrupt_meta", "error: --restart: "),
    ("foreign_scene", "error: --restart: the checkpoint is from another scene"),
    ("other_out", "error: --out: a restart continues in its own folder"),
    ("missing_rank_file", "error: --restart: cannot read"),
    ("timeseries_gone", "error: --restart: "),
    ("fields_truncated", "error: --restart: "),
])
def test_bad_restart_exits_2_and_touches_nothing(run_cli, finished_run, tmp_path, case, expected):
    tmp, run = finished_run
    folder = tmp_path / "copy"
    shutil.copytree(run, folder)
    config, extra = _config(tmp_path, t_end=0.3), []
    if case == "no_checkpoint":
        shutil.rmtree(folder / "checkpoint")
    elif case == "not_a_folder":
        folder = folder / "timeseries.csv"
    elif case == "corrupt_meta":
        (folder / "checkpoint" / "meta.json").write_text("{not json")
    elif case == "foreign_scene":
        extra = ["--set", "fluid.mu=0.002"]
    elif case == "other_out":
        extra = ["--out", tmp_path / "elsewhere"]
    elif case == "missing_rank_file":
        (folder / "checkpoint" / "rank0000.npz").unlink()
    elif case == "timeseries_gone":
        (folder / "timeseries.csv").unlink()
    elif case == "fields_truncated":
        xdmf = folder / "fields.xdmf"
        xdmf.write_text(xdmf.read_text()[: xdmf.stat().st_size // 2])
    before = _snapshot(folder) if folder.is_dir() else None
    result = run_cli("run", config, "--restart", folder, "--no-progress", *extra)
    assert result.returncode == 2, result.stderr
    assert len(result.stderr.splitlines()) == 1 and "Traceback" not in result.stderr, result.stderr
    assert result.stderr.startswith(expected), result.stderr
    if before is not None:
        assert _snapshot(folder) == before
    assert not (tmp_path / "elsewhere").exists()


@pytest.mark.parametrize("delay", [0.0, 0.37, 0.81])
def test_kill_9_leaves_readable_output(run_cli, tmp_path, repo_root, delay):
    """SIGKILL at an arbitrary moment: timeseries.csv parses, and every step fields.xdmf lists is in
    fields.h5 and readable (h5 flushed before the .xdmf is atomically replaced): at worst the step being
    written is missing."""
    import re

    import h5py

    out = tmp_path / "run"
    proc = subprocess.Popen(run_cli.command("run", _config(tmp_path, t_end=20.0), "--out", out, "--no-progress",
                                            "--set", "output.every=1"), env=run_cli.env,
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    csv = out / "timeseries.csv"
    deadline = time.time() + 120
    while time.time() < deadline and (not csv.exists() or csv.read_text().count("\n") < 4):
        time.sleep(0.05)
    time.sleep(delay)
    proc.kill()
    proc.wait(timeout=60)
    rows = read_timeseries(csv)["t"]
    times = [float(t) for t in re.findall(r'<Time Value="([^"]+)"', (out / "fields.xdmf").read_text())]
    assert len(rows) >= 3 and len(times) >= len(rows) - 1
    np.testing.assert_allclose(times, 0.05 * np.arange(len(times)), atol=1e-12)
    with h5py.File(out / "fields.h5", "r") as f:
        for k in range(len(times)):
            assert np.isfinite(f[f"mesh/geometry/{k:06d}"][:]).all()
            assert np.isfinite(f[f"point/velocity/{k:06d}"][:]).all()


def test_a_finished_run_is_extended_from_its_last_step(run_cli, tmp_path):
    """A finished run ends with a checkpoint of its last step: ``--restart`` with a later ``time.t_end``
    computes only the new steps (2 of 5) and gives the 5-step run's time series to 1e-12."""
    short, full = tmp_path / "short", tmp_path / "full"
    config = _config(tmp_path, t_end=0.15)  # 3 steps
    assert run_cli("run", config, "--out", short, "--no-progress").returncode == 0
    meta = json.loads((short / "checkpoint" / "meta.json").read_text())
    assert meta["step"] == meta["rows"] == 3
    again = run_cli("run", config, "--restart", short, "--no-progress", "--set", "time.t_end=0.25")
    assert again.returncode == 0, again.stderr
    assert "restart from the checkpoint of step 3" in (short / "run.log").read_text()
    summary = json.loads((short / "summary.json").read_text())
    assert summary["time"]["steps"] == 5 and summary["status"] == "completed"
    assert run_cli("run", _config(tmp_path, t_end=0.25), "--out", full, "--no-progress").returncode == 0
    a, b = read_timeseries(full / "timeseries.csv"), read_timeseries(short / "timeseries.csv")
    assert list(a) == list(b) and len(a["t"]) == len(b["t"]) == 5
    for key in a:
        assert np.abs(a[key] - b[key]).max() <= 1e-12 * max(np.abs(a[key]).max(), 1.0), key
    # the continued fields.xdmf lists the same times as plain numbers (what ParaView's reader parses)
    assert (short / "fields.xdmf").read_text().count("<Time ") == (full / "fields.xdmf").read_text().count("<Time ")
    np.testing.assert_array_equal(xdmf_times(short / "fields.xdmf"), xdmf_times(full / "fields.xdmf"))
