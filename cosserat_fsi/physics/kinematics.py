"""Kinematic operators of the seed: 2D (the micro-rotation is the scalar ω = ω e_z) and 3D (ω a vector).

Seed eq. (18): Du = ∇u + ∇uᵀ (no factor ½). In UFL ``grad(u)[i, j] = ∂u_i/∂x_j``.
"""

import ufl


def D(u):
    """Seed eq. (18): Du = ∇u + ∇uᵀ."""
    return ufl.grad(u) + ufl.grad(u).T


def curl_scalar(omega):
    """curl of the out-of-plane field ω e_z: (∂ω/∂y, −∂ω/∂x)."""
    return ufl.as_vector((omega.dx(1), -omega.dx(0)))


def curl_vector(u):
    """Scalar curl of an in-plane vector field: ∂u₂/∂x − ∂u₁/∂y."""
    return u[1].dx(0) - u[0].dx(1)


def curl(f):
    """curl of a 2D field: the vector curl of a scalar ω (= ω e_z), the scalar curl of an in-plane vector;
    ``ufl.curl`` in 3D."""
    if ufl.shape(f) == ():
        return curl_scalar(f)
    if ufl.shape(f) == (2,):
        return curl_vector(f)
    return ufl.curl(f)


def spin(omega):
    """The skew tensor W_ij = ε_ijk ω_k of seed eq. (20) (div W = curl ω): [[0, ω], [−ω, 0]] in 2D (ω = ω e_z),
    [[0, ω₃, −ω₂], [−ω₃, 0, ω₁], [ω₂, −ω₁, 0]] in 3D."""
    if ufl.shape(omega) == ():
        return ufl.as_matrix(((0, omega), (-omega, 0)))
    w1, w2, w3 = omega[0], omega[1], omega[2]
    return ufl.as_matrix(((0, w3, -w2), (-w3, 0, w1), (w2, -w1, 0)))


def pulled_back_divergence(u, displacement):
    """div u in the configuration x + ``displacement``, written on x: tr(∇u F⁻¹), F = I + ∇(displacement)
    (∇_{x'} = ∇ F⁻¹; with dx' = det F dx the integrals match). Generalised-α's corrector uses it for the
    solid's div u^{n+1} = 0 in Ω^{n+1} on the mesh of t^{n+α_f}."""
    F = ufl.Identity(len(u)) + ufl.grad(displacement)
    return ufl.tr(ufl.grad(u) * ufl.inv(F))
