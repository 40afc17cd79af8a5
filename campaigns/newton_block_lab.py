"""The linear systems of a steady Newton step, solved by variants of the iterative solver
(docs/perf_linear_solvers.md, "Where the iterations go: exact blocks" and "What did not work for the steady path").

    python campaigns/newton_block_lab.py CONFIG LEVEL VARIANTS_JSON [--at rest solution] [--block] [--set k=v ...]
    python campaigns/newton_block_lab.py CONFIG LEVEL '[]' --at rest --mumps-estimate

The scene (a steady one, e.g. configs/schaefer_turek_3d1z.yaml) at geometry level LEVEL: its Newton Jacobian
at rest (the boundary data only: nearly Stokes) and at its solution (converged by MUMPS first: the full
convection and the Newton reaction term (∇w)u). The right-hand side is J x for a random x with zero Dirichlet
rows (as a Newton correction has), so that the Dirichlet rows, which every preconditioner solves exactly, do
not make up most of ‖b‖. Each variant is ``{"name": ..., "opts": {petsc option: value}, "schur": "mass"?}``:
the opts go to ``solver.petsc_options`` of ``solver.type: iterative`` (FGMRES to rtol 1e-8, at most 300
iterations); ``"schur": "mass"`` drops the convection from the Schur approximation; ``"pmat": "picard"`` builds
the preconditioner on the Picard (Oseen) operator, the Jacobian without its reaction term (∇w)δu. With
``--block`` only the velocity block is solved, by GMRES(200) to rtol 1e-8, with ``"pc"`` (default hypre) and
the opts under the prefix ``lab_``. Prints one line per (state, variant): iterations, seconds, outcome. With
``--mumps-estimate`` MUMPS analyses the Jacobian (the ordering and symbolic factorisation of the code's direct
solver, no numerical factorisation: it is stopped by a 1 MB working-memory limit) and prints its estimates: the
factorisation's memory (INFOG(16): the largest rank, INFOG(17): all ranks, in MB), the factors' entries
(INFOG(3)) and the elimination's flops (RINFOG(1)): what MUMPS would need at a size that does not fit.
"""

from __future__ import annotations

import argparse
import json
import time

from mpi4py import MPI
from petsc4py import PETSc


def _right_hand_side(A) -> PETSc.Vec:
    """J x, x random, zero on the Dirichlet rows (those whose diagonal dolfinx set to exactly 1)."""
    x, b = A.createVecRight(), A.createVecLeft()
    x.setRandom()
    A.mult(x, b)
    b.array[A.getDiagonal().array == 1.0] = 0.0
    return b


def _full(sim, A, state, variant, comm, P=None) -> tuple[int, str]:
    """FGMRES with the code's fieldsplit Schur preconditioner and the variant's options."""
    from cosserat_fsi.errors import DivergenceError
    from cosserat_fsi.solvers.linear_solver import LinearSolver

    stepper = sim.stepper
    config = sim.scene.solver.model_copy(update={"type": "iterative", "krylov_rtol": 1e-8, "max_iterations": 300,
                                                 "petsc_options": variant.get("opts", {})})
    solver = LinearSolver(config, comm, problem=sim.problem, steady=True)
    stepper.solution.x.array[:] = state
    solver.convecting_velocity = None if variant.get("schur") == "mass" else stepper.convecting_velocity()
    y = A.createVecRight()
    try:
        solver.set_operator(A)
        if P is not None:  # the fieldsplit's blocks from P (the outer Krylov solve stays on A)
            solver.ksp.setOperators(A, P)
        solver.solve(_right_hand_side(A), y)
        outcome = "converged"
    except DivergenceError as exc:
        outcome = str(exc).split(";")[0]
    its = solver.ksp.getIterationNumber()
    solver.ksp.destroy()
    return its, outcome


def picard_matrix(sim, A, bcs) -> PETSc.Mat:
    """A − ρ((δu·∇)w, ũ): the Newton Jacobian without its reaction term (∇w)δu, w the current iterate's
    velocity — the Picard (Oseen) operator, as a preconditioning matrix (Dirichlet rows kept)."""
    import dolfinx.fem.petsc as fem_petsc
    import ufl

    from cosserat_fsi import compat

    problem = sim.problem
    W = problem.space.W
    du, v = problem.split(ufl.TrialFunction(W))[0], problem.split(ufl.TestFunction(W))[0]
    w = sim.stepper.convecting_velocity()
    R = fem_petsc.assemble_matrix(compat.form(problem.rho * ufl.inner(ufl.grad(w) * du, v) * ufl.dx), bcs=bcs,
                                  diagonal=0.0)
    R.assemble()
    P = A.copy()
    P.axpy(-1.0, R, structure=PETSc.Mat.Structure.SUBSET_NONZERO_PATTERN)
    return P


def _block(sim, A, variant, comm, P=None) -> tuple[int, str]:
    """The velocity block alone by GMRES(200) with the variant's PC (built on ``P``'s block when given)."""
    from cosserat_fsi.solvers.block_preconditioner import primal_index_set

    primal = primal_index_set(sim.problem.space, comm)
    K = A.createSubMatrix(primal, primal)
    options = PETSc.Options()
    for key, value in variant.get("opts", {}).items():
        options[f"lab_{key}"] = value
    ksp = PETSc.KSP().create(comm)
    ksp.setOptionsPrefix("lab_")
    ksp.setOperators(K, P.createSubMatrix(primal, primal) if P is not None else K)
    ksp.setType("gmres")
    ksp.setGMRESRestart(200)
    ksp.setTolerances(rtol=1e-8, max_it=300)
    ksp.getPC().setType(variant.get("pc", "hypre"))
    ksp.setFromOptions()
    ksp.solve(_right_hand_side(K), K.createVecRight())
    for key in variant.get("opts", {}):
        options.delValue(f"lab_{key}")
    its, reason = ksp.getIterationNumber(), ksp.getConvergedReason()
    ksp.destroy()
    return its, "converged" if reason > 0 else f"not converged (reason {reason})"


def _mumps_estimate(sim, A, comm) -> str:
    """MUMPS's analysis of A by the scene's direct solver (solvers/linear_solver.py: its controls), stopped
    before the numerical factorisation."""
    from cosserat_fsi.solvers.linear_solver import LinearSolver

    solver = LinearSolver(sim.scene.solver.model_copy(update={"type": "direct", "petsc_options": {}}), comm)
    solver.set_operator(A)
    pc = solver.ksp.getPC()
    F = pc.getFactorMatrix()
    F.setMumpsIcntl(23, 1)  # 1 MB of working memory allowed: the factorisation stops after the analysis (-19)
    pc.setUp()
    stopped, largest, total = F.getMumpsInfog(1), F.getMumpsInfog(16), F.getMumpsInfog(17)
    entries = F.getMumpsInfog(3)  # the factors' entries (estimated; negative: millions)
    entries = -1e6 * entries if entries < 0 else entries
    flops = F.getMumpsRinfog(1)  # the elimination's floating-point operations (estimated)
    solver.ksp.destroy()
    return (f"MUMPS analysis (INFOG(1) = {stopped}): factorisation memory {largest} MB on the largest rank, "
            f"{total} MB in all; {entries:.3g} entries in the factors, {flops:.3g} flops")


def jacobians(config: str, level: int, sets: list[str], at: list[str], comm, cache: str | None = None):
    """Yield (state name, the Simulation, its Newton, the Jacobian, the state's array) for each of ``at``
    ("rest": the boundary data only; "solution": MUMPS's converged Newton, read from ``cache`` (a path with
    the rank in it) if that exists, else solved and written there)."""
    import os

    import dolfinx.fem.petsc as fem_petsc
    import numpy as np

    from cosserat_fsi.app.runner import load_mesh
    from cosserat_fsi.config import load_scene
    from cosserat_fsi.simulation import Simulation

    scene = load_scene(config, [f"geometry.level={level}", "solver.type=direct", *sets])
    sim = Simulation(scene, *load_mesh(scene, comm)[:3], comm)
    stepper = sim.stepper
    newton = stepper._newton()
    stepper.state.to_mixed(stepper.solution, stepper.space)
    newton.apply_bcs()
    for where in at:
        if where == "solution":
            if cache is not None and os.path.exists(cache):
                stepper.solution.x.array[:] = np.load(cache)
            else:
                start = time.perf_counter()
                sim.step()
                if cache is not None:
                    np.save(cache, stepper.solution.x.array)
                if comm.rank == 0:
                    print(f"MUMPS Newton: {time.perf_counter() - start:.1f} s", flush=True)
        newton.A.zeroEntries()
        fem_petsc.assemble_matrix(newton.A, newton.J, bcs=newton.bcs)
        newton.A.assemble()
        yield where, sim, newton, newton.A.copy(), stepper.solution.x.array.copy()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("config")
    parser.add_argument("level", type=int)
    parser.add_argument("variants", type=json.loads)
    parser.add_argument("--at", nargs="+", default=["rest", "solution"], choices=["rest", "solution"])
    parser.add_argument("--block", action="store_true", help="the velocity block alone")
    parser.add_argument("--mumps-estimate", action="store_true", help="MUMPS's memory estimate (analysis only)")
    parser.add_argument("--set", nargs="*", default=[])
    args = parser.parse_args()
    comm = MPI.COMM_WORLD
    for where, sim, newton, A, state in jacobians(args.config, args.level, args.set, args.at, comm):
        if args.mumps_estimate:
            start = time.perf_counter()
            line = _mumps_estimate(sim, A, comm)
            if comm.rank == 0:
                print(f"{where:8s} {A.getSize()[0]} unknowns: {line} ({time.perf_counter() - start:.1f} s)", flush=True)
        for variant in args.variants:
            start = time.perf_counter()
            P = picard_matrix(sim, A, newton.bcs) if variant.get("pmat") == "picard" else None
            its, outcome = (_block(sim, A, variant, comm, P) if args.block
                            else _full(sim, A, state, variant, comm, P))
            if comm.rank == 0:
                print(f"{where:8s} {variant['name']:32s} {its:4d} iterations {time.perf_counter() - start:7.1f} s  "
                      f"{outcome}", flush=True)


if __name__ == "__main__":
    main()
