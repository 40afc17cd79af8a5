"""Fluid part of the monolithic system, time-continuous: seed eqs. (31) and (32) as residual forms.

The functions take the material acceleration (a UFL expression) from whoever discretises time, as Ambit's
``amom``, and return one residual form F(u, p, ω; ũ, p̃, τ̃) linear in the test functions:

* the characteristics scheme passes ``acceleration = (α u − α h)/δt`` with u the TrialFunction and splits
  F with ``ufl.lhs``/``ufl.rhs`` (first order: α = 1, h = u^n∘X^n; BDF2: α = 3/2,
  h = (4 u^n∘X¹ − u^{n−1}∘X²)/3); its history α h may live at quadrature points, hence ``dx_inertia``;
* a steady solver passes ``acceleration = grad(u) u`` with u a Function and differentiates F;
* the observables assemble :func:`cauchy_momentum_residual` with the solution for the residual forces.

Viscous convention: the seed writes (μ + μ_r) Du:Dũ with Du = ∇u + ∇uᵀ (eq. 18). Its strong form (23) has
(μ + μ_r)Δu, which the weak form only gives with a factor ½: ∫ μ Du:∇ũ = ½ ∫ μ Du:Dũ. We use the ½; the
Poiseuille solutions (tests) fix it. ``viscous_form="laplacian"`` uses (μ + μ_r) ∇u:∇ũ instead: the same
equations inside the domain when div u = 0, but its natural outflow condition is the benchmarks'
do-nothing condition μ ∂u/∂n − p n = 0, which Poiseuille flow satisfies.

The pressure penalty enters as −ζ (p, p̃) (the seed writes +ζ; the sign only selects which pressure the
pure-Dirichlet problem picks). problem/model.py passes ζ = solver.penalty/(μ + μ_r) in the fluid cells when the
velocity is prescribed on the whole boundary, else 0 (the boundary fixes the pressure; any ζ > 0 would remove
ζ ∫ p of the mass).
"""

from __future__ import annotations

import ufl

from .kinematics import D, curl


def viscous(u, v, viscosity, form: str):
    """½ ν Du:Dũ (``symmetric``, seed) or ν ∇u:∇ũ (``laplacian``)."""
    if form == "symmetric":
        return 0.5 * viscosity * ufl.inner(D(u), D(v))
    return viscosity * ufl.inner(ufl.grad(u), ufl.grad(v))


def viscous_stress(u, p, viscosity, form: str):
    """The stress whose natural boundary term the weak form has: ν Du − p I (``symmetric``: ½ ν Du:Dũ =
    ν Du:∇ũ) or ν ∇u − p I (``laplacian``)."""
    grad = D(u) if form == "symmetric" else ufl.grad(u)
    return viscosity * grad - p * ufl.Identity(len(u))


def momentum_residual(u, p, v, *, rho, acceleration, mu, body_force, dx, viscous_form: str = "laplacian",
                      dx_inertia=None, omega=None, mu_r=None) -> ufl.Form:
    """Seed eq. (31), fluid part, tested with ũ = ``v``:

    ∫ ρ a·ũ − p div ũ + ½ (μ + μ_r) Du:Dũ − 2μ_r (curl ω)·ũ − f·ũ       [or (μ + μ_r) ∇u:∇ũ].

    ``omega``/``mu_r`` None: the Newtonian fluid (no micro-rotation).
    """
    dx_inertia = dx if dx_inertia is None else dx_inertia
    internal = viscous(u, v, mu, viscous_form) - p * ufl.div(v)
    if omega is not None:
        internal = internal + viscous(u, v, mu_r, viscous_form) - 2 * mu_r * ufl.inner(curl(omega), v)
    return (rho * ufl.inner(acceleration, v) * dx_inertia + internal * dx
            - ufl.inner(body_force, v) * dx)


def continuity_residual(u, p, q, *, penalty, dx, divergence=None) -> ufl.Form:
    """The continuity part of seed eq. (31), tested with p̃ = ``q``: ∫ −p̃ div u − ζ p p̃ (``divergence``:
    the expression that stands for div u, e.g. pulled back from another configuration)."""
    return (-q * (ufl.div(u) if divergence is None else divergence) - penalty * p * q) * dx


def micro_rotation_residual(u, omega, tau, *, rho, inertia, acceleration, mu_r, lambda1, body_couple, dx,
                            dx_inertia=None, lambda2=None) -> ufl.Form:
    """Seed eq. (32), tested with τ̃ = ``tau`` (``acceleration``: the material derivative of ω):

    ∫ ρ I a_ω·τ̃ + λ₁ ∇ω:∇τ̃ + λ₂ div ω div τ̃ + 4μ_r ω·τ̃ − 2μ_r (curl u)·τ̃ − g·τ̃.

    In 3D ω is a vector and all terms are vector equations. In 2D ω = ω e_z has zero divergence, so the λ₂
    term vanishes and is not written (``lambda2`` is ignored for a scalar ω).
    """
    dx_inertia = dx if dx_inertia is None else dx_inertia
    internal = (lambda1 * ufl.inner(ufl.grad(omega), ufl.grad(tau))
                + 4 * mu_r * ufl.inner(omega, tau)
                - 2 * mu_r * ufl.inner(curl(u), tau))
    if lambda2 is not None and ufl.shape(omega) != ():
        internal = internal + lambda2 * ufl.div(omega) * ufl.div(tau)
    return (internal * dx
            + rho * inertia * ufl.inner(acceleration, tau) * dx_inertia
            - ufl.inner(body_couple, tau) * dx)


def cauchy_momentum_residual(T, v, *, rho, acceleration, body_force, dx, dx_inertia=None) -> ufl.Form:
    """The momentum balance ρ a = div T + f with the full Cauchy stress T (eq. 20), tested with ``v``:

    ∫ ρ a·v + T:∇v − f·v = ∫_∂ T n·v.

    With v = e_i on a body's boundary nodes and 0 at all others, minus this is the force on the body
    (the variational or "residual" drag and lift, which converge faster than the surface integral of T n).
    """
    dx_inertia = dx if dx_inertia is None else dx_inertia
    return (rho * ufl.inner(acceleration, v) * dx_inertia
            + (ufl.inner(T, ufl.grad(v)) - ufl.inner(body_force, v)) * dx)


def half_curl_wall(u, omega, tau, *, lambda1, ds, mesh, gamma=10.0) -> ufl.Form:
    """The wall condition ω = ½ curl u, imposed weakly (Nitsche) on the facets of ``ds``:

    −(λ₁ ∂ω/∂n, τ)_Γ + (λ₁ ∂τ/∂n, ω − ½ curl u)_Γ + (γ λ₁/h (ω − ½ curl u), τ)_Γ.

    Consistent (the exact solution satisfies it term by term) and, with the antisymmetric pair of
    normal-derivative terms, coercive in ω for any γ > 0. With λ₁ = 0 the ω equation has no
    derivatives and needs no wall condition: the terms vanish. Bilinear: it is its own residual.
    """
    n, h = ufl.FacetNormal(mesh), ufl.CellDiameter(mesh)
    jump = omega - 0.5 * curl(u)
    if ufl.shape(omega) != ():  # 3D: the same terms for the vector ω
        return (-lambda1 * ufl.inner(ufl.dot(ufl.grad(omega), n), tau)
                + lambda1 * ufl.inner(ufl.dot(ufl.grad(tau), n), jump)
                + gamma * lambda1 / h * ufl.inner(jump, tau)) * ds
    return (-lambda1 * ufl.dot(ufl.grad(omega), n) * tau + lambda1 * ufl.dot(ufl.grad(tau), n) * jump
            + gamma * lambda1 / h * jump * tau) * ds


def nitsche_slip(u, p, v, q, *, viscosity, viscous_form: str, ds, mesh, gamma: float = 20.0,
                 normal=None) -> ufl.Form:
    """Slip (u·n = 0, zero tangential part of σn) on the facets of ``ds``, weakly: the symmetric Nitsche
    terms (Freund & Stenberg 1995) with σ = :func:`viscous_stress` of the weak form in use,

    −(n·σ(u, p)n, ũ·n)_Γ − (n·σ(ũ, p̃)n, u·n)_Γ + (γ ν/h u·n, ũ·n)_Γ.

    The first term replaces the natural term ∫_Γ σn·ũ by its normal part (the tangential traction is left
    zero); the second keeps the form symmetric (it adds p̃ u·n to the continuity equation); the third,
    with h the cell diameter, makes it coercive for γ large enough (20 for P2). Consistent: the exact
    solution satisfies it term by term, on any boundary, straight or oblique. ``normal``: the n of the
    projections (u·n, n·σ n_h) where it is not the facet normal n_h (a curved wall's polygon:
    problem/slip_normal.py). Linear in (u, p) and in (ũ, p̃): it is its own residual.
    """
    n, h = ufl.FacetNormal(mesh), ufl.CellDiameter(mesh)
    m = n if normal is None else normal
    normal_stress = ufl.dot(ufl.dot(viscous_stress(u, p, viscosity, viscous_form), n), m)
    adjoint = ufl.dot(ufl.dot(viscous_stress(v, q, viscosity, viscous_form), n), m)
    un, vn = ufl.dot(u, m), ufl.dot(v, m)
    return (-normal_stress * vn - adjoint * un + gamma * viscosity / h * un * vn) * ds
