"""Shared pytest fixtures and helpers for both dolfinx stacks.

``run_cli(*args)`` (a fixture) runs ``python -m cosserat_fsi ARGS`` in a subprocess with a clean environment;
``mpirun(n)`` gives the MPI launcher matching this interpreter; ``repo_root`` and ``mpi_comm`` are what they say.

``cosserat_fsi.compat`` is imported first: on the PyPI wheel stack it imports ``dolfinx_solver``
before ``dolfinx``. Nothing heavy is imported here otherwise; mpi4py is imported lazily by the
fixtures that need it.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

def _world_size() -> int:
    """Ranks of this pytest run, from the launcher's environment (OpenMPI, MPICH), without importing MPI."""
    for key in ("OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_SIZE"):
        if os.environ.get(key, "").isdigit():
            return int(os.environ[key])
    return 1


# An MPI run a test launches (``mpirun -n 2`` from a serial pytest) shares the 2 cores with the other pytest
# worker: MPI's busy polling would spin on a core the other process needs. Yielding while idle, measured on
# tests/faults/test_mpi.py with 2 workers: 118 -> 81 s (Open MPI), 92 -> 80 s (MPICH). Not when this pytest is
# itself a rank of the MPI tier (the ranks own both cores): there MPICH's heavy yield made tests/test_fsi.py +
# test_restart.py 1.75x slower (29.6 -> 51.8 s; Open MPI's yield 28.7 -> 30.5 s). A value already set wins.
if _world_size() == 1:
    os.environ.setdefault("OMPI_MCA_mpi_yield_when_idle", "1")
    os.environ.setdefault("MPIR_CVAR_ENABLE_HEAVY_YIELD", "1")

# Modules whose absence only means "this machine has no dolfinx stack": tests that do not need it
# (config, CLI error messages) still run. Any other import error in compat is a bug and is raised.
_OPTIONAL = ("cosserat_fsi.compat", "dolfinx", "dolfinx_solver", "petsc4py", "mpi4py", "basix", "ufl", "ffcx")
try:
    import cosserat_fsi.compat  # noqa: F401
except ImportError as exc:  # ModuleNotFoundError included
    if getattr(exc, "name", None) not in _OPTIONAL:
        raise

REPO = Path(__file__).resolve().parents[1]
# Meshes are cached in the repository's meshes/ (as the Makefile does); subprocesses inherit it.
os.environ.setdefault("COSSERAT_FSI_MESH_CACHE", str(REPO / "meshes"))
# The campaign scripts (campaigns/*.py) are not installed: tests import them from the repository.
if str(REPO / "campaigns") not in sys.path:
    sys.path.insert(0, str(REPO / "campaigns"))

from inprocess import main_in_process, own_process, under_mpi  # noqa: E402 (tests/ is on the path once this file is read)


@pytest.fixture(scope="session")
def repo_root() -> Path:
    return REPO


@pytest.fixture(scope="session")
def mpi_comm():
    """``MPI.COMM_WORLD`` (skips when mpi4py is missing)."""
    try:
        from mpi4py import MPI
    except ImportError:
        pytest.skip("mpi4py not available")
    return MPI.COMM_WORLD


def _version_text(exe: str) -> str:
    try:
        out = subprocess.run([exe, "--version"], capture_output=True, text=True, timeout=30)
    except (OSError, subprocess.SubprocessError):
        return ""
    return out.stdout + out.stderr


def _find_launcher() -> tuple[list[str] | None, str]:
    """Command prefix (without ``-n N``) matching this interpreter's MPI library, or (None, why)."""
    try:
        from mpi4py import MPI
    except ImportError:
        return None, "mpi4py not available"
    lib = MPI.Get_library_version()
    here = Path(sys.executable).parent  # the venv's bin/, not resolved through the symlink
    if "Open MPI" in lib:
        candidates = [here / "mpirun", shutil.which("mpirun"), "/usr/bin/mpirun"]
        for exe in candidates:
            if exe and os.access(exe, os.X_OK) and "Open MPI" in _version_text(str(exe)):
                return [str(exe), "--allow-run-as-root", "--oversubscribe"], ""
        return None, "no OpenMPI mpirun found for " + sys.executable
    if "MPICH" in lib:
        candidates = [here / "mpiexec", shutil.which("mpiexec")]
        for exe in candidates:
            if exe and os.access(exe, os.X_OK):
                text = _version_text(str(exe))
                if "HYDRA" in text or "MPICH" in text:
                    return [str(exe)], ""
        return None, "no MPICH mpiexec found next to " + sys.executable
    return None, "unknown MPI library: " + lib.splitlines()[0]


_MPI_VARIABLES = ("OMPI_COMM_WORLD", "OMPI_MCA_ess", "OMPI_MCA_orte", "PMIX_", "PMI_", "HYDRA_")


def subprocess_env() -> dict[str, str]:
    """``os.environ`` without this process's MPI launcher variables (a child would take itself for one of
    our ranks; a nested OpenMPI ``mpirun`` exits 1 without a word), one BLAS/OpenMP thread, root allowed."""
    env = {k: v for k, v in os.environ.items() if not k.startswith(_MPI_VARIABLES)}
    env.update(OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1",
               OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1")
    return env


class _Cli:
    """``run_cli(*args, launcher=(), cwd=None, timeout=600)``: ``python -m cosserat_fsi ARGS``, output captured
    as text: in this process (tests/inprocess.py) unless under ``launcher`` (e.g. ``mpirun(2)``), in ``cwd``,
    with ``subprocess_only=True``, ``plot`` (inprocess.own_process) or from a pytest under MPI — then a
    subprocess. ``run_cli.command(*args)``
    and ``run_cli.env`` are the pieces, for a ``subprocess.Popen`` that a test signals."""

    env = property(lambda self: subprocess_env())

    @staticmethod
    def command(*args) -> list[str]:
        return [sys.executable, "-m", "cosserat_fsi", *map(str, args)]

    def __call__(self, *args, launcher=(), cwd=None, timeout: float = 600,
                 subprocess_only=False) -> subprocess.CompletedProcess:
        if not (launcher or cwd is not None or subprocess_only or under_mpi() or own_process(args)):
            code, out, err, _ = main_in_process(args, timeout)
            if code is None:
                raise subprocess.TimeoutExpired(self.command(*args), timeout, out, err)
            return subprocess.CompletedProcess(self.command(*args), code, out, err)
        return subprocess.run([*launcher, *self.command(*args)], capture_output=True, text=True, cwd=cwd,
                              env=self.env, timeout=timeout)


@pytest.fixture(scope="session")
def run_cli() -> _Cli:
    """Runs the command line in a subprocess (see ``_Cli``)."""
    return _Cli()


class _MpiRun:
    """``mpirun(n)`` returns the command prefix that starts ``n`` ranks with this interpreter's MPI.

    Start the subprocess with ``env=mpirun.env`` (or use ``mpirun.run``): once MPI is initialised in
    the pytest process (importing dolfinx does it), OpenMPI has put PMIX_*/OMPI_MCA_* variables into
    the C-level environment, which a plain ``subprocess.run`` passes on; a nested OpenMPI ``mpirun``
    then exits 1 without a word (measured). ``mpirun.env`` is built from ``os.environ``, which does not
    hold them.
    """

    def __init__(self, prefix: list[str]):
        self.prefix = prefix

    def __call__(self, n: int) -> list[str]:
        return [*self.prefix, "-n", str(int(n))]

    @property
    def env(self) -> dict[str, str]:
        return subprocess_env()

    def run(self, n: int, args: list[str], timeout: float = 600, **kwargs) -> subprocess.CompletedProcess:
        """``subprocess.run(mpirun(n) + args)`` with the right environment, text output captured."""
        kwargs.setdefault("capture_output", True)
        kwargs.setdefault("text", True)
        return subprocess.run([*self(n), *map(str, args)], env=self.env, timeout=timeout, **kwargs)


@pytest.fixture(scope="session")
def mpirun(mpi_comm) -> _MpiRun:
    """Launcher for subprocess comparisons between 1 and N ranks; skips when none is found,
    and inside a parallel pytest run (no nested mpirun)."""
    if mpi_comm.size > 1:
        pytest.skip("nested mpirun from a parallel pytest run")
    prefix, why = _find_launcher()
    if prefix is None:
        pytest.skip(why)
    return _MpiRun(prefix)


@pytest.fixture(autouse=True)
def _free_mpi_objects(request):
    """After each test, collect its meshes, functions and PETSc objects on every rank together: each holds a
    duplicated communicator, and MPICH runs out of context ids (2,048) over a long ``-m mpi`` session if
    they wait for the garbage collector's own schedule; and PETSc 3.18 keeps the objects Python collects
    until ``garbage_cleanup`` (0.45 GB a 3D FSI test, kept to the end of the session). Then give the freed
    heap back to the system (``malloc_trim``) and record the peak resident memory of this process and of its
    largest child so far (:func:`pytest_terminal_summary` prints the largest).

    On one rank what survives that collection (the imported modules, their caches, the compiled forms) is then
    frozen (``gc.freeze``): later collections, here and each Simulation's own, skip it. A full collection of a
    worker's heap cost 70 ms (155,000 objects, after one small run), 1 ms after the freeze; the collections
    were half the time of the in-process fault tests (cProfile of tests/faults/test_scene_observables.py and
    test_scene_topology.py: 16.1 of 33.7 s). Under mpirun the heap is collected fully each time (the
    communicators of the objects a cycle frees later must reach MPI on every rank)."""
    import gc

    yield
    if "cosserat_fsi.compat" in sys.modules:  # gc.collect, then PETSc's deferred objects
        from mpi4py import MPI

        sys.modules["cosserat_fsi.compat"].free_petsc_garbage(MPI.COMM_WORLD)
    else:
        gc.collect()
    if _world_size() < 2:
        gc.freeze()
    _trim_heap()
    request.node.user_properties.append(("peak_memory_gib", _peak_memory_gib()))


def _trim_heap() -> None:
    """glibc's ``malloc_trim(0)``: the pages of freed memory back to the system (nothing elsewhere)."""
    import ctypes
    import ctypes.util

    try:
        ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6").malloc_trim(0)
    except (OSError, AttributeError):
        pass


def _peak_memory_gib() -> tuple[float, float]:
    """(this process's, its largest waited-for child's) peak resident set, GiB (``getrusage``)."""
    import resource

    return tuple(resource.getrusage(who).ru_maxrss / 2**20  # KiB on Linux
                 for who in (resource.RUSAGE_SELF, resource.RUSAGE_CHILDREN))


def pytest_collection_modifyitems(items):
    """The tests marked slow first, each group in its collected order: on two xdist workers the run then
    ends on short tests, not with one worker on a long one while the other has nothing left to take. The
    ``two_ranks`` tests (serial = parallel comparisons) are skipped on one rank, where both runs are one."""
    items.sort(key=lambda item: item.get_closest_marker("slow") is None)
    if _world_size() < 2:
        skip = pytest.mark.skip(reason="serial = parallel: needs mpirun -n 2 (make test-mpi runs it)")
        for item in items:
            if item.get_closest_marker("two_ranks") is not None:
                item.add_marker(skip)


_PEAKS = {"test process": (0.0, ""), "child process": (0.0, "")}


def pytest_runtest_logreport(report):
    """Keep the largest peak memory reported by any test (from every xdist worker), and the test that first
    reached it."""
    if report.when != "teardown":
        return
    for key, value in report.user_properties:
        if key == "peak_memory_gib":
            for what, peak in zip(_PEAKS, value):
                if peak > _PEAKS[what][0]:
                    _PEAKS[what] = (peak, report.nodeid)


def pytest_terminal_summary(terminalreporter):
    """One line per kind of process: its peak resident memory and the test during which it was reached."""
    for what, (peak, nodeid) in _PEAKS.items():
        if nodeid:
            terminalreporter.write_line(f"peak memory of a {what}: {peak:.2f} GiB (reached in {nodeid})")


@pytest.fixture
def shared_tmp():
    """A temporary directory shared by all ranks of COMM_WORLD (removed after the test)."""
    import tempfile

    from mpi4py import MPI

    comm = MPI.COMM_WORLD
    path = Path(comm.bcast(tempfile.mkdtemp() if comm.rank == 0 else None, root=0))
    yield path
    comm.barrier()
    if comm.rank == 0:
        shutil.rmtree(path)
