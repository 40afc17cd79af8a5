"""Memory per rank of the parts of a steady 3D-1Z solve on a user XDMF mesh, stage by stage, for meshes too large
to solve on this machine (docs/perf_scale_3d.md, "A 2 M-tetrahedra mesh: memory by part"). Run by hand, not a
test:

    python campaigns/big_mesh_memory.py MESH.xdmf [MESH.xdmf ...] --stages read space jacobian pc solve \
        --out runs/big_mesh_memory

For each mesh (``cosserat-fsi mesh ... --format xdmf``), one 2-rank process builds what ``cosserat-fsi run`` builds
for 3D-1Z's flow on it (``solver.type: auto``), stopping after the last of ``--stages``:

- ``read``: ``runner.load_mesh`` (every rank reads its share of the .h5);
- ``space``: the Simulation (mixed P2/P1 space, dofmaps, state, compiled forms, point locator, stepper);
- ``jacobian``: the steady Newton's matrices (its Jacobian J, and with the iterative solver the matrix J + the
  streamline diffusion its AMG is built from), with PETSc's MatGetInfo of each;
- ``pc``: the iterative solver set up on them (fieldsplit Schur, BoomerAMG on the velocity block, the PCD
  matrices and their inner solvers);
- ``solve``: the Stokes start's linear solve (FGMRES; its Krylov vectors).

After each stage rank 0 prints a JSON line: every rank's resident (VmRSS) and peak (VmHWM) memory, MiB. A
watchdog in the parent ends the run when the machine's available memory falls under ``--min-free-gb`` or the
run's own exceeds ``--max-gb``.
Adds to OUT/memory.json; ``--table`` prints its tables (the parts' bytes per unknown).
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from xdmf_memory import REPO, XDMF_SCENE, launcher  # noqa: E402

STAGES = ("read", "space", "jacobian", "pc", "solve")


def _status() -> tuple[float, float]:
    """(VmRSS after glibc's malloc_trim: the memory in use, VmHWM: the peak) of this process, MiB."""
    import ctypes

    ctypes.CDLL("libc.so.6").malloc_trim(0)
    fields = dict(line.split(":", 1) for line in Path("/proc/self/status").read_text().splitlines() if ":" in line)
    return tuple(int(fields[k].split()[0]) / 1024.0 for k in ("VmRSS", "VmHWM"))


def _matrix(A) -> dict:
    """This rank's part of ``A``: rows, nonzeros and PETSc's memory figure (MatGetInfo, local; 0 on PETSc
    versions that no longer count it, as Debian's: the resident memory's rise is the measure)."""
    from petsc4py import PETSc

    info = A.getInfo(PETSc.Mat.InfoType.LOCAL)
    return {"rows": A.getLocalSize()[0], "nz_used": int(info["nz_used"]), "nz_allocated": int(info["nz_allocated"]),
            "petsc_memory_mib": round(info["memory"] / 2**20, 1)}


def stages(scene_path: str, last: str, solver_type: str) -> None:
    """Under mpirun: the stages up to ``last``; rank 0 prints a JSON line after each."""
    from mpi4py import MPI

    comm = MPI.COMM_WORLD
    t0 = time.perf_counter()

    def report(stage: str, **extra) -> None:
        rss, hwm = _status()
        rows = comm.gather({"rss": rss, "hwm": hwm, **extra.pop("per_rank", {})})
        if comm.rank == 0:
            row = {"stage": stage, "wall_s": round(time.perf_counter() - t0, 1), **extra,
                   "rss_mib_per_rank": [round(r.pop("rss"), 1) for r in rows],
                   "peak_mib_per_rank": [round(r.pop("hwm"), 1) for r in rows]}
            if any(rows):
                row["per_rank"] = rows
            print(json.dumps(row), flush=True)

    from cosserat_fsi.app.runner import load_mesh
    from cosserat_fsi.config import load_scene

    report("start")
    scene = load_scene(scene_path, [f"solver.type={solver_type}"])
    mesh, cell_tags, facet_tags, _ = load_mesh(scene, comm)
    report("read", cells=mesh.topology.index_map(3).size_global, vertices=mesh.topology.index_map(0).size_global,
           per_rank={"cells": mesh.topology.index_map(3).size_local})
    if last == "read":
        return
    from cosserat_fsi.simulation import Simulation

    sim = Simulation(scene, mesh, cell_tags, facet_tags, comm)
    stepper, W = sim.stepper, sim.problem.space.W
    report("space", unknowns=sim.num_dofs()["total"], linear_solver=stepper.linear_kind,
           per_rank={"owned": W.dofmap.index_map.size_local * W.dofmap.index_map_bs})
    if last == "space":
        return
    newton = stepper._newton()
    matrices = {"J": _matrix(newton.A)}
    if newton.P is not None:
        matrices["J_pc"] = _matrix(newton.P)
    report("jacobian", per_rank=matrices)
    if last == "jacobian" or newton.linear_solver is None:
        return
    from cosserat_fsi.problem.boundary import steady_time

    t = steady_time(scene)
    stepper.boundary.update(t)
    sim.problem.update_sources(t)
    sim.state.to_mixed(stepper.solution, stepper.space)
    stepper.convection.value = 0.0  # the Stokes start (SteadyFluid._solve: continuation, stokes_first)
    newton.apply_bcs()
    newton.residual_norm()
    newton._jacobian()
    solver = newton.linear_solver
    solver.ksp.setUp()
    for sub in solver.ksp.getPC().getFieldSplitSubKSP():
        sub.setUp()
    report("pc")
    if last == "pc":
        return
    solver.solve(newton.b, newton.delta)
    report("solve", krylov_iterations=solver.ksp.getIterationNumber())


def _available_gib() -> float:
    for line in Path("/proc/meminfo").read_text().splitlines():
        if line.startswith("MemAvailable:"):
            return int(line.split()[1]) / 2**20
    return float("inf")


def _group_gib(pgid: int) -> float:
    """The resident memory of the processes of process group ``pgid``, GiB."""
    total = 0
    for proc in Path("/proc").iterdir():
        try:
            if proc.name.isdigit() and os.getpgid(int(proc.name)) == pgid:
                status = (proc / "status").read_text()
                total += int(status.split("VmRSS:")[1].split()[0]) if "VmRSS:" in status else 0
        except (OSError, IndexError, ValueError):
            continue
    return total / 2**20


def run_watched(argv: list[str], env: dict, min_free_gb: float, max_gb: float) -> tuple[list[dict], str | None]:
    """Run ``argv`` (its own process group), its JSON lines as they come; killed (the group) when the available
    memory falls under ``min_free_gb`` or the group's exceeds ``max_gb``: (rows, why it was stopped or failed,
    else None)."""
    proc = subprocess.Popen(argv, env=env, stdout=subprocess.PIPE, text=True, start_new_session=True)
    killed: list[str] = []

    def watch():
        while proc.poll() is None:
            free, used = _available_gib(), _group_gib(proc.pid)
            if free < min_free_gb or used > max_gb:
                killed.append(f"stopped: {free:.1f} GiB available (at least {min_free_gb:g}), {used:.1f} GiB used "
                              f"(at most {max_gb:g})")
                os.killpg(proc.pid, signal.SIGKILL)
                return
            time.sleep(1.0)

    threading.Thread(target=watch, daemon=True).start()
    rows = []
    for line in proc.stdout:
        if line.startswith("{"):
            rows.append(json.loads(line))
            print(line.rstrip(), flush=True)
    code = proc.wait()
    return rows, killed[0] if killed else (f"exit code {code}" if code else None)


PARTS = {"read": "mesh (the read)", "space": "spaces, dofmaps, state, forms", "jacobian": "J and J + SD",
         "pc": "preconditioner", "solve": "Krylov vectors"}


def table(results: list[dict]) -> None:
    """Markdown tables from memory.json: each stage's resident / peak memory per rank (MiB), and each part's
    bytes per unknown (the rise of the ranks' summed resident memory over the stage before; in brackets the rise
    of the peak over it, the part's transient)."""
    print("| mesh | tetrahedra | unknowns | stage | resident per rank (MiB) | peak per rank (MiB) | rank 0 / rank 1 |")
    print("|---|---|---|---|---|---|---|")
    for run in results:
        rows = {row["stage"]: row for row in run["stages"]}
        cells, unknowns = rows["read"]["cells"], rows.get("space", {}).get("unknowns")
        for stage, row in rows.items():
            rss, peak = row["rss_mib_per_rank"], row["peak_mib_per_rank"]
            print(f"| {run['mesh']} | {cells:,} | {f'{unknowns:,}' if unknowns else ''} | {stage} | "
                  f"{' / '.join(f'{v:,.0f}' for v in rss)} | {' / '.join(f'{v:,.0f}' for v in peak)} | "
                  f"{peak[0] / peak[1]:.2f} |")
    print("\n| part | " + " | ".join(run["mesh"] for run in results) + " |")
    print("|---|" + "---|" * len(results))
    print("| fixed per rank (MiB) | " + " | ".join(f"{run['stages'][0]['rss_mib_per_rank'][0]:.0f}"
                                               for run in results) + " |")
    for stage, name in PARTS.items():
        cells = []
        for run in results:
            rows = [row["stage"] for row in run["stages"]]
            unknowns = next((row["unknowns"] for row in run["stages"] if "unknowns" in row), None)
            if stage not in rows or unknowns is None:
                cells.append("")
                continue
            now, before = run["stages"][rows.index(stage)], run["stages"][rows.index(stage) - 1]
            rise = (sum(now["rss_mib_per_rank"]) - sum(before["rss_mib_per_rank"])) * 2**20 / unknowns
            peak = (sum(now["peak_mib_per_rank"]) - sum(before["rss_mib_per_rank"])) * 2**20 / unknowns
            its = f", {now['krylov_iterations']} iterations" if "krylov_iterations" in now else ""
            cells.append(f"{rise:,.0f} ({peak:,.0f}){its}")
        print(f"| {name} (bytes per unknown) | " + " | ".join(cells) + " |")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("meshes", nargs="*", help="XDMF meshes of the 3D-1Z duct (cosserat-fsi mesh --format xdmf)")
    parser.add_argument("--stages", nargs="+", choices=STAGES, default=["read"], help="the last one is where it stops")
    parser.add_argument("--out", default="runs/big_mesh_memory")
    parser.add_argument("--min-free-gb", type=float, default=3.0, help="stop when the machine has less available")
    parser.add_argument("--max-gb", type=float, default=11.5, help="stop when the run's processes hold more")
    parser.add_argument("--solver", default="auto", choices=("auto", "iterative", "direct"),
                        help="solver.type (auto: MUMPS below 500,000 unknowns)")
    parser.add_argument("--table", action="store_true", help="print OUT/memory.json's tables (no run)")
    parser.add_argument("--child", nargs=3, help=argparse.SUPPRESS)  # SCENE LAST-STAGE SOLVER
    args = parser.parse_args()
    if args.child:
        return stages(*args.child)
    last = max(args.stages, key=STAGES.index)
    out = Path(args.out).resolve()
    out.mkdir(parents=True, exist_ok=True)
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(p for p in (str(REPO), os.environ.get("PYTHONPATH")) if p),
           "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"}
    results = json.loads((out / "memory.json").read_text()) if (out / "memory.json").exists() else []
    if args.table:
        return table(results)
    for mesh in map(Path, args.meshes):
        scene = out / f"{mesh.stem}.yaml"
        scene.write_text(XDMF_SCENE.format(path=mesh.resolve()))
        argv = [*launcher(), sys.executable, __file__, "--child", str(scene), last, args.solver]
        rows, stopped = run_watched(argv, env, args.min_free_gb, args.max_gb)
        results.append({"mesh": mesh.name, "solver": args.solver, "last_stage": last, "stopped": stopped,
                        "stages": rows})
        (out / "memory.json").write_text(json.dumps(results, indent=1) + "\n")
        if stopped:
            print(json.dumps({"mesh": mesh.name, "stopped": stopped}), flush=True)


if __name__ == "__main__":
    main()
