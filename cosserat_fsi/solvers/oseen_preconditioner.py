"""The iterative solver's pieces for a steady Newton step (seed eqs. 31–32 without the time derivative: an
Oseen operator with the convecting velocity w of the iterate):

- the Schur complement by the pressure convection–diffusion approximation S⁻¹ ≈ −(ν I + A_p⁻¹ K_p) M_p⁻¹
  (Olshanskii & Vassilevski 2007, with the boundary conditions of Blechta & Řehoř's "BRM2": A_p with p = 0 on
  the open boundaries, K_p = ρ(w·∇p, p̃) − ρ(min(w·n, 0) p, p̃) on the prescribed-velocity ones), M_p⁻¹ by
  conjugate gradients, A_p⁻¹ by one AMG cycle;
- the velocity block's preconditioning matrix: the Jacobian plus a streamline diffusion ρδ((w·∇)δu, (w·∇)v),
  which the AMG needs where the cell Péclet number is large (its cycle does not reduce the error of the
  Galerkin convection there); the outer Krylov solve keeps the Jacobian.
"""

from __future__ import annotations

import ufl
from petsc4py import PETSc

from .. import compat
from .pressure_matrices import inner_solver, pressure_laplace_matrix, viscosity

STREAMLINE_SCALE = 0.25
"""δ = STREAMLINE_SCALE · h/(2|w|) (1 − 1/Pe_h), Pe_h = |w| h/(2ν) > 1 (Elman, Silvester & Wathen's weight
scaled): 1, 0.5, 0.25, 0.125 of it measured 169 / 114 / 88 / 101 FGMRES iterations on 3D-1Z's converged
Newton step (level 0), 1/16 did not converge (docs/perf_linear_solvers.md,
"Steady Newton: PCD with outflow conditions and a streamline-diffusion AMG")."""


STREAMLINE_DEGREE = 6
"""Quadrature degree of the streamline diffusion: that of ((w·∇)δu, (w·∇)v) with w and δu of degree 2 (UFL's
estimate, with δ's square root and conditional, took 1,000 points per tetrahedron)."""


def streamline_diffusion(problem, velocity, du, v):
    """ρ δ_K ((w·∇)δu, (w·∇)v) with the cell-wise δ_K of :data:`STREAMLINE_SCALE` (h the cell diameter)."""
    rho = problem.rho
    nu = viscosity(problem) / float(problem.scene.fluid.rho)
    h = ufl.CellDiameter(problem.mesh)
    speed = ufl.sqrt(ufl.dot(velocity, velocity) + 1e-300)
    peclet = speed * h / (2 * nu)
    delta = ufl.conditional(ufl.gt(peclet, 1.0), STREAMLINE_SCALE * h / (2 * speed) * (1 - 1 / peclet), 0.0)
    dx = ufl.dx(domain=problem.mesh, metadata={"quadrature_degree": STREAMLINE_DEGREE})
    return rho * delta * ufl.inner(ufl.grad(du) * velocity, ufl.grad(v) * velocity) * dx


def convection_form(problem, velocity):
    """K_p = ρ(w·∇p, p̃) − ρ(min(w·n, 0) p, p̃) on the boundaries with a prescribed velocity (the inflow's
    Robin term of the pressure convection–diffusion operator), compiled."""
    mesh = problem.mesh
    Q = problem.space.space("pressure")
    p, q = ufl.TrialFunction(Q), ufl.TestFunction(Q)
    form = problem.rho * ufl.dot(velocity, ufl.grad(p)) * q * ufl.dx(domain=mesh)
    ds = ufl.Measure("ds", domain=mesh, subdomain_data=problem.facet_tags)
    n = ufl.FacetNormal(mesh)
    inflow = ufl.min_value(ufl.dot(velocity, n), 0.0)
    for name, bc in problem.conditions().items():
        if bc.type == "velocity" and name in problem.facet_ids:
            form = form - problem.rho * inflow * p * q * ds(problem.facet_ids[name])
    return compat.form(form)


class PressureConvectionDiffusion:
    """S⁻¹ ≈ −(ν I + A_p⁻¹ K_p) M_p⁻¹ as a petsc4py ``python`` PC (module docstring); K_p reassembled with each
    Newton iterate (:meth:`update`)."""

    MASS_RTOL = 1e-10

    def __init__(self, problem, mass, order, velocity, nu, amg, comm):
        self.nu, self.order = nu, order
        self.mass_ksp = ksp = PETSc.KSP().create(comm)
        ksp.setOperators(mass)
        ksp.setType("cg")
        ksp.getPC().setType("jacobi")
        ksp.setTolerances(rtol=self.MASS_RTOL, max_it=500)
        ksp.setUp()
        self.laplace = pressure_laplace_matrix(problem, order)
        self.lap_ksp = inner_solver(self.laplace, amg, comm)
        self.kp_form = convection_form(problem, velocity)
        self.full = self.Kp = None
        self.t, self.s = mass.createVecLeft(), mass.createVecLeft()

    def update(self):
        """K_p of the current iterate."""
        import dolfinx.fem.petsc as fem_petsc

        if self.full is None:
            self.full = fem_petsc.assemble_matrix(self.kp_form)
        else:
            self.full.zeroEntries()
            fem_petsc.assemble_matrix(self.full, self.kp_form)
        self.full.assemble()
        self.Kp = self.full.createSubMatrix(self.order, self.order, submat=self.Kp)

    def setUp(self, pc):
        pass

    def apply(self, pc, x, y):
        self.mass_ksp.solve(x, self.t)
        self.Kp.mult(self.t, self.s)
        self.lap_ksp.solve(self.s, y)
        y.axpy(self.nu, self.t)
        y.scale(-1.0)

    def view(self, pc, viewer):
        viewer.printfASCII(f"pressure convection-diffusion: -(nu I + A_p^-1 K_p) M_p^-1, nu = {self.nu:g}\n")
