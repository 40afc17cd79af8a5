"""The force on a body: the residual ("variational") form and the surface integral of −T n, one component per
space dimension (``drag`` along x, ``lift`` along y, in 3D ``side`` along z), and the Schäfer–Turek
coefficients made from them."""

from __future__ import annotations

from .. import compat
from ..physics import fluid
from ..physics.stress import body_traction
from ..tags import FLUID

import dolfinx
import ufl

COMPONENTS = ("drag", "lift", "side")  # the force along x, y, z


def force_columns(dim: int) -> list[str]:
    """The force columns of timeseries.csv in ``dim`` dimensions: the residual form's components, then the
    surface form's (``drag, lift, drag_surface, lift_surface``; in 3D with ``side`` and ``side_surface``)."""
    names = list(COMPONENTS[:dim])
    return names + [f"{name}_surface" for name in names]


def force_forms(sim, u, T, n, ds, body_tags):
    """Forms for the force's components by the residual method, then by the surface integral of −T n, fluid
    side (the order of :func:`force_columns`).

    With a solid flag the fluid–solid interface is interior: its traction is taken from the fluid cell
    (χ_f = 1 on fluid cells), and the cylinder arc that clamps the flag is left out the same way.
    """
    gdim = sim.mesh.geometry.dim
    phis = _body_test_functions(sim, body_tags)
    traction = body_traction(T, n)
    if not sim.model.solid:
        residual = _momentum_residual(sim, u, T, ufl.dx(domain=sim.mesh))
        surface = [traction[i] * ds(body_tags) for i in range(gdim)]
    else:
        chi = sim.problem.cellwise(1.0, 0.0)  # fluid indicator
        dx_fluid = ufl.dx(domain=sim.mesh, subdomain_data=sim.cell_tags)(FLUID)
        residual = _momentum_residual(sim, u, T, dx_fluid)
        ids = sim.problem.facet_ids
        dS = ufl.Measure("dS", domain=sim.mesh, subdomain_data=sim.facet_tags)
        surface = [0 for _ in range(gdim)]
        exterior = [tag for name, tag in ids.items() if tag in body_tags and name != "interface"]
        for i in range(gdim):  # a file scene may lack either group
            for tag in exterior:
                surface[i] = surface[i] + chi * traction[i] * ds(tag)
            if "interface" in ids and ids["interface"] in body_tags:
                fluid_side = chi("+") * traction[i]("+") + chi("-") * traction[i]("-")
                surface[i] = surface[i] + fluid_side * dS(ids["interface"])
    return [compat.form(-residual(phi)) for phi in phis] + [compat.form(f) for f in surface]


def _body_test_functions(sim, body_tags):
    """φ_x, φ_y (, φ_z): P2 fields equal to e_i on the body's boundary nodes and 0 at all other nodes."""
    V = sim.velocity.function_space
    fdim = sim.mesh.topology.dim - 1
    facets = sim.problem.facets(*(name for name, tag in sim.problem.facet_ids.items() if tag in body_tags))
    phis = []
    for i in range(sim.mesh.geometry.dim):
        Vi, to_V = compat.collapse(V.sub(i))
        dofs = dolfinx.fem.locate_dofs_topological((V.sub(i), Vi), fdim, facets)[0]
        phi = dolfinx.fem.Function(V)
        phi.x.array[dofs] = 1.0
        phis.append(phi)
    return phis


def _momentum_residual(sim, u, T, dx):
    """φ ↦ the momentum residual (eq. 20 stress form) of the step just taken, with the scheme's acceleration.

    With φ = e_i on the body and 0 elsewhere it equals ∫_body T n·e_i ds (n out of the fluid), so
    −residual(φ_i) is the force on the body: the variational ("residual") drag, lift (and side), which
    converge faster than the surface integral of T n.
    """
    if dx.subdomain_id() != "everywhere":  # restricted to the fluid cells
        dxi = sim.dx_inertia(subdomain_data=sim.cell_tags)(dx.subdomain_id())
    else:
        dxi = sim.dx_inertia

    def residual(phi):
        return fluid.cauchy_momentum_residual(T, phi, rho=sim.problem.rho, acceleration=sim.acceleration(u),
                                              body_force=sim.problem.body_force, dx=dx, dx_inertia=dxi)

    return residual


def schaefer_turek_coefficients(drag: float, lift: float, rho: float, u_mean: float, diameter: float = 0.1,
                                span: float = 1.0):
    """c_D = 2 F_D / (ρ Ū² D), c_L = 2 F_L / (ρ Ū² D) (Schäfer & Turek 1996); in 3D (3D-1Z) divided by the
    cylinder's ``span`` H = 0.41 too: 2 F / (ρ Ū² D H) (data/three_d_references.yaml)."""
    scale = 2.0 / (rho * u_mean**2 * diameter * span)
    return drag * scale, lift * scale
