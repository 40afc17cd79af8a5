"""Solid terms of the monolithic system: the incompressible Mooney–Rivlin body of seed eqs. (6)–(14), (28)–(29).

Conventions: ``G = grad(d)`` with G_ij = ∂d_i/∂x_j (UFL). The reference position of the material at x
is x − d(x), so F = (I − G)⁻¹ and B⁻¹ = (FFᵀ)⁻¹ = I − G − Gᵀ + GᵀG (the seed writes the last term
∇d∇dᵀ with its transposed-gradient convention). In 2D with det F = 1, Cayley–Hamilton gives
B = (tr B) I − B⁻¹, so the neo-Hookean stress −pI + μ_s B equals −p'I + μ_s (Dd − GᵀG) with a redefined
pressure: the stress coefficient of (Dd − GᵀG) is the shear modulus μ_s, the seed's 2c₁ (eq. 14), and
the Mooney–Rivlin c₂ only enters the pressure.

Seed eq. (28): with d^{n+1} = d^n + δt u^{n+1},
    Dd − GᵀG ≈ Dd^n − G_nᵀG_n + δt (Du − HᵀG_n − G_nᵀH),   H = grad(u^{n+1}),
and since the tensor is symmetric, ∫ σ:∇ũ = ½ ∫ σ:Dũ.
"""

import ufl

from .kinematics import D


def strain_measure(d):
    """Dd − GᵀG = I − B⁻¹ (seed eqs. 11–14)."""
    G = ufl.grad(d)
    return D(d) - G.T * G


def linearised_stress_residual(u, v, d_star, *, mu_s, dt, dx_solid) -> ufl.Form:
    """The solid terms of seed eq. (31) with the seed's linearisation (28) around d* (``d_star``), tested
    with ũ = ``v``; ``dt`` is the δt of d^{n+1} = d* + δt u^{n+1} (δt/α for BDF2):

    ½ μ_s ∫_s [Dd* − G*ᵀG* + δt (Du − HᵀG* − G*ᵀH)] : Dũ,   G* = ∇d*, H = ∇u.

    Linear in u.
    """
    G, H = ufl.grad(d_star), ufl.grad(u)
    return 0.5 * mu_s * ufl.inner(strain_measure(d_star) + dt * (D(u) - H.T * G - G.T * H), D(v)) * dx_solid


def corrector_stress_residual(u, v, d_star, d_predicted, *, mu_s, dt, dx_solid) -> ufl.Form:
    """The solid terms of seed eq. (31) for a corrector pass: d^{n+1} = d* + δt u^{n+1} as in
    :func:`linearised_stress_residual`, but the strain measure linearised around the predicted
    d^{n+1} (``d_predicted``, on the predicted configuration Ω^{n+1} the pass is assembled on), one
    Newton step of S(d) = Dd − GᵀG:

    ½ μ_s ∫_s [S(d̂) + Dδ − ∇δᵀĜ − Ĝᵀ∇δ] : Dũ,   δ = d* + δt u − d̂,  Ĝ = ∇d̂.

    With d̂ = d* it is eq. (28) (the predictor); its error is quadratic in d^{n+1} − d̂.
    """
    G = ufl.grad(d_predicted)
    delta = d_star + dt * u - d_predicted
    H = ufl.grad(delta)
    return 0.5 * mu_s * ufl.inner(strain_measure(d_predicted) + D(delta) - H.T * G - G.T * H, D(v)) * dx_solid


def elastic_energy_density(d, mu_s):
    """Stored energy per unit volume of the solid stress −pI + μ_s (Dd − GᵀG), F = (I − grad d)⁻¹.

    2D: neo-Hookean μ_s/2 (tr B − 2 − 2 ln J); it equals the incompressible μ_s/2 (tr B − 2) when J = det F
    = 1, and stays ≥ 0 when the discrete J is not exactly 1 (tr B ≥ 2J ≥ 2 + 2 ln J).
    3D: Dd − GᵀG = I − B⁻¹ is not B − I there (Cayley–Hamilton gives B = (tr B) I − B⁻¹ in 2D only): the
    stress −p'I − μ_s B⁻¹ is the incompressible Mooney–Rivlin material with c₁ = 0, 2c₂ = μ_s (the same
    linear elasticity, shear modulus μ_s, at small strain), energy μ_s/2 (tr B⁻¹ − 3) at J = 1;
    μ_s/2 (tr B⁻¹ − 3 + 2 ln J) ≥ 0 for any J (tr B⁻¹ ≥ 3 J^(−2/3) ≥ 3 − 2 ln J).
    """
    if len(d) == 3:
        F_inv = ufl.Identity(3) - ufl.grad(d)
        return 0.5 * mu_s * (ufl.tr(F_inv.T * F_inv) - 3 - 2 * ufl.ln(ufl.det(F_inv)))
    F = ufl.inv(ufl.Identity(len(d)) - ufl.grad(d))
    return 0.5 * mu_s * (ufl.tr(F * F.T) - 2 - 2 * ufl.ln(ufl.det(F)))


def volume_correction_residual(q, d, *, dt, dx_solid) -> ufl.Form:
    """Right-hand side that turns the solid's continuity equation into div u^{n+1} = −ln J^n / δt.

    The seed's update x^{n+1} = x^n + δt u^{n+1} with div u^{n+1} = 0 changes areas by O(δt² det ∇u) per
    step (a rigid rotation inflates), a drift the incompressible law cannot see because a dilation only
    moves the pressure. Asking the next velocity to undo the accumulated J^n = det F^n ≠ 1 removes it;
    it vanishes when J^n = 1, so the scheme is unchanged for a motion it integrates exactly.
    With the continuity residual's −(q, div u): the residual term −(q, ln J^n / δt)_s, F = (I − grad d)⁻¹.
    """
    return -q * ufl.ln(volume_ratio(d)) / dt * dx_solid


def volume_ratio(d):
    """J = det F of the Eulerian displacement d on the current configuration: 1/det(I − ∇d), F = (I − ∇d)⁻¹."""
    return 1.0 / ufl.det(ufl.Identity(len(d)) - ufl.grad(d))
