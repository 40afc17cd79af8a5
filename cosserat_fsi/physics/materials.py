"""Compressible hyperelastic solids: Saint Venant–Kirchhoff and neo-Hookean, pure UFL.

Two descriptions of the same law:

- Eulerian (the monolithic step, seed §3): the displacement d is a field on the current configuration, the
  reference position of the material at x is x − d(x), so F⁻¹ = I − ∇d, J = det F = 1/det(I − ∇d) and the
  Cauchy stress σ(d) = J⁻¹ F S Fᵀ (S the second Piola–Kirchhoff stress);
- Lagrangian (the steady solid, physics/lagrangian.py): F = I + ∇_X d on the reference configuration and the
  first Piola–Kirchhoff stress P = F S.

Laws (μ, λ the Lamé parameters; in 2D the tensors are 2 × 2 and the laws are exactly those of plane strain,
F₃₃ = 1):

- ``saint_venant_kirchhoff``: S = λ tr(E) I + 2μ E, E = ½(FᵀF − I) (the Turek–Hron benchmarks' law);
- ``neo_hookean``: ψ = μ/2 (I₁ − d) − μ ln J + λ/2 (ln J)², S = μ (I − C⁻¹) + λ ln J C⁻¹, so
  σ = J⁻¹ [μ (B − I) + λ ln J I].

Both reduce to linear elasticity σ = λ tr(ε) I + 2μ ε at small strain. The stresses are rational (and
logarithmic) in ∇d: UFL's degree estimate for them is far above what the P2 fields need (hundreds to
thousands of points a cell), so give the solid measure a quadrature degree.
"""

from __future__ import annotations

import ufl

LAWS = ("saint_venant_kirchhoff", "neo_hookean")


def lame(E: float, nu: float) -> tuple[float, float]:
    """(μ, λ) of Young's modulus E and Poisson's ratio ν (3D and plane strain)."""
    return E / (2.0 * (1.0 + nu)), E * nu / ((1.0 + nu) * (1.0 - 2.0 * nu))


def second_piola_kirchhoff(law: str, F, mu, lam):
    """S(F) of ``law``."""
    I = ufl.Identity(ufl.shape(F)[0])
    C = F.T * F
    if law == "saint_venant_kirchhoff":
        E = 0.5 * (C - I)
        return lam * ufl.tr(E) * I + 2.0 * mu * E
    if law == "neo_hookean":
        C_inv = ufl.inv(C)
        return mu * (I - C_inv) + lam * ufl.ln(ufl.det(F)) * C_inv
    raise ValueError(f"unknown solid law {law!r} (one of {', '.join(LAWS)})")


def cauchy_stress(law: str, d, mu, lam):
    """σ(d) = J⁻¹ F S Fᵀ of the Eulerian displacement d (F = (I − ∇d)⁻¹)."""
    return cauchy_of_gradient(law, ufl.grad(d), mu, lam)


def cauchy_of_gradient(law: str, G, mu, lam):
    """σ as a function of the Eulerian displacement gradient G = ∇d: F = (I − G)⁻¹, J = det F."""
    I = ufl.Identity(ufl.shape(G)[0])
    F = ufl.inv(I - G)
    J = ufl.det(F)
    if law == "neo_hookean":  # J⁻¹ F S Fᵀ written without C⁻¹
        return (mu * (F * F.T - I) + lam * ufl.ln(J) * I) / J
    return F * second_piola_kirchhoff(law, F, mu, lam) * F.T / J


def first_piola_kirchhoff(law: str, d, mu, lam):
    """P = F S of the Lagrangian displacement d (F = I + ∇_X d)."""
    F = ufl.Identity(len(d)) + ufl.grad(d)
    return F * second_piola_kirchhoff(law, F, mu, lam)


def energy_density(law: str, d, mu, lam):
    """The stored energy per unit current volume, ψ(F)/J, of the Eulerian displacement d: ψ = λ/2 (tr E)² +
    μ tr(E²) (SVK), μ/2 (I₁ − d) − μ ln J + λ/2 (ln J)² (neo-Hookean)."""
    dim = len(d)
    I = ufl.Identity(dim)
    F = ufl.inv(I - ufl.grad(d))
    J = ufl.det(F)
    C = F.T * F
    if law == "neo_hookean":
        psi = 0.5 * mu * (ufl.tr(C) - dim) - mu * ufl.ln(J) + 0.5 * lam * ufl.ln(J) ** 2
    elif law == "saint_venant_kirchhoff":
        E = 0.5 * (C - I)
        psi = 0.5 * lam * ufl.tr(E) ** 2 + mu * ufl.inner(E, E)
    else:
        raise ValueError(f"unknown solid law {law!r} (one of {', '.join(LAWS)})")
    return psi / J


def stress_residual(law: str, d, v, *, mu, lam, dx_solid) -> ufl.Form:
    """∫_s σ(d) : ∇v: the solid's stress term of the momentum equation on the current configuration."""
    return ufl.inner(cauchy_stress(law, d, mu, lam), ufl.grad(v)) * dx_solid


def linearised_stress_residual(law: str, u, v, d_star, *, mu, lam, dt, dx_solid, around=None) -> ufl.Form:
    """The solid's stress term at d = d* + δt u, linearised (the analogue of seed eq. 28 for a compressible
    law) around a = ``around`` (default d*): ∫_s [σ(a) + Dσ(a)[d* + δt u − a]] : ∇v, with Dσ(a)[w] the
    Gateaux derivative of σ at a in the direction w. Linear in u; its error against σ(d* + δt u) is
    quadratic in d* + δt u − a (O(δt²) around d*)."""
    base = d_star if around is None else around
    # σ depends on d only through G = ∇d: Dσ(a)[w] = ∂σ/∂G (∇a) : ∇w
    G = ufl.variable(ufl.grad(base))
    sigma = cauchy_of_gradient(law, G, mu, lam)
    step = dt * ufl.grad(u) if around is None else ufl.grad(d_star + dt * u - around)
    i, j, k, m = ufl.indices(4)
    change = ufl.as_tensor(ufl.diff(sigma, G)[i, j, k, m] * step[k, m], (i, j))
    return ufl.inner(sigma + change, ufl.grad(v)) * dx_solid
