"""Cost of one time step, per phase, on a given scene (benchmark script, not a test).

    python campaigns/bench.py [--config configs/turek_hron_cfd3.yaml] [--set KEY=VALUE ...]
                                 [--steps 200] [--json docs/perf/NAME.json]
    mpirun -n 2 python campaigns/bench.py ...

Reports, per step: backtracking, right-hand side assembly, the solve with the factorisation reused, and,
for comparison, a fresh MUMPS factorisation + solve of the same matrix (the median of
``--fresh-repeats``: the cost a solver that refactorises every step would pay). ``--json`` stores
the figures; ``--report`` turns every stored JSON into the step-cost table of docs/perf_step_cost.md,
"Cost of one step".
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
os.environ.setdefault("COSSERAT_FSI_MESH_CACHE", str(ROOT / "meshes"))


def measure(config: str, overrides: list[str], steps: int, fresh_repeats: int = 5) -> dict:
    from mpi4py import MPI
    from petsc4py import PETSc

    from cosserat_fsi import compat
    from cosserat_fsi.config import load_scene
    from cosserat_fsi.app.runner import load_mesh
    from cosserat_fsi.simulation import Simulation

    comm = MPI.COMM_WORLD
    scene = load_scene(config, ["time.tolerance=null", *overrides])  # a step's cost at the scene's fixed dt
    t0 = time.perf_counter()
    mesh, ct, ft, _ = load_mesh(scene, comm)
    sim = Simulation(scene, mesh, ct, ft, comm)
    setup = time.perf_counter() - t0
    sim.run(sim.order)  # JIT, first factorisation (BDF2: and its own matrix)
    sim.timers.totals.clear()
    solver = sim.stepper.solver
    counts = (getattr(solver, "factorisations", 0), getattr(solver, "krylov_iterations", 0))
    comm.Barrier()
    t0 = time.perf_counter()
    sim.run(sim.step_count + steps)
    comm.Barrier()
    per_step = (time.perf_counter() - t0) / steps
    phases = {k: v / steps for k, v in sim.timers.totals.items()}
    # a fresh factorisation + solve of the same matrix: the refactorise-every-step floor; the median of
    # ``fresh_repeats`` (a new KSP each time: symbolic and numeric factorisation; one alone varies by ±10 %)
    x = sim.stepper.A.createVecRight()
    fresh_all = []
    for _ in range(fresh_repeats):
        ksp = PETSc.KSP().create(comm)
        ksp.setType("preonly")
        ksp.getPC().setType("lu")
        ksp.getPC().setFactorSolverType("mumps")
        ksp.setOperators(sim.stepper.A)
        comm.Barrier()
        t0 = time.perf_counter()
        ksp.solve(sim.stepper.b, x)
        comm.Barrier()
        fresh_all.append(time.perf_counter() - t0)
        ksp.destroy()
    fresh = float(np.median(fresh_all))
    return {
        "stack": f"dolfinx {compat.dolfinx.__version__}", "ranks": comm.size, "config": str(config),
        "overrides": overrides, "scheme": scene.time.scheme, "dt": scene.time.dt,
        "vertices": mesh.topology.index_map(0).size_global, "dofs": sim.num_dofs()["total"],
        "setup_s": setup, "per_step_s": per_step, "phases_s": phases, "fresh_factor_solve_s": fresh,
        "fresh_factor_solve_all_s": fresh_all,
        "factorisations_per_step": (getattr(solver, "factorisations", 0) - counts[0]) / steps,
        "krylov_iterations_per_step": (getattr(solver, "krylov_iterations", 0) - counts[1]) / steps,
    }


def report(paths) -> str:
    """The step-cost table of docs/perf_step_cost.md, "Cost of one step", from stored JSON files.

    *step / fresh*: the whole step against one fresh MUMPS factorisation + solve of its matrix (the floor
    of a solver that refactorises every step). *rest share*: everything but the solve (assembly,
    back-tracking, mesh motion) as a share of a step that would refactorise, rest / (rest + fresh).
    """
    rows = ["| stack | ranks | scene | vertices | dofs | scheme | s/step | assemble matrix | backtrack | rhs | "
            "solve (reused LU) | mesh motion | fresh LU + solve | step / fresh | rest share |",
            "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for path in sorted(paths):
        r = json.loads(Path(path).read_text())
        p = r["phases_s"]
        scene = Path(r["config"]).stem + "".join(f" {o}" for o in r["overrides"])
        rest = r["per_step_s"] - p.get("solve", 0.0)
        fresh = r["fresh_factor_solve_s"]
        rows.append(f"| {r['stack']} | {r['ranks']} | {scene} | {r['vertices']:,} | {r['dofs']:,} | {r['scheme']} | "
                    f"{r['per_step_s']:.4f} | {p.get('assemble_matrix', 0):.4f} | {p.get('backtrack', 0):.4f} | "
                    f"{p.get('assemble_vector', 0):.4f} | {p.get('solve', 0):.4f} | {p.get('mesh_motion', 0):.4f} | "
                    f"{fresh:.4f} | {r['per_step_s'] / fresh:.2f} | {rest / (rest + fresh):.0%} |")
    return "\n".join(rows)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python campaigns/bench.py", description=__doc__.splitlines()[0])
    parser.add_argument("--config", default=str(ROOT / "configs/turek_hron_cfd3.yaml"))
    parser.add_argument("--set", action="append", default=[])
    parser.add_argument("--steps", type=int, default=200)
    parser.add_argument("--json")
    parser.add_argument("--fresh-repeats", dest="fresh_repeats", type=int, default=5,
                        help="fresh factorisations + solves timed after the steps (their median is reported)")
    parser.add_argument("--report", nargs="*", help="JSON files to tabulate (markdown on stdout)")
    args = parser.parse_args(argv)
    if args.report is not None:
        print(report(args.report))
        return 0
    result = measure(args.config, args.set, args.steps, args.fresh_repeats)
    from mpi4py import MPI

    if MPI.COMM_WORLD.rank == 0:
        print(json.dumps(result, indent=2))
        if args.json:
            Path(args.json).parent.mkdir(parents=True, exist_ok=True)
            Path(args.json).write_text(json.dumps(result, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
