"""One error path under MPI (``mpirun -n 2``): a fault on rank 0 or on rank 1 at each step that rank 0 does
alone (taking the folder, meshing, committing, creating and writing the files, checkpoints, the summary)
ends both ranks within 30 s with the same exit code and one message, printed once; summary.json, when
written, says ``failed``. A fault inside a collective numerical step ends both ranks through MPI_Abort."""

from __future__ import annotations

import json

import pytest

from faultlib import MPI_TIMEOUT, check, cli, snapshot

STEPS = {  # failpoint -> (kind, exit code, start of the message)
    "lock": ("error", 1, "internal error: RuntimeError: injected fault at lock"),
    "mesh": ("error", 1, "internal error: RuntimeError: injected fault at mesh"),
    "commit": ("error", 1, "internal error: RuntimeError: injected fault at commit"),
    "timeseries.open": ("enospc", 2, "error: output: cannot write (No space left on device)"),
    "fields.open": ("enospc", 2, "error: output: cannot write (No space left on device)"),
    "timeseries.write": ("enospc", 2, "error: "),
    "fields.write": ("enospc", 2, "error: "),
    "checkpoint": ("enospc", 2, "error: output: cannot write (No space left on device)"),
    "checkpoint.rank": ("enospc", 2, "error: "),
    "summary": ("error", 1, "internal error: RuntimeError: injected fault at summary"),
}


@pytest.mark.slow
@pytest.mark.parametrize("rank", [0, 1])
@pytest.mark.parametrize("step", STEPS)
def test_fault_on_one_rank_ends_both(mpi_launcher, tiny_config, tmp_path, step, rank):
    kind, code, start = STEPS[step]
    out = tmp_path / "run"
    hit = 2 if step in ("timeseries.write", "fields.write") else 1  # mid-run for the row and field writes
    result = cli("run", tiny_config, "--out", out, "--no-progress", launcher=mpi_launcher, timeout=MPI_TIMEOUT,
                 COSSERAT_FSI_FAILPOINT=f"{step}@{rank}:{kind}:{hit}")
    line = check(result, code, start)
    assert result.stderr.count(line) == 1  # one message, printed once
    if (out / "summary.json").exists():
        assert json.loads((out / "summary.json").read_text())["status"] == "failed"
    assert not (out / ".lock").exists()


@pytest.mark.slow
def test_fault_inside_a_collective_step_aborts_every_rank(mpi_launcher, tiny_config, tmp_path):
    """Rank 1 fails between two collectives of a step (rank 0 waits in the next one): MPI_Abort ends both
    with the exit code; the message names the failure once."""
    out = tmp_path / "run"
    result = cli("run", tiny_config, "--out", out, "--no-progress", launcher=mpi_launcher, timeout=MPI_TIMEOUT,
                 COSSERAT_FSI_FAILPOINT="observe@1:error:2")
    assert result.returncode == 1, result
    assert "Traceback" not in result.stderr
    ours = [x for x in result.stderr.splitlines() if x.startswith("internal error: ")]
    assert len(ours) == 1 and "injected fault at observe" in ours[0], result


@pytest.mark.slow
def test_damaged_checkpoint_under_two_ranks(mpi_launcher, tiny_config, run_copy):
    (run_copy / "checkpoint" / "rank0000.npz").write_bytes(b"PK\x03\x04 broken")
    before = snapshot(run_copy)
    result = cli("run", tiny_config, "--restart", run_copy, launcher=mpi_launcher, timeout=MPI_TIMEOUT)
    line = check(result, 2, "error: --restart: cannot read")
    assert result.stderr.count(line) == 1
    assert snapshot(run_copy) == before


@pytest.mark.slow
def test_restart_on_two_ranks_of_a_serial_run(mpi_launcher, tiny_config, run_copy):
    """Across rank counts restarts work (the checkpoint is keyed by coordinates)."""
    result = cli("run", tiny_config, "--restart", run_copy, "--no-progress", "--set", "time.t_end=0.25",
                 launcher=mpi_launcher, timeout=60)
    assert result.returncode == 0, result
    assert json.loads((run_copy / "summary.json").read_text())["status"] == "completed"
    assert len((run_copy / "timeseries.csv").read_text().splitlines()) == 1 + 5


def test_second_run_into_a_folder_holding_a_run(mpi_launcher, tiny_config, run_copy):
    before = snapshot(run_copy)
    result = cli("run", tiny_config, "--out", run_copy, launcher=mpi_launcher, timeout=MPI_TIMEOUT)
    line = check(result, 2, "error: --out:", "already holds a run")
    assert result.stderr.count(line) == 1
    assert snapshot(run_copy) == before


@pytest.mark.slow
@pytest.mark.parametrize("rank", [0, 1])
@pytest.mark.parametrize("kind, code", [("sigterm", 143), ("sigint", 130)])
def test_signal_to_one_rank_in_the_time_loop(mpi_launcher, tiny_config, tmp_path, rank, kind, code):
    """A signal that only one rank receives: both ranks stop after the step, with a checkpoint, one message
    and summary.json ``interrupted``."""
    out = tmp_path / "run"
    result = cli("run", tiny_config, "--out", out, "--no-progress", launcher=mpi_launcher, timeout=MPI_TIMEOUT,
                 COSSERAT_FSI_FAILPOINT=f"timeseries.write@{rank}:{kind}:2")
    line = check(result, code, "interrupted: signal", "checkpoint written")
    assert result.stderr.count(line) == 1
    assert json.loads((out / "summary.json").read_text())["status"] == "interrupted"
    assert (out / "checkpoint" / "meta.json").is_file() and not (out / ".lock").exists()
