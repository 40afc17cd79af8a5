"""``time.scheme: characteristics1 | characteristics2``: the seed's characteristics scheme (§5) and its BDF2.

The material derivative is (α u − α h)/δt with h the earlier velocities at the feet of the characteristics
(histories.py: first order α = 1, h = u^n∘X^n; BDF2 α = 3/2, α h = 2u^n∘X¹ − ½u^{n−1}∘X²), evaluated at the
quadrature points of the inertia terms; no convection in the matrix. On a fixed mesh the matrix does not
change from step to step, so it is assembled and factorised once per value of α: once for the seed's first-
order scheme, twice for BDF2 (its first step is first order). On a moving mesh it is reassembled every step;
BDF2 then solves on the BDF2 base X + (4D^n − D^{n−1})/3, where d* = (4d^n − d^{n−1})/3 lives (bdf.py).

``corrector_passes`` (characteristics2 with a solid): after the solve, move the mesh to the predicted
Ω^{n+1}, back-track again from there, linearise the solid stress around the predicted d^{n+1} and solve
again (the kept factorisation preconditions it). On FSI3's seed mesh at δt = 0.004 one pass brings the
amplitude error from 8.4 % to 0.9 % at 2.4× the cost (docs/study_fsi3.md).
"""

from __future__ import annotations

import numpy as np

from .bdf import BdfStep
from .histories import Histories

import dolfinx


class Characteristics(BdfStep):
    """The seed's scheme (``characteristics1``) and its BDF2 (``characteristics2``)."""

    @staticmethod
    def levels(time) -> int:
        return 1 if time.scheme == "characteristics1" else 2

    @classmethod
    def histories_for(cls, problem, motion, comm):
        scene = problem.scene
        return Histories(scene, problem, float(scene.time.dt), comm, moving=motion is not None)

    def __init__(self, problem, state, boundary, histories, solver, motion, timers, comm):
        time = problem.scene.time
        super().__init__(problem, state, boundary, histories, solver, motion, timers, comm,
                         order=self.levels(time))
        self._build_forms()
        if self.solve_displacement is not None and getattr(time, "corrector_passes", 0):
            self.passes = int(time.corrector_passes)
            self.motion_base = np.zeros_like(self.solve_displacement.x.array)
            V = state.displacement.function_space
            self.d_predicted, self.u_predicted = dolfinx.fem.Function(V), dolfinx.fem.Function(V)
            self.a_corrector, self.L_corrector = self._forms(self.d_predicted)

    def _pass(self, bdf, t_new: float) -> None:
        """One corrector pass: with the solution as the prediction of u^{n+1}, move the mesh to the
        predicted Ω^{n+1} (solid vertices s* + (δt/α) u, extension as in ``motion.move``), back-track from
        its quadrature points, linearise the solid stress around the predicted d^{n+1} = d* + (δt/α) u and
        solve again (the solver keeps its factorisation as the preconditioner). The configuration and the
        state's time levels stay those of the step."""
        m, dt_a = self.motion, self.dt / bdf.alpha
        with self.timers("mesh_motion"):
            self.u_predicted.x.array[:] = self._new_velocity()
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
            self.histories.update(bdf, self.state, self.solve_displacement)
        with self.timers("assemble_vector"):
            self._vector(self.L_corrector, self.a_corrector)
        self._solve(t_new)
