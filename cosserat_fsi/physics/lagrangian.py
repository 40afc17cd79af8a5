"""Steady residuals on the reference configuration (Lagrangian solid, ALE fluid), for time_schemes/steady_solid.py.

The solid is the seed's incompressible law (eqs. 6–14) written as in physics/solid.py (or a compressible law of
physics/materials.py, P = F S, without the constraint), σ = −pI + μ_s (I − B⁻¹)
(the neo-Hookean −pI + μ_s B up to a redefinition of p, see there), pulled back to the reference mesh with
the deformation gradient F = I + ∇d (∇ with respect to the reference coordinates X):

    P = J σ F⁻ᵀ,   ∫ P : ∇φ dX − ∫ J f·φ dX = 0,   J − 1 = 0.

The fluid is the steady Navier–Stokes equations (seed eq. 31 without ∂/∂t and micro-rotation) on the
fluid cells moved by the same displacement field d (harmonically extended into the fluid), ∇ₓ = ∇ F⁻¹:

    ∫ J [ρ (∇ₓu) u·φ + μ ∇ₓu : ∇ₓφ − p divₓφ − q divₓu − f·φ] dX = 0    (``laplacian`` viscous form).

All functions return UFL forms and create no dolfinx objects.
"""

import ufl

from . import materials


def deformation(d):
    """(F, J, F⁻¹) of the displacement d on the reference configuration."""
    F = ufl.Identity(len(d)) + ufl.grad(d)
    return F, ufl.det(F), ufl.inv(F)


def solid_statics(d, p, phi, q, *, mu_s, body_force, dx_solid, law=None, lambda_s=None):
    """Static equilibrium and incompressibility of the solid: ∫ P:∇φ − J f·φ − q (J − 1) dX; with a
    compressible ``law`` (physics/materials.py) ∫ P(F):∇φ − f·φ dX, f the load per reference volume (ρ_s
    is the reference density), and no pressure in the solid."""
    if law is not None and law != "mooney_rivlin_incompressible":
        P = materials.first_piola_kirchhoff(law, d, mu_s, lambda_s)
        return (ufl.inner(P, ufl.grad(phi)) - ufl.inner(body_force, phi)) * dx_solid
    F, J, Finv = deformation(d)
    sigma = -p * ufl.Identity(len(d)) + mu_s * (ufl.Identity(len(d)) - Finv.T * Finv)
    P = J * sigma * Finv.T
    return (ufl.inner(P, ufl.grad(phi)) - J * ufl.inner(body_force, phi) - q * (J - 1.0)) * dx_solid


def ale_navier_stokes(u, p, d, phi, q, *, rho, mu, body_force, penalty, dx_fluid, convection=1.0):
    """Steady Navier–Stokes on the configuration X + d, written on the reference cells (ALE)."""
    F, J, Finv = deformation(d)
    grad_u, grad_phi = ufl.grad(u) * Finv, ufl.grad(phi) * Finv
    return J * (convection * rho * ufl.inner(grad_u * u, phi) + mu * ufl.inner(grad_u, grad_phi)
                - p * ufl.tr(grad_phi) - q * ufl.tr(grad_u) - penalty * p * q
                - ufl.inner(body_force, phi)) * dx_fluid


def rest_and_extension(u, d, psi, *, dx_solid, dx_fluid, rest_weight=1.0e6, extension_weight=1.0e-6):
    """The equations tested with ψ: the solid is at rest (u = 0 on the solid cells) and the fluid cells follow
    the solid by the harmonic extension of d. The weights keep the interface rows (where both meet) the
    solid's: the extension's share there moves u by ≈ (extension/rest weight) d / h², about 1e-12 d/h²."""
    return (rest_weight * ufl.inner(u, psi) * dx_solid
            + extension_weight * ufl.inner(ufl.grad(d), ufl.grad(psi)) * dx_fluid)
