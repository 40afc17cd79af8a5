"""Command line: ``cosserat-fsi run|mesh|plot|study|info``.

Every command ends with one line on stderr at most and an exit code, never a traceback (app/failure.py,
docs/reliability.md): ``error:`` 2, ``diverged:`` 3, ``interrupted:`` 130/143, ``internal error:`` 1.
``run`` owns its output folder (io/runfolder.py): parse → validate → check the folder → lock → check
the checkpoint → set up → commit → write. Importing this module imports neither dolfinx, petsc4py nor
gmsh: they are loaded only by the subcommands that need them.
"""

from __future__ import annotations

import argparse
import os
import math
import logging
import platform
import re
import sys
from pathlib import Path

from cosserat_fsi import __version__
from cosserat_fsi.app.failure import (Context, RunLog, check_utf8_arguments, install_signal_handlers, report,
                                      robust_streams, say, write_traceback)
from cosserat_fsi.cache import check_caches
from cosserat_fsi.config import load_scene
from cosserat_fsi.errors import DivergenceError, InputError
from cosserat_fsi.files import read_json

log = logging.getLogger("cosserat_fsi")


def _say(message: str, stream=None) -> None:
    """Print on rank 0 only."""
    say(message, stream)


class _Parser(argparse.ArgumentParser):
    """ArgumentParser whose usage errors are one line and exit code 2 (like InputError)."""

    def error(self, message):
        """Report a usage error on one line (no usage dump) and exit 2."""
        _say(f"error: {self.prog}: {message} (see --help)", sys.stderr)
        raise SystemExit(2)


def setup_logging(out_dir: Path, comm) -> logging.Logger:
    """Log the ``cosserat_fsi`` logger at INFO to ``<out_dir>/run.log`` and stderr, on rank 0 only."""
    run_log = RunLog(comm)
    if comm.rank == 0:
        run_log.commit(Path(out_dir), append=True)
    return log


def _validate_run(args):
    """Everything about a run that can be checked without touching a file: (scene, out, mode)."""
    if args.restart is not None and not args.restart.strip():
        raise InputError("--restart: needs the folder of the run to continue (got an empty path)")
    if args.out is not None and not args.out.strip():
        raise InputError("--out: needs a folder (got an empty path)")
    if args.restart is not None and args.overwrite:
        raise InputError("--overwrite: not with --restart (a restart continues the run in its folder)")
    scene = load_scene(args.config, args.set)  # the geometry's size is checked there (geometry/_model.py)
    check_caches()
    out, mode = (Path(args.out) if args.out else Path("runs") / scene.name), "overwrite" if args.overwrite else "new"
    if args.restart is not None:
        restart = Path(args.restart)
        if args.out and Path(args.out).resolve() != restart.resolve():
            raise InputError("--out: a restart continues in its own folder; leave --out out or give the same one")
        out, mode = restart, "restart"
    return scene, out, mode


class _OneRank:
    """COMM_WORLD of a process not started by an MPI launcher, before mpi4py is imported (its import and
    MPI_Init cost most of a refused run's second)."""

    rank, size = 0, 1


def _world():
    """MPI.COMM_WORLD when started by a launcher (or mpi4py is loaded), else a one-rank stand-in."""
    launched = any(v in os.environ for v in ("OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_RANK", "PMI_RANK"))
    if launched or "mpi4py.MPI" in sys.modules:
        from mpi4py import MPI

        return MPI.COMM_WORLD
    return _OneRank()


def _check_restart(scene, out: Path) -> None:
    """Rank 0: the checkpoint and the folder can be continued (all but the column names)."""
    from cosserat_fsi.io.checkpoint import check_restart_files, read_checkpoint, scene_fingerprint

    meta, _ = read_checkpoint(out, None, scene_fingerprint(scene))
    check_restart_files(out, meta, scene.time.t_end, None, scene.output.fields)


def _cmd_run(args, context) -> int:
    from cosserat_fsi.io.runfolder import RunFolder
    from cosserat_fsi.parallel import agree, on_root

    comm = _world()
    scene, out, mode = agree(comm, _validate_run, args)
    folder = RunFolder(out) if comm.rank == 0 else None
    run_log = RunLog(comm)
    try:
        on_root(comm, folder.acquire if folder else None, mode, step="lock")
        if mode == "restart":  # cheap checks of every file before the heavy imports (again, fully, in run_scene)
            on_root(comm, _check_restart, scene, out)
        log.info("cosserat-fsi %s: scene %s -> %s (%d rank%s)",
                 __version__, scene.name, out, comm.size, "" if comm.size == 1 else "s")
        from cosserat_fsi.app.runner import run_scene  # heavy: dolfinx, PETSc
        from mpi4py import MPI

        comm = MPI.COMM_WORLD

        try:
            import gmsh  # noqa: F401  (gmsh 4.8 resets SIGINT/SIGTERM when imported: import it now...)
        except ImportError:
            pass
        install_signal_handlers()  # ...and put ours back

        def commit():  # rank 0, once everything is checked and set up: from here on the folder is the run's
            folder.commit_overwrite()
            context.traceback_file = run_log.commit(out, append=mode == "restart")

        try:
            summary = run_scene(scene, out, comm, progress=scene.output.progress and not args.no_progress,
                                restart=mode == "restart", commit=commit)
        except DivergenceError:
            _say_how_it_did(out, comm)
            raise
        _say_how_it_did(out, comm, summary)
        log.info("done: %s", out)
    finally:
        if folder is not None:
            folder.release()
        run_log.close()
    return 0


def _say_how_it_did(out: Path, comm, summary: dict | None = None):
    """The run's last lines: the benchmark table, headline observables, wall time (app/verdict.py)."""
    if comm.rank != 0:
        return
    from cosserat_fsi.app.verdict import verdict_lines

    if summary is None:
        try:
            summary = read_json(out / "summary.json", "summary file")
        except InputError:
            return
    try:
        for line in verdict_lines(summary):
            log.info("%s", line)
    except Exception as exc:  # noqa: BLE001 (a report, not the run: never turn a finished run into a failure)
        log.info("(no verdict: %s: %s)", type(exc).__name__, exc)


def _cmd_mesh(args, context=None) -> int:
    if args.out is not None and args.format != "xdmf":
        raise InputError("--out: only with --format xdmf (a .msh is kept in the mesh cache)")
    if args.format == "xdmf" and _world().size > 1:
        refused = InputError("--format xdmf: converts on one process (the .msh is read whole there); run "
                             "`cosserat-fsi mesh` without mpirun")
        refused.shared = True  # every rank refuses: said once
        raise refused
    scene = load_scene(args.config, args.set)
    if args.format == "xdmf":  # app/xdmf_mesh.py: OUT/NAME.xdmf + NAME.h5 + NAME.names.json
        from cosserat_fsi.app.xdmf_mesh import convert
        from cosserat_fsi.geometry.xdmf_file import table

        out = convert(scene, Path(args.out) if args.out else Path(args.config).resolve().parent)
        names = table(out)
        _say(f"{out}: {names['cells']['fluid']} fluid and {names['cells']['solid']} solid cells; facet groups "
             f"{', '.join(sorted(names['facets'])) or 'none'}")
        return 0
    from cosserat_fsi.geometry import build_msh

    if scene.geometry.msh_params().get("format") == "xdmf":  # already converted: its table says its size
        from cosserat_fsi.geometry.xdmf_file import table

        cells = table(scene.geometry.path)["cells"]
        _say(f"{scene.geometry.path}: {cells['fluid'] + cells['solid']} cells")
        return 0
    path = build_msh(scene.geometry)
    import gmsh

    gmsh.initialize()
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.open(str(path))
        vertices = len(gmsh.model.mesh.getNodes()[0])
        cells = sum(len(tags) for tags in gmsh.model.mesh.getElements(dim=scene.geometry.DIM)[1])
    finally:
        gmsh.finalize()
    _say(f"{path}: {vertices} vertices, {cells} cells")
    return 0


def _cmd_plot(args, context=None) -> int:
    from cosserat_fsi.app.plots import plot_run

    for path in plot_run(args.run_dir, args.out, args.time):
        _say(str(path))
    return 0


def _cmd_study(args, context=None) -> int:
    from cosserat_fsi.app.study import main_study

    _say(str(main_study(args.study, args.out, args.jobs, args.report_only)))
    return 0


def _versions() -> list[tuple[str, str]]:
    """(name, version) of the package, Python and the numerical stack (``-`` when missing)."""
    try:
        import cosserat_fsi.compat  # noqa: F401  (imports dolfinx_solver before dolfinx on the wheel stack)
    except ImportError:
        pass
    rows = [("cosserat-fsi", __version__), ("python", platform.python_version())]
    for name in ("dolfinx", "basix", "ufl", "ffcx", "petsc4py", "gmsh", "h5py", "numpy"):
        try:
            module = __import__(name)
            rows.append((name, str(getattr(module, "__version__", "?"))))
        except ImportError:
            rows.append((name, "-"))
    try:
        from petsc4py import PETSc

        rows.append(("PETSc", ".".join(map(str, PETSc.Sys.getVersion()))))
        rows.append(("MUMPS", "yes" if PETSc.Sys.hasExternalPackage("mumps") else "no"))
    except ImportError:
        rows += [("PETSc", "-"), ("MUMPS", "-")]
    try:
        from mpi4py import MPI

        rows.append(("MPI", MPI.Get_library_version().splitlines()[0].strip()))
    except ImportError:
        rows.append(("MPI", "-"))
    rows.append(("BLAS", _loaded_blas()))
    return rows


def _loaded_blas() -> str:
    """Paths of the BLAS libraries mapped into this process (Linux only), or ``-``."""
    try:
        maps = Path("/proc/self/maps").read_text().splitlines()
    except OSError:
        return "-"
    blas = re.compile(r"lib((open|flexi|scipy_open)blas|blas|blis|mkl_rt)")
    libs = sorted({line.split()[-1] for line in maps if blas.match(line.rsplit("/", 1)[-1])})
    return ", ".join(libs) or "-"


def _cmd_info(args, context=None) -> int:
    rows = _versions()
    width = max(len(name) for name, _ in rows)
    _say("\n".join(f"{name:<{width}}  {value}" for name, value in rows))
    return 0


def _finite_float(text: str) -> float:
    """argparse type: a finite number."""
    value = float(text)
    if not math.isfinite(value):
        raise ValueError(text)
    return value


_finite_float.__name__ = "finite number"  # argparse names the type in its message


def _parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="cosserat-fsi", description=__doc__.splitlines()[0])
    parser.add_argument("--version", action="version", version=f"cosserat-fsi {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)

    def scene_args(p):
        p.add_argument("config", help="scene YAML file (see configs/)")
        p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                       help="override a config value, e.g. --set time.dt=1e-3 (repeatable; KEY=null removes the key)")

    run = sub.add_parser("run", help="run a scene")
    scene_args(run)
    run.add_argument("--out", help="output directory (default: runs/<scene name>)")
    run.add_argument("--no-progress", action="store_true", help="no progress bar")
    run.add_argument("--overwrite", action="store_true",
                     help="replace the run already in --out (removed only once the new one is set up)")
    run.add_argument("--restart", metavar="DIR",
                     help="continue the run in DIR from its last checkpoint: same scene but for time.t_end "
                          "(not before the checkpoint) and output; any number of ranks (the checkpoint is "
                          "keyed by coordinates, not by partition). Everything is checked before a byte "
                          "of DIR changes")
    run.set_defaults(func=_cmd_run)
    mesh = sub.add_parser("mesh", help="build (or find cached) the scene's mesh and print its size; with "
                          "--format xdmf, convert it to NAME.xdmf + NAME.h5 + NAME.names.json (read distributed)")
    scene_args(mesh)
    mesh.add_argument("--format", choices=("msh", "xdmf"), default="msh",
                      help="msh (default): the cached gmsh mesh; xdmf: write the checked, renumbered mesh and its "
                           "tags as XDMF/HDF5 for `geometry: {name: file, path: NAME.xdmf}` (one process)")
    mesh.add_argument("--out", help="folder for the XDMF files (default: the scene file's folder)")
    mesh.set_defaults(func=_cmd_mesh)
    plot = sub.add_parser("plot", help="PNGs of a run: time series (with the reference band) and snapshots")
    plot.add_argument("run_dir", help="output folder of `cosserat-fsi run`")
    plot.add_argument("--out", help="folder for the PNGs (default: RUN_DIR/plots)")
    plot.add_argument("--time", action="append", type=_finite_float, metavar="T",
                      help="snapshot at the output step nearest to T (repeatable; default: the last step)")
    plot.set_defaults(func=_cmd_plot)
    study = sub.add_parser("study", help="run a ladder of runs (mesh × δt × options) and report error, time, memory")
    study.add_argument("study", help="study YAML file (see studies/)")
    study.add_argument("--out", help="folder for the report, figures and runs (default: the current directory)")
    study.add_argument("--jobs", type=int, default=1, help="runs at a time (default 1)")
    study.add_argument("--report-only", action="store_true", help="only rewrite the report from finished runs")
    study.set_defaults(func=_cmd_study)
    info = sub.add_parser("info", help="versions of the numerical stack")
    info.set_defaults(func=_cmd_info)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``cosserat-fsi`` console script; returns the exit code (app/failure.py)."""
    robust_streams()
    install_signal_handlers()
    context = Context()
    from cosserat_fsi import parallel

    parallel.traceback_sink = lambda exc: write_traceback(exc, context)
    try:
        argv = sys.argv[1:] if argv is None else list(argv)
        check_utf8_arguments(argv)
        args = _parser().parse_args(argv)
        if args.command == "mesh":
            check_caches()
        return args.func(args, context)
    except SystemExit as exc:  # argparse: --help, --version, usage errors (already printed)
        return exc.code if isinstance(exc.code, int) else 0
    except BaseException as exc:  # noqa: BLE001 (every end is one line and an exit code)
        code = report(exc, context)
    import gc

    gc.collect()  # a failed run's objects (held by the traceback) go while PETSc is alive, not at its finalize
    return code


if __name__ == "__main__":
    sys.exit(main())
