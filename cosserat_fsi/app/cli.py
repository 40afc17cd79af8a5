"""Command line: ``cosserat-fsi run|mesh|plot|study|info``.

Bad input (``InputError``, argparse usage errors) prints ``error: <message>`` on one line to stderr and
exits 2; a diverged run prints ``diverged: <message>`` and exits 3; SIGTERM/SIGINT write a checkpoint,
print ``interrupted: <message>`` and exit 128 + the signal number. Importing this module imports neither
dolfinx, petsc4py nor gmsh: they are loaded only by the subcommands that need them.
"""

from __future__ import annotations

import argparse
import logging
import os
import platform
import re
import sys
from pathlib import Path

from cosserat_fsi import __version__
from cosserat_fsi.config import load_scene
from cosserat_fsi.errors import DivergenceError, InputError, Interrupted

log = logging.getLogger("cosserat_fsi")


def _rank() -> int:
    """MPI rank, without importing mpi4py: from mpi4py if already loaded, else the launcher's environment."""
    mpi = sys.modules.get("mpi4py.MPI")
    if mpi is not None:
        return mpi.COMM_WORLD.rank
    for var in ("OMPI_COMM_WORLD_RANK", "PMI_RANK", "PMIX_RANK"):
        if os.environ.get(var, "").isdigit():
            return int(os.environ[var])
    return 0


def _say(message: str, stream=None) -> None:
    """Print on rank 0 only."""
    if _rank() == 0:
        print(message, file=stream or sys.stdout, flush=True)


class _Parser(argparse.ArgumentParser):
    """ArgumentParser whose usage errors are one line and exit code 2 (like InputError)."""

    def error(self, message):
        """Report a usage error on one line (no usage dump) and exit 2."""
        _say(f"error: {self.prog}: {message} (see --help)", sys.stderr)
        raise SystemExit(2)


def setup_logging(out_dir: Path, comm) -> logging.Logger:
    """Log the ``cosserat_fsi`` logger at INFO to ``<out_dir>/run.log`` and stderr, on rank 0 only."""
    for handler in list(log.handlers):
        log.removeHandler(handler)
        handler.close()
    log.propagate = False
    if comm.rank != 0:
        log.addHandler(logging.NullHandler())
        return log
    log.setLevel(logging.INFO)
    file_handler = logging.FileHandler(Path(out_dir) / "run.log", encoding="utf-8")
    file_handler.setFormatter(logging.Formatter("%(asctime)s %(levelname)s %(name)s: %(message)s"))
    stream_handler = logging.StreamHandler(sys.stderr)
    stream_handler.setFormatter(logging.Formatter("%(message)s"))
    log.addHandler(file_handler)
    log.addHandler(stream_handler)
    return log


def _check_out_dir(out: Path) -> None:
    """Create ``out`` if needed and check a file can be written there (InputError naming --out if not)."""
    try:
        out.mkdir(parents=True, exist_ok=True)
        probe = out / f".write-test-{os.getpid()}"
        probe.write_bytes(b"")
        probe.unlink()
    except OSError as exc:
        raise InputError(f"--out: cannot write to {out} ({exc.strerror or exc})") from None


def _cmd_run(args) -> int:
    scene = load_scene(args.config, args.set)
    out = Path(args.out) if args.out else Path("runs") / scene.name
    if args.restart:
        restart = Path(args.restart)
        if args.out and Path(args.out).resolve() != restart.resolve():
            raise InputError("--out: a restart continues in its own folder; leave --out out or give the same one")
        if not restart.is_dir():
            raise InputError(f"--restart: {restart} is not a folder")
        out = restart
    _check_out_dir(out)
    from cosserat_fsi.app.runner import run_scene  # heavy: dolfinx, PETSc, MPI
    from mpi4py import MPI

    comm = MPI.COMM_WORLD
    if args.restart:  # check the checkpoint before anything in the folder is touched (run.log included)
        from cosserat_fsi.io.checkpoint import read_checkpoint, scene_fingerprint

        read_checkpoint(out, comm, scene_fingerprint(scene))
        for name in ("timeseries.csv",) + (("fields.xdmf", "fields.h5") if scene.output.fields else ()):
            if not (out / name).is_file():
                raise InputError(f"--restart: {out / name} is missing (the checkpoint cannot be continued)")
    setup_logging(out, comm)
    log.info("cosserat-fsi %s: scene %s -> %s (%d rank%s)",
             __version__, scene.name, out, comm.size, "" if comm.size == 1 else "s")
    run_scene(scene, out, comm, progress=scene.output.progress and not args.no_progress,
              restart=bool(args.restart))
    log.info("done: %s", out)
    return 0


def _cmd_mesh(args) -> int:
    scene = load_scene(args.config, args.set)
    from cosserat_fsi.geometry import build_msh

    path = build_msh(scene.geometry.name, scene.geometry.level, scene.geometry.msh_params())
    import gmsh

    gmsh.initialize()
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.open(str(path))
        vertices = len(gmsh.model.mesh.getNodes()[0])
        cells = sum(len(tags) for tags in gmsh.model.mesh.getElements(dim=2)[1])
    finally:
        gmsh.finalize()
    _say(f"{path}: {vertices} vertices, {cells} cells")
    return 0


def _cmd_plot(args) -> int:
    from cosserat_fsi.app.plots import plot_run

    for path in plot_run(args.run_dir, args.out, args.time):
        _say(str(path))
    return 0


def _cmd_study(args) -> int:
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


def _cmd_info(args) -> int:
    rows = _versions()
    width = max(len(name) for name, _ in rows)
    _say("\n".join(f"{name:<{width}}  {value}" for name, value in rows))
    return 0


def _parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="cosserat-fsi", description=__doc__.splitlines()[0])
    parser.add_argument("--version", action="version", version=f"cosserat-fsi {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)

    def scene_args(p):
        p.add_argument("config", help="scene YAML file (see configs/)")
        p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                       help="override a config value, e.g. --set time.dt=1e-3 (repeatable)")

    run = sub.add_parser("run", help="run a scene")
    scene_args(run)
    run.add_argument("--out", help="output directory (default: runs/<scene name>)")
    run.add_argument("--no-progress", action="store_true", help="no progress bar")
    run.add_argument("--restart", metavar="DIR",
                     help="continue the run in DIR from its checkpoint (same scene but for time.t_end and "
                          "output, same number of ranks)")
    run.set_defaults(func=_cmd_run)
    mesh = sub.add_parser("mesh", help="build (or find cached) the scene's mesh and print its size")
    scene_args(mesh)
    mesh.set_defaults(func=_cmd_mesh)
    plot = sub.add_parser("plot", help="PNGs of a run: time series (with the reference band) and snapshots")
    plot.add_argument("run_dir", help="output folder of `cosserat-fsi run`")
    plot.add_argument("--out", help="folder for the PNGs (default: RUN_DIR/plots)")
    plot.add_argument("--time", action="append", type=float, metavar="T",
                      help="snapshot at the output step nearest to T (repeatable; default: the last step)")
    plot.set_defaults(func=_cmd_plot)
    study = sub.add_parser("study", help="run a ladder of runs (mesh × δt × options) and report error, time, memory")
    study.add_argument("study", help="study YAML file (see studies/)")
    study.add_argument("--out", help="folder for the report, figures and runs (default: docs/)")
    study.add_argument("--jobs", type=int, default=1, help="runs at a time (default 1)")
    study.add_argument("--report-only", action="store_true", help="only rewrite the report from finished runs")
    study.set_defaults(func=_cmd_study)
    info = sub.add_parser("info", help="versions of the numerical stack")
    info.set_defaults(func=_cmd_info)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``cosserat-fsi`` console script; returns the exit code."""
    args = _parser().parse_args(argv)
    try:
        return args.func(args)
    except InputError as exc:
        _say("error: " + " ".join(str(exc).split()), sys.stderr)
        return InputError.exit_code
    except DivergenceError as exc:
        _say("diverged: " + " ".join(str(exc).split()), sys.stderr)
        return DivergenceError.exit_code
    except Interrupted as exc:
        _say("interrupted: " + " ".join(str(exc).split()), sys.stderr)
        return exc.exit_code


if __name__ == "__main__":
    sys.exit(main())
