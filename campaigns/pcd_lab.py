"""The steady Newton step's Schur approximations and velocity-block matrices, variant by variant
(docs/perf_linear_solvers.md, "Steady Newton: PCD with outflow conditions and a streamline-diffusion AMG").

    python campaigns/pcd_lab.py CONFIG LEVEL VARIANTS_JSON [--at rest solution] [--set k=v ...]

As campaigns/newton_block_lab.py (the Jacobian at rest and at the MUMPS solution, which is cached in
/tmp/pcd_lab_*.npy
a random right-hand side
FGMRES to 1e-8, at most ``"max"`` (300) iterations), with the
Schur approximation replaced by the variant's: ``"pcd": "brm1"`` −M_p⁻¹(ν I + K_p A_p⁻¹) with p = 0 on the
inflow (the form the code had before), ``"brm2"`` −(ν I + A_p⁻¹K_p)M_p⁻¹ with p = 0 on the open boundaries
and the inflow term in K_p (the code's)
``"mass"``: ``diag`` (1/diag M_p), ``cg`` (CG to 1e-10)

``"lap"``: ``amg`` (one BoomerAMG cycle) or ``lu``. ``"sd": s`` builds the fieldsplit on the Jacobian plus s
times Elman's streamline diffusion (the code's scale is oseen_preconditioner.STREAMLINE_SCALE), ``"picard": 1``
without the reaction term (∇w)δu
``"opts"``: solver.petsc_options.
"""
import argparse
import json
import os
import sys
import time

from mpi4py import MPI
from petsc4py import PETSc
import dolfinx.fem.petsc as fem_petsc
import ufl

from cosserat_fsi import compat
from cosserat_fsi.solvers import pressure_matrices as pm

sys.path.insert(0, os.path.dirname(__file__))
import newton_block_lab as lab  # noqa: E402


def sd_matrix(sim, bcs, scale=1.0, picard=False, A=None):
    """A + ρ scale·δ((w·∇)δu, (w·∇)v) (δ Elman's weight), without the reaction term if ``picard``."""
    problem = sim.problem
    W = problem.space.W
    du, v = problem.split(ufl.TrialFunction(W))[0], problem.split(ufl.TestFunction(W))[0]
    w = sim.stepper.convecting_velocity()
    nu = pm.viscosity(problem) / float(problem.scene.fluid.rho)
    h = ufl.CellDiameter(problem.mesh)
    wn = ufl.sqrt(ufl.dot(w, w) + 1e-30)
    pe = wn * h / (2 * nu)
    delta = ufl.conditional(ufl.gt(pe, 1.0), h / (2 * wn) * (1 - 1 / pe), 0.0) * scale
    form = problem.rho * delta * ufl.inner(ufl.grad(du) * w, ufl.grad(v) * w) * ufl.dx if scale else None
    if picard:
        form = (form if form is not None else 0) - problem.rho * ufl.inner(ufl.grad(w) * du, v) * ufl.dx
    R = fem_petsc.assemble_matrix(compat.form(form), bcs=bcs, diagonal=0.0)
    R.assemble()
    P = A.copy()
    P.axpy(1.0, R, structure=PETSc.Mat.Structure.SUBSET_NONZERO_PATTERN)
    return P


def _inflow(kind: str) -> bool:
    """BRM1's p = 0: the boundaries with a prescribed velocity."""
    return kind == "velocity"


class LabPCD:
    """The variant's Schur approximation, a petsc4py python PC."""

    def __init__(self, sim, problem, order, nu, variant, comm):
        self.nu = nu
        kind = variant.get("pcd", "brm1")
        self.kind = kind
        Q = problem.space.space("pressure")
        mesh = problem.mesh
        ds = ufl.Measure("ds", domain=mesh, subdomain_data=problem.facet_tags)
        w = sim.stepper.convecting_velocity()
        M = pm.pressure_mass_matrix(problem, order)
        dirichlet = _inflow if kind == "brm1" else pm._open
        L = pm.pressure_laplace_matrix(problem, order, dirichlet)
        n = ufl.FacetNormal(mesh)
        p, q = ufl.TrialFunction(Q), ufl.TestFunction(Q)
        kform = problem.rho * ufl.dot(w, ufl.grad(p)) * q * ufl.dx
        if kind == "brm2":
            for name, bc in problem.conditions().items():
                if bc.type == "velocity" and name in problem.facet_ids:
                    kform = kform - problem.rho * ufl.dot(w, n) * p * q * ds(problem.facet_ids[name])
        K = fem_petsc.assemble_matrix(compat.form(kform))
        K.assemble()
        self.K = K.createSubMatrix(order, order)
        self.mk = self._ksp(M, variant.get("mass", "diag"), comm)
        self.lk = self._ksp(L, variant.get("lap", "amg"), comm)
        self.t, self.s = M.createVecLeft(), M.createVecLeft()
        self.keep = (M, L)

    def _ksp(self, A, how, comm):
        ksp = PETSc.KSP().create(comm)
        ksp.setOperators(A)
        pc = ksp.getPC()
        kinds = {"diag": ("preonly", "jacobi"), "cg": ("cg", "jacobi"), "amg": ("preonly", "hypre"),
                 "lu": ("preonly", "lu")}
        ksp.setType(kinds[how][0])
        pc.setType(kinds[how][1])
        if how == "cg":
            ksp.setTolerances(rtol=1e-10, max_it=500)
        if how == "lu":
            pc.setFactorSolverType("mumps")
        ksp.setUp()
        return ksp

    def setUp(self, pc):
        pass

    def apply(self, pc, x, y):
        if self.kind == "brm1":  # -M^-1 (nu I + K A^-1) x
            self.lk.solve(x, self.t)
            self.K.mult(self.t, self.s)
            self.s.axpy(self.nu, x)
            self.mk.solve(self.s, y)
        else:  # -(nu I + A^-1 K) M^-1 x
            self.mk.solve(x, self.t)
            self.K.mult(self.t, self.s)
            self.lk.solve(self.s, y)
            y.axpy(self.nu, self.t)
        y.scale(-1.0)


def run(sim, A, state, variant, comm, bcs):
    """FGMRES with the variant: (iterations, outcome)."""
    from cosserat_fsi.errors import DivergenceError
    from cosserat_fsi.solvers.linear_solver import LinearSolver
    stepper = sim.stepper
    config = sim.scene.solver.model_copy(update={"type": "iterative", "krylov_rtol": 1e-8,
                                                 "max_iterations": variant.get("max", 300),
                                                 "petsc_options": variant.get("opts", {})})
    solver = LinearSolver(config, comm, problem=sim.problem, steady=True)
    stepper.solution.x.array[:] = state
    solver.convecting_velocity = stepper.convecting_velocity()
    P = None
    if variant.get("sd") is not None or variant.get("picard"):
        P = sd_matrix(sim, bcs, float(variant.get("sd", 0.0)), bool(variant.get("picard")), A)
    y = A.createVecRight()
    try:
        solver.set_operator(A)
        if P is not None:
            solver.ksp.setOperators(A, P)
        if variant.get("pcd"):
            primal, pressure, order, mass = solver.preconditioner_objects
            ctx = LabPCD(sim, sim.problem, order, pm.viscosity(sim.problem), variant, comm)
            solver.ksp.getPC().getFieldSplitSubKSP()[1].getPC().setPythonContext(ctx)
            solver._lab = ctx
        solver.solve(lab._right_hand_side(A), y)
        outcome = "converged"
    except DivergenceError as exc:
        outcome = str(exc).split(";")[0][:60]
    its = solver.ksp.getIterationNumber()
    solver.ksp.destroy()
    return its, outcome


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("config")
    ap.add_argument("level", type=int)
    ap.add_argument("variants", type=json.loads)
    ap.add_argument("--at", nargs="+", default=["rest", "solution"])
    ap.add_argument("--set", nargs="*", default=[])
    args = ap.parse_args()
    comm = MPI.COMM_WORLD
    name = os.path.splitext(os.path.basename(args.config))[0]
    cache = f"/tmp/pcd_lab_{name}_L{args.level}_n{comm.size}_r{comm.rank}.npy"
    for where, sim, newton, A, state in lab.jacobians(args.config, args.level, args.set, args.at, comm, cache):
        for variant in args.variants:
            t0 = time.perf_counter()
            its, outcome = run(sim, A, state, variant, comm, newton.bcs)
            if comm.rank == 0:
                print(f"L{args.level} {where:8s} {variant['name']:28s} {its:4d} its "
                      f"{time.perf_counter() - t0:7.1f} s {outcome}", flush=True)


if __name__ == "__main__":
    main()
