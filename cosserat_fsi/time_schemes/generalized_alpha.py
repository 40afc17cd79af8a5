"""``time.scheme: generalized_alpha``: the generalised-α method (Jansen, Whiting & Hulbert 2000) on the nodal
values, with the convection relative to the moving mesh (nodal.py).

For FSI at large δt, where BDF2's own damping (4.5 % of the amplitude per period at ωδt = 1/3) decides the
error. With u̇ the time derivative of the nodal values, the step solves

    ρ (u̇^{n+α_m} + ((u* − w*)·∇)u^{n+α_f}) + the viscous, couple and solid stresses at u^{n+α_f}, d^{n+α_f} = f,
    div u^{n+1} = 0,   u^{n+1} = u^n + δt((1 − γ)u̇^n + γu̇^{n+1}),   ḋ^{n+α_m} = u^{n+α_f} (likewise for d),

x^{n+a} = (1 − a)x^n + a x^{n+1}, on the configuration of t^{n+α_f} (its solid vertices at s^n + α_f δt ḋ^n,
u* = α_f(2u^n − u^{n−1}) + (1 − α_f)u^n and w* its extension). d^{n+α_f} = d* + k u^{n+1} is linear in
u^{n+1}: eq. (28) around d* with δt → k = α_f²γδt/α_m. α_m = (3 − ρ∞)/(2(1 + ρ∞)), α_f = 1/(1 + ρ∞),
γ = ½ + α_m − α_f: second order, and the stiffest modes are damped by ρ∞ per step (ρ∞ = 0 is BDF2 with
the base X + 2D^n − D^{n−1} of ``ale_bdf2``). The first step is backward Euler (no u̇^0 needed). ρ∞ = 1 (the
implicit midpoint rule, no damping) is unstable with a solid: eq. (28) drops the geometric part of the
stress's change, which the configuration then supplies explicitly, and the solid's stiffest modes (ωδt ≈
100 on FSI3) grow. Measured on the flag alone at δt = 0.005: the θ-method with θ = ½ and 0.55 blows up
within 0.6 s, θ = 0.6 holds. The pressure is that of t^{n+α_f}. On a moving mesh the continuity equation
holds for u^{n+α_f} in the fluid of Ω^{n+α_f}, where the step is solved (div u^{n+1} = 0 there is an O(δt)
error made anew every step: first order), and for u^{n+1} in the solid (with div u^{n+α_f} there FSI3
diverged within 3 s of flutter).

``corrector_passes`` with a moving solid: each pass re-places the mesh at the predicted t^{n+α_f} and
re-linearises the solid stress and the convection there; the solid's div u^{n+1} = 0 is then taken in
Ω^{n+1}, pulled back with the predicted motion d^{n+1} − d^{n+α_f}. Each pass is one step of a fixed-point
iteration whose limit is implicit in the geometry and the stress: without passes FSI3 diverges at ρ∞ = 0.5,
one pass is far from the limit, two are close (a third changes the amplitude by 0.1 point). Without a
moving solid the passes are Picard passes of the convection, as with ``ale_bdf2``.
"""

from __future__ import annotations

import numpy as np

from .. import compat
from ..physics.kinematics import pulled_back_divergence
from ..mesh.motion import PrescribedMotion
from .nodal import MeshConvection, NodalHistories
from .time_step import TimeStep

import dolfinx
import ufl
from petsc4py import PETSc


def generalized_alpha(rho_infinity: float) -> tuple[float, float, float]:
    """(α_m, α_f, γ) of the generalised-α method for first-order systems (Jansen, Whiting & Hulbert 2000):
    second order, amplification ρ∞ of the unresolved modes."""
    alpha_m = 0.5 * (3.0 - rho_infinity) / (1.0 + rho_infinity)
    alpha_f = 1.0 / (1.0 + rho_infinity)
    return alpha_m, alpha_f, 0.5 + alpha_m - alpha_f


class GeneralizedAlpha(TimeStep):
    """Generalised-α on the nodal values (module docstring)."""

    RATES = True
    ORDER = 2
    NODAL_CONVECTION = True

    @staticmethod
    def levels(time) -> int:
        return 1  # u^{n−1} (the predictor's) is kept anyway; the rates carry the rest

    @classmethod
    def histories_for(cls, problem, motion, comm):
        return NodalHistories(problem)

    def __init__(self, problem, state, boundary, histories, solver, motion, timers, comm):
        super().__init__(problem, state, boundary, histories, solver, motion, timers, comm)
        time, mesh = problem.scene.time, problem.mesh
        self.coefficients = generalized_alpha(float(time.rho_infinity))
        self.step_dt = dolfinx.fem.Constant(mesh, PETSc.ScalarType(self.dt))  # the volume correction's time
        self.alpha_f = dolfinx.fem.Constant(mesh, PETSc.ScalarType(1.0))  # the step's α_f
        # u^n and ω^n of the step (the state moves on before the observers use the forms)
        self.u_old = dolfinx.fem.Function(state.velocity.function_space)
        self.omega_old = (dolfinx.fem.Function(state.micro_rotation.function_space)
                          if state.micro_rotation is not None else None)
        self.convection = MeshConvection(problem, motion)
        if motion is not None:
            self._step_rate = dolfinx.fem.Function(problem.space.space("velocity"))  # (d^{n+1} − d^n)/δt, ...
        passes = int(time.corrector_passes)
        # with a moving solid the passes re-place the mesh at the predicted t^{n+α_f}; else Picard passes
        moving_solid = (problem.model.solid and motion is not None and not isinstance(motion, PrescribedMotion))
        self.solid_passes, self.picard_passes = (passes, 0) if moving_solid else (0, passes)
        self.a_form, self.L_form = self._forms()
        if self.solid_passes:
            V = state.displacement.function_space
            self.d_to_end = dolfinx.fem.Function(V)  # the predicted d^{n+1} − d^{n+α_f}
            self.d_predicted = dolfinx.fem.Function(V)
            self.a_corrector, self.L_corrector = self._forms(self.d_predicted)
        self.b = compat.create_vector(self.L_form, problem.space.W)

    # ------------------------------------------------------------------------------ the forms
    def _at(self, f, old):
        """f^{n+α_f} = α_f f + (1 − α_f) f^n (``old`` holds f^n)."""
        return self.alpha_f * f + (1.0 - self.alpha_f) * old

    def _convected(self, f, rate):
        return self.convection.material_derivative(f, rate)

    def _volume_correction_step(self):
        return self.step_dt if self.correction_time is None else self.correction_time

    def _evaluation(self, u, omega_at, d_predicted):
        """The stresses at (u^{n+α_f}, ω^{n+α_f}); on a moving mesh the continuity equation div u^{n+α_f} = 0
        in the fluid and the solid's div u^{n+1} = 0 (in Ω^{n+1} in a corrector pass)."""
        at = (self._at(u, self.u_old), omega_at)
        divergence = None
        if self.motion is not None:
            divergence = ufl.div(at[0])
            fluid = self.convection.fluid_cells
            if fluid is not None:
                divergence = fluid * divergence + (1.0 - fluid) * self._solid_divergence(u, d_predicted)
        return at, divergence

    def _solid_divergence(self, u, d_predicted):
        """The solid's div u^{n+1}: on Ω^{n+α_f}, where the step is solved; in a corrector pass pulled back
        from Ω^{n+1}: tr(∇u F⁻¹), F = I + ∇(x^{n+1} − x^{n+α_f}) with the predicted d^{n+1} − d^{n+α_f}."""
        if d_predicted is None:
            return ufl.div(u)
        # d_to_end is the solid's only in solid cells (this expression is multiplied by their indicator,
        # and 0 · NaN is NaN): masked, the fluid cells see F = I
        return pulled_back_divergence(u, (1.0 - self.convection.fluid_cells) * self.d_to_end)

    # --------------------------------------------------------------------------------- one step
    def _attempt(self) -> None:
        """Solve t^n → t^{n+1} of size ``self.dt``: place the mesh at t^{n+α_f} and solve (the state is not
        changed)."""
        state, dt = self.state, self.dt
        self.step_dt.value, self.inv_dt.value = dt, 1.0 / dt
        # the first step by backward Euler (α_m = α_f = γ = 1): it needs no u̇^0, whose error would stay
        # in u as O(δt) (u̇^0 = 0 is exact only from rest); its O(δt²) error is made once
        alpha_m, alpha_f, gamma = (1.0, 1.0, 1.0) if state.step_count == 0 else self.coefficients
        self.alpha_f.value = alpha_f
        t_f, t_new = state.t + alpha_f * dt, self._time_after_step()
        self.t_new, self.step_coefficients = t_new, (alpha_m, alpha_f, gamma)
        u_n, u_prev = state.velocity.x.array.copy(), state.velocity_prev.x.array
        self.u_n = u_n
        last = state.steps.last
        ratio = dt / last if last > 0.0 else 1.0
        self._rates_before = self._shift_rates(dt) if state.step_count >= 2 and ratio != 1.0 else None
        # u^{n+1} predicted: (1 + ω)u^n − ωu^{n−1} (2u^n − u^{n−1} at constant steps)
        u_pred = u_n if state.step_count == 0 else (1.0 + ratio) * u_n - ratio * u_prev
        self.u_old.x.array[:] = u_n
        if self.omega_old is not None:
            self.omega_old.x.array[:] = state.micro_rotation.x.array
        ratio = alpha_m / gamma  # u̇^{n+α_m} = ratio (u^{n+1} − u^n)/δt + (1 − ratio) u̇^n
        for target, now, rate in ((self.histories.velocity, state.velocity, state.velocity_rate),
                                  (self.histories.micro_rotation, state.micro_rotation, state.micro_rotation_rate)):
            if target is not None:  # α h = ratio f^n − δt (1 − ratio) ḟ^n, α = ratio
                target.x.array[:] = ratio * now.x.array - dt * (1.0 - ratio) * rate.x.array
        self.alpha.value = ratio
        self.d_rate = d_rate = None
        if self.d_star is not None:  # d^{n+α_f} = d* + k u^{n+1}
            self.d_rate = d_rate = state.displacement_rate.x.array
            self.d_star.x.array[:] = state.displacement.x.array + alpha_f * dt * (
                ((1.0 - gamma) - gamma * (1.0 - alpha_m) / alpha_m) * d_rate
                + (gamma / alpha_m) * (1.0 - alpha_f) * u_n)
            self.solid_dt.value = alpha_f * alpha_f * gamma * dt / alpha_m
        with self.timers("mesh_motion"):
            self.convection.set(alpha_f * u_pred + (1.0 - alpha_f) * u_n, t_f)
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
        for _ in range(self.picard_passes):
            self._picard(alpha_f, t_new)
        for _ in range(self.solid_passes if state.step_count > 0 else 0):
            self._correct(alpha_f, t_f, t_new)

    def _commit(self, observe=None) -> None:
        """The attempted step becomes t^{n+1}: rates, levels, d, t; ``observe()`` while the mesh is still
        the one solved on; then the mesh moves to Ω^{n+1}."""
        state, dt = self.state, self.dt
        self._update_state(*self.step_coefficients, self.u_n, self.d_rate, self.t_new)
        state.steps.accepted(dt)
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

    def _shift_rates(self, dt: float) -> list:
        """A step of another size than the last: the rates move to the new step's lag. The rate ḟ^n of
        generalised-α approximates ḟ(t^n + (α_f − α_m) δt_{n−1}) (so that ḟ^{n+α_m} = ḟ(t^{n+α_f}) and
        γ = ½ + α_m − α_f make the update second order); left there, a step of another size makes an O(δt)
        error each time (first order on a varying step). ḟ^n += (α_f − α_m)(δt_n − δt_{n−1}) f̈, with f̈ from
        the rates of the last two steps. Returns the rates as they were (a rejected attempt puts them back)."""
        state = self.state
        alpha_m, alpha_f, _ = self.coefficients
        last = state.steps.last
        before = [(f, f.x.array.copy()) for f in state.rates()]
        for f in state.rates():
            previous = state.rates_prev[id(f)].x.array
            f.x.array[:] += (alpha_f - alpha_m) * (dt - last) / last * (f.x.array - previous)
        return before

    def _rejected(self) -> None:
        if self._rates_before is not None:
            for f, values in self._rates_before:
                f.x.array[:] = values
        super()._rejected()

    def candidate_displacement(self):
        """d^{n+1} at the solid's nodes (as :meth:`_update_state` will set it) of the attempted step, or None."""
        if self.d_star is None:
            return None
        alpha_m, alpha_f, gamma = self.step_coefficients
        dim, nodes = self.problem.mesh.geometry.dim, self.problem.solid_velocity_dofs
        r = self.d_rate.reshape(-1, dim)[nodes]
        u_f = (alpha_f * self._new_velocity().reshape(-1, dim)[nodes]
               + (1.0 - alpha_f) * self.u_n.reshape(-1, dim)[nodes])
        r_new = (u_f - (1.0 - alpha_m) * r) / alpha_m
        return self.state.displacement.x.array.reshape(-1, dim)[nodes] + self.dt * ((1.0 - gamma) * r + gamma * r_new)

    def _update_state(self, alpha_m, alpha_f, gamma, u_n, d_rate, t_new):
        """The rates u̇^{n+1}, ω̇^{n+1}, the levels, ḋ^{n+1} and d^{n+1}, t^{n+1}."""
        state, dt = self.state, self.dt
        x, space = self.solution.x.array, self.problem.space
        for f in state.rates():  # the rates of this step, for the next one's change of step
            state.rates_prev[id(f)].x.array[:] = f.x.array
        for rate, now, name in ((state.velocity_rate, state.velocity, "velocity"),
                                (state.micro_rotation_rate, state.micro_rotation, "micro_rotation")):
            if rate is not None:  # u̇^{n+1} = (u^{n+1} − u^n)/(γδt) − (1 − γ)/γ u̇^n
                rate.x.array[:] = ((x[space.dofs(name)] - now.x.array) / (gamma * dt)
                                   - (1.0 - gamma) / gamma * rate.x.array)
        state.shift(self.solution, space)
        if self.d_star is not None:  # ḋ^{n+1} = (u^{n+α_f} − (1 − α_m) ḋ^n)/α_m on the solid, d^{n+1}
            dim, nodes = self.problem.mesh.geometry.dim, self.problem.solid_velocity_dofs
            state.new_displacement_level()
            d, r = state.displacement.x.array.reshape(-1, dim), d_rate.reshape(-1, dim)
            u_new, u_old = state.velocity.x.array.reshape(-1, dim)[nodes], u_n.reshape(-1, dim)[nodes]
            u_f = alpha_f * u_new + (1.0 - alpha_f) * u_old
            r_new = (u_f - (1.0 - alpha_m) * r[nodes]) / alpha_m
            d[nodes] += dt * ((1.0 - gamma) * r[nodes] + gamma * r_new)
            r[nodes] = r_new
            state.displacement.x.scatter_forward()
            state.displacement_rate.x.scatter_forward()
        state.t, state.step_count = t_new, state.step_count + 1

    # ------------------------------------------------------------------------------ the mesh
    def _to_alpha_f_configuration(self, alpha_f: float, t_f: float):
        """The mesh goes to the configuration of t^{n+α_f}: the solid vertices at s^n + α_f δt ḋ^n, extended
        (a prescribed motion: its displacement at t^{n+α_f}). With the last rate ḋ^n, not an extrapolation
        of u: the configuration carries the part of the stress's change that eq. (28) leaves explicit, and
        an extrapolation (2u^n − u^{n−1}) amplifies the solid's fast modes there: with it FSI3 diverged at
        δt = 0.005 even at ρ∞ = 0, which is then BDF2 (whose base X + 2D^n − D^{n−1} is this configuration)."""
        m, state = self.motion, self.state
        if m is None:
            return
        if isinstance(m, PrescribedMotion):
            m.place(np.asarray(m.motion(m._X0_dof, t_f), dtype=float).ravel(), state.t)
            self.histories.mesh_moved(rebuild=False)
        else:
            self._place_solid_moved_by(alpha_f * self.dt * state.displacement_rate.x.array)

    def _place_solid_moved_by(self, increment: np.ndarray):
        """Place the mesh with its solid vertices at s^n + P1(``increment``) (a P2 velocity-space array;
        only its solid vertices' values count), the rest by the extension."""
        m, step = self.motion, self._step_rate
        step.x.array[:] = increment
        m._u_P1.interpolate(step)
        m.place(m.extend(m.solid_displacement.x.array + m._u_P1.x.array), self.state.t)
        self.histories.mesh_moved(rebuild=False)

    # ------------------------------------------------------------------------------ the passes
    def _picard(self, alpha_f: float, t_new: float):
        """A Picard pass: the convection re-linearised around u^{n+α_f} of the step's solution, solved again."""
        u_f = alpha_f * self._new_velocity() + (1.0 - alpha_f) * self.state.velocity.x.array
        self.convection.relinearise(u_f)
        self._reassemble(self.a_form)
        with self.timers("assemble_vector"):
            self._vector()
        self._solve(t_new)

    def _correct(self, alpha_f: float, t_f: float, t_new: float):
        """A pass with a moving solid: with the solution as the prediction of u^{n+1}, d^{n+α_f} = d* + k u^{n+1}
        predicted, the mesh re-placed at the predicted t^{n+α_f} (solid vertices s^n + P1(d^{n+α_f} − d^n),
        extended), the convection at u^{n+α_f} with the mesh velocity it gives, the solid stress linearised
        around d^{n+α_f} (one Newton step of S(d) = Dd − GᵀG, ``solid.corrector_stress_residual``), solved
        again (the kept factorisation as the preconditioner)."""
        state = self.state
        dim, nodes = self.problem.mesh.geometry.dim, self.problem.solid_velocity_dofs
        u_new = self._new_velocity()
        d_hat = self.d_predicted.x.array
        d_hat[:] = self.d_star.x.array
        d_hat.reshape(-1, dim)[nodes] += float(self.solid_dt.value) * u_new.reshape(-1, dim)[nodes]
        self.d_predicted.x.scatter_forward()
        increment = d_hat - state.displacement.x.array  # d^{n+α_f} − d^n
        self.d_to_end.x.array[:] = (1.0 - alpha_f) / alpha_f * increment  # d^{n+1} − d^{n+α_f}
        self.d_to_end.x.scatter_forward()
        with self.timers("mesh_motion"):
            self._place_solid_moved_by(increment)
            self.convection.set(alpha_f * u_new + (1.0 - alpha_f) * self.u_old.x.array, t_f)
        self._reassemble(self.a_corrector)
        with self.timers("assemble_vector"):
            self._vector(self.L_corrector, self.a_corrector)
        self._solve(t_new)
