"""The step size controller (``time.tolerance``, time_schemes/time_control.py) on its own: a fake stepper driven by
TimeStep.advance with a scripted error, the judge's rules one by one, and Milne's estimate against the true
local error of BDF2 on a scalar ODE. The adaptive FSI runs (restart, ranks, remesh) are in
test_adaptive_runs.py."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
from mpi4py import MPI

from cosserat_fsi.errors import DivergenceError
from cosserat_fsi.time_schemes.state import StepSizes
from cosserat_fsi.time_schemes.time_control import TimeControl
from cosserat_fsi.time_schemes.time_step import TimeStep
from cosserat_fsi.time_schemes.variable_step import BdfWeights, estimate_factor, predicted


def _time(**kwargs):
    values = {"tolerance": 1e-3, "dt": 0.01, "t_end": 1.0, "dt_min": None, "dt_max": None, "error_floor": 0.01}
    return SimpleNamespace(**{**values, **kwargs})


def _control(**kwargs) -> TimeControl:
    return TimeControl(_time(**kwargs), 2, MPI.COMM_SELF)


class FakeStepper:
    """What TimeStep.advance needs of a scheme, with an error E(t, δt) given by ``error``: the attempts, the
    commits and the restores after a rejection are recorded, and every attempt sees the state as it was."""

    advance = TimeStep.advance

    def __init__(self, control, error, motion_fails=lambda t, dt: False):
        self.control, self.error, self.motion_fails = control, error, motion_fails
        self.state = SimpleNamespace(t=0.0, step_count=0, steps=StepSizes())
        self.attempts, self.accepted, self.rejections = [], [], 0
        control.error = lambda stepper: None if stepper.state.step_count < 2 else self.error(stepper.state.t,
                                                                                              stepper.dt)

    def _attempt(self):
        s = self.state
        self.attempts.append((s.step_count, self.dt, s.t, s.steps.as_array().copy()))
        if self.attempts[-1][0] == (self.attempts[-2][0] if len(self.attempts) > 1 else -1):
            assert self.attempts[-1][2] == self.attempts[-2][2]  # retried from the same t^n
        self.t_new = self.control.time_after(s, self.dt)

    def check_motion(self):
        if self.motion_fails(self.state.t, self.dt):
            raise DivergenceError(f"t = {self.t_new:.6g}: the mesh motion would make a cell inverted")

    def _rejected(self):
        self.rejections += 1

    def _commit(self, observe=None):
        s = self.state
        s.t, s.step_count = self.t_new, s.step_count + 1
        s.steps.accepted(self.dt)
        self.accepted.append(self.dt)


def _bumpy(t, dt):
    """A scalar model of a step's error, C(t) δt³ (order 2), with a sharp feature near t = 0.4 that forces
    rejections (a step from the smooth part into it is too large)."""
    scale = 0.02 * (1.0 + 0.8 * np.sin(7.0 * t)) / (1.0 + 40.0 * np.exp(-((t - 0.4) / 0.02) ** 2))
    return (dt / scale) ** 3


def _run(control, error=_bumpy, motion_fails=lambda t, dt: False):
    stepper = FakeStepper(control, error, motion_fails)
    while not control.finished(stepper.state):
        stepper.advance()
    return stepper


def test_the_controller_contract_on_a_scripted_error():
    """Rejections retry from the same t^n with a smaller step (counted in ``steps.rejected``), every accepted
    step has E <= 1, no accepted step grows by more than 2x nor right after a rejection, the first two steps
    are time.dt, and the last step ends exactly at t_end."""
    control = _control(t_end=1.0)
    stepper = _run(control)
    s, dts = stepper.state, np.array(stepper.accepted)
    assert s.t == 1.0 and abs(dts.sum() - 1.0) < 1e-12 and s.step_count == len(dts)
    assert dts[0] == dts[1] == 0.01
    assert stepper.rejections == s.steps.rejected >= 3
    for k, dt in enumerate(dts[2:], start=2):
        assert _bumpy(sum(dts[:k]), dt) <= 1.0
    by_step = {}
    for step, dt, _, _ in stepper.attempts:
        by_step.setdefault(step, []).append(dt)
    assert sum(len(a) - 1 for a in by_step.values()) == stepper.rejections
    for step, tries in by_step.items():
        assert all(b < a for a, b in zip(tries, tries[1:])), (step, tries)  # each retry smaller
        if step + 1 in by_step and step + 1 < len(dts) - 1:
            first_next = by_step[step + 1][0]
            assert first_next <= 2.0 * tries[-1] * (1 + 1e-12)  # growth at most 2x
            if len(tries) > 1:
                assert first_next <= tries[-1] * (1 + 1e-12), step  # no growth right after a rejection
    assert s.steps.smallest == dts.min() and s.steps.largest == dts.max()
    assert dts.max() / dts.min() > 10.0  # the feature at t = 0.4 did shape the steps


def test_a_step_that_keeps_shrinking_is_said_in_the_log(caplog):
    """The sharp feature at t = 0.4 takes the step below a tenth of its largest: one warning, at that time,
    naming the field whose estimate drives it; a smooth error says nothing."""
    with caplog.at_level("WARNING", logger="cosserat_fsi"):
        stepper = _run(_control(t_end=1.0))
    lines = [r.getMessage() for r in caplog.records if "time step has shrunk" in r.getMessage()]
    assert len(lines) >= 1 and all("(velocity" in line for line in lines), lines
    assert 0.3 < float(lines[0].split()[2].rstrip(":")) < 0.45 and max(stepper.accepted) / min(stepper.accepted) > 10
    caplog.clear()
    with caplog.at_level("WARNING", logger="cosserat_fsi"):
        _run(_control(t_end=1.0), lambda t, dt: (dt / 0.02) ** 3)
    assert not [r for r in caplog.records if "shrunk" in r.getMessage()]


def test_the_estimate_names_the_part_that_dominates():
    """E² split per part (velocity, solid displacement) for the log; E itself is the RMS over both parts."""
    c = _control()
    parts = [(np.full((4, 2), 1e-6), np.ones((4, 2))), (np.full((2, 2), 1e-4), np.ones((2, 2)))]
    e = c.norm(parts, [np.ones(4), np.ones(2)])
    assert e == pytest.approx(np.sqrt((8 * 1e-12 + 4 * 1e-8) / 12) / c.step_tolerance)
    assert c._shares[1] > 0.99 and sum(c._shares) == pytest.approx(1.0)


def test_a_step_the_mesh_cannot_follow_is_rejected_and_retried_smaller():
    """A mesh motion that fails (here: any step longer than 0.004 that reaches into [0.3, 0.35)) rejects the
    step like a non-finite solution (δt / 4), the run goes on; failing even at dt_min, it stops naming the
    failure."""
    def fails(t, dt):
        return t < 0.35 and t + dt > 0.3 and dt > 0.004

    stepper = _run(_control(t_end=1.0), lambda t, dt: 1e-3, fails)
    times = np.cumsum([0.0] + stepper.accepted[:-1])
    assert stepper.state.t == 1.0 and stepper.rejections == stepper.state.steps.rejected >= 1
    assert not any(fails(t, dt) for t, dt in zip(times, stepper.accepted))
    retried = [(a, b) for a, b in zip(stepper.attempts, stepper.attempts[1:]) if a[0] == b[0]]
    assert retried and all(b[1] == pytest.approx(a[1] / 4.0) for a, b in retried)
    with pytest.raises(DivergenceError, match=r"a step of time\.dt_min = 0\.001 failed too: t = [\d.]+: the mesh"):
        _run(_control(t_end=1.0, dt_min=1e-3), lambda t, dt: 1e-3, lambda t, dt: t >= 0.3)


def test_a_step_rejected_at_dt_min_stops_the_run_naming_its_time():
    control = _control(t_end=1.0, dt_min=1e-3)
    with pytest.raises(DivergenceError, match=r"t = 0\.02: a step of time\.dt_min = 0\.001 is rejected"):
        _run(control, lambda t, dt: 50.0)  # never met: 0.01 → 0.002 → 0.001 rejected


@pytest.mark.parametrize("t_end", [0.1, 0.1 + 3e-12, 1.0 / 3.0])
def test_the_last_step_lands_on_t_end(t_end):
    """A step within a relative 1e-9 of the end is stretched to it (no sliver of a step after it)."""
    stepper = _run(_control(t_end=t_end, dt_max=0.007), lambda t, dt: 1e-6)
    assert stepper.state.t == t_end and min(stepper.accepted[:-1]) > 1e-6
    assert max(stepper.accepted) <= 0.01  # dt_max bounds the controller, not the first steps (time.dt)


@pytest.mark.parametrize("t_stop", [0.3, 0.5, 0.62, 0.77])
def test_a_run_extended_past_its_end_steps_on_as_the_uninterrupted_run(t_stop):
    """Run to ``t_stop`` (its last steps cut to land there), then on to t = 1 (a restart with a later t_end):
    the first step after ``t_stop`` is the uninterrupted run's (the cut steps are judged as the step they were
    cut from), not one grown from the cut step (which the keep band [0.9, 1.2) would hold there)."""
    whole = _run(_control(t_end=1.0))
    control = _control(t_end=t_stop)
    stepper = _run(control)
    cut, taken = stepper.accepted[-1], len(stepper.accepted)
    control.t_end = 1.0
    while not control.finished(stepper.state):
        stepper.advance()
    at = int(np.searchsorted(np.cumsum(whole.accepted), t_stop))
    assert cut < 0.99 * whole.accepted[at]  # the step that landed on t_stop was cut
    assert stepper.accepted[taken] == pytest.approx(whole.accepted[at], rel=1e-12)


def test_judge_rules():
    """The factors one by one: a tiny error grows the step 2x, not after a rejection; a factor in [1, 1.2) keeps
    the step (a fixed mesh's matrix is not refactorised); E > 1 shrinks by max(0.2, 0.9 E^(-1/3)); a non-finite
    solution by 4; dt_max and dt_min bound the proposals."""
    c = _control(dt_max=0.03, dt_min=0.002)
    state = SimpleNamespace(t=0.5, steps=StepSizes())
    assert c.judge(state, 0.01, 1e-9) and state.steps.next == 0.02  # no memory yet: 0.9 E^(-1/3), at most 2
    assert state.steps.error == 1e-9
    state.steps.error = 0.5  # E_prev: the PI factor 0.9 E^(-0.7/3) E_prev^(0.4/3)
    assert c.judge(state, 0.02, 1e-6) and state.steps.next == 0.03  # 2x, then dt_max
    assert not c.judge(state, 0.01, 8.0) and state.steps.next == pytest.approx(0.01 * 0.9 / 2.0)
    assert state.steps.rejected == 1 and state.steps.error == 1e-6  # a rejection leaves the memory
    state.steps.error = 0.5
    assert c.judge(state, 0.0045, 1e-6) and state.steps.next == 0.0045  # no growth right after a rejection
    state.steps.error = 0.5
    assert c.judge(state, 0.01, 1e-6) and state.steps.next == 0.02  # then again
    assert not c.judge(state, 0.01, 1e6) and state.steps.next == 0.002  # 0.2 at most, then dt_min
    assert not c.judge(state, 0.01, None, DivergenceError("nan")) and state.steps.next == 0.0025
    state.steps.error = 0.5
    e = 0.8  # 0.9 · 0.8^(-0.7/3) · 0.5^(0.4/3) = 0.864: shrinks
    assert c.judge(state, 0.01, e)
    assert state.steps.next == pytest.approx(0.01 * 0.9 * e ** (-0.7 / 3) * 0.5 ** (0.4 / 3))
    state.steps.error = 0.5
    assert c.judge(state, 0.01, 0.6) and state.steps.next == 0.01  # 0.926: in the keep band [0.9, 1.2)
    state.steps.error = e = 0.3  # 0.9 · 0.3^(-0.1) = 1.06: kept
    assert c.judge(state, 0.01, e) and state.steps.next == 0.01
    assert state.steps.rejected == 3
    with pytest.raises(DivergenceError, match="t = 0.5: "):
        c.judge(state, 0.002, 2.0)


def _bdf2_ode(t0, dt, k1, k2, y, dy):
    """One variable BDF2 step of y' = dy(t) from exact values at t0 − k1 − k2, t0 − k1, t0: (the step's
    value, Milne's estimate of its local error, the true local error)."""
    w = BdfWeights(2, dt, dt / k1)
    y_new = (w.history(y(t0), y(t0 - k1)) + dt * dy(t0 + dt)) / w.alpha
    guess = predicted(2, dt, k1, k2, y(t0), y(t0 - k1), y(t0 - k1 - k2))
    return y_new, estimate_factor(2, dt, k1, k2) * (y_new - guess), y_new - y(t0 + dt)


@pytest.mark.parametrize("ratio, before", [(1.0, 1.0), (0.5, 0.7), (2.0, 1.3), (0.3, 3.0)])
def test_the_estimate_is_the_local_error_on_a_scalar_ode(ratio, before):
    """y' = cos(3t) + 2t (so y‴ ≠ 0): Milne's estimate C/(C + C_P)(y − y_P) of a BDF2 step with step ratio
    ω and an earlier ratio k₁/k₂ is the true local error to O(δt): within 2 % at δt = 1e-3, and the
    relative difference halves with δt (first order)."""
    def y(t):
        return np.sin(3.0 * t) / 3.0 + t * t

    def dy(t):
        return np.cos(3.0 * t) + 2.0 * t

    misfit = []
    for dt in (2e-3, 1e-3):
        k1 = dt / ratio
        _, estimate, true = _bdf2_ode(0.7, dt, k1, k1 / before, y, dy)
        misfit.append(abs(estimate / true - 1.0))
    assert misfit[1] < 0.02, misfit
    assert 1.6 < misfit[0] / misfit[1] < 2.5, misfit
