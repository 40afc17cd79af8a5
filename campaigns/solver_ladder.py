"""Direct (MUMPS) against iterative (FGMRES + Schur fieldsplit + AMG) per time step, on 2D and 3D ladders
(docs/perf_scale_3d.md, "Direct vs iterative per time step" and "3D time steps: the cavity and the flag";
docs/perf_linear_solvers.md, "Iterations under refinement and ranks").

    python campaigns/solver_ladder.py [--quick] [--ranks 1 2] [--cases ...] [--solvers direct iterative]
                                      [--amg auto] [--set key=value ...] [--out docs/runs/solver_ladder.json]

A case is inline scene sections or a shipped config with overrides (FSI3: the first 10 steps from rest, the
fixed δt = 0.005; fsi3d: the 3D flag, 4 steps, MUMPS keeping its factorisation, fsi3d_refactorised: a
factorisation every step; 3d_cavity: the lid-driven cube). Per run: the linear solver's counts (solves,
Krylov iterations mean and largest per solve), CPU and wall time per step, peak memory per rank. ``--set``
overrides scene keys of every config case (e.g. ``solver.krylov_rtol=1e-8``).

Each case is a fixed-mesh BDF2 scene run for 4 steps in a subprocess (serial, or under the stack's
mpirun): step 1 includes the first factorisation (direct) or the AMG setup (iterative), step 2 the second
(the BDF2 coefficient changes once), steps 3-4 are the steady per-step cost (back-substitution, or the
Krylov iterations). Per step: CPU seconds of rank 0's process (the machine may be shared: CPU time, not wall
time, is comparable), and the peak resident memory of the largest rank. One BLAS thread per rank.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import time
from pathlib import Path

CASES = {  # name -> (scene sections, levels)
    "2d_cavity": ({"geometry": {"name": "square"}, "fluid": {"rho": 1.0, "mu": 0.01}, "inflow": {"u_mean": 1.0},
                   "time": {"dt": 0.01, "t_end": 0.04, "scheme": "characteristics2"}}, (2, 3, 4)),
    "3d_cavity": ({"geometry": {"name": "cube"}, "fluid": {"rho": 1.0, "mu": 0.01, "body_force": [0.0, 0.0, 0.0]},
                   "inflow": {"u_mean": 1.0},
                   "time": {"dt": 0.01, "t_end": 0.04, "scheme": "characteristics2"}}, (1, 2, 3)),
}
FSI3 = ({"config": "configs/turek_hron_fsi3.yaml", "set": ["time.tolerance=null"]}, (0, 1, 2))
CASES["fsi3"] = FSI3
CASES["fsi3d"] = ({"config": "configs/turek_hron_3d_fsi.yaml", "set": []}, (0, 1, 2))
CASES["fsi3d_refactorised"] = ({"config": "configs/turek_hron_3d_fsi.yaml",  # MUMPS factorises every step
                                "set": ["solver.reuse_factorization=false"]}, (0, 1))
STEPS = {"fsi3": 10, "fsi3d": 4, "fsi3d_refactorised": 4}
"""Steps per run (default 4)."""


def one(sections: dict, steps: int = 4) -> dict:
    """Run the scene for ``steps`` steps on COMM_WORLD; CPU and wall seconds per step, peak RSS (GB), the
    linear solver's counts."""
    import numpy as np
    from mpi4py import MPI

    from cosserat_fsi.app.runner import load_mesh
    from cosserat_fsi.config import validate_scene
    from cosserat_fsi.simulation import Simulation

    from cosserat_fsi.config import load_scene

    comm = MPI.COMM_WORLD
    if "config" in sections:
        scene = load_scene(sections["config"], sections["set"])
    else:
        scene = validate_scene(sections)
    mesh, ct, ft, _ = load_mesh(scene, comm)
    sim = Simulation(scene, mesh, ct, ft, comm)
    cpu, wall = [], []
    for _ in range(steps):
        c, w = time.process_time(), time.perf_counter()
        sim.step()
        cpu.append(time.process_time() - c)
        wall.append(time.perf_counter() - w)
    solver = sim.stepper.solver
    rss = comm.allreduce(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024**2, op=MPI.MAX)
    return {"dofs": sim.num_dofs()["total"], "ranks": comm.size, "cpu": np.round(cpu, 3).tolist(),
            "wall": np.round(wall, 3).tolist(), "peak_rss_gb": round(rss, 3),
            "krylov_iterations": getattr(solver, "krylov_iterations", None), "counts": solver.counts()}


def _launcher(ranks: int) -> list[str]:
    from cosserat_fsi.app.cases import mpi_launcher

    return [] if ranks == 1 else mpi_launcher(ranks)


def table(results: list[dict]) -> str:
    """The iterations-under-refinement table (markdown): per case, solver and level, the unknowns, Krylov
    iterations per solve (mean / largest) on each rank count, CPU per step after the first two (rank 0),
    peak memory per rank and per unknown."""
    rows = ["| case | solver | level | unknowns | iterations per solve (mean / max): 1 · 2 · 4 ranks "
            "| CPU per step (steps 3+, 1 rank) | peak RSS per rank (1 rank) | kB per unknown |",
            "|---|---|---|---|---|---|---|---|"]
    keys = sorted({(r["case"], r["solver"], r.get("amg") or "", r["level"]) for r in results if "counts" in r})
    for case, solver, amg, level in keys:
        key = (case, solver, amg, level)
        runs = {r["ranks"]: r for r in results
                if "counts" in r and (r["case"], r["solver"], r.get("amg") or "", r["level"]) == key}
        serial = runs.get(1)
        if serial is None:
            continue
        its = []
        for n in (1, 2, 4):
            k = runs.get(n, {}).get("counts", {}).get("krylov_iterations")
            its.append(f"{k['mean']:.1f} / {k['max']}" if k else "–")
        kind = serial["counts"]["type"].split(":")[0]
        name = f"{kind}, {serial['counts']['type'].split('AMG ')[-1]}" if kind == "iterative" else "MUMPS"
        cpu = sum(serial["cpu"][2:]) / max(len(serial["cpu"]) - 2, 1)
        counts = " · ".join(its) if solver == "iterative" else "–"
        per_unknown = 1e6 * serial["peak_rss_gb"] / serial["dofs"]
        rows.append(f"| {case} | {name} | {level} | {serial['dofs']:,} | {counts} | {cpu:.3f} s "
                    f"| {serial['peak_rss_gb']:.2f} GB | {per_unknown:.0f} |")
    return "\n".join(rows)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--ranks", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--quick", action="store_true", help="the two smallest levels only")
    parser.add_argument("--cases", nargs="+", default=list(CASES))
    parser.add_argument("--out", type=Path, default=Path("docs/runs/solver_ladder.json"))
    parser.add_argument("--solvers", nargs="+", default=["direct", "iterative"])
    parser.add_argument("--amg", default="auto", choices=["auto", "gamg", "hypre"])
    parser.add_argument("--set", nargs="*", default=[], help="scene overrides for the config cases")
    parser.add_argument("--one", help=argparse.SUPPRESS)  # internal: run one case (JSON sections)
    parser.add_argument("--steps", type=int, default=4, help=argparse.SUPPRESS)
    parser.add_argument("--table", action="store_true", help="print the markdown table of --out and stop")
    args = parser.parse_args()
    if args.one:
        result = one(json.loads(args.one), args.steps)
        from mpi4py import MPI

        if MPI.COMM_WORLD.rank == 0:
            print("RESULT " + json.dumps(result), flush=True)
        return
    if args.table:
        print(table(json.loads(args.out.read_text())))
        return
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"}
    results = json.loads(args.out.read_text()) if args.out.exists() else []
    done = {(r["case"], r["level"], r["solver"], r["ranks"], r.get("amg")) for r in results}
    for case in args.cases:
        sections, levels = CASES[case]
        for level in levels[:2] if args.quick else levels:
            for ranks in args.ranks:
                for solver in args.solvers:
                    amg = args.amg if solver == "iterative" else None
                    if (case, level, solver, ranks, amg) in done:
                        continue
                    scene = json.loads(json.dumps(sections))
                    if "config" in scene:
                        scene["set"] += [*args.set, f"geometry.level={level}", f"solver.type={solver}"]
                        scene["set"] += [f"solver.amg={amg}"] if amg else []
                    else:
                        scene["geometry"]["level"] = level
                        scene["solver"] = {"type": solver, **({"amg": amg} if amg else {})}
                    cmd = [*_launcher(ranks), sys.executable, __file__, "--one", json.dumps(scene),
                           "--steps", str(STEPS.get(case, 4))]
                    proc = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=7200)
                    line = [x for x in proc.stdout.splitlines() if x.startswith("RESULT ")]
                    if proc.returncode != 0 or not line:
                        print(f"{case} L{level} {solver} np{ranks}: failed\n{proc.stderr[-2000:]}", flush=True)
                        continue
                    result = {"case": case, "level": level, "solver": solver, "amg": amg, **json.loads(line[0][7:])}
                    results.append(result)
                    print(json.dumps(result), flush=True)
                    args.out.parent.mkdir(parents=True, exist_ok=True)
                    args.out.write_text(json.dumps(results, indent=1) + "\n")


if __name__ == "__main__":
    main()
