"""Helpers of the fault suite (see conftest.py): running the CLI with a timeout, the contract check,
byte snapshots of folders."""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

from inprocess import main_in_process, own_process, under_mpi

HERE = Path(__file__).resolve().parent
REPO = HERE.parents[1]
TIMEOUT = 120  # s, any subprocess (a hang fails the case)
MPI_TIMEOUT = 30  # s, a run under 2 ranks with a fault must end within this

TINY = """\
geometry: {name: schaefer_turek, level: 0}
fluid: {rho: 1.0, mu: 0.001}
inflow: {u_mean: 1.0, ramp_time: 0.2}
time: {scheme: characteristics1, dt: 0.05, t_end: 0.15}
output: {every: 1, checkpoint_every: 2, progress: false}
"""
"""3 steps, checkpoints at steps 2 and 3 (the last step's is the one kept), every step's fields: the run every
folder/restart case starts from."""


def env(**extra) -> dict:
    """The environment of a subprocess: this package first, one BLAS thread, no MPI launcher variables."""
    drop = ("OMPI_COMM_WORLD", "OMPI_MCA_ess", "OMPI_MCA_orte", "PMIX_", "PMI_", "HYDRA_", "COSSERAT_FSI_FAILPOINT")
    out = {k: v for k, v in os.environ.items() if not k.startswith(drop)}
    out.update(PYTHONPATH=str(REPO) + os.pathsep + out.get("PYTHONPATH", ""), OPENBLAS_NUM_THREADS="1",
               OMP_NUM_THREADS="1", MPLBACKEND="Agg", OMPI_ALLOW_RUN_AS_ROOT="1",
               OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1")
    out.update({k: str(v) for k, v in extra.items()})
    return out


class Result:
    def __init__(self, returncode, stdout, stderr, seconds):
        self.returncode, self.stdout, self.stderr, self.seconds = returncode, stdout, stderr, seconds

    def __repr__(self):
        return (f"exit {self.returncode} after {self.seconds:.1f} s\nstderr:\n{self.stderr}\n"
                f"stdout:\n{self.stdout[-2000:]}")


def cli(*args, timeout: float = TIMEOUT, launcher=(), cwd=None, subprocess_only=False, **environ) -> Result:
    """``python -m cosserat_fsi ARGS`` (bytes or str), with a timeout: a hang fails the case. In this process
    (``cli.main``, the same code after the interpreter's start) unless the case needs a process of its own: a
    launcher, a working folder, environment variables, a signal or a kill from outside (``subprocess_only``),
    ``plot`` (inprocess.own_process), or a pytest itself under MPI (the case is a serial run)."""
    if not (launcher or cwd is not None or environ or subprocess_only or under_mpi() or own_process(args)):
        return _in_process(args, timeout)
    cmd = [*launcher, sys.executable, "-m", "cosserat_fsi", *[a if isinstance(a, bytes) else str(a) for a in args]]
    start = time.monotonic()
    try:
        proc = subprocess.run(cmd, capture_output=True, timeout=timeout, env=env(**environ), cwd=cwd)
    except subprocess.TimeoutExpired as exc:
        pytest.fail(f"hang: {' '.join(map(str, cmd))} did not end within {timeout} s\n{exc.stderr!r}")
    return Result(proc.returncode, proc.stdout.decode("utf-8", "replace"),
                  proc.stderr.decode("utf-8", "replace"), time.monotonic() - start)


def _in_process(args, timeout: float) -> Result:
    code, out, err, seconds = main_in_process(args, timeout)
    if code is None:
        pytest.fail(f"hang: cosserat-fsi {' '.join(map(str, args))} did not end within {timeout} s\n{err}")
    return Result(code, out, err, seconds)


def check(result: Result, code: int, start: str | None = None, contains: str | None = None) -> str:
    """The contract of one fault: exit ``code``, at most 3 stderr lines, no traceback; the message line
    (the last stderr line) starts with ``start`` and contains ``contains``. Returns that line."""
    lines = result.stderr.splitlines()
    assert result.returncode == code, result
    assert "Traceback" not in result.stderr and "Traceback" not in result.stdout, result
    assert len(lines) <= 3, result
    line = lines[-1] if lines else ""
    if start is not None:
        assert line.startswith(start), result
    if contains is not None:
        assert contains in line, result
    return line


def snapshot(folder: Path) -> dict:
    """Every file under ``folder`` (hidden ones too) -> its bytes; folders -> None."""
    folder = Path(folder)
    if not folder.exists():
        return {}
    return {p.relative_to(folder): (p.read_bytes() if p.is_file() else None)
            for p in sorted(folder.rglob("*")) if not p.is_symlink()}




def in_process_main(capsys, tmp_path):
    """The body of the ``main`` fixtures: ``cli.main(argv)`` -> (exit code, stderr) in-process, with an
    ``out`` folder holding one file that every call checks to stay byte for byte as it was (``call.out``);
    the signal handlers are put back afterwards. Use as ``yield from in_process_main(capsys, tmp_path)``."""
    import signal

    from cosserat_fsi.app import cli as cli_module

    handlers = {s: signal.getsignal(s) for s in (signal.SIGTERM, signal.SIGINT)}
    out = tmp_path / "out"
    out.mkdir()
    (out / "keep.txt").write_text("precious")
    before = snapshot(out)

    def call(*argv):
        code = cli_module.main([str(a) for a in argv])
        err = capsys.readouterr().err
        assert snapshot(out) == before
        return code, err

    call.out = out
    yield call
    for sig, handler in handlers.items():
        signal.signal(sig, handler)
