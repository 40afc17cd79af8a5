"""Fluid part of the monolithic system: seed eqs. (31) and (32), time-discrete with characteristics.

Both functions return ``(a, L)`` UFL forms; they are pure (no dolfinx objects are created here).

Time discretisation: ``alpha * (u^{n+1} - h) / dt`` with the *history* h built by the characteristics:
first order (seed): alpha = 1, h = u^n∘X^n; BDF2: alpha = 3/2, h = (4 u^n∘X¹ − u^{n−1}∘X²)/3, so the
right-hand side is ``alpha * rho / dt * h``. The caller passes ``alpha`` and ``history = alpha * h``.
The inertia terms use the measure ``dx_inertia``: the history lives at its quadrature points (the feet of
the quadrature points, evaluated exactly, as FreeFEM's ``convect``), which avoids the extra dissipation
of interpolating u^n∘X^n at the nodes.

Viscous convention: the seed writes (μ + μ_r) Du:Dũ with Du = ∇u + ∇uᵀ (eq. 18). Its strong form (23) has
(μ + μ_r)Δu, which the weak form only gives with a factor ½: ∫ μ Du:∇ũ = ½ ∫ μ Du:Dũ. We use the ½; the
Poiseuille solutions (tests) fix it. ``viscous_form="laplacian"`` uses (μ + μ_r) ∇u:∇ũ instead: the same
equations inside the domain when div u = 0, but its natural outflow condition is the benchmarks'
do-nothing condition μ ∂u/∂n − p n = 0, which Poiseuille flow satisfies.
"""

import ufl

from .kinematics import D, curl_scalar, curl_vector


def viscous(u, v, viscosity, form: str):
    """½ ν Du:Dũ (``symmetric``, seed) or ν ∇u:∇ũ (``laplacian``)."""
    if form == "symmetric":
        return 0.5 * viscosity * ufl.inner(D(u), D(v))
    return viscosity * ufl.inner(ufl.grad(u), ufl.grad(v))


def navier_stokes(u, p, v, q, *, rho, mu, inv_dt, alpha, history, body_force, penalty, dx,
                  viscous_form="laplacian", dx_inertia=None):
    """Seed eq. (31) without solid and micro-rotation terms.

    a = α ρ/δt (u, ũ) + μ/2 (Du, Dũ) − (p, div ũ) − (p̃, div u) − ζ (p, p̃)   [or μ (∇u, ∇ũ)],
    L = ρ/δt (α h, ũ) + (f, ũ).
    """
    dx_inertia = dx if dx_inertia is None else dx_inertia
    a = (alpha * rho * inv_dt * ufl.inner(u, v) * dx_inertia
         + (viscous(u, v, mu, viscous_form) - p * ufl.div(v) - q * ufl.div(u) - penalty * p * q) * dx)
    L = rho * inv_dt * ufl.inner(history, v) * dx_inertia + ufl.inner(body_force, v) * dx
    return a, L


def micropolar(u, omega, v, tau, *, rho, mu_r, lambda1, inertia, inv_dt, alpha, history, body_couple, dx,
               viscous_form="laplacian", dx_inertia=None):
    """Micropolar terms: the μ_r parts of seed eq. (31) and the micro-rotation equation (32), 2D.

    a = μ_r/2 (Du, Dũ) [or μ_r (∇u, ∇ũ)] − 2μ_r (curl ω, ũ)
        + α ρ I/δt (ω, τ) + λ₁ (∇ω, ∇τ) + 4μ_r (ω, τ) − 2μ_r (curl u, τ),
    L = ρ I/δt (α h_ω, τ) + (g, τ).
    In 2D ω = ω e_z has zero divergence, so the λ₂ term of eq. (32) vanishes.
    """
    dx_inertia = dx if dx_inertia is None else dx_inertia
    a = ((viscous(u, v, mu_r, viscous_form)
          - 2 * mu_r * ufl.inner(curl_scalar(omega), v)
          + lambda1 * ufl.inner(ufl.grad(omega), ufl.grad(tau))
          + 4 * mu_r * omega * tau
          - 2 * mu_r * curl_vector(u) * tau) * dx
         + alpha * rho * inertia * inv_dt * omega * tau * dx_inertia)
    L = rho * inertia * inv_dt * history * tau * dx_inertia + body_couple * tau * dx
    return a, L


def half_curl_wall(u, omega, tau, *, lambda1, ds, mesh, gamma=10.0):
    """The wall condition ω = ½ curl u, imposed weakly (Nitsche) on the facets of ``ds``:

    a = −(λ₁ ∂ω/∂n, τ)_Γ + (λ₁ ∂τ/∂n, ω − ½ curl u)_Γ + (γ λ₁/h (ω − ½ curl u), τ)_Γ.

    Consistent (the exact solution satisfies it term by term) and, with the antisymmetric pair of
    normal-derivative terms, coercive in ω for any γ > 0. With λ₁ = 0 the ω equation has no
    derivatives and needs no wall condition: the terms vanish.
    """
    n, h = ufl.FacetNormal(mesh), ufl.CellDiameter(mesh)
    jump = omega - 0.5 * curl_vector(u)
    return (-lambda1 * ufl.dot(ufl.grad(omega), n) * tau + lambda1 * ufl.dot(ufl.grad(tau), n) * jump
            + gamma * lambda1 / h * jump * tau) * ds
