"""Readers check what they read: ``plot`` and ``study`` answer a damaged, foreign or missing file with a
one-line exit 2 naming it (and touch nothing); ``plot`` on a run still being written plots what is flushed."""

from __future__ import annotations

import json
import shutil

import h5py
import numpy as np
import pytest

from faultlib import check, cli, snapshot


def _truncate(path, size):
    path.write_bytes(path.read_bytes()[:size])


PLOT_DAMAGE = {
    "timeseries_binary": (lambda f: (f / "timeseries.csv").write_bytes(bytes(range(256))), "timeseries.csv is not"),
    "timeseries_nul_rows": (lambda f: (f / "timeseries.csv").write_bytes(
        (f / "timeseries.csv").read_bytes()[:60] + b"\0" * 200 + b"\n"), "timeseries.csv: line"),
    "timeseries_no_header": (lambda f: (f / "timeseries.csv").write_text("1,2,3\n"), "timeseries.csv is not"),
    "timeseries_empty": (lambda f: (f / "timeseries.csv").write_text(""), "timeseries.csv is not"),
    "timeseries_a_folder": (lambda f: ((f / "timeseries.csv").unlink(), (f / "timeseries.csv").mkdir()),
                            "timeseries.csv is a folder"),
    "h5_garbage": (lambda f: (f / "fields.h5").write_bytes(b"garbage" * 100), "fields.h5 cannot be read"),
    "h5_truncated": (lambda f: _truncate(f / "fields.h5", 3000), "fields.h5"),
    "h5_foreign": (lambda f: h5py.File(f / "fields.h5", "w").create_dataset("mesh/topology", data=[1.5]),
                   "is not the fields file of a cosserat-fsi run"),
    "h5_bad_topology": (lambda f: _set(f, "mesh/topology", np.full((4, 3), 10**6)), "the mesh is damaged"),
    "h5_velocity_wrong_shape": (lambda f: _set(f, "point/velocity/000003", np.zeros((5, 3))), "wrong shape"),
    "h5_missing": (lambda f: (f / "fields.h5").unlink(), "fields.h5 is missing"),
    "xdmf_missing": (lambda f: (f / "fields.xdmf").unlink(), "fields.xdmf is missing"),
    "xdmf_damaged": (lambda f: (f / "fields.xdmf").write_text("<Xdmf>"), "not a complete XDMF file"),
    "xdmf_bad_times": (lambda f: (f / "fields.xdmf").write_text(
        (f / "fields.xdmf").read_text().replace('Time Value="0.1"', 'Time Value="nan"')), "not increasing numbers"),
    "xdmf_more_steps_than_h5": (lambda f: _delete(f, "mesh/geometry/000003"), "fields.h5 has 3 steps, 4 are needed"),
}


def _delete(folder, key):
    with h5py.File(folder / "fields.h5", "a") as f:
        del f[key]


def _set(folder, key, data):
    with h5py.File(folder / "fields.h5", "a") as f:
        del f[key]
        f.create_dataset(key, data=data)


@pytest.mark.parametrize("damage, expected", PLOT_DAMAGE.values(), ids=PLOT_DAMAGE)
def test_plot_of_a_damaged_run(run_copy, tmp_path, damage, expected):
    damage(run_copy)
    before = snapshot(run_copy)
    result = cli("plot", run_copy, "--out", tmp_path / "plots")
    check(result, 2, "error: ", expected)
    assert snapshot(run_copy) == before


@pytest.mark.parametrize("what, expected", [
    ("missing", "RUN_DIR: "), ("file", "is not a folder"), ("empty", "has no timeseries.csv"),
], ids=["missing", "a_file", "empty_folder"])
def test_plot_of_something_that_is_not_a_run(tmp_path, what, expected):
    target = tmp_path / "x"
    if what == "file":
        target.write_text("hello")
    elif what == "empty":
        target.mkdir()
    check(cli("plot", target), 2, "error: ", expected)


def test_plot_of_a_run_in_progress_plots_what_is_flushed(run_copy, tmp_path):
    """A half-written last row, an .h5 step not yet listed in the .xdmf, no summary.json: the listed
    steps are plotted (exit 0) and nothing in the run folder changes."""
    with open(run_copy / "timeseries.csv", "a") as f:
        f.write("2.0000000000e-01,1.23")  # the row being written
    (run_copy / "summary.json").unlink()
    with h5py.File(run_copy / "fields.h5", "a") as f:
        f.create_dataset("mesh/geometry/000004", data=np.zeros((3, 2)))  # a step being written
    before = snapshot(run_copy)
    result = cli("plot", run_copy, "--out", tmp_path / "plots")
    assert result.returncode == 0 and "Traceback" not in result.stderr, result
    names = sorted(p.name for p in (tmp_path / "plots").iterdir())
    assert "snapshot_t0.1500.png" in names and "forces.png" in names and not any(n.startswith(".") for n in names)
    assert snapshot(run_copy) == before


def test_plot_with_a_damaged_summary_plots_without_the_reference(run_copy, tmp_path):
    (run_copy / "summary.json").write_text("[1, 2")
    result = cli("plot", run_copy, "--out", tmp_path / "plots", "--time", "0.05")
    assert result.returncode == 0, result
    assert (tmp_path / "plots" / "snapshot_t0.0500.png").exists()


STUDY = "name: s\nconfig: {config}\nobservables: [c_D]\nladder: {{time.dt: [0.05]}}\n"


@pytest.mark.parametrize("make, expected", [
    (lambda t, c: t, "is a folder, not a study file"),
    (lambda t, c: _write(t / "s.yaml", bytes(range(256)) * 4), "binary data"),
    (lambda t, c: _write(t / "s.yaml", b"name: caf\xe9\n"), "not UTF-8 text"),
    (lambda t, c: _write(t / "s.yaml", STUDY.format(config=c).replace("[0.05]", "[.nan]").encode()),
     "ladder.time.dt: must be a finite number"),
    (lambda t, c: _write(t / "s.yaml", (STUDY.format(config=c) + "ranks: 100000\n").encode()), "ranks: "),
    (lambda t, c: _write(t / "s.yaml", STUDY.format(config=c).replace(
        "{time.dt: [0.05]}", "{time.dt: [" + ", ".join(["0.05"] * 40) + "], time.t_end: [" + ", ".join(
            ["0.1"] * 40) + "]}").encode()), "1,600 runs, more than 1,000"),
], ids=["a_folder", "binary", "latin1", "nan_in_ladder", "ranks_huge", "too_many_runs"])
def test_study_of_bad_input(tmp_path, tiny_config, make, expected):
    path = make(tmp_path, tiny_config)
    result = cli("study", path, "--out", tmp_path / "out")
    check(result, 2, "error: ", expected)
    assert not (tmp_path / "out" / "runs").exists()


def _write(path, data: bytes):
    path.write_bytes(data)
    return path


@pytest.mark.parametrize("summary", ["{broken", "[1, 2, 3]", '{"status": "completed", "wall_time": "x"}'],
                         ids=["not_json", "a_list", "wrong_types"])
def test_study_report_of_a_damaged_run(tmp_path, benchmark_run, summary):
    """``--report-only`` over a run folder whose summary.json is damaged: exit 2 naming it."""
    config, finished = benchmark_run
    study = _write(tmp_path / "s.yaml", STUDY.format(config=config).encode())
    run = tmp_path / "out" / "runs" / "study-s" / "dt0.05"
    shutil.copytree(finished, run)
    (run / "summary.json").write_text(summary)
    before = snapshot(run)
    result = cli("study", study, "--out", tmp_path / "out", "--report-only")
    check(result, 2, "error: ", f"{run / 'summary.json'}: not the summary of a cosserat-fsi run")
    assert snapshot(run) == before


def test_plot_of_a_run_that_has_just_started(run_copy, tmp_path):
    """fields.h5 created, fields.xdmf not yet, the folder locked by its run: the time series are plotted."""
    import fcntl
    import os

    (run_copy / "fields.xdmf").unlink()
    with open(run_copy / ".lock", "w") as lock:
        lock.write(json.dumps({"pid": os.getpid()}))
        lock.flush()
        fcntl.flock(lock, fcntl.LOCK_EX)
        result = cli("plot", run_copy, "--out", tmp_path / "plots")
    assert result.returncode == 0, result
    assert sorted(p.name for p in (tmp_path / "plots").iterdir()) == ["flow.png", "forces.png"]
