"""The histories α·h of the characteristics schemes (seed §5.1) and the accelerations built from them.

First order (seed): α = 1, h = u^n∘X^n with the feet x − δt (u^n − w)(x) (w the mesh velocity). BDF2:
α = 3/2, α h = 2 u^n∘X¹ − ½ u^{n−1}∘X², feet x − δt u*, x − 2δt u*, u* = 2u^n − u^{n−1} at constant steps;
with a step ratio ω the weights of variable_step.BdfWeights (α h = a₁u^n∘X¹ − a₂u^{n−1}∘X², the second
foot x − (δt_n + δt_{n−1})u*, u* = (1 + ω)u^n − ωu^{n−1}); on a moving mesh the
feet are located in the configurations u^n and u^{n−1} were computed on. α h lives at the quadrature points
of the inertia terms (FreeFEM's ``convect``: the feet of the quadrature points, evaluated exactly); ω's
at the P2 nodes instead with ``micropolar.nodal_characteristics``. The low-level point location and
evaluation are in points/location.py, the points traced back from in points/back_tracking_nodes.py.
"""

from __future__ import annotations

import numpy as np

from .. import compat
from ..points import _kernels, location
from ..points.back_tracking_nodes import BackTrackingNodes
from ..points.location import PointLocator, evaluate, is_p2, reference_basis
from .state import State

import dolfinx
import ufl


class Histories:
    """α·h for u (``velocity``) and ω (``micro_rotation`` or None), the measure ``dx_inertia`` of the
    inertia terms, and the point locators: ``chars.locator`` on the current mesh, ``earlier_locators``
    (Ω of u^n, Ω of u^{n−1}) for BDF2 on a moving mesh."""

    def __init__(self, scene, problem, dt: float, comm, moving: bool):
        mesh, sp = problem.mesh, problem.space
        self.dt, self.comm, self.moving = dt, comm, moving
        self.micro = problem.model.micro_rotation
        V = sp.space("velocity")
        self.degree = scene.time.quadrature_degree
        self.velocity = dolfinx.fem.Function(compat.quadrature_space(mesh, self.degree, (mesh.geometry.dim,)))
        self.dx_inertia = ufl.dx(domain=mesh, metadata={"quadrature_degree": self.degree})
        self.omega_apart = bool(self.micro and scene.micropolar.nodal_characteristics)
        self.micro_rotation = None
        if self.micro:
            self.micro_rotation = dolfinx.fem.Function(
                sp.space("micro_rotation") if self.omega_apart
                else compat.quadrature_space(mesh, self.degree, (3,) if mesh.geometry.dim == 3 else ()))
        self.chars = BackTrackingNodes(V, sp.space("micro_rotation") if self.micro else None, comm)
        self.earlier_locators = (self.chars.locator, self.chars.locator)
        self._shift, self._shift_current = dolfinx.fem.Function(V), dolfinx.fem.Function(V)

    # ----------------------------------------------------------------------------- accelerations
    @staticmethod
    def acceleration(u, history, alpha, inv_dt):
        """(α u − α h)/δt: the scheme's material acceleration of ``u`` (``history`` = α h)."""
        return (alpha * u - history) * inv_dt

    # ------------------------------------------------------------------------------------ update
    def update(self, bdf, state: State, solve_displacement=None) -> None:
        """Set α·h from ``state`` (``bdf``: the step's BdfWeights; first order, α = 1, or the BDF2 feet).
        ``solve_displacement``: the P1 mesh displacement of the configuration the step is solved on (BDF2
        on a moving mesh)."""
        chars, micro, degree = self.chars, self.micro, self.degree
        with_omega = micro and not self.omega_apart
        current = [state.velocity] + ([state.micro_rotation] if with_omega else [])
        previous = [state.velocity_prev] + ([state.micro_rotation_prev] if with_omega else [])
        if bdf.order == 2 and self._compiled_bdf2(current, previous):
            self._bdf2_quadrature(bdf, state, current, previous)
        else:
            hist = self._values(bdf, degree, state, current, previous, solve_displacement)
            _set_quadrature(self.velocity, hist[0])
            if with_omega:
                _set_quadrature(self.micro_rotation, hist[1])
        if self.omega_apart:
            values = self._values(bdf, None, state, [state.micro_rotation], [state.micro_rotation_prev],
                                  solve_displacement)[0]
            self.micro_rotation.x.array[:] = chars.to_S(values).ravel()
            self.micro_rotation.x.scatter_forward()

    def _values(self, bdf, degree, state, fns_n, fns_nm1, solve_displacement) -> list:
        """α·h of ``fns_n`` (and ``fns_nm1`` for BDF2) at the quadrature points of ``degree`` in every
        cell, or at the local P2 nodes (``degree`` None)."""
        chars, comm, dt, dt2 = self.chars, self.comm, bdf.dt, bdf.second_foot
        if degree:
            x, cells = chars.quadrature_nodes(degree)

            def at_x(f):
                return chars.at_quadrature_nodes(f, degree)
        else:
            x, cells = chars.nodes(), None

            def at_x(f):
                return chars.nodal(f)
        if bdf.order == 1:
            u_x = at_x(state.velocity)
            w_x = at_x(state.mesh_velocity) if self.moving else 0.0
            return self._at_feet(x, x - dt * _pad(u_x - w_x), fns_n, cells)
        if not self.moving:  # BDF2: feet x − δt u*, x − (δt_n + δt_{n−1}) u*, u* = (1 + ω)u^n − ωu^{n−1}
            u_star = _pad(at_x(self._extrapolated(bdf, state)))
            feet1, feet2 = x - dt * u_star, x - dt2 * u_star
            vals1 = self._at_feet(x, feet1, fns_n, cells)
            vals2 = self._at_feet(x, feet2, fns_nm1, cells)
        else:
            # moving mesh: u^n (and ω^n) live on Ω^{n−1}, u^{n−1} on Ω^{n−2}, where they were computed;
            # the feet (physical points) are located in those configurations of the mesh. A mesh-
            # velocity shift of the feet (as in the first-order scheme) is only O(δt²) accurate
            # per step, which would make the scheme first order.
            # Points outside such an earlier configuration (its boundary moved: a solid-only scene)
            # are pulled back to the image of x in it (same cell, same barycentric coordinates).
            loc_n, loc_nm1 = self.earlier_locators
            x_n, x_nm1 = (self._earlier_position(x, loc, disp, degree, solve_displacement)
                          for loc, disp in ((loc_n, state.configuration_n), (loc_nm1, state.configuration_nm1)))
            (un_x,) = evaluate(loc_n, [state.velocity], x, x_n, comm, hint=cells)
            (unm1_x,) = evaluate(loc_nm1, [state.velocity_prev], x, x_nm1, comm, hint=cells)
            u_star = _pad(bdf.extrapolated(un_x, unm1_x))
            feet1, feet2 = x - dt * u_star, x - dt2 * u_star
            vals1 = evaluate(loc_n, fns_n, feet1, x_n, comm, hint=cells)
            vals2 = evaluate(loc_nm1, fns_nm1, feet2, x_nm1, comm, hint=cells)
        return [bdf.history(v1, v2) for v1, v2 in zip(vals1, vals2)]

    # ------------------------------------------------------------- BDF2 at the quadrature points, compiled
    def _compiled_bdf2(self, current, previous) -> bool:
        """Can the fused kernel do this step: numba on, 2D (``is_p2``: triangles), P2 fields (u a 2-vector,
        ω a scalar)?"""
        loc = self.chars.locator

        def sizes(fns):
            return [f.function_space.dofmap.index_map_bs for f in fns]
        return (location.COMPILED and all(is_p2(loc, f) for f in current + previous)
                and sizes(current) == sizes(previous) and sizes(current) in ([2], [2, 1]))

    def _bdf2_quadrature(self, bdf, state: State, fns_n, fns_nm1) -> None:
        """``_values`` + ``_set_quadrature`` of BDF2 at the quadrature points in one compiled pass
        (``_kernels.bdf2_quadrature``: u*, the feet, both evaluations and a₁v₁ − a₂v₂ written straight into
        the quadrature functions); the points whose walks fail (feet outside the local mesh, on other
        ranks, across a boundary) then take the general path (``evaluate``), which is collective."""
        chars, degree, dt, comm = self.chars, self.degree, bdf.dt, self.comm
        x, cells = chars.quadrature_nodes(degree)
        loc = chars.locator
        loc_n, loc_nm1 = self.earlier_locators if self.moving else (loc, loc)
        with_w = len(fns_n) == 2
        targets = [self.velocity] + ([self.micro_rotation] if with_w else [])
        qdofs = [self._quadrature_dofs(f) for f in targets]
        dofs_u = loc.dofs(fns_n[0].function_space)
        dofs_w = loc.dofs(fns_n[1].function_space) if with_w else dofs_u
        w_n, w_nm1 = (fns_n[1].x.array, fns_nm1[1].x.array) if with_w else (fns_n[0].x.array,) * 2
        phi = reference_basis(degree)
        status, u_star = _kernels.bdf2_quadrature(
            x, len(phi), phi, self.moving, (dt, bdf.second_foot, bdf.a1, bdf.ratio, bdf.a1, bdf.a2),
            location._TOL, location._WALK_STEPS, (loc_n.x0, loc_n.Jinv_flat),
            (loc_nm1.x0, loc_nm1.Jinv_flat), loc.neighbours, dofs_u, fns_n[0].x.array, fns_nm1[0].x.array,
            dofs_w, w_n, w_nm1, with_w, qdofs[0], targets[0].x.array, qdofs[-1], targets[-1].x.array)
        # the rest, as _values does it (point by point the same operations, so the same numbers)
        if self.moving:
            x_n = chars.quadrature_nodes(degree, loc_n)[0]
            x_nm1 = chars.quadrature_nodes(degree, loc_nm1)[0]
            lost = np.flatnonzero(status == 2)
            (un_x,) = evaluate(loc_n, [state.velocity], x[lost], x_n[lost], comm, hint=cells[lost])
            (unm1_x,) = evaluate(loc_nm1, [state.velocity_prev], x[lost], x_nm1[lost], comm, hint=cells[lost])
            u_star[lost] = bdf.extrapolated(un_x, unm1_x)
        else:
            x_n = x_nm1 = x
        rest = np.flatnonzero(status)
        u_rest = _pad(u_star[rest])
        feet1, feet2 = x[rest] - dt * u_rest, x[rest] - bdf.second_foot * u_rest
        vals1 = evaluate(loc_n, fns_n, feet1, x_n[rest], comm, hint=cells[rest])
        vals2 = evaluate(loc_nm1, fns_nm1, feet2, x_nm1[rest], comm, hint=cells[rest])
        for f, dofs, v1, v2 in zip(targets, qdofs, vals1, vals2):
            bs = f.function_space.dofmap.index_map_bs
            f.x.array.reshape(-1, bs)[dofs[rest]] = bdf.history(v1, v2)

    def _extrapolated(self, bdf, state: State):
        """u* = (1 + ω)u^n − ωu^{n−1} as a P2 function (coefficient by coefficient; the compiled BDF2 pass
        combines the coefficients the same way)."""
        u_star = self.__dict__.get("_u_star")
        if u_star is None:
            u_star = self._u_star = dolfinx.fem.Function(state.velocity.function_space)
        u_star.x.array[:] = bdf.extrapolated(state.velocity.x.array, state.velocity_prev.x.array)
        return u_star

    def _quadrature_dofs(self, f) -> np.ndarray:
        """The dof of f's quadrature space at each quadrature point (cell-major, as quadrature_nodes)."""
        cache = self.__dict__.setdefault("_qdofs", {})
        if id(f) not in cache:
            n_cells = len(self.chars.locator.x0)
            cache[id(f)] = np.ascontiguousarray(compat.cell_dofs(f.function_space)[:n_cells].ravel(),
                                                dtype=np.int32)
        return cache[id(f)]

    def _earlier_position(self, x, locator, displacement, degree, solve_displacement):
        """Where the points x of the current mesh were in an earlier configuration of it (``locator``,
        reached with the P1 vertex ``displacement``): the same cell and barycentric coordinates."""
        if degree:
            return self.chars.quadrature_nodes(degree, locator)[0]
        shift = self._shift
        shift.interpolate(displacement)
        current = self._shift_current
        current.interpolate(solve_displacement)
        return x - _pad(self.chars.nodal(current) - self.chars.nodal(shift))

    def _at_feet(self, anchors, feet, functions, cells=None):
        return evaluate(self.chars.locator, functions, feet, anchors, self.comm, hint=cells)

    # ------------------------------------------------------------------------------ locators
    @property
    def locator(self):
        """The point locator of the current mesh."""
        return self.chars.locator

    def mesh_moved(self, rebuild: bool) -> None:
        """The mesh moved: ``rebuild`` a new locator (BDF2 keeps the old one as an earlier configuration)
        or update the current one in place."""
        if rebuild:
            self.chars.locator = PointLocator(self.chars.locator.mesh)
        else:
            self.chars.locator.update()

    def remember_configuration(self) -> None:
        """BDF2 on a moving mesh, after the solve: the current configuration is the one u^n was computed
        on; the previous one that of u^{n−1}."""
        self.earlier_locators = (self.chars.locator, self.earlier_locators[0])

    def relocate(self, motion, state: State) -> None:
        """After a restore: locators on the restored mesh and, for BDF2, on its earlier configurations."""
        self.chars.locator.update()
        if state.configuration_n is not None:
            self.earlier_locators = tuple(
                PointLocator(self.chars.locator.mesh, motion.X0 + f.x.array.reshape(-1, motion.dim)[motion.node_dof])
                for f in (state.configuration_n, state.configuration_nm1))


def _set_quadrature(f, values):
    """Write values at the quadrature points (cell-major, as quadrature_nodes) into ``f``."""
    dofs = compat.cell_dofs(f.function_space)
    bs = f.function_space.dofmap.index_map_bs
    arr = f.x.array.reshape(-1, bs)
    rows = dofs[: len(values) // dofs.shape[1]].ravel()
    if np.array_equal(rows, np.arange(len(rows))):
        arr[: len(rows)] = values.reshape(-1, bs)  # dofs in cell-major order (a quadrature space's): a copy
    else:
        arr[rows] = values.reshape(-1, bs)


def _pad(v):
    """(n, 2) → (n, 3) with z = 0 (points and displacements in dolfinx are 3D)."""
    return np.hstack([v, np.zeros((len(v), 1))]) if np.ndim(v) == 2 and v.shape[1] == 2 else v
