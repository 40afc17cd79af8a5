"""One case runner for every campaign (study, validation, extremes, seed figures): a case is one
``cosserat-fsi run`` of a scene file with ``--set`` overrides into its own folder, in a subprocess.

``run_case`` skips a case whose ``summary.json`` says it is finished (completed up to the scene's ``t_end``,
or diverged: a deterministic outcome; delete the folder to run it again) with the scene the case asks for
now, continues it with ``--restart`` when its folder holds a checkpoint of that scene (interrupted, or
completed with a shorter ``t_end``), and otherwise runs it from the start, replacing the folder's earlier run.
The scene a folder's run was made with is its ``config.yaml`` (the resolved scene): :func:`scene_changes`
compares it with the case's (the name and the output switches that change no number aside); a folder
holding a run without a readable ``config.yaml`` is not a case's own run and stops the campaign (InputError
naming it) rather than being replaced. The run's stdout/stderr go to ``<folder>/stdout.log`` and its exit code to
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

from ..errors import InputError
from ..files import read_json

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


IGNORED = ("name", "output.progress", "output.fields", "output.checkpoint_every")
"""Scene keys that change no number of a run: a folder's run made with other values is still the case's."""


def resolved_scene(scene) -> dict[str, Any]:
    """The resolved scene as summary.json's ``resolved_scene`` holds it (a mesh file by its content)."""
    data = scene.model_dump(mode="json")
    if scene.geometry.name == "file":  # the mesh file by its content, not by where it is
        try:
            data["geometry"]["path"] = "sha256:" + scene.geometry.content_digest()
        except (OSError, ValueError):
            pass
    return data


def _flat(data: dict, prefix: str = "") -> dict[str, Any]:
    out = {}
    for key, value in data.items():
        if isinstance(value, dict) and value:
            out.update(_flat(value, f"{prefix}{key}."))
        else:
            out[f"{prefix}{key}"] = value
    return out


def case_scene(case: Case):
    """The scene the case asks for now (its config file and overrides)."""
    from cosserat_fsi.config import load_scene

    return load_scene(case.config, [override(k, v) for k, v in case.overrides.items()])


def _ran(folder: Path) -> dict | None:
    """The resolved scene of the run in ``folder``: its config.yaml, else its summary.json's
    ``resolved_scene``; None when it has neither. InputError naming the folder when its config.yaml is not
    a scene (not a case's own run: it is not replaced)."""
    from cosserat_fsi.config import load_scene

    path = folder / "config.yaml"
    if path.exists():
        try:
            return resolved_scene(load_scene(path))
        except InputError as exc:
            raise InputError(f"{folder}: holds a run whose config.yaml is not a scene of this version ({exc}); "
                             "not replaced: move the folder away to run it again") from None
    try:
        summary = read_json(folder / "summary.json", "summary file")
    except InputError:
        return None
    found = summary.get("resolved_scene") if isinstance(summary, dict) else None
    return found if isinstance(found, dict) else None


def scene_changes(case: Case, scene=None) -> list[str] | None:
    """The dotted keys in which the run in ``case.out`` was made with another scene than the case asks for
    now (``IGNORED`` aside; ``time.t_end`` only when the run's is later: a shorter run is continued); [] for
    the same scene, None when the folder does not say its scene (no config.yaml, a summary.json without
    ``resolved_scene``)."""
    ran = _ran(case.out)
    if ran is None:
        return None
    before = {k: v for k, v in _flat(ran).items() if k not in IGNORED}
    now = {k: v for k, v in _flat(resolved_scene(scene or case_scene(case))).items() if k not in IGNORED}
    t_end_before, t_end_now = before.pop("time.t_end", None), now.pop("time.t_end", None)
    changed = [k for k in {**now, **before} if before.get(k, "<absent>") != now.get(k, "<absent>")]
    if t_end_before is not None and t_end_now is not None and t_end_before > t_end_now:
        changed.append("time.t_end")
    return changed


def status(case: Case, strict: bool = False) -> str:
    """``finished``, ``resume`` (a checkpoint of the same scene to continue from) or ``start`` (from the
    beginning: no run yet, a failed one, or one made with another scene). ``strict``: a run whose folder does
    not say its scene (only an older summary.json) is run again too."""
    summary = case.out / "summary.json"
    checkpoint = (case.out / "checkpoint" / "meta.json").exists()
    if not summary.exists() and not (case.out / "config.yaml").exists():
        return "resume" if checkpoint else "start"
    scene = case_scene(case)
    changed = scene_changes(case, scene)
    if changed or (strict and changed is None):  # another scene's run (or a later t_end): replaced
        return "start"
    if summary.exists():
        try:
            done = read_json(summary, "summary file")
        except InputError:  # damaged: run it again (--overwrite below)
            done = {}
        done = done if isinstance(done, dict) else {}
        if done.get("status") == "diverged":
            return "finished"
        if done.get("status") == "completed":
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


def run_case(case: Case, python: str | None = None, cwd: Path | None = None, strict: bool = False) -> Path:
    """Run ``case`` unless it is finished (see the module docstring; ``strict``: :func:`status`); returns its
    folder."""
    state = status(case, strict)
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
              report: Callable[[Path], None] | None = None, strict: bool = False) -> list[Path]:
    """Run the cases, ``jobs`` at a time; ``report(folder)`` after each. Returns the folders in order.
    ``strict``: see :func:`status`; every case's folder is checked before any runs."""
    cases = list(cases)
    for case in cases:  # a folder that is not a case's own run stops the campaign before anything runs
        _ran(case.out)

    def one(case: Case) -> Path:
        folder = run_case(case, python, cwd, strict)
        if report:
            report(folder)
        return folder

    pool = ThreadPoolExecutor(max_workers=max(1, jobs))
    try:
        return list(pool.map(one, cases))
    except BaseException:  # Ctrl-C, SIGTERM: the running cases stop too (with a checkpoint), no orphans
        pool.shutdown(wait=False, cancel_futures=True)
        _stop_running()
        raise
    finally:
        pool.shutdown(wait=True)
