"""The fault suite (``pytest -m faults``, docs/reliability.md): every case misuses the program and checks the
contract: the exit code, at most 3 lines on stderr, no traceback, no hang (a timeout on every
subprocess), and every file that was there before is byte for byte what it was.

Cheap by design: most cases fail before any mesh or solve; the few that need a run copy one tiny finished
run (Schäfer-Turek level 0, 3 steps) built once per session. Subprocesses inherit PYTHONPATH, so the
worktree's package is the one run. Helpers: faultlib.py.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from faultlib import HERE, TINY, cli

def pytest_collection_modifyitems(items):
    for item in items:
        if HERE in Path(str(item.fspath)).parents:
            item.add_marker(pytest.mark.faults)


@pytest.fixture(scope="session")
def tiny_config(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("config") / "tiny.yaml"
    path.write_text(TINY)
    return path


@pytest.fixture(scope="session")
def finished(tmp_path_factory, tiny_config) -> Path:
    """A finished tiny run (built once per session; copy it before changing anything)."""
    out = tmp_path_factory.mktemp("finished") / "run"
    result = cli("run", tiny_config, "--out", out, "--no-progress")
    assert result.returncode == 0, result
    return out


@pytest.fixture
def run_copy(finished, tmp_path) -> Path:
    """A private copy of the finished tiny run."""
    folder = tmp_path / "run"
    shutil.copytree(finished, folder)
    return folder


@pytest.fixture(scope="session")
def mpi_launcher(mpirun) -> list[str]:
    """``mpirun -n 2`` of this interpreter's MPI (tests/conftest.py's ``mpirun``), quiet: OpenMPI's ``-q``
    drops the launcher's banner on a non-zero exit, which is not the program's output."""
    from mpi4py import MPI

    prefix = list(mpirun.prefix)
    if "Open MPI" in MPI.Get_library_version():
        prefix.append("-q")
    return [*prefix, "-n", "2"]


@pytest.fixture(scope="session")
def benchmark_run(tmp_path_factory):
    """The tiny scene naming the Schäfer–Turek 2D-1 benchmark, run once: a study's
    observables are columns of a benchmark's table."""
    config = tmp_path_factory.mktemp("bench") / "tiny.yaml"
    config.write_text(TINY + "benchmark: schaefer_turek_2d1\n")
    out = config.parent / "run"
    result = cli("run", config, "--out", out, "--no-progress")
    assert result.returncode == 0, result
    return config, out
