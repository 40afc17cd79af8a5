"""The BDF step shared by the characteristics schemes (characteristics.py) and ``ale_bdf2`` (ale_bdf.py).

First order (seed §5): α = 1, the acceleration (u − h)/δt. BDF2: α = 3/2, the first step first order. The
solid's displacement is linearised around d* = d^n (first order) or (4d^n − d^{n−1})/3 (BDF2) with
d^{n+1} = d* + (δt/α) u^{n+1} (eq. 28). On a moving mesh BDF2 solves on a configuration of its own: the BDF2
base X + (4D^n − D^{n−1})/3 where d* lives, or (``EXTRAPOLATED_CONFIGURATION``) the extrapolation
X + 2D^n − D^{n−1}, the nodes' places at t^{n+1} to O(δt²); the solid vertices then move on from the base.
With steps of varying size (``time.tolerance``, or
``Simulation.step(dt=...)``) the weights are those of the step ratio (variable_step.BdfWeights) everywhere.
With ``solid.displacement: linear`` each step's d^{n+1} is replaced by its interpolant linear on each cell,
the degree of the mesh that moves with the solid (docs/perf_adaptive_step.md).
"""

from __future__ import annotations

import numpy as np

from .. import compat
from .time_step import TimeStep
from .variable_step import BdfWeights

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
        self._velocity_now = None  # check_motion(): the attempted step's velocity
        solid = problem.scene.solid
        self.linear_displacement = self.d_star is not None and solid.displacement == "linear"
        self._linear_spaces = None  # (P1 vector function, scratch function of d's space)

    def _build_forms(self):
        """The step's forms and right-hand side vector (once the subclass has set up what they use)."""
        self.a_form, self.L_form = self._forms()
        self.b = compat.create_vector(self.L_form, self.problem.space.W)

    # --------------------------------------------------------------------------------- one step
    def weights(self) -> BdfWeights:
        """The BDF weights of the coming step of size ``self.dt`` (first order, or BDF2's first step: backward
        Euler; BDF2: the step ratio ω = δt_n/δt_{n−1})."""
        state = self.state
        if self.order == 1 or state.step_count == 0:
            return BdfWeights(1, self.dt)
        last = state.steps.last
        return BdfWeights(2, self.dt, self.dt / last if last > 0.0 else 1.0)

    def _attempt(self) -> None:
        """Solve t^n → t^{n+1} of size ``self.dt`` on Ω^n (BDF2 moving: its own configuration); the state is
        not changed (a rejected attempt is simply tried again)."""
        state = self.state
        self.bdf = bdf = self.weights()
        alpha = bdf.alpha
        if self.solve_displacement is not None:
            with self.timers("mesh_motion"):
                self._to_solve_configuration(bdf)
        if self.d_star is not None:
            self.d_star.x.array[:] = bdf.base(state.displacement.x.array, state.displacement_prev.x.array)
        t_new = self.t_new = self._time_after_step()
        self._prepare(bdf, t_new)
        self._matrix(alpha)
        self.boundary.update(t_new)
        self.problem.update_sources(t_new)
        with self.timers("backtrack"):
            self.histories.update(bdf, state, self.solve_displacement)
        with self.timers("assemble_vector"):
            self._vector()
        self._solve(t_new)
        for _ in range(self.passes if bdf.order == 2 else 0):
            self._pass(bdf, t_new)

    def _commit(self, observe=None) -> None:
        """The attempted step becomes t^{n+1}: the levels, d, t; ``observe()`` while the mesh is still the
        one solved on; then the mesh moves to Ω^{n+1}."""
        state, bdf = self.state, self.bdf
        state.shift(self.solution, self.problem.space)
        if self.d_star is not None:
            self._update_displacement(bdf.alpha)
        state.t, state.step_count = self.t_new, state.step_count + 1
        state.steps.accepted(self.dt)
        if observe is not None:
            observe()
        if self.motion is not None:
            with self.timers("mesh_motion"):
                self._move_mesh(bdf)

    def candidate_displacement(self):
        """d^{n+1} = d* + (δt/α) u^{n+1} at the solid's nodes (an array of the node's components) of the
        attempted step, or None without a solid."""
        if self.d_star is None:
            return None
        dim, nodes = self.problem.mesh.geometry.dim, self.problem.solid_velocity_dofs
        u = self._new_velocity().reshape(-1, dim)[nodes]
        d = self.d_star.x.array.reshape(-1, dim)[nodes] + (self.dt / self.bdf.alpha) * u
        return self._linear_on_cells(d) if self.linear_displacement else d

    def _linear_on_cells(self, values: np.ndarray) -> np.ndarray:
        """The solid nodes' displacement ``values`` (node × component) → its interpolant linear on each cell:
        a vertex keeps its value, a mid-edge node gets the mean of its edge's two (``solid.displacement:
        linear``; the solid's edges have solid vertices, so the fluid's values do not enter)."""
        V = self.state.displacement.function_space
        if self._linear_spaces is None:
            dim = self.problem.mesh.geometry.dim
            P1 = compat.function_space(V.mesh, "Lagrange", 1, shape=(dim,))
            self._linear_spaces = (dolfinx.fem.Function(P1), dolfinx.fem.Function(V))
        linear, full = self._linear_spaces
        nodes = self.problem.solid_velocity_dofs
        full.x.array[:] = self.state.displacement.x.array
        full.x.array.reshape(-1, values.shape[1])[nodes] = values
        full.x.scatter_forward()
        linear.interpolate(full)
        full.interpolate(linear)
        return full.x.array.reshape(-1, values.shape[1])[nodes].copy()

    def _prepare(self, bdf: BdfWeights, t_new: float) -> None:
        """Before the matrix is assembled (the nodal scheme sets its convecting velocity)."""

    def _pass(self, bdf: BdfWeights, t_new: float) -> None:
        """One more solve of the step (``time.corrector_passes``)."""
        raise NotImplementedError

    def _matrix(self, alpha: float):
        """Assemble (and have the solver factorise) the matrix when α or δt changed or the matrix can change."""
        if (self.A is not None and self._alpha_of_A == (alpha, self.dt) and self.motion is None
                and not self.NODAL_CONVECTION):
            return
        self.alpha.value = alpha
        self.inv_dt.value = 1.0 / self.dt
        self.solid_dt.value = self.dt / alpha
        self._reassemble(self.a_form)
        self._alpha_of_A = (alpha, self.dt)

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
        state.new_displacement_level()
        dim = self.problem.mesh.geometry.dim
        d, d_star = state.displacement.x.array.reshape(-1, dim), self.d_star.x.array.reshape(-1, dim)
        nodes = self.problem.solid_velocity_dofs
        d[nodes] = d_star[nodes] + (self.dt / alpha) * state.velocity.x.array.reshape(-1, dim)[nodes]
        if self.linear_displacement:
            d[nodes] = self._linear_on_cells(d[nodes])
        state.displacement.x.scatter_forward()

    # ------------------------------------------------------------------------------ the mesh
    def _to_solve_configuration(self, bdf: BdfWeights):
        """BDF2 on a moving mesh: put the mesh at Ω* = X + D*, D* the BDF2 base of D (``BdfWeights.base``:
        (4D^n − D^{n−1})/3 at constant steps; Ω^n for the first-order start step), where d* lives, or at the
        extrapolation X + (1 + ω)D^n − ωD^{n−1} (``extrapolate``: the solid's nodes are the same material
        points, so d* and eq. 28 stay, but the gradients and the interface are those of t^{n+1} up to
        O(δt²)), and locate in it."""
        D = self.motion.displacement.x.array
        E = self.solve_displacement.x.array
        D_prev = self.state.mesh_displacement_prev.x.array
        E[:] = bdf.base(D, D_prev)
        if self.motion_base is not None:
            self.motion_base[:] = E
        if self.extrapolate and bdf.order == 2:
            E[:] = bdf.extrapolated(D, D_prev)
        self.motion.place(E, self.state.t)
        self.histories.mesh_moved(rebuild=True)

    def _motion_base(self):
        """s* of the solid vertices' move (None: s^n)."""
        return (None if self.order == 1 else self.motion_base if self.motion_base is not None
                else self.solve_displacement.x.array)

    def check_motion(self) -> None:
        """The attempted step's mesh motion, checked before the step is accepted (MeshMotion.plan)."""
        if not hasattr(self.motion, "plan"):
            return
        if self._velocity_now is None:
            self._velocity_now = dolfinx.fem.Function(self.state.velocity.function_space)
        self._velocity_now.x.array[:] = self._new_velocity()
        with self.timers("mesh_motion"):
            self.motion.plan(self._velocity_now, self.dt, self.t_new, self.bdf.alpha, self._motion_base())

    def _move_mesh(self, bdf: BdfWeights):
        """Ω^n → Ω^{n+1} (mesh motion) and the mesh velocity; BDF2 keeps the configurations."""
        state, m = self.state, self.motion
        if self.order == 2:  # the configuration u^n was computed on, for the next BDF2 feet
            state.configuration_nm1.x.array[:] = state.configuration_n.x.array
            state.configuration_n.x.array[:] = self.solve_displacement.x.array
            state.mesh_displacement_prev.x.array[:] = m.displacement.x.array
            self.histories.remember_configuration()
        w_P1 = m.move(state.velocity, self.dt, state.t, bdf.alpha, self._motion_base())
        state.mesh_velocity.interpolate(w_P1)
        self.histories.mesh_moved(rebuild=self.order == 2)
