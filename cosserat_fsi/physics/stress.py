"""Cauchy stress of the Cosserat fluid (seed eq. 20) and the traction on bodies.

    T = −p I + μ(∇u + ∇uᵀ) + μ_r(∇u − ∇uᵀ) + 2 μ_r [[0, ω], [−ω, 0]]

(shared/reference/micropolar_exact.md). It is nonsymmetric when μ_r ≠ 0; forces on bodies integrate the
full T n, not the natural boundary term of the (μ + μ_r) Du:Dũ weak form.
"""

import ufl

from .kinematics import D, spin


def cauchy_stress(u, p, mu, mu_r=None, omega=None):
    """Seed eq. (20). ``mu_r=None``: classical Newtonian stress −pI + μ Du."""
    T = -p * ufl.Identity(len(u)) + mu * D(u)
    if mu_r is not None:
        T = T + mu_r * (ufl.grad(u) - ufl.grad(u).T)
        if omega is not None:
            T = T + 2 * mu_r * spin(omega)
    return T


def body_traction(T, n):
    """Traction of the fluid on a body, −T n, with n the outward normal of the fluid domain."""
    return -ufl.dot(T, n)
