"""One time step of the characteristics scheme (seed §5): histories → assemble → solve → update → move.

The forms are Problem.residual with the acceleration (α u − α h)/δt, split into matrix and right-hand
side. On a fixed mesh the matrix does not change from step to step (the convection is in the right-hand
side), so it is assembled and factorised once per value of the BDF coefficient α: once for the seed's
first-order scheme, twice for BDF2 (its first step is first order). On a moving mesh it is reassembled
every step; BDF2 then solves on the extrapolated configuration Ω* = X + (4D^n − D^{n−1})/3 (second order
in the geometry) where d* = (4d^n − d^{n−1})/3 lives.

``time.convection: ale`` (issue 12) discretises the fluid's material derivative along the mesh's nodes
instead of the characteristics: α(u − h)/δt with h the nodal values of the earlier levels, plus the
convection ((u* − w*)·∇)u in the matrix, u* = 2u^n − u^{n−1} and w* the mesh velocity u* gives (zero in
solid cells, where the mesh is the material and the nodal BDF2 is already the material derivative). One
linear solve per step as before, no back-tracking; the matrix changes every step (the kept factorisation
preconditions GMRES), and BDF2 on a moving mesh is solved on the extrapolated configuration, where the
nodes are at t^{n+1} to O(δt²).

``time.scheme: generalized_alpha`` (with ``ale``; Jansen, Whiting & Hulbert 2000): for FSI at large δt,
where BDF2's own damping (4.5 % of the amplitude per period at ωδt = 1/3) decides the error. With u̇ the
time derivative of the nodal values, the step solves

    ρ (u̇^{n+α_m} + ((u* − w*)·∇)u^{n+α_f}) + the viscous, couple and solid stresses at u^{n+α_f}, d^{n+α_f} = f,
    div u^{n+1} = 0,   u^{n+1} = u^n + δt((1 − γ)u̇^n + γu̇^{n+1}),   ḋ^{n+α_m} = u^{n+α_f} (likewise for d),

x^{n+a} = (1 − a)x^n + a x^{n+1}, on the configuration of t^{n+α_f} (its solid vertices at s^n + α_f δt ḋ^n,
u* = α_f(2u^n − u^{n−1}) + (1 − α_f)u^n and w* its extension). d^{n+α_f} = d* + k u^{n+1} is linear in
u^{n+1}: eq. (28) around d* with δt → k = α_f²γδt/α_m. α_m = (3 − ρ∞)/(2(1 + ρ∞)), α_f = 1/(1 + ρ∞),
γ = ½ + α_m − α_f: second order, and the stiffest modes are damped by ρ∞ per step (ρ∞ = 0 is BDF2 with
the base X + 2D^n − D^{n−1} of ``ale``). The first step is backward Euler (no u̇^0 needed). ρ∞ = 1 (the
implicit midpoint rule, no damping) is unstable with a solid: eq. (28) drops the geometric part of the
stress's change, which the configuration then supplies explicitly, and the solid's stiffest modes (ωδt ≈
100 on FSI3) grow. Measured on the flag alone at δt = 0.005: the θ-method with θ = ½ and 0.55 blows up
within 0.6 s, θ = 0.6 holds. The pressure is that of t^{n+α_f}. On a moving mesh the continuity equation
holds for u^{n+α_f} in the fluid (div u^{n+α_f} = 0 in Ω^{n+α_f}, where the step is solved: div u^{n+1}
= 0 there is an O(δt) error made anew every step, which made the scheme first order on a moving mesh),
and for u^{n+1} in the solid (with div u^{n+α_f} there FSI3 diverged within 3 s of flutter).
With ``time.corrector_passes`` and a moving solid each pass re-places the mesh at the predicted
t^{n+α_f} and re-linearises the solid stress and the convection there (``_correct_generalized_alpha``):
without it (session 14) FSI3 diverged at ρ∞ = 0.5. In a pass the solid's div u^{n+1} = 0 is taken in
Ω^{n+1}: pulled back with the predicted motion d^{n+1} − d^{n+α_f} (``kinematics.pulled_back_divergence``).
Each pass is one step of a fixed-point iteration whose limit is implicit in the geometry and the stress;
on FSI3 one pass is far from it and two are close (three change the amplitude by 0.1 point;
docs/performance.md, session 16).
"""

from __future__ import annotations

import numpy as np
from mpi4py import MPI

from .. import compat
from ..errors import DivergenceError
from ..physics.kinematics import pulled_back_divergence
from ..timers import Timers
from .boundary import BoundaryConditions
from .histories import Histories
from .linear_solver import LinearSolver
from .mesh_motion import PrescribedMotion
from .problem import Problem
from .state import State

import dolfinx
import dolfinx.fem.petsc as fem_petsc
import ufl
from petsc4py import PETSc

# the earlier levels the state keeps (generalised-α keeps the rates instead: State(rates=True));
# steady: scheme/steady.py
SCHEMES = {"characteristics1": 1, "characteristics2": 2, "generalized_alpha": 1, "steady": 1}


def generalized_alpha(rho_infinity: float) -> tuple[float, float, float]:
    """(α_m, α_f, γ) of the generalised-α method for first-order systems (Jansen, Whiting & Hulbert 2000):
    second order, amplification ρ∞ of the unresolved modes."""
    alpha_m = 0.5 * (3.0 - rho_infinity) / (1.0 + rho_infinity)
    alpha_f = 1.0 / (1.0 + rho_infinity)
    return alpha_m, alpha_f, 0.5 + alpha_m - alpha_f


class Stepper:
    """Advances a :class:`State` by one step of the scheme ``time.scheme`` (``order`` 1 or 2).

    The Simulation's stepper interface (shared with scheme/steady.py): ``advance(observe)``, ``solution``
    and ``space`` (the mixed solution), ``split_solution()``, ``acceleration(u)``, ``dx_inertia``,
    ``locator``, ``restored()``, ``check()``, ``report``.
    """

    report = None  # a Newton report (steady solvers)

    def __init__(self, problem: Problem, state: State, boundary: BoundaryConditions, histories: Histories,
                 solver: LinearSolver, motion=None, timers: Timers | None = None, comm=MPI.COMM_WORLD):
        scene = problem.scene
        self.problem, self.state, self.boundary, self.histories = problem, state, boundary, histories
        self.solver, self.motion, self.comm = solver, motion, comm
        self.timers = timers if timers is not None else Timers()
        self.dt = float(scene.time.dt)
        self.order = SCHEMES[scene.time.scheme]
        self.ga = (generalized_alpha(float(scene.time.rho_infinity)) if scene.time.scheme == "generalized_alpha"
                   else None)
        mesh = problem.mesh
        self.alpha = dolfinx.fem.Constant(mesh, PETSc.ScalarType(1.0))
        self.inv_dt = dolfinx.fem.Constant(mesh, PETSc.ScalarType(1.0 / self.dt))
        self.solid_dt = dolfinx.fem.Constant(mesh, PETSc.ScalarType(self.dt))  # δt/α of d = d* + (δt/α) u
        # the solid terms are linearised around d* = d^n (first order) or (4d^n − d^{n−1})/3 (BDF2)
        self.d_star = dolfinx.fem.Function(state.displacement.function_space) if problem.model.solid else None
        # BDF2 on a moving mesh: the displacement Ω* − X of the configuration the step is solved on
        self.solve_displacement = (dolfinx.fem.Function(motion.M) if motion is not None and self.order == 2
                                   else None)
        self.step_dt = dolfinx.fem.Constant(mesh, PETSc.ScalarType(self.dt))  # generalised-α's volume correction
        # generalised-α: u^n and ω^n of the step (the state's move on before the observers use the forms)
        self.u_old = self.omega_old = None
        self.alpha_f = dolfinx.fem.Constant(mesh, PETSc.ScalarType(1.0))  # the step's α_f
        if self.ga is not None:
            self.u_old = dolfinx.fem.Function(state.velocity.function_space)
            if state.micro_rotation is not None:
                self.omega_old = dolfinx.fem.Function(state.micro_rotation.function_space)
        # ... and the BDF2 base (4D^n − D^{n−1})/3 the solid vertices move on from (time.solve_configuration)
        # (time.convection: ale always: its nodal values are those of the nodes' places at t^{n+1})
        self.extrapolate = self.solve_displacement is not None and (
            scene.time.solve_configuration == "extrapolated" or scene.time.convection == "ale")
        # time.corrector_passes: re-solve on the predicted Ω^{n+1} around the predicted d^{n+1}
        self.passes = int(scene.time.corrector_passes) if self.solve_displacement is not None else 0
        self.motion_base = (np.zeros_like(self.solve_displacement.x.array) if self.extrapolate or self.passes
                            else None)
        # time.convection: ale — the convecting velocity c = u* − w* of ((u* − w*)·∇)u, none in solid cells
        self.ale = scene.time.convection == "ale"  # (always with generalised-α)
        self.convecting = self.fluid_cells = None
        if self.ale:
            V = problem.space.space("velocity")
            self.convecting = dolfinx.fem.Function(V, name="convecting_velocity")
            self.fluid_cells = problem.cellwise(1.0, 0.0) if problem.model.solid else None
            if motion is not None:
                self._w_P1, self._w = dolfinx.fem.Function(motion.M), dolfinx.fem.Function(V)
                self._step_rate = dolfinx.fem.Function(V)  # generalised-α: (d^{n+1} − d^n)/δt and the like
        # ale: time.corrector_passes re-linearise the convection around the last solution (Picard)
        self.picard = int(scene.time.corrector_passes) if self.ale else 0
        if self.ale:
            self.passes = 0
        # generalised-α with a moving solid: the passes re-place the mesh at the predicted t^{n+α_f} and
        # re-linearise the solid stress there too (the convection with it)
        self.ga_passes = 0
        if (self.ga is not None and problem.model.solid and motion is not None
                and not isinstance(motion, PrescribedMotion)):
            self.ga_passes, self.picard = self.picard, 0
        self.solution = dolfinx.fem.Function(problem.space.W, name="state")
        self.a_form, self.L_form = self._forms()
        # generalised-α passes: the predicted d^{n+1} − d^{n+α_f}, the solid's motion to Ω^{n+1}
        self.d_to_end = (dolfinx.fem.Function(state.displacement.function_space)
                         if self.ga_passes else None)
        if self.passes or self.ga_passes:
            self.d_predicted = dolfinx.fem.Function(state.displacement.function_space)
            self.u_predicted = dolfinx.fem.Function(state.velocity.function_space)
            self.a_corrector, self.L_corrector = self._forms(self.d_predicted)
        self.A = None
        self._alpha_of_A = None
        self.b = compat.create_vector(self.L_form, problem.space.W)

    def acceleration(self, u):
        """The material acceleration of u (the step's, with u the solution: residual forces)."""
        h = self.histories.velocity
        return self._convected(self._at_alpha_f(u, self.u_old),
                               Histories.acceleration(u, h, self.alpha, self.inv_dt))

    def _at_alpha_f(self, f, old):
        """Generalised-α: f^{n+α_f} = α_f f + (1 − α_f) f^n (``old`` holds f^n); other schemes: f."""
        if self.ga is None:
            return f
        return self.alpha_f * f + (1.0 - self.alpha_f) * old

    def _convected(self, f, rate):
        """``rate`` + ((u* − w*)·∇)f in fluid cells with ``time.convection: ale`` (the BDF of the nodal
        values is the rate along the mesh's motion w; the material derivative adds (u − w)·∇f), else
        ``rate``."""
        if not self.ale:
            return rate
        convection = ufl.grad(f) * self.convecting if ufl.shape(f) != () else ufl.dot(ufl.grad(f), self.convecting)
        return rate + (convection if self.fluid_cells is None else self.fluid_cells * convection)

    @property
    def space(self):
        return self.problem.space

    def split_solution(self) -> tuple:
        """(u, p, ω or None) of the solution, as UFL expressions."""
        return self.problem.split(self.solution)

    @property
    def dx_inertia(self):
        return self.histories.dx_inertia

    @property
    def locator(self):
        """The point locator of the current mesh."""
        return self.histories.chars.locator

    def check(self) -> None:
        """Nothing to report after the run: a time step that fails raises at once."""

    def _forms(self, d_predicted=None):
        pr, h = self.problem, self.histories
        trial, test = ufl.TrialFunctions(pr.space.W), ufl.TestFunctions(pr.space.W)
        u, _, omega = pr.split(trial)
        omega_f = self._at_alpha_f(omega, self.omega_old) if omega is not None else None
        micro = (self._convected(omega_f, Histories.acceleration(omega, h.micro_rotation, self.alpha, self.inv_dt))
                 if omega is not None else None)
        at = divergence = None
        if self.ga is not None:
            at = (self._at_alpha_f(u, self.u_old), omega_f)
            if self.motion is not None:  # div u^{n+α_f} = 0 in the fluid of Ω^{n+α_f} (module docstring)
                divergence = ufl.div(at[0])
                if self.fluid_cells is not None:  # the solid: div u^{n+1} = 0 (in Ω^{n+1}: corrector)
                    divergence = (self.fluid_cells * divergence
                                  + (1.0 - self.fluid_cells) * self._solid_divergence(u, d_predicted))
        F = pr.residual(trial, test, acceleration=self.acceleration(u), micro_acceleration=micro,
                        dx_inertia=h.dx_inertia, at=at, divergence=divergence)
        if pr.model.solid:
            F = F + pr.solid_residual(trial, test, self.d_star, self.solid_dt, d_predicted,
                                      step=self.step_dt if self.ga is not None else None)
        return compat.form(ufl.lhs(F)), compat.form(ufl.rhs(F))

    def _solid_divergence(self, u, d_predicted):
        """Generalised-α, the solid's div u^{n+1}: on Ω^{n+α_f}, where the step is solved; in a corrector
        pass pulled back from Ω^{n+1}: tr(∇u F⁻¹), F = I + ∇(x^{n+1} − x^{n+α_f}) with the predicted
        d^{n+1} − d^{n+α_f} (``self.d_to_end``)."""
        if d_predicted is None:  # (with generalised-α only its passes give one, and they set d_to_end)
            return ufl.div(u)
        # d_to_end is the solid's only in solid cells (this expression is multiplied by their indicator,
        # and 0 · NaN is NaN): masked, the fluid cells see F = I
        return pulled_back_divergence(u, (1.0 - self.fluid_cells) * self.d_to_end)

    # --------------------------------------------------------------------------------- one step
    def advance(self, observe=None) -> None:
        """t^n → t^{n+1}: solve on Ω^n (BDF2 moving: Ω*), update d, then move the mesh to Ω^{n+1}.
        ``observe()`` is called after the solve, while the mesh is still the one solved on."""
        if self.ga is not None:
            return self._advance_generalized_alpha(observe)
        state = self.state
        alpha = 1.0 if (self.order == 1 or state.step_count == 0) else 1.5
        if self.solve_displacement is not None:
            with self.timers("mesh_motion"):
                self._to_solve_configuration(alpha)
        if self.d_star is not None:
            d, d_prev = state.displacement.x.array, state.displacement_prev.x.array
            self.d_star.x.array[:] = d if alpha == 1.0 else (4.0 * d - d_prev) / 3.0
        t_new = (state.step_count + 1) * self.dt
        if self.ale:
            with self.timers("mesh_motion"):
                self._convecting_velocity(alpha, t_new)
        self._matrix(alpha)
        self.boundary.update(t_new)
        self.problem.update_sources(t_new)
        with self.timers("backtrack"):
            self.histories.update(alpha, state, self.solve_displacement)
        with self.timers("assemble_vector"):
            self._vector()
        self._solve(t_new)
        for _ in range(self.passes if alpha != 1.0 else 0):
            self._correct(alpha, t_new)
        for _ in range(self.picard if alpha != 1.0 else 0):
            self._picard(t_new)
        state.shift(self.solution, self.problem.space)
        if self.d_star is not None:
            self._update_displacement(alpha)
        state.t, state.step_count = t_new, state.step_count + 1
        if observe is not None:
            observe()
        if self.motion is not None:
            with self.timers("mesh_motion"):
                self._move_mesh(alpha)

    def _advance_generalized_alpha(self, observe=None) -> None:
        """t^n → t^{n+1} by generalised-α (module docstring): place the mesh at t^{n+α_f}, solve, update
        the rates and d, move the mesh to Ω^{n+1}. ``observe()`` as in :meth:`advance`."""
        state, dt = self.state, self.dt
        # the first step by backward Euler (α_m = α_f = γ = 1): it needs no u̇^0, whose error would stay
        # in u as O(δt) (u̇^0 = 0 is exact only from rest); its O(δt²) error is made once
        alpha_m, alpha_f, gamma = (1.0, 1.0, 1.0) if state.step_count == 0 else self.ga
        self.alpha_f.value = alpha_f
        t_f, t_new = state.t + alpha_f * dt, (state.step_count + 1) * dt
        u_n, u_prev = state.velocity.x.array.copy(), state.velocity_prev.x.array
        u_pred = u_n if state.step_count == 0 else 2.0 * u_n - u_prev  # u^{n+1} predicted
        self.u_old.x.array[:] = u_n
        if self.omega_old is not None:
            self.omega_old.x.array[:] = state.micro_rotation.x.array
        ratio = alpha_m / gamma  # u̇^{n+α_m} = ratio (u^{n+1} − u^n)/δt + (1 − ratio) u̇^n
        for target, now, rate in ((self.histories.velocity, state.velocity, state.velocity_rate),
                                  (self.histories.micro_rotation, state.micro_rotation, state.micro_rotation_rate)):
            if target is not None:  # α h = ratio f^n − δt (1 − ratio) ḟ^n, α = ratio
                target.x.array[:] = ratio * now.x.array - dt * (1.0 - ratio) * rate.x.array
        self.alpha.value = ratio
        d_rate = None
        if self.d_star is not None:  # d^{n+α_f} = d* + k u^{n+1}
            d_rate = state.displacement_rate.x.array
            self.d_star.x.array[:] = state.displacement.x.array + alpha_f * dt * (
                ((1.0 - gamma) - gamma * (1.0 - alpha_m) / alpha_m) * d_rate
                + (gamma / alpha_m) * (1.0 - alpha_f) * u_n)
            self.solid_dt.value = alpha_f * alpha_f * gamma * dt / alpha_m
        with self.timers("mesh_motion"):
            self._set_convecting(alpha_f * u_pred + (1.0 - alpha_f) * u_n, t_f)
            self._to_alpha_f_configuration(alpha_f, t_f)
        for f in (self.u_old, self.omega_old, self.d_star):
            if f is not None:
                f.x.scatter_forward()
        self._reassemble(self.a_form)
        self.boundary.update(t_new)
        self.problem.update_sources(t_f)
        with self.timers("assemble_vector"):
            self._vector()
        self._solve(t_new)
        for _ in range(self.picard):
            self._picard(t_new)
        for _ in range(self.ga_passes if state.step_count > 0 else 0):
            self._correct_generalized_alpha(alpha_f, t_f, t_new)
        x, space = self.solution.x.array, self.problem.space
        for rate, now, name in ((state.velocity_rate, state.velocity, "velocity"),
                                (state.micro_rotation_rate, state.micro_rotation, "micro_rotation")):
            if rate is not None:  # u̇^{n+1} = (u^{n+1} − u^n)/(γδt) − (1 − γ)/γ u̇^n
                rate.x.array[:] = ((x[space.dofs(name)] - now.x.array) / (gamma * dt)
                                   - (1.0 - gamma) / gamma * rate.x.array)
        state.shift(self.solution, space)
        if self.d_star is not None:  # ḋ^{n+1} = (u^{n+α_f} − (1 − α_m) ḋ^n)/α_m on the solid, d^{n+1}
            dim, nodes = self.problem.mesh.geometry.dim, self.problem.solid_velocity_dofs
            state.displacement_prev.x.array[:] = state.displacement.x.array
            d, r = state.displacement.x.array.reshape(-1, dim), d_rate.reshape(-1, dim)
            u_new, u_old = state.velocity.x.array.reshape(-1, dim)[nodes], u_n.reshape(-1, dim)[nodes]
            u_f = alpha_f * u_new + (1.0 - alpha_f) * u_old
            r_new = (u_f - (1.0 - alpha_m) * r[nodes]) / alpha_m
            d[nodes] += dt * ((1.0 - gamma) * r[nodes] + gamma * r_new)
            r[nodes] = r_new
            state.displacement.x.scatter_forward()
            state.displacement_rate.x.scatter_forward()
        state.t, state.step_count = t_new, state.step_count + 1
        if observe is not None:
            observe()
        if self.motion is not None:
            with self.timers("mesh_motion"):
                m, step = self.motion, self._step_rate
                if self.d_star is not None:  # the solid vertices move as d: s^{n+1} = s^n + (d^{n+1} − d^n)
                    step.x.array[:] = (state.displacement.x.array - state.displacement_prev.x.array) / dt
                w_P1 = m.move(step, dt, state.t)
                state.mesh_velocity.interpolate(w_P1)
                self.histories.mesh_moved(rebuild=False)

    def _to_alpha_f_configuration(self, alpha_f: float, t_f: float):
        """Generalised-α: the mesh goes to the configuration of t^{n+α_f}: the solid vertices at
        s^n + α_f δt ḋ^n, extended (a prescribed motion: its displacement at t^{n+α_f}). With the last rate
        ḋ^n, not an extrapolation of u: the configuration carries the part of the stress's change that
        eq. (28) leaves explicit, and an extrapolation (2u^n − u^{n−1}) amplifies the solid's fast modes
        there: with it FSI3 diverged at δt = 0.005 even at ρ∞ = 0, which is then BDF2 (whose base
        X + 2D^n − D^{n−1} is this configuration)."""
        m, state = self.motion, self.state
        if m is None:
            return
        if isinstance(m, PrescribedMotion):
            m.place(np.asarray(m.motion(m._X0_dof, t_f), dtype=float).ravel(), state.t)
            self.histories.mesh_moved(rebuild=False)
        else:
            self._place_solid_moved_by(alpha_f * self.dt * state.displacement_rate.x.array)

    def _place_solid_moved_by(self, increment: np.ndarray):
        """Generalised-α: place the mesh with its solid vertices at s^n + P1(``increment``) (a P2 velocity-
        space array; only its solid vertices' values count), the rest by the extension."""
        m, step = self.motion, self._step_rate
        step.x.array[:] = increment
        m._u_P1.interpolate(step)
        m.place(m.extend(m.solid_displacement.x.array + m._u_P1.x.array), self.state.t)
        self.histories.mesh_moved(rebuild=False)

    def _correct_generalized_alpha(self, alpha_f: float, t_f: float, t_new: float):
        """Generalised-α with a moving solid and ``time.corrector_passes``: with the solution as the
        prediction of u^{n+1}, d^{n+α_f} = d* + k u^{n+1} predicted, the mesh re-placed at the predicted
        t^{n+α_f} (solid vertices s^n + P1(d^{n+α_f} − d^n), extended), the convection at u^{n+α_f} with
        the mesh velocity it gives, the solid stress linearised around d^{n+α_f} (one Newton step of
        S(d) = Dd − GᵀG, ``solid.corrector_stress_residual``), solved again (kept factorisation as the
        preconditioner). The converged limit is generalised-α implicit in the geometry and the stress."""
        state, space = self.state, self.problem.space
        dim, nodes = self.problem.mesh.geometry.dim, self.problem.solid_velocity_dofs
        u_new = np.ravel(self.solution.x.array[space.dofs("velocity")])
        d_hat = self.d_predicted.x.array
        d_hat[:] = self.d_star.x.array
        d_hat.reshape(-1, dim)[nodes] += float(self.solid_dt.value) * u_new.reshape(-1, dim)[nodes]
        self.d_predicted.x.scatter_forward()
        increment = d_hat - state.displacement.x.array  # d^{n+α_f} − d^n
        self.d_to_end.x.array[:] = (1.0 - alpha_f) / alpha_f * increment  # d^{n+1} − d^{n+α_f}
        self.d_to_end.x.scatter_forward()
        with self.timers("mesh_motion"):
            self._place_solid_moved_by(increment)
            self._set_convecting(alpha_f * u_new + (1.0 - alpha_f) * self.u_old.x.array, t_f)
        self._reassemble(self.a_corrector)
        with self.timers("assemble_vector"):
            self._vector(self.L_corrector, self.a_corrector)
        self._solve(t_new)

    def _matrix(self, alpha: float):
        """Assemble (and have the solver factorise) the matrix when α changed or the mesh moved."""
        if self.A is not None and self._alpha_of_A == alpha and self.motion is None and not self.ale:
            return
        self.alpha.value = alpha
        self.solid_dt.value = self.dt / alpha
        self._reassemble(self.a_form)
        self._alpha_of_A = alpha

    def _reassemble(self, a_form):
        """Assemble ``a_form`` into the matrix (created at the first call) and hand it to the solver."""
        with self.timers("assemble_matrix"):
            bcs = self.boundary.bcs
            if self.A is None:
                self.A = fem_petsc.assemble_matrix(a_form, bcs=bcs)
            else:
                self.A.zeroEntries()
                fem_petsc.assemble_matrix(self.A, a_form, bcs=bcs)
            self.A.assemble()
            self.solver.set_operator(self.A)

    def _solve(self, t_new: float):
        """Solve for the step's solution (``self.b`` assembled); DivergenceError if it is not finite."""
        with self.timers("solve"):
            self.solver.solve(self.b, compat.petsc_vec(self.solution))
            self.solution.x.scatter_forward()
        self._check_finite(t_new)

    def _convecting_velocity(self, alpha: float, t_new: float):
        """``time.convection: ale``: the convecting velocity (:meth:`_set_convecting`) with u* = u^n (first
        order) or 2u^n − u^{n−1} at t^{n+1}."""
        u, u_prev = self.state.velocity.x.array, self.state.velocity_prev.x.array
        self._set_convecting(u if alpha == 1.0 else 2.0 * u - u_prev, t_new)

    def _set_convecting(self, u_star: np.ndarray, t: float):
        """c = u* − w*, w* the mesh velocity u* gives: the extension of u* from the solid's vertices (the
        solid vertices move with the velocity and the extension is linear, so the mesh velocity at t is the
        extension of u(t); an extrapolated u* makes it O(δt²)); a prescribed motion's, its rate at t."""
        c, m = self.convecting, self.motion
        c.x.array[:] = u_star
        self._u_star = c.x.array.copy()
        if m is not None:
            self._w_P1.x.array[:] = (m.velocity_of(c, t) if isinstance(m, PrescribedMotion)
                                     else m.velocity_of(c))
            self._w.interpolate(self._w_P1)
            c.x.array[:] -= self._w.x.array
        c.x.scatter_forward()

    def _picard(self, t_new: float):
        """``time.convection: ale`` with ``time.corrector_passes``: the convecting velocity becomes
        u^{n+1} − w* with the step's solution for u^{n+1} (one Picard iteration of the convection; the
        mesh, its velocity and the histories stay), and the step is solved again."""
        c = self.convecting
        u_new = np.ravel(self.solution.x.array[self.problem.space.dofs("velocity")])
        if self.ga is not None:  # generalised-α convects with u^{n+α_f}
            a_f = float(self.alpha_f.value)
            u_new = a_f * u_new + (1.0 - a_f) * self.state.velocity.x.array
        c.x.array[:] += u_new - self._u_star
        self._u_star = u_new.copy()
        c.x.scatter_forward()
        self._reassemble(self.a_form)
        with self.timers("assemble_vector"):
            self._vector()
        self._solve(t_new)

    def _correct(self, alpha: float, t_new: float):
        """One corrector pass (``time.corrector_passes``): with the solution as the prediction of u^{n+1},
        move the mesh to the predicted Ω^{n+1} (solid vertices s* + (δt/α) u, extension as in
        ``motion.move``), back-track from its quadrature points, linearise the solid stress around the
        predicted d^{n+1} = d* + (δt/α) u and solve again (the solver keeps its factorisation as the
        preconditioner). The configuration and the state's time levels stay those of the step."""
        m, dt_a = self.motion, self.dt / alpha
        space = self.problem.space
        with self.timers("mesh_motion"):
            self.u_predicted.x.array[:] = self.solution.x.array[space.dofs("velocity")]
            m._u_P1.interpolate(self.u_predicted)
            s = self.motion_base.copy()
            entries = m._solid_entries
            s[entries] += dt_a * m._u_P1.x.array[entries]
            self.solve_displacement.x.array[:] = m.extend(s)
            m.place(self.solve_displacement.x.array, self.state.t)
            self.histories.mesh_moved(rebuild=True)
        nodes = self.problem.solid_velocity_dofs
        d_hat = self.d_predicted.x.array
        d_hat[:] = self.d_star.x.array
        dim = self.problem.mesh.geometry.dim
        d_hat.reshape(-1, dim)[nodes] += dt_a * self.u_predicted.x.array.reshape(-1, dim)[nodes]
        self.d_predicted.x.scatter_forward()
        self._reassemble(self.a_corrector)
        with self.timers("backtrack"):
            self.histories.update(alpha, self.state, self.solve_displacement)
        with self.timers("assemble_vector"):
            self._vector(self.L_corrector, self.a_corrector)
        self._solve(t_new)

    def _vector(self, L_form=None, a_form=None):
        b, bcs = self.b, self.boundary.bcs
        with b.localForm() as loc:
            loc.set(0.0)
        fem_petsc.assemble_vector(b, self.L_form if L_form is None else L_form)
        fem_petsc.apply_lifting(b, [self.a_form if a_form is None else a_form], bcs=[bcs])
        b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        fem_petsc.set_bc(b, bcs)

    def _check_finite(self, t):
        bad = not np.isfinite(self.solution.x.array).all()
        reason = self.solver.converged_reason()
        if self.comm.allreduce(bad or reason < 0, op=MPI.LOR):
            raise DivergenceError(f"step {self.state.step_count + 1} (t = {t:.6g}): non-finite solution "
                                  f"(linear solver reason {reason}); try a smaller time.dt or a finer mesh")

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
        start step), where d* = (4d^n − d^{n−1})/3 lives, and locate in it. With
        ``time.solve_configuration: extrapolated`` the mesh goes to X + 2D^n − D^{n−1} instead, O(δt²) from
        Ω^{n+1}: the solid's nodes are the same material points, so d* and the linearisation (28) stay,
        but the gradients and the interface are those of t^{n+1} up to O(δt²) (on Ω* they lag by
        (2δt/3) u, an O(δt) error in the stress and the interface position)."""
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

    def restored(self) -> None:
        """After ``state.restore``: the mixed solution (the Krylov initial guess), the mesh, the locators,
        and a fresh matrix."""
        self.state.to_mixed(self.solution, self.problem.space)
        if self.motion is not None:  # the mesh: reference + displacement
            m = self.motion
            self.problem.mesh.geometry.x[:, :m.dim] = m.X0 + m.displacement.x.array.reshape(-1, m.dim)[m.node_dof]
            self.histories.relocate(m, self.state)
        self.A, self._alpha_of_A = None, None
        self.solver.reset()
