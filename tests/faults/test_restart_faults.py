"""Restarts check before they touch: a damaged, foreign or in-use checkpoint folder is a one-line exit 2
naming the file, and every byte of the folder stays as it was; field steps written earlier are kept
whatever ``output.fields`` says now."""

from __future__ import annotations

import fcntl
import json
import re
import shutil
import zipfile

import h5py
import numpy as np
import pytest

from faultlib import check, cli, snapshot


def _meta(folder, **changes):
    path = folder / "checkpoint" / "meta.json"
    meta = json.loads(path.read_text())
    meta.update(changes)
    path.write_text(json.dumps(meta))


def _npz(folder, **arrays):
    path = folder / "checkpoint" / "rank0000.npz"
    with np.load(path) as data:
        content = {k: data[k] for k in data.files}
    content.update(arrays)
    np.savez(path, **content)


DAMAGE = {  # what is done to the copy -> what the message must contain
    "meta_not_json": (lambda f: (f / "checkpoint/meta.json").write_text("{not json"), "meta.json is not a checkpoint"),
    "meta_binary": (lambda f: (f / "checkpoint/meta.json").write_bytes(b"\x00\xff" * 50), "binary data"),
    "meta_a_list": (lambda f: (f / "checkpoint/meta.json").write_text("[1, 2]"), "is not a cosserat-fsi checkpoint"),
    "meta_ranks_text": (lambda f: _meta(f, ranks="two"), "has a bad 'ranks'"),
    "meta_ranks_huge": (lambda f: _meta(f, ranks=10**9), "has a bad 'ranks'"),
    "meta_step_negative": (lambda f: _meta(f, step=-1, rows=-1), "has a bad 'step'"),
    "meta_t_nan": (lambda f: (f / "checkpoint/meta.json").write_text(re.sub(
        r'"t": [0-9.e+-]+', '"t": NaN', (f / "checkpoint/meta.json").read_text())), "has a bad 't'"),
    "meta_rows_mismatch": (lambda f: _meta(f, rows=1), "has 1 rows for step 3"),
    "meta_format": (lambda f: _meta(f, format=99), "is not a cosserat-fsi checkpoint"),
    "no_checkpoint": (lambda f: shutil.rmtree(f / "checkpoint"), "has no checkpoint"),
    "rank_file_missing": (lambda f: (f / "checkpoint/rank0000.npz").unlink(), "cannot read"),
    "rank_file_truncated": (lambda f: (f / "checkpoint/rank0000.npz").write_bytes(
        (f / "checkpoint/rank0000.npz").read_bytes()[:300]), "cannot read"),
    "rank_file_foreign_zip": (lambda f: zipfile.ZipFile(f / "checkpoint/rank0000.npz", "w").writestr("x.txt", "hi"),
                              "does not match the other rank files"),
    "rank_file_nan": (lambda f: _npz(f, **{"t": np.array(np.nan)}), "is not finite numbers"),
    "rank_file_other_step": (lambda f: _npz(f, step_count=np.array(7)), "is of another step"),
    "timeseries_missing": (lambda f: (f / "timeseries.csv").unlink(), "timeseries.csv is missing"),
    "timeseries_short": (lambda f: (f / "timeseries.csv").write_text(
        "".join((f / "timeseries.csv").read_text().splitlines(keepends=True)[:2])),
        "has 1 rows, the checkpoint needs 3"),
    "timeseries_damaged_row": (lambda f: (f / "timeseries.csv").write_text(
        (f / "timeseries.csv").read_text().replace("e-", "x-", 1)), "line 2 is not a row of"),
    "timeseries_foreign": (lambda f: (f / "timeseries.csv").write_text("a,b\n1,2\n"),
                           "is not a cosserat-fsi time series"),
    "timeseries_other_columns": (lambda f: (f / "timeseries.csv").write_text(
        (f / "timeseries.csv").read_text().replace("drag", "dragg", 1)), "has other columns"),
    "xdmf_missing": (lambda f: (f / "fields.xdmf").unlink(), "fields.xdmf: file not found"),
    "xdmf_damaged": (lambda f: (f / "fields.xdmf").write_text("<Xdmf><Time Value="), "not a complete XDMF file"),
    "h5_garbage": (lambda f: (f / "fields.h5").write_bytes(b"\x89HDF\r\n" + bytes(200)), "fields.h5 cannot be read"),
    "h5_foreign": (lambda f: h5py.File(f / "fields.h5", "w").create_dataset("x", data=[1]),
                   "is not the fields file of a cosserat-fsi run"),
}


@pytest.mark.parametrize("damage, expected", DAMAGE.values(), ids=DAMAGE)
def test_damaged_restart_is_refused_and_touches_nothing(tiny_config, run_copy, damage, expected):
    damage(run_copy)
    before = snapshot(run_copy)
    result = cli("run", tiny_config, "--restart", run_copy, "--no-progress", "--set", "time.t_end=0.25")
    check(result, 2, "error: ", expected)
    assert snapshot(run_copy) == before


def test_t_end_before_the_checkpoint(tiny_config, run_copy):
    before = snapshot(run_copy)
    result = cli("run", tiny_config, "--restart", run_copy, "--set", "time.t_end=0.05")
    check(result, 2, "error: time.t_end: 0.05 is before the checkpoint's time 0.1")
    assert snapshot(run_copy) == before


def test_foreign_scene(tiny_config, run_copy):
    before = snapshot(run_copy)
    result = cli("run", tiny_config, "--restart", run_copy, "--set", "fluid.mu=0.002")
    check(result, 2, "error: --restart: the checkpoint is from another scene")
    assert snapshot(run_copy) == before


def test_restart_of_a_folder_in_use(tiny_config, run_copy):
    """A run (here: this test, holding the lock) writes there: refused naming its PID."""
    import os

    with open(run_copy / ".lock", "w") as f:
        f.write(json.dumps({"pid": os.getpid(), "host": os.uname().nodename}))
        f.flush()
        fcntl.flock(f, fcntl.LOCK_EX)
        before = snapshot(run_copy)
        check(cli("run", tiny_config, "--restart", run_copy), 2, "error: --out:", f"process {os.getpid()}")
        assert snapshot(run_copy) == before


def test_restart_while_a_reader_holds_fields_h5(tiny_config, run_copy):
    """ParaView or plot has fields.h5 open (HDF5's lock): refused naming the file, nothing touched."""
    with open(run_copy / "fields.h5", "rb") as f:
        fcntl.flock(f, fcntl.LOCK_SH)  # what HDF5 takes for a reader
        before = snapshot(run_copy)
        result = cli("run", tiny_config, "--restart", run_copy, "--set", "time.t_end=0.25")
        check(result, 2, "error: --restart:", "fields.h5 is open in another program")
        assert snapshot(run_copy) == before


def test_restart_of_a_file(tiny_config, run_copy):
    check(cli("run", tiny_config, "--restart", run_copy / "timeseries.csv"), 2, "error: --restart:", "is not a folder")


@pytest.mark.slow
def test_field_steps_are_kept_across_restarts_with_fields_off(tiny_config, run_copy):
    """fields on (steps 0..3), restart to 0.25 with fields off, then to 0.35 with fields on: the steps
    written first are still there, byte for byte, and the new ones follow."""
    with h5py.File(run_copy / "fields.h5", "r") as f:
        first = {k: f[f"mesh/geometry/{k}"][()] for k in sorted(f["mesh/geometry"])}
    times_before = (run_copy / "fields.xdmf").read_text().count("<Time ")
    off = cli("run", tiny_config, "--restart", run_copy, "--no-progress", "--set", "time.t_end=0.25",
              "--set", "output.fields=false", "--set", "output.checkpoint_every=1")
    assert off.returncode == 0, off
    assert (run_copy / "fields.xdmf").read_text().count("<Time ") == times_before
    on = cli("run", tiny_config, "--restart", run_copy, "--no-progress", "--set", "time.t_end=0.35")
    assert on.returncode == 0, on
    with h5py.File(run_copy / "fields.h5", "r") as f:
        names = sorted(f["mesh/geometry"])
        assert len(names) > len(first)
        for k, data in first.items():
            if int(k) < 3:  # the steps up to the checkpoint of the first run (step 2) are kept
                assert np.array_equal(f[f"mesh/geometry/{k}"][()], data)
    assert len((run_copy / "timeseries.csv").read_text().splitlines()) == 1 + 7
