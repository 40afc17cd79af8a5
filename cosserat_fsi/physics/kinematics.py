"""Kinematic operators of the seed (2D; the micro-rotation is the scalar ω = ω e_z).

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
    """The tensor [[0, ω], [−ω, 0]] (= −ε·ω of seed eq. 20 in 2D)."""
    return ufl.as_matrix(((0, omega), (-omega, 0)))
