"""The BDF step shared by the characteristics schemes (characteristics.py) and ``ale_bdf2`` (ale_bdf.py).

First order (seed §5): α = 1, the acceleration (u − h)/δt. BDF2: α = 3/2, the first step first order. The
solid's displacement is linearised around d* = d^n (first order) or (4d^n − d^{n−1})/3 (BDF2) with
d^{n+1} = d* + (δt/α) u^{n+1} (eq. 28). On a moving mesh BDF2 solves on a configuration of its own: the BDF2
base X + (4D^n − D^{n−1})/3 where d* lives, or (``EXTRAPOLATED_CONFIGURATION``) the extrapolation
X + 2D^n − D^{n−1}, the nodes' places at t^{n+1} to O(δt²); the solid vertices then move on from the base.
"""

from __future__ import annotations

import numpy as np

from .. import compat
from .time_step import TimeStep

import dolfinx


class BdfStep(TimeStep):
    """histories → assemble → solve (→ passes) → update d → move the mesh, at order ``order``."""

    EXTRAPOLATED_CONFIGURATION = False

    def __init__(self, problem, state, boundary, histories, solver, motion, timers, comm,
                 *, order: int):
        super().__init__(problem, state, boundary, histories, solver, motion, timers, comm)
        self.order = order
        # BDF2 on a moving mesh: the displacement Ω* − X of the configuration the step is solved on
        self.solve_displacement = (dolfinx.fem.Function(motion.M) if motion is not None and order == 2 else None)
        self.extrapolate = self.solve_displacement is not None and self.EXTRAPOLATED_CONFIGURATION
        # the BDF2 base the solid vertices move on from, when the mesh is solved on another configuration
        self.motion_base = np.zeros_like(self.solve_displacement.x.array) if self.extrapolate else None
        self.passes = 0  # re-solves per BDF2 step (time.corrector_passes, :meth:`_pass`)
        self._alpha_of_A = None

    def _build_forms(self):
        """The step's forms and right-hand side vector (once the subclass has set up what they use)."""
        self.a_form, self.L_form = self._forms()
        self.b = compat.create_vector(self.L_form, self.problem.space.W)

    # --------------------------------------------------------------------------------- one step
    def advance(self, observe=None) -> None:
        """t^n → t^{n+1}: solve on Ω^n (BDF2 moving: its own configuration), update d, then move the mesh
        to Ω^{n+1}. ``observe()`` is called after the solve, while the mesh is still the one solved on."""
        state = self.state
        alpha = 1.0 if (self.order == 1 or state.step_count == 0) else 1.5
        if self.solve_displacement is not None:
            with self.timers("mesh_motion"):
                self._to_solve_configuration(alpha)
        if self.d_star is not None:
            d, d_prev = state.displacement.x.array, state.displacement_prev.x.array
            self.d_star.x.array[:] = d if alpha == 1.0 else (4.0 * d - d_prev) / 3.0
        t_new = (state.step_count + 1) * self.dt
        self._prepare(alpha, t_new)
        self._matrix(alpha)
        self.boundary.update(t_new)
        self.problem.update_sources(t_new)
        with self.timers("backtrack"):
            self.histories.update(alpha, state, self.solve_displacement)
        with self.timers("assemble_vector"):
            self._vector()
        self._solve(t_new)
        for _ in range(self.passes if alpha != 1.0 else 0):
            self._pass(alpha, t_new)
        state.shift(self.solution, self.problem.space)
        if self.d_star is not None:
            self._update_displacement(alpha)
        state.t, state.step_count = t_new, state.step_count + 1
        if observe is not None:
            observe()
        if self.motion is not None:
            with self.timers("mesh_motion"):
                self._move_mesh(alpha)

    def _prepare(self, alpha: float, t_new: float) -> None:
        """Before the matrix is assembled (the nodal scheme sets its convecting velocity)."""

    def _pass(self, alpha: float, t_new: float) -> None:
        """One more solve of the step (``time.corrector_passes``)."""
        raise NotImplementedError

    def _matrix(self, alpha: float):
        """Assemble (and have the solver factorise) the matrix when α changed or the matrix can change."""
        if (self.A is not None and self._alpha_of_A == alpha and self.motion is None
                and not self.NODAL_CONVECTION):
            return
        self.alpha.value = alpha
        self.solid_dt.value = self.dt / alpha
        self._reassemble(self.a_form)
        self._alpha_of_A = alpha

    def restored(self) -> None:
        super().restored()
        self._alpha_of_A = None

    def _update_displacement(self, alpha: float):
        """Seed §5.1: d^{n+1} = d^n∘X^n + δt u^{n+1}. The solid nodes move with the material, so in their
        frame X^n is the identity: d^{n+1}_i = d*_i + (δt/α) u^{n+1}_i (exact at the vertices; at the P2
        mid-edge nodes up to O(δt h² ∇²u) per step). Back-tracking d with the ALE velocity u − w instead
        (w the P1 mesh velocity) gives the same vertices but lets the mid-edge values drift from them; on
        the seed's FSI3 run that drift triggers a local pressure blow-up at the flag tip."""
        state = self.state
        state.displacement_prev.x.array[:] = state.displacement.x.array
        dim = self.problem.mesh.geometry.dim
        d, d_star = state.displacement.x.array.reshape(-1, dim), self.d_star.x.array.reshape(-1, dim)
        nodes = self.problem.solid_velocity_dofs
        d[nodes] = d_star[nodes] + (self.dt / alpha) * state.velocity.x.array.reshape(-1, dim)[nodes]
        state.displacement.x.scatter_forward()

    # ------------------------------------------------------------------------------ the mesh
    def _to_solve_configuration(self, alpha: float):
        """BDF2 on a moving mesh: put the mesh at Ω* = X + (4D^n − D^{n−1})/3 (Ω^n for the first-order
        start step), where d* = (4d^n − d^{n−1})/3 lives, or at X + 2D^n − D^{n−1} (``extrapolate``: the
        solid's nodes are the same material points, so d* and eq. 28 stay, but the gradients and the
        interface are those of t^{n+1} up to O(δt²)), and locate in it."""
        D = self.motion.displacement.x.array
        E = self.solve_displacement.x.array
        D_prev = self.state.mesh_displacement_prev.x.array
        E[:] = D if alpha == 1.0 else (4.0 * D - D_prev) / 3.0
        if self.motion_base is not None:
            self.motion_base[:] = E
        if self.extrapolate and alpha != 1.0:
            E[:] = 2.0 * D - D_prev
        self.motion.place(E, self.state.t)
        self.histories.mesh_moved(rebuild=True)

    def _move_mesh(self, alpha: float):
        """Ω^n → Ω^{n+1} (mesh motion) and the mesh velocity; BDF2 keeps the configurations."""
        state, m = self.state, self.motion
        if self.order == 2:  # the configuration u^n was computed on, for the next BDF2 feet
            state.configuration_nm1.x.array[:] = state.configuration_n.x.array
            state.configuration_n.x.array[:] = self.solve_displacement.x.array
            state.mesh_displacement_prev.x.array[:] = m.displacement.x.array
            self.histories.remember_configuration()
        base = (None if self.order == 1 else self.motion_base if self.motion_base is not None
                else self.solve_displacement.x.array)
        w_P1 = m.move(state.velocity, self.dt, state.t, alpha, base)
        state.mesh_velocity.interpolate(w_P1)
        self.histories.mesh_moved(rebuild=self.order == 2)
