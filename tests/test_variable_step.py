"""Variable steps: the BDF weights of a step ratio, second order on a random step sequence (fixed mesh,
moving mesh, the solid), the error estimate and the step controller (``time.tolerance``)."""

from __future__ import annotations

import numpy as np
import pytest
from mpi4py import MPI

from cosserat_fsi.config import validate_scene
from cosserat_fsi.app.runner import load_mesh
from cosserat_fsi.time_schemes import variable_step
from cosserat_fsi.time_schemes.variable_step import BdfWeights, estimate_factor, predicted
from cosserat_fsi.simulation import Simulation

PATTERN = np.array([1.0, 1.8, 0.6, 1.3, 0.7])  # step ratios 1.8, 0.33, 2.17, 0.54


def steps(n_repeats: int, t_end: float = 1.0) -> np.ndarray:
    """The random-looking step pattern repeated ``n_repeats`` times, scaled to end at ``t_end``: halving
    the steps keeps every ratio, so the error falls as δt^p with the same constant."""
    seq = np.tile(PATTERN, n_repeats)
    return seq * t_end / seq.sum()


@pytest.mark.parametrize("ratio", [1.0, 0.37, 2.2])
def test_bdf2_weights_are_exact_on_quadratics(ratio):
    """α f^{n+1} − (a₁f^n − a₂f^{n−1}) = δt f'(t^{n+1}) for every quadratic f; the extrapolation is exact on
    lines, the predictor on quadratics; the second foot is t^{n+1} − t^{n−1}."""
    h, k = 0.3, 0.3 / ratio
    w = BdfWeights(2, h, ratio)
    t0, t1, t2 = -k, 0.0, h
    for f, df in ((lambda t: 1.0 + 0 * t, lambda t: 0.0), (lambda t: t, lambda t: 1.0),
                  (lambda t: 3 * t * t - t, lambda t: 6 * t - 1)):
        assert abs(w.alpha * f(t2) - w.history(f(t1), f(t0)) - h * df(t2)) < 1e-13
    assert abs(w.extrapolated(2 * t1 + 1, 2 * t0 + 1) - (2 * t2 + 1)) < 1e-13
    assert abs(w.second_foot - (t2 - t0)) < 1e-13
    k2 = 0.17

    def q(t):
        return 2 * t * t - 3 * t + 0.5
    assert abs(predicted(2, h, k, k2, q(t1), q(t0), q(t0 - k2)) - q(t2)) < 1e-12
    assert abs(predicted(1, h, k, k2, q(t1), q(t0)) - (q(t1) + h * (q(t1) - q(t0)) / k)) < 1e-13


def test_constant_steps_give_the_classical_weights_and_constants():
    """ω = 1: α = 3/2, α h = 2f^n − ½f^{n−1}, u* = 2u^n − u^{n−1}, d* = (4d^n − d^{n−1})/3, the second foot
    2δt, bit for bit; Milne's factor 2/11 (BDF2 against the quadratic), 1/3 (backward Euler, the line)."""
    w = BdfWeights(2, 0.1)
    x, y = np.array([0.3, -1.7]), np.array([0.9, 2.1])
    assert w.alpha == 1.5 and w.second_foot == 0.2
    assert np.array_equal(w.history(x, y), 2.0 * x - 0.5 * y)
    assert np.array_equal(w.extrapolated(x, y), 2.0 * x - y)
    assert np.array_equal(w.base(x, y), (4.0 * x - y) / 3.0)
    assert abs(estimate_factor(2, 0.1, 0.1, 0.1) - 2.0 / 11.0) < 1e-15
    assert abs(estimate_factor(1, 0.1, 0.1, 0.1) - 1.0 / 3.0) < 1e-15


def _taylor_green(scheme, sequence, motion=None):
    """L² error of the Taylor–Green vortex at T = sum(sequence) after the given steps."""
    from test_navier_stokes import TaylorGreen, _l2

    import dolfinx

    T, exact = float(np.sum(sequence)), TaylorGreen(0.1)
    scene = validate_scene({"geometry": {"name": "square", "level": 2, "length": float(np.pi)},
                            "fluid": {"rho": 1.0, "mu": 0.1},
                            "time": {"dt": float(sequence[0]), "t_end": T, "scheme": scheme}})
    mesh, ct, ft, _ = load_mesh(scene, MPI.COMM_WORLD)
    sim = Simulation(scene, mesh, ct, ft, exact=exact, prescribed_motion=motion)
    error = []

    def measure(sim):  # on the mesh the last step was solved on (generalised-α: after it moved on)
        if sim.step_count == len(sequence):
            u_exact = dolfinx.fem.Function(sim.velocity.function_space)
            u_exact.interpolate(lambda x: exact.velocity(x, T))
            error.append(_l2(sim, sim.velocity - u_exact))

    for dt in sequence:
        sim.step([] if scheme == "generalized_alpha" else [measure], dt=dt)
    if scheme == "generalized_alpha":
        measure(sim)
    assert abs(sim.t - T) < 1e-12
    return error[0]


@pytest.mark.parametrize("scheme, order", [("characteristics1", 1), ("characteristics2", 2), ("ale_bdf2", 2),
                                           ("generalized_alpha", 2)])
def test_order_on_a_random_step_sequence(scheme, order):
    """Taylor–Green on a fixed mesh with steps of ratios 0.33 to 2.2: the scheme's order in δt."""
    errors = np.array([_taylor_green(scheme, steps(n)) for n in (1, 2, 4)])
    rates = np.log2(errors[:-1] / errors[1:])
    assert np.all(np.abs(rates - order) < 0.3), (errors, rates)


def test_a_constant_step_weight_breaks_the_order(monkeypatch):
    """The test above can fail: with the constant-step weights (ω taken as 1) on the same sequence BDF2 is
    first order."""
    monkeypatch.setattr(variable_step.BdfWeights, "alpha", property(lambda self: 1.0 if self.order == 1 else 1.5))
    errors = np.array([_taylor_green("characteristics2", steps(n)) for n in (1, 2, 4)])
    rates = np.log2(errors[:-1] / errors[1:])
    assert np.all(rates < 1.5), (errors, rates)


@pytest.mark.slow
@pytest.mark.parametrize("scheme", ["characteristics2", "ale_bdf2", "generalized_alpha"])
def test_order_on_a_random_step_sequence_on_a_moving_mesh(scheme):
    """The same on the wobbling mesh of test_fsi (mesh velocity up to 1.6): the configurations, the feet and
    the mesh velocity of each step use its own δt."""
    from test_fsi import _tg_wobble

    errors = np.array([_taylor_green(scheme, steps(n), _tg_wobble) for n in (2, 4, 8)])
    rates = np.log2(errors[:-1] / errors[1:])
    assert np.all((rates > 1.7) & (rates < 2.9)), (errors, rates)


def _flag_uy(scheme, sequence):
    scene = validate_scene({"geometry": {"name": "flag", "level": 0},
                            "solid": {"rho": 1000.0, "mu_s": 2e6, "gravity": 2.0, "gravity_ramp_time": 0.2},
                            "time": {"dt": float(sequence[0]), "t_end": float(np.sum(sequence)), "scheme": scheme}})
    mesh, ct, ft, _ = load_mesh(scene, MPI.COMM_WORLD)
    sim = Simulation(scene, mesh, ct, ft)
    from cosserat_fsi.observables import Observables

    obs = Observables(sim)
    for dt in sequence:
        sim.step(dt=dt)
    return obs.evaluate()["uy_A"]


@pytest.mark.slow
@pytest.mark.parametrize("scheme, counts", [("characteristics2", (10, 20, 40)), ("ale_bdf2", (10, 20, 40)),
                                            ("generalized_alpha", (15, 30, 60))])
def test_solid_order_on_a_random_step_sequence(scheme, counts):
    """The flag under a ramped gravity (no fluid, test_fsi.test_solid_time_order) on the random sequence,
    against the Richardson extrapolation of the scheme's own constant steps of 5e-4 and 1e-3 (second order;
    within 1.8e-7 of its δt = 2.5e-4 run, whose 1200 steps cost as much as the rest): d's update (eq. 28 with
    the variable weights), its base, the mesh and generalised-α's rates follow the step. The errors stay those
    of constant steps of the same count (within 1.5×) and fall at the same rate. Measured (15, 30, 60 repeats
    of the pattern; constant steps in brackets): BDF2 3.21e-5, 7.48e-6, 1.72e-6 (3.00e-5, 6.95e-6, 1.58e-6);
    ale_bdf2 4.10e-5, 1.20e-5, 3.62e-6 (3.68e-5, 1.00e-5, 2.81e-6); generalised-α 9.02e-6, 2.94e-6, 9.84e-7
    (8.45e-6, 2.45e-6, 7.39e-7); without the shift of its rates to the new step's lag
    (``GeneralizedAlpha._shift_rates``) it is first order: 2.64e-5, 1.17e-5, 5.48e-6 against the 2.5e-4 run
    (rates 1.18, 1.10). BDF2 and ale_bdf2 on 10, 20, 40 repeats (a third fewer steps): BDF2 7.27e-5, 1.78e-5,
    4.16e-6 (6.79e-5, 1.66e-5, 3.85e-6), ale_bdf2 8.64e-5, 2.54e-5, 6.90e-6 (7.82e-5, 2.12e-5, 5.70e-6);
    generalised-α keeps 15, 30, 60 (on 10 its second error is 1.497× the constant steps', at the bound)."""
    constant_values = np.array([_flag_uy(scheme, np.full(5 * n, 0.3 / (5 * n))) for n in counts])
    half = _flag_uy(scheme, np.full(10 * counts[-1], 0.3 / (10 * counts[-1])))
    ref = half + (half - constant_values[-1]) / 3  # the finest constant steps and half of them: e(δt) ≈ C δt²
    errors = np.array([abs(_flag_uy(scheme, steps(n, 0.3)) - ref) for n in counts])
    constant = np.abs(constant_values - ref)
    rates = np.log2(errors[:-1] / errors[1:])
    constant_rates = np.log2(constant[:-1] / constant[1:])  # the constant steps' own order (test_fsi's, here)
    assert np.all(errors < 1.5 * constant), (errors, constant)
    assert np.all((rates > 1.5) & (rates < 3.2)), (errors, rates)
    assert np.all((constant_rates > 1.5) & (constant_rates < 3.2)), (constant, constant_rates)
