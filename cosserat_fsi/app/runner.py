"""Run one scene: mesh → simulation → observables → outputs (the CLI contract of `cosserat-fsi run`).

Above 350 lines because the error path around the loop lives here with it: the order of work (check,
set up, commit, write), the shared end-of-step check, the summary that tells how the run ended.

Writes into the output folder: config.yaml (resolved), timeseries.csv, line_NAME.csv (``observables.lines``),
fields.xdmf + fields.h5, summary.json (and run.log through the CLI's logging).
"""

from __future__ import annotations

import json
import logging
import resource
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from mpi4py import MPI

from .. import __version__, compat
from ..config import Scene, as_scene, dump_resolved
from ..config.scene import condition_lines
from ..config.usage import usage_warnings
from ..errors import DivergenceError, InputError, InternalError, Interrupted
from ..exact import exact_for
from ..geometry import build_msh
from .xdmf_mesh import load as load_xdmf
from ..io import MovingMeshXDMF, TimeSeriesWriter, read_timeseries
from ..io.profiles import check_profiles, open_profiles, write_profiles
from ..mesh.report import log_solid_resolution
from ..io.checkpoint import (check_restart_files, read_checkpoint, read_checkpoint_mesh, scene_fingerprint,
                             write_checkpoint)
from ..io.runfolder import atomic_write_text
from ..parallel import agree, failpoint, is_shared, on_root, share
from ..observables import Observables
from ..simulation import Simulation
from ..signals import signal_handlers
from .cases import resolved_scene
from .progress import advance as _advance, progress_bar as _progress_bar
from .stop_signals import StopSignals
from .verdict import (check_reference, classify_signals, compare_with_reference, compare_with_scene_reference,
                      time_summary)

log = logging.getLogger("cosserat_fsi")

PERIODIC_BENCHMARKS = {"turek_hron_cfd3", "schaefer_turek_2d2", "turek_hron_fsi3", "seed_fsi3"}


def load_mesh(scene: Scene, comm: MPI.Comm) -> tuple[Any, Any, Any, Path]:
    """Build (rank 0, cached) and read the scene's mesh (an .xdmf: by every rank): (mesh, tags, tags, path)."""
    geo = scene.geometry
    if geo.msh_params().get("format") == "xdmf":  # read distributed, checked there
        return (*load_xdmf(scene, comm), Path(geo.path))
    path = on_root(comm, _build_checked, scene, step="mesh")
    mesh, cell_tags, facet_tags = compat.read_msh(path, comm, gdim=geo.DIM)
    return mesh, cell_tags, facet_tags, path


def _build_checked(scene: Scene) -> Path:
    """The scene's mesh file (built if needed); a file scene checked against what its file holds."""
    path = build_msh(scene.geometry)
    if scene.geometry.name == "file":
        from ..geometry.file import check_scene, read_names

        check_scene(scene, read_names(path))
    return path


def run_scene(scene: Scene, out_dir: Path, comm: MPI.Comm = MPI.COMM_WORLD, progress: bool = True,
              restart: bool = False, commit: Callable[[], None] | None = None) -> dict:
    """Run ``scene`` (a Scene, or a mapping validated as a scene file's content) and write its outputs into
    ``out_dir`` (created if missing); returns the summary (also summary.json).

    ``restart``: continue the run in ``out_dir`` from its checkpoint (same scene up to time.t_end and
    output): the time series and fields after the checkpoint are dropped and rewritten; field steps
    before it are kept even if ``output.fields`` is now off. A checkpoint is written every
    ``output.checkpoint_every`` steps, at the last step (so ``--restart`` with a later ``time.t_end`` extends a
    finished run without recomputing it; not with ``checkpoint_every: 0``) and on SIGTERM/SIGINT, which then
    stop the run (:class:`Interrupted`).

    Order (docs/reliability.md): read and check the checkpoint and every file of the folder, build the
    mesh and the simulation, and only then ``commit()`` (rank 0: the CLI removes an overwritten run and
    starts run.log) and write. A failure before the commit leaves the folder as it was; after it,
    summary.json says ``completed``, ``diverged``, ``interrupted`` or ``failed``. Every rank-0-only step
    shares its outcome with the other ranks (``parallel``).
    """
    scene = as_scene(scene, "run_scene")
    out_dir = Path(out_dir)
    wall0 = time.perf_counter()
    handlers = signal_handlers()
    fingerprint = scene_fingerprint(scene)
    meta = state = None
    if restart:
        meta, state = agree(comm, read_checkpoint, out_dir, comm, fingerprint)
    mesh, cell_tags, facet_tags, msh = load_mesh(scene, comm)
    n_vertices = mesh.topology.index_map(0).size_global
    if remeshed := restart and meta.get("mesh") is not None:  # the checkpoint's mesh is a remeshed one
        mesh, cell_tags, facet_tags = read_checkpoint_mesh(out_dir, meta, comm, scene.geometry.DIM)
    signal_handlers(handlers)  # gmsh and PETSc reset SIGINT/SIGTERM (even at the C level): put them back
    sim = Simulation(scene, mesh, cell_tags, facet_tags, comm, exact=exact_for(scene))
    sim.remesh_folder = out_dir / "meshes"
    # on the reference mesh (point A is found there; on a remeshed mesh where the checkpoint saw it)
    observables = Observables(sim, np.asarray(meta["point_A"]) if remeshed and meta.get("point_A") else None,
                              meta.get("solid_points") if remeshed else None)
    signal_handlers(handlers)
    check_reference(scene, observables.columns)
    if restart:
        agree(comm, sim.restore, state)
        if remeshed:
            sim.mesh_file, sim.remeshes = out_dir / meta["mesh"], list(meta.get("remeshes", []))
        on_root(comm, check_restart_files, out_dir, meta, scene.time.t_end, observables.columns,
                scene.output.fields)
        on_root(comm, check_profiles, out_dir, observables.lines, meta["t"])

    micro = sim.model.micro_rotation
    conditions = [] if sim.exact is not None else condition_lines(scene, sim.problem.conditions(), micro)

    def start():  # rank 0: from here on the folder is this run's
        if commit is not None:
            commit()
        else:  # called from Python: the folder is the caller's
            out_dir.mkdir(parents=True, exist_ok=True)
        atomic_write_text(out_dir / "config.yaml", dump_resolved(scene, conditions))

    on_root(comm, start, step="commit")
    for line in usage_warnings(scene):  # set output keys this run does not use (config/usage.py)
        log.warning("%s", line)
    if restart:
        log.info("restart from the checkpoint of step %d (t = %.6g)", sim.step_count, sim.t)
    log.info("mesh %s: %d vertices, %d cells", Path(msh).name, n_vertices,
             mesh.topology.index_map(mesh.topology.dim).size_global)
    log.info("model: %s", sim.model.describe())
    if sim.time_control is not None:  # the controller's bounds, defaults included
        log.info("%s", sim.time_control.describe())
    log.info("dofs: %s", sim.num_dofs())
    log.info("boundaries:%s", "".join(f"\n  {c}" for c in conditions) or " the exact solution's (but the outlet)")
    for line in observables.locations():  # where the probes landed; the solid's cells across
        log.info("%s", line)
    if sim.model.solid:
        log_solid_resolution(sim.mesh, sim.cell_tags, comm)
    setup_time = time.perf_counter() - wall0
    steady = scene.time.scheme == "steady"
    n_steps = sim.steps_to(scene.time.t_end)  # steady: one "step", the Newton solve
    every = scene.output.every
    series = fields = bar = stop = None
    profiles: dict = {}
    earlier_field_steps = meta["field_steps"] if restart else 0
    status, message = "completed", ""
    every_ck = scene.output.checkpoint_every

    def checkpoint():
        with sim.timers("checkpoint"):
            remesh = {}
            if sim.mesh_file is not None:  # a restart reads this mesh (and finds A where it was on it)
                remesh = {"mesh": str(Path(sim.mesh_file).relative_to(out_dir)), "remeshes": sim.remeshes,
                          "point_A": point_A_on_mesh, "solid_points": solid_points_on_mesh}
            write_checkpoint(out_dir, sim, comm, {
                "fingerprint": fingerprint, "rows": sim.step_count,
                "field_steps": fields.num_steps if fields is not None else earlier_field_steps, **remesh})

    point_A_on_mesh = meta.get("point_A") if remeshed else None  # point A on the remeshed mesh's reference
    solid_points_on_mesh = meta.get("solid_points") if remeshed else None  # likewise the named solid points

    def remeshed_to(sim, record):  # a new mesh: observables on it, a new topology in the fields
        nonlocal observables, point_A_on_mesh, solid_points_on_mesh
        stop.reinstall()  # the time loop's handlers (a checkpoint on a signal), not the start-up ones
        point_A = observables.point_A_now()
        point_A_on_mesh = None if point_A is None else point_A.tolist()
        solid_points_on_mesh = observables.solid_points_now()
        observables = Observables(sim, point_A, solid_points_on_mesh)
        if fields is not None:
            fields.new_mesh(sim.mesh)
        log.info("t = %.6g: remesh %d (%s): minimum fluid cell quality %.4g -> %.4g, %d cells, %.3g s", record["t"],
                 len(sim.remeshes), record["reason"], record["quality_before"], record["quality_after"],
                 record["cells"], record["seconds"])

    sim.on_remesh.append(remeshed_to)

    def observe(sim):  # after the solve, on the mesh the step was solved on
        failpoint("observe")  # the fault suite's fault inside a collective step (MPI_Abort path)
        with sim.timers("observables"):
            series.write(sim.t, observables.evaluate())

    def after_step(sim):
        k = sim.step_count
        if fields is not None and (steady or k % every == 0):
            with sim.timers("output"):
                _write_fields(fields, sim)
        if steady or k % every == 0:
            write_profiles(profiles, observables, sim)
        if k % every == 0 and getattr(sim.motion, "min_quality", None) is not None:
            log.info("t = %.6g: minimum cell quality %.4g (lowest so far %.4g)", sim.t, sim.motion.min_quality,
                     sim.motion.lowest_quality)
        if bar is not None:
            _advance(bar, sim)
        signum = _step_end(comm, stop, [series, *profiles.values()])
        if signum:
            checkpoint()
            stopped = Interrupted(f"signal {signum} at step {k} (t = {sim.t:.6g}): checkpoint written; resume "
                                  f"with `cosserat-fsi run CONFIG --restart {out_dir}`", signum)
            stopped.shared = True  # every rank stops here (the signal is shared by _step_end): one summary
            raise stopped
        if every_ck and not steady and (k % every_ck == 0 or sim.finished(scene.time.t_end)):  # the last step too
            checkpoint()

    try:
        series = TimeSeriesWriter(out_dir / "timeseries.csv", observables.columns, comm,
                                  keep_rows=meta["rows"] if restart else None)
        profiles = open_profiles(out_dir, observables.lines, comm, meta["t"] if restart else None)
        if scene.output.fields:
            fields = MovingMeshXDMF(out_dir / "fields.xdmf", mesh, comm,
                                    keep_steps=earlier_field_steps if restart and earlier_field_steps else None)
        bar = _progress_bar(n_steps, progress and comm.rank == 0,
                            scene.time.t_end if sim.time_control is not None else None)
        if bar is not None:
            _advance(bar, sim)
        with StopSignals() as stop:
            if fields is not None and fields.num_steps == 0 and not steady:
                _write_fields(fields, sim)
            if not restart and not steady:
                write_profiles(profiles, observables, sim)
            sim.run_to(scene.time.t_end, observers=[observe], after_step=[after_step])
            sim.check()  # a steady Newton that did not converge: exit 3 after the outputs
        for writer in (series, *profiles.values()):
            writer.close()
            share(comm, writer.error)
    except BaseException as exc:
        if comm.size > 1 and not (is_shared(exc) or isinstance(exc, DivergenceError)):
            status = "local"
            raise  # only this rank knows: no collective summary; the CLI ends every rank (MPI_Abort)
        status, message = _status_of(exc)
        raise
    finally:
        if bar is not None:
            bar.close()
        if series is not None:
            series.close()
        [writer.close() for writer in profiles.values()]
        if fields is not None:
            fields.close()
        if status != "local":
            summary = _write_summary(scene, sim, out_dir, n_vertices, setup_time,
                                     time.perf_counter() - wall0, status, message, comm)
    return summary


def _status_of(exc: BaseException) -> tuple[str, str]:
    """summary.json's (status, message) for a run that ended with ``exc``."""
    if isinstance(exc, DivergenceError):
        return "diverged", str(exc)
    if isinstance(exc, (Interrupted, KeyboardInterrupt)):
        return "interrupted", str(exc) or "Ctrl-C (SIGINT)"
    if isinstance(exc, InternalError):
        return "failed", f"{exc.kind}: {exc}"
    return "failed", f"{type(exc).__name__}: {exc}"


def _step_end(comm, stop, writers) -> int:
    """End of a step, on every rank: a failed row write (disk full) is raised everywhere; else the largest
    signal number any rank received (0: none)."""
    error = next((w.error for w in writers if w.error is not None), None)
    if comm.size > 1:
        signum, failed = comm.allreduce((stop.signum, error is not None), op=MPI.MAX)
    else:
        signum, failed = stop.signum, error is not None
    if failed:
        share(comm, error)
    return signum


def _write_summary(scene, sim, out_dir, n_vertices, setup_time, wall, status, message, comm) -> dict | None:
    """summary.json, written whatever ended the run; its own failure does not hide the run's."""
    import sys

    running = sys.exc_info()[1]
    try:
        return _summary(scene, sim, out_dir, n_vertices, setup_time, wall, status, message, comm)
    except BaseException as exc:
        if running is None:
            raise
        log.error("summary.json not written: %s", exc)
        return None


def _write_fields(fields, sim):
    point = {"velocity": sim.velocity, "pressure": sim.pressure}
    if sim.model.micro_rotation:
        point["micro_rotation"] = sim.micro_rotation
    if sim.model.solid:
        point["displacement"] = sim.displacement
    cells = None
    if sim.cell_tags is not None:
        n_owned = compat.num_owned_cells(sim.mesh)
        marker = np.zeros(n_owned)
        ct = sim.cell_tags
        owned = ct.indices < n_owned
        marker[ct.indices[owned]] = ct.values[owned]
        cells = {"subdomain": marker}
    fields.write(sim.t, point, cells)


def _summary(scene, sim, out_dir, n_vertices, setup_time, wall, status, message, comm) -> dict:
    """summary.json: versions, sizes, timings, peak memory, periodic analysis, comparison with the reference."""
    ranks = comm.allgather(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0)  # MiB (Linux: KiB)
    memory = {"peak_rss_mib_max_rank": max(ranks), "peak_rss_mib_sum": sum(ranks), "peak_rss_mib_per_rank": ranks}
    log.info("peak memory per rank (MiB): %s", " ".join(f"{m:.0f}" for m in ranks))

    def build_and_write():  # rank 0
        try:
            series = read_timeseries(out_dir / "timeseries.csv") if sim.step_count else {}
        except (OSError, InputError):  # a write that failed (disk full) may have left it short
            series = {}
        steps = max(sim.step_count, 1)
        summary = {
            "scene": scene.name,
            "resolved_scene": resolved_scene(scene),  # what `study` and the campaigns compare (app/cases.py)
            "status": status,
            "message": message,
            "versions": {"cosserat_fsi": __version__, **compat.versions()},
            "ranks": comm.size,
            "mesh": {"geometry": scene.geometry.name, "level": scene.geometry.level, "vertices": n_vertices},
            "model": sim.model.describe(),
            "dofs": sim.num_dofs(),
            "time": time_summary(scene, sim),
            "memory": memory,
            "wall_time": {"total": wall, "setup": setup_time, "per_step": (wall - setup_time) / steps,
                          "phases": dict(sim.timers.totals)},
            "final": {k: float(v[-1]) for k, v in series.items() if k not in ("t", "dt") and len(v)},
        }
        # periodic analysis only of the periodic signals; the others are "steady" or "not periodic yet"
        summary["signals"], summary["periodic"] = classify_signals(series)
        solver = getattr(sim.stepper, "solver", None) or getattr(sim.stepper, "newton", None)
        if solver is not None and hasattr(solver, "counts"):  # what the linear solves did
            summary["linear_solver"] = {**solver.counts(), "peak_rss_mib_max_rank": memory["peak_rss_mib_max_rank"],
                                        "peak_rss_kib_per_unknown": 1024.0 * memory["peak_rss_mib_sum"]
                                        / max(summary["dofs"]["total"], 1)}
        if sim.report is not None:  # steady solve: Newton's iterations and residuals
            summary["newton"] = sim.report.as_dict()
        if "omega_max" in series and len(series["omega_max"]):
            summary["omega_max"] = float(np.max(series["omega_max"]))  # max over the run of max |ω|
        if getattr(sim.motion, "lowest_quality", None) is not None:  # 4√3|K|/Σ|e|², lowest over the run
            summary["mesh_quality"] = {"final": sim.motion.min_quality, "lowest": sim.motion.lowest_quality}
        if scene.solid is not None and scene.solid.mesh_motion.remesh is not None:
            summary["remeshes"] = {"count": len(sim.remeshes), "events": sim.remeshes}
        if scene.benchmark:
            summary["benchmark"] = compare_with_reference(scene, summary)
        if scene.reference:
            summary["reference"] = compare_with_scene_reference(scene.reference, summary)
        atomic_write_text(out_dir / "summary.json", json.dumps(summary, indent=2, default=_json))
        return summary

    return on_root(comm, build_and_write, step="summary")


def _json(obj):
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, Path):
        return str(obj)
    raise TypeError(type(obj))
