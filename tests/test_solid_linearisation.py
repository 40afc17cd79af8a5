"""The solid stress linearisations of physics/solid.py against the exact stress at t^{n+1}.

The exact solid term of a step assembled on Ω^n, with d^{n+1} = d* + ε u at the material points and
x^{n+1} = x + ε u (F_ε = I + ε ∇u): μ_s ∫_{Ω^{n+1}} S(∇_{n+1}d^{n+1}) : ∇_{n+1}ũ, pulled back to Ω^n with
∇_{n+1} = ∇ F_ε⁻¹ and dx_{n+1} = det F_ε dx. The seed's eq. (28) (``linearised_stress_residual``) drops
O(ε) terms (a consistent linearisation that kept them, O(ε²), measured no better in FSI3 and was removed:
docs/perf_time_schemes.md, "Options removed (findings)"); the corrector pass's form is one Newton step.
"""

from __future__ import annotations

import numpy as np
from mpi4py import MPI

from cosserat_fsi import compat
from cosserat_fsi.physics import solid

import dolfinx
import dolfinx.fem.petsc as fem_petsc
import ufl
from petsc4py import PETSc


def _exact_residual(u, v, d_star, eps, dx):
    I = ufl.Identity(2)
    F_step = I + eps * ufl.grad(u)
    F_inv = ufl.inv(F_step)
    K = ufl.grad(d_star + eps * u) * F_inv  # ∇_{n+1} d^{n+1}
    S = K + K.T - K.T * K
    return ufl.inner(S, ufl.grad(v) * F_inv) * ufl.det(F_step) * dx


def vector(form):
    """The assembled vector of a linear form (ghosts summed)."""
    b = fem_petsc.assemble_vector(compat.form(form))
    b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
    return b


def _differences():
    mesh = dolfinx.mesh.create_unit_square(MPI.COMM_WORLD, 6, 6)
    V = compat.function_space(mesh, "Lagrange", 2, shape=(2,))
    d_star, u = dolfinx.fem.Function(V), dolfinx.fem.Function(V)
    d_star.interpolate(lambda x: np.vstack([0.15 * np.sin(2 * x[1]) + 0.05 * x[0] ** 2, -0.2 * x[0] * x[1]]))
    u.interpolate(lambda x: np.vstack([np.cos(x[0] + 2 * x[1]), 0.5 * x[0] ** 2 - x[1]]))
    v = ufl.TestFunction(V)
    dx = ufl.dx(domain=mesh)

    out = []
    for eps in (4e-3, 2e-3, 1e-3):
        exact = vector(_exact_residual(u, v, d_star, eps, dx))
        approx = vector(solid.linearised_stress_residual(u, v, d_star, mu_s=1.0, dt=eps, dx_solid=dx))
        approx.axpy(-1.0, exact)
        out.append(approx.norm())
    return np.array(out)


def test_seed_linearisation_drops_first_order_terms():
    """The seed's eq. (28) on Ω^n differs from the exact term by O(ε): rates ≈ 1 (measured differences
    1.2e-3, 5.7e-4, 2.8e-4)."""
    differences = _differences()
    rates = np.log2(differences[:-1] / differences[1:])
    assert np.all(np.abs(rates - 1.0) < 0.1), (differences, rates)
    assert 0.8e-3 < differences[0] < 1.6e-3, differences


def test_corrector_stress_is_one_newton_step():
    """``corrector_stress_residual`` (time.corrector_passes): around d̂ = d* it is the seed's eq. (28)
    (to round-off); around a prediction d̂ = d* + ε u + e its difference from the exact strain measure
    S(d* + ε u) (same configuration) is quadratic in the prediction error e (ratio 4 per halving)."""
    mesh = dolfinx.mesh.create_unit_square(MPI.COMM_WORLD, 6, 6)
    V = compat.function_space(mesh, "Lagrange", 2, shape=(2,))
    d_star, u, e, d_hat = (dolfinx.fem.Function(V) for _ in range(4))
    d_star.interpolate(lambda x: np.vstack([0.15 * np.sin(2 * x[1]) + 0.05 * x[0] ** 2, -0.2 * x[0] * x[1]]))
    u.interpolate(lambda x: np.vstack([np.cos(x[0] + 2 * x[1]), 0.5 * x[0] ** 2 - x[1]]))
    e.interpolate(lambda x: np.vstack([np.sin(3 * x[0]) * x[1], np.cos(x[0] * x[1])]))
    v, dx, eps = ufl.TestFunction(V), ufl.dx(domain=mesh), 1e-2

    seed = vector(solid.linearised_stress_residual(u, v, d_star, mu_s=1.0, dt=eps, dx_solid=dx))
    same = vector(solid.corrector_stress_residual(u, v, d_star, d_star, mu_s=1.0, dt=eps, dx_solid=dx))
    same.axpy(-1.0, seed)
    assert same.norm() < 1e-13 * seed.norm()
    exact = vector(0.5 * ufl.inner(solid.strain_measure(d_star + eps * u), ufl.sym(ufl.grad(v)) * 2) * dx)
    errors = []
    for size in (0.04, 0.02, 0.01):
        d_hat.x.array[:] = d_star.x.array + eps * u.x.array + size * e.x.array
        b = vector(solid.corrector_stress_residual(u, v, d_star, d_hat, mu_s=1.0, dt=eps, dx_solid=dx))
        b.axpy(-1.0, exact)
        errors.append(b.norm())
    ratios = np.array(errors[:-1]) / np.array(errors[1:])
    assert np.all(np.abs(ratios - 4) < 0.2), (errors, ratios)


def test_pulled_back_divergence_is_the_divergence_on_the_moved_mesh():
    """``kinematics.pulled_back_divergence`` (generalised-α's solid continuity on Ω^{n+1}, assembled on
    Ω^{n+α_f}): ∫_Ω q tr(∇u F⁻¹) det F dx equals ∫ q div u on the mesh moved by the (P1, so exactly
    representable) displacement, to round-off; the plain div u on Ω is off by O(|∇ displacement|)."""
    from cosserat_fsi.physics.kinematics import pulled_back_divergence

    mesh = dolfinx.mesh.create_unit_square(MPI.COMM_WORLD, 5, 5)
    V = compat.function_space(mesh, "Lagrange", 2, shape=(2,))
    M = compat.function_space(mesh, "Lagrange", 1, shape=(2,))
    Q = compat.function_space(mesh, "Lagrange", 1)
    u, shift = dolfinx.fem.Function(V), dolfinx.fem.Function(M)
    u.interpolate(lambda x: np.vstack([np.cos(x[0] + 2 * x[1]), 0.5 * x[0] ** 2 - x[1] * x[0]]))
    shift.interpolate(lambda x: np.vstack([0.08 * np.sin(3 * x[1]), 0.05 * x[0] * x[1]]))
    q = ufl.TestFunction(Q)
    dx = ufl.dx(domain=mesh)

    F = ufl.Identity(2) + ufl.grad(shift)
    pulled = vector(q * pulled_back_divergence(u, shift) * ufl.det(F) * dx)
    plain = vector(q * ufl.div(u) * dx)
    # move the mesh by the P1 shift (the geometry is P1: the vertices' values are the shift's dof values)
    x = mesh.geometry.x
    X = x.copy()
    points = dolfinx.fem.Function(M)
    points.interpolate(lambda y: y[:2])  # the vertices' coordinates in M's dof order
    coordinates = points.x.array.reshape(-1, 2)
    moved = coordinates + shift.x.array.reshape(-1, 2)
    where = {tuple(np.round(c, 12)): i for i, c in enumerate(coordinates)}
    for k in range(len(x)):
        x[k, :2] = moved[where[tuple(np.round(x[k, :2], 12))]]
    on_moved = vector(q * ufl.div(u) * ufl.dx(domain=mesh))
    x[:] = X
    scale = on_moved.norm()
    pulled.axpy(-1.0, on_moved)
    plain.axpy(-1.0, on_moved)
    assert pulled.norm() < 1e-12 * scale, (pulled.norm(), scale)
    assert plain.norm() > 1e-2 * scale, (plain.norm(), scale)

