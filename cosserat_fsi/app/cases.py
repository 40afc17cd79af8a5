"""One case runner for every campaign (study, validation, extremes, seed figures): a case is one
``cosserat-fsi run`` of a scene file with ``--set`` overrides into its own folder, in a subprocess.

``run_case`` skips a case whose ``summary.json`` says it is finished (completed up to the scene's ``t_end``,
or diverged: a deterministic outcome; delete the folder to run it again), continues it with ``--restart``
when its folder holds a checkpoint (interrupted, or completed with a shorter ``t_end``), and otherwise runs
it from the start. The run's stdout/stderr go to ``<folder>/stdout.log`` and its exit code to
``<folder>/exit_code``. ``run_cases`` runs several at a time (``jobs``).
"""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import threading
from collections.abc import Callable, Iterable, Mapping
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

FINISHED = ("completed", "diverged")


def override(key: str, value: Any) -> str:
    """``key=value`` for ``--set``, the value written as YAML reads it back (strings as they are)."""
    return f"{key}={value if isinstance(value, str) else json.dumps(value)}"


@dataclass(frozen=True)
class Case:
    """One run: the scene file, its overrides (dotted key -> value) and the output folder."""

    config: Path
    out: Path
    overrides: Mapping[str, Any] = field(default_factory=dict)
    ranks: int = 1

    def set_args(self) -> list[str]:
        """The overrides as ``--set key=value`` arguments."""
        return [a for key, value in self.overrides.items() for a in ("--set", override(key, value))]


def status(case: Case) -> str:
    """``finished``, ``resume`` (a checkpoint to continue from) or ``start``."""
    summary = case.out / "summary.json"
    checkpoint = (case.out / "checkpoint" / "meta.json").exists()
    if summary.exists():
        try:
            done = json.loads(summary.read_text())
        except (OSError, ValueError):  # damaged: run it again (--overwrite below)
            done = {}
        done = done if isinstance(done, dict) else {}
        if done.get("status") == "diverged":
            return "finished"
        if done.get("status") == "completed":
            from cosserat_fsi.config import load_scene

            scene = load_scene(case.config, [override(k, v) for k, v in case.overrides.items()])
            if done.get("time", {}).get("t_final", 0.0) >= scene.time.t_end - 0.5 * scene.time.dt:
                return "finished"
    return "resume" if checkpoint else "start"


def mpi_launcher(ranks: int) -> list[str]:
    """Command prefix that starts ``ranks`` processes with the MPI next to this interpreter (else on PATH)."""
    here = Path(sys.executable).parent
    for exe in (here / "mpiexec", here / "mpirun", shutil.which("mpirun"), shutil.which("mpiexec")):
        if exe and os.access(str(exe), os.X_OK):
            text = subprocess.run([str(exe), "--version"], capture_output=True, text=True).stdout
            extra = ["--allow-run-as-root", "--oversubscribe"] if "Open MPI" in text else []
            return [str(exe), *extra, "-n", str(ranks)]
    raise RuntimeError("no MPI launcher (mpiexec/mpirun) found")


def run_case(case: Case, python: str | None = None, cwd: Path | None = None) -> Path:
    """Run ``case`` unless it is finished (see the module docstring); returns its folder."""
    state = status(case)
    if state == "finished":
        return case.out
    case.out.mkdir(parents=True, exist_ok=True)
    # an earlier attempt that failed or was cut short is replaced (--overwrite: once the new run is set up)
    where = ["--restart", str(case.out)] if state == "resume" else ["--out", str(case.out), "--overwrite"]
    cmd = [python or sys.executable, "-m", "cosserat_fsi", "run", str(case.config), *where, "--no-progress",
           *case.set_args()]
    if case.ranks > 1:
        cmd = mpi_launcher(case.ranks) + cmd
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"}
    with open(case.out / "stdout.log", "w") as log:
        proc = subprocess.Popen(cmd, stdout=log, stderr=subprocess.STDOUT, cwd=cwd, env=env)
        with _LOCK:
            _RUNNING.add(proc)
        try:
            proc.wait()
        finally:
            with _LOCK:
                _RUNNING.discard(proc)
    (case.out / "exit_code").write_text(f"{proc.returncode}\n")
    return case.out


_RUNNING: set[subprocess.Popen] = set()
_LOCK = threading.Lock()


def _stop_running(grace: float = 120.0) -> None:
    """SIGTERM to every running case (each writes a checkpoint and stops), SIGKILL after ``grace`` s."""
    with _LOCK:
        running = list(_RUNNING)
    for proc in running:
        try:
            proc.send_signal(signal.SIGTERM)
        except OSError:
            pass
    for proc in running:
        try:
            proc.wait(timeout=grace)
        except subprocess.TimeoutExpired:
            proc.kill()


def run_cases(cases: Iterable[Case], jobs: int = 1, python: str | None = None, cwd: Path | None = None,
              report: Callable[[Path], None] | None = None) -> list[Path]:
    """Run the cases, ``jobs`` at a time; ``report(folder)`` after each. Returns the folders in order."""
    def one(case: Case) -> Path:
        folder = run_case(case, python, cwd)
        if report:
            report(folder)
        return folder

    pool = ThreadPoolExecutor(max_workers=max(1, jobs))
    try:
        return list(pool.map(one, list(cases)))
    except BaseException:  # Ctrl-C, SIGTERM: the running cases stop too (with a checkpoint), no orphans
        pool.shutdown(wait=False, cancel_futures=True)
        _stop_running()
        raise
    finally:
        pool.shutdown(wait=True)
