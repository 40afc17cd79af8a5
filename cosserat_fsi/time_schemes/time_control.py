"""``time.tolerance``: the step size chosen from an embedded error estimate (variable_step.py).

Each attempted step's error is estimated from its solution and the explicit predictor (Milne's device) for
the velocity and, in the solid, the displacement, in a weighted RMS norm

    E = RMS_i( e_i / (|f(x_i)| + floor · max_j |f(x_j)|) ) / tol^{(p+1)/p},

over every owned dof of u (and of d at the solid's nodes; a global reduction, so every rank decides the
same), each component weighted by its node's magnitude |f(x_i)| (rotation invariant: weighted by component,
the velocity component that passes through zero at every vortex of a wake decided CFD3's step), with
``floor`` = ``time.error_floor`` (the absolute floor, relative to the field's largest value) and p the
scheme's order. The per-step tolerance tol^{(p+1)/p} makes the delivered error proportional to tol
(tolerance proportionality: with an error per step held at τ, δt ∝ τ^{1/(p+1)} and the global error
∝ δt^p = τ^{p/(p+1)}). E ≤ 1 accepts the step; the next one is δt·min(2, max(0.2, 0.9 E^{−0.7/k}
E_prev^{0.4/k})), k = p + 1 (the PI controller of Gustafsson; Hairer & Wanner IV.2), kept unchanged when the
factor is between 0.9 and 1.2 (a fixed mesh's matrix is then refactorised only for a real change) and within
[``dt_min``, ``dt_max``]. E > 1 rejects it, and so does a failed step: a non-finite solution, or (the BDF
steps) a mesh motion the step would need that puts the solid within the gap of a wall or inverts a cell
(TimeStep.check_motion). It is tried again from the same state with δt·max(0.2, 0.9 E^{−1/k}) (0.25 after
a failure), not below ``dt_min``; a step rejected at
``dt_min`` stops the run (DivergenceError: exit 3). The first p steps take ``time.dt``: the predictor needs
p + 1 earlier levels, and so do the p + 1 steps after a remesh (State.transfer_to: the carried levels are
interpolations, and the solution's jump onto the new mesh is not an error a smaller step reduces). The last
step ends at ``t_end`` (the last two share what is left when one step would not reach it); a step so cut
is judged as the step the controller wanted (its estimate scaled by that step's (δt_wanted/δt)^k, the
estimate being O(δt^k)), so the proposal after it, which a checkpoint keeps, is the one the run would have
gone on with: a restart that extends a finished run does not inherit its cut last step. Generalised-α is
estimated as BDF2 (the same predictor and constant; its own local error constant depends on ρ∞), its rates
moved to each new step's lag (generalized_alpha.py ``_shift_rates``).
"""

from __future__ import annotations

import logging

import numpy as np
from mpi4py import MPI

from ..errors import DivergenceError
from .variable_step import estimate_factor, predicted

log = logging.getLogger("cosserat_fsi")

SAFETY, GROWTH, SHRINK, KEEP = 0.9, 2.0, 0.2, (0.9, 1.2)


class TimeControl:
    """The step size controller of one run (module docstring); its memory lives in ``state.steps``."""

    def __init__(self, time, order: int, comm):
        self.tolerance, self.order, self.comm = float(time.tolerance), order, comm
        self.dt0, self.t_end = float(time.dt), float(time.t_end)
        self.dt_min = float(time.dt_min) if time.dt_min is not None else 1e-3 * self.dt0
        self.dt_max = float(time.dt_max) if time.dt_max is not None else np.inf
        self.floor = float(time.error_floor) if time.error_floor is not None else 0.01
        self.step_tolerance = self.tolerance ** ((order + 1.0) / order)
        self._rejected_now = False
        self._largest = (0.0, 0.0)  # the largest accepted step since the last "shrinking" line, and its time
        self._shares: list[float] = []  # each part's share of the last E² (velocity, displacement)

    @classmethod
    def of(cls, time, order: int, comm) -> TimeControl | None:
        """The controller of the scene's ``time`` section, or None for a fixed step."""
        return cls(time, order, comm) if getattr(time, "tolerance", None) is not None else None

    def describe(self) -> str:
        """One line for run.log."""
        return (f"adaptive step: time.tolerance {self.tolerance:g} (per step {self.step_tolerance:.3g}, order "
                f"{self.order}), error floor {self.floor:g} of the largest value, first step {self.dt0:g}, "
                f"dt_min {self.dt_min:g}, dt_max {self.dt_max:g}")

    # ---------------------------------------------------------------------------------- steps
    def wanted(self, state) -> float:
        """The step the controller proposes, before it is cut to end at t_end."""
        return min(state.steps.next or self.dt0, self.dt_max)

    def cut_to_end(self, state, dt: float) -> bool:
        """Is ``dt`` the :meth:`proposal`, cut short of the controller's step to land on t_end?"""
        return dt == self.proposal(state) < self.wanted(state)

    def proposal(self, state) -> float:
        """The size of the coming step: the controller's, within [dt_min, dt_max], ending at t_end."""
        dt = self.wanted(state)
        remaining = self.t_end - state.t
        if dt >= remaining * (1.0 - 1e-9):
            return remaining
        return 0.5 * remaining if dt > 0.5 * remaining else dt  # two halves, not a tiny last step

    def time_after(self, state, dt: float) -> float:
        """t^n + δt (t_end exactly for the last step)."""
        t = state.t + dt
        return self.t_end if abs(t - self.t_end) <= 1e-9 * max(1.0, abs(self.t_end)) else t

    def finished(self, state, t_end: float | None = None) -> bool:
        """Has ``state`` reached ``t_end`` (default: the scene's time.t_end)?"""
        t_end = self.t_end if t_end is None else t_end
        return t_end - state.t <= 1e-9 * max(1.0, abs(t_end))

    # -------------------------------------------------------------------------------- the estimate
    def parts(self, stepper) -> list[tuple[np.ndarray, np.ndarray]] | None:
        """Per field (u; d at the solid's nodes), at its owned nodes as (nodes, components): the estimated
        local error of the attempted step and the step's values; None while there are too few levels."""
        state, order = stepper.state, self.order
        transferred = state.steps.transferred  # the levels up to a remesh's are interpolated: wait for p + 1 new
        if state.step_count < order or (transferred > 0 and state.step_count - transferred <= order):
            return None
        steps, dt = state.steps, stepper.dt
        factor = estimate_factor(order, dt, steps.last, steps.before)
        V = state.velocity.function_space
        bs = V.dofmap.index_map_bs
        owned = V.dofmap.index_map.size_local * bs
        levels = [state.velocity, state.velocity_prev, state.velocity_prev2]
        u_new = stepper._new_velocity()[:owned].reshape(-1, bs)
        fields = [(u_new, predicted(order, dt, steps.last, steps.before, *[
            f.x.array[:owned].reshape(-1, bs) if f is not None else None for f in levels]))]
        d_new = stepper.candidate_displacement()
        if d_new is not None:
            nodes = stepper.problem.solid_velocity_dofs
            mine = nodes < V.dofmap.index_map.size_local
            dim = d_new.shape[1]

            def at_nodes(f):
                return None if f is None else f.x.array.reshape(-1, dim)[nodes[mine]]
            fields.append((d_new[mine], predicted(order, dt, steps.last, steps.before, *map(
                at_nodes, (state.displacement, state.displacement_prev, state.displacement_prev2)))))
        return [(factor * (new - guess), new) for new, guess in fields]

    def weights(self, parts, floor: float | None = None) -> list[np.ndarray]:
        """Each node's weight, per part: its magnitude + ``floor`` (default: the controller's) × the field's
        largest magnitude on any rank (rotation invariant: a component passing through zero in a vortex street
        is not measured against the floor alone)."""
        floor = self.floor if floor is None else floor
        sizes = [np.linalg.norm(new, axis=1) for _, new in parts]
        scales = np.array([size.max(initial=0.0) for size in sizes])
        self.comm.Allreduce(MPI.IN_PLACE, scales, op=MPI.MAX)  # elementwise (the pickled MAX compares arrays)
        return [size + floor * scale for size, scale in zip(sizes, scales)]

    def norm(self, parts, weights) -> float:
        """E: the weighted RMS over every owned dof of every part on all ranks, over the per-step tolerance
        (each part's share of E² is kept for the log)."""
        sums, shares = np.zeros(2), np.zeros(len(parts))
        for k, ((diff, _), weight) in enumerate(zip(parts, weights)):
            w = weight[:, None]
            ratio = np.divide(diff, w, out=np.zeros_like(diff), where=w > 0.0).ravel()
            shares[k] = ratio @ ratio
            sums += (shares[k], len(ratio))
        total, count = self.comm.allreduce(sums, op=MPI.SUM)
        self.comm.Allreduce(MPI.IN_PLACE, shares, op=MPI.SUM)
        self._shares = list(shares / shares.sum()) if shares.sum() > 0.0 else []
        return float(np.sqrt(total / max(count, 1.0))) / self.step_tolerance

    def error(self, stepper) -> float | None:
        """E of the attempted step (module docstring), or None while there are too few levels."""
        parts = self.parts(stepper)
        return None if parts is None else self.norm(parts, self.weights(parts))

    def _report_shrinking(self, state, dt: float) -> None:
        """A warning each time the accepted step falls below a tenth of the largest one accepted since the
        last warning: a step that keeps shrinking is said, with the field whose error estimate drives it."""
        if dt >= self._largest[0]:
            self._largest = (dt, state.t)
        elif dt < 0.1 * self._largest[0]:
            names = ("velocity", "solid displacement")
            driver = names[int(np.argmax(self._shares))] if self._shares else "velocity"
            log.warning("t = %.6g: the time step has shrunk to %.3g, a tenth of the %.3g at t = %.6g (%s %.0f %% "
                        "of the error estimate)", state.t, dt, *self._largest, driver,
                        100 * max(self._shares, default=1.0))
            self._largest = (dt, state.t)

    @staticmethod
    def accepts(error: float | None) -> bool:
        """Whether an attempt with estimate ``error`` (None: no estimate yet) is accepted."""
        return error is None or error <= 1.0

    def judge(self, state, dt: float, error: float | None, failure: DivergenceError | None = None) -> bool:
        """Accept (True: ``state.steps.next`` set) or reject (False: a smaller ``next``) the attempted step;
        DivergenceError when a step at ``dt_min`` is rejected."""
        steps, k = state.steps, self.order + 1.0
        if failure is None and error is None:  # no estimate yet: the first steps keep time.dt
            steps.next, self._rejected_now = dt, False
            return True
        if failure is None and self.accepts(error):
            if self.cut_to_end(state, dt):  # judged as the step it was cut from (module docstring)
                wanted = self.wanted(state)
                dt, error = wanted, error * (wanted / dt) ** k
            if error == 0.0:
                factor = GROWTH
            elif steps.error > 0.0:
                factor = SAFETY * error ** (-0.7 / k) * steps.error ** (0.4 / k)
            else:
                factor = SAFETY * error ** (-1.0 / k)
            factor = min(1.0 if self._rejected_now else GROWTH, max(SHRINK, factor))
            if KEEP[0] <= factor < KEEP[1]:
                factor = 1.0
            steps.next = min(max(dt * factor, self.dt_min), self.dt_max)
            steps.error, self._rejected_now = max(error, 1e-12), False
            self._report_shrinking(state, dt)
            return True
        steps.rejected += 1
        self._rejected_now = True
        what = (f"the step failed: {failure}" if failure is not None
                else f"error estimate {error * self.step_tolerance:.3g} > {self.step_tolerance:.3g}")
        if dt <= self.dt_min * (1.0 + 1e-9):
            if failure is not None:
                raise DivergenceError(f"t = {state.t:.6g}: a step of time.dt_min = {self.dt_min:g} failed too: "
                                      f"{failure}")
            raise DivergenceError(f"t = {state.t:.6g}: a step of time.dt_min = {self.dt_min:g} is rejected "
                                  f"({what}); the time.tolerance cannot be met: lower time.dt_min, or raise "
                                  f"time.tolerance")
        factor = 0.25 if failure is not None else max(SHRINK, SAFETY * error ** (-1.0 / k))
        steps.next = max(dt * factor, self.dt_min)
        log.debug("t = %.6g: step %.4g rejected (%s), retried with %.4g", state.t, dt, what, steps.next)
        return False
