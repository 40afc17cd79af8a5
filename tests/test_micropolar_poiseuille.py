"""Micropolar Poiseuille flow in a channel (shared/reference/micropolar_exact.md §1, seed eqs. 22-24): P2
convergence, the wall traction and the sign of the 2 μ_r ω stress term, independence of the steady state from
the time scheme, and the Newtonian flow of the ``half_curl`` wall condition. The equations and helpers:
tests/test_micropolar.py."""

from __future__ import annotations

import numpy as np
import pytest

from cosserat_fsi.exact import NP, UFL, MicropolarPoiseuille
from cosserat_fsi.observables import Observables
from cosserat_fsi.physics.stress import cauchy_stress
from cosserat_fsi.points.location import probe
from test_micropolar import _integral, _l2, _rates, _run, _scene

import ufl


def _poiseuille_run(level, exact, H, L, scheme="characteristics2", dt=10.0, steps=5):
    scene = _scene(geometry={"name": "channel", "level": level, "length": L, "height": H},
                   fluid={"rho": 1.0, "mu": exact.mu, "viscous_form": "laplacian"},
                   micropolar={"mu_r": exact.mu_r, "lambda1": exact.lambda1, "inertia": 1.0},
                   time={"dt": dt, "t_end": steps * dt, "scheme": scheme})
    return _run(scene, exact=exact)


def test_poiseuille_convergence_and_values():
    """Micropolar Poiseuille (G = h = μ = μ_r = λ₁ = 1, channel 2 × 2, do-nothing outlet, Laplacian form):
    steady state from exact initial/boundary data with δt = 10 (5 BDF2 steps). Measured, levels 0/1/2:
    ‖u − u_ex‖ 9.1e-5, 1.1e-5, 1.4e-6 and ‖ω − ω_ex‖ 1.8e-4, 2.3e-5, 2.9e-6 (rates 2.98, 3.00: P2;
    the cosh/sinh profiles do not saturate it);
    the wall shear traction (T n)·e_x on the top wall converges at O(h²) (error 8.3e-3, 2.3e-3, 6.1e-4), and
    so does ‖T_xy + G (y − h)‖ inside (4.7e-3, 1.2e-3, 3.0e-4): the only check of the sign of the 2 μ_r ω
    term of the stress, since ω = 0 on the walls. Level 2: u(centre) = 0.28473576, ω(h + 0.5) = 0.05168045,
    Q = 0.37072085, Δp = 2.0000015 (reference 0.28473571, 0.05168046, 0.37072084, G L = 2)."""
    G, h, L = 1.0, 1.0, 2.0
    H = 2 * h
    exact = MicropolarPoiseuille(G=G, h=h, mu=1.0, mu_r=1.0, lambda1=1.0, L=L)
    err_u, err_w, err_traction, err_shear = [], [], [], []
    for level in (0, 1, 2):
        sim, ft = _poiseuille_run(level, exact, H, L)
        X = ufl.SpatialCoordinate(sim.mesh)
        err_u.append(_l2(sim, sim.velocity - exact.velocity(X, 0.0, UFL)))
        err_w.append(_l2(sim, sim.micro_rotation - exact.micro_rotation(X, 0.0, UFL)))
        # full nonsymmetric stress; the weight y/H keeps the top wall of the walls tag (3)
        ds = ufl.ds(domain=sim.mesh, subdomain_data=ft)
        T = cauchy_stress(sim.velocity, sim.pressure, sim.problem.mu, sim.problem.mu_r, sim.micro_rotation)
        n = ufl.FacetNormal(sim.mesh)
        shear = _integral(sim.comm, ufl.dot(T, n)[0] * X[1] / H * ds(3)) / L
        err_traction.append(abs(shear + G * h))  # (T n)_x = (μ + μ_r) u' + 2 μ_r ω = −G h on y = H
        # inside, where ω ≠ 0 (it vanishes on the walls): T_xy = (μ + μ_r) u' + 2 μ_r ω = −G (y − h)
        err_shear.append(_l2(sim, T[0, 1] + G * (X[1] - h)))
    assert np.all(_rates(err_u) > 2.8) and np.all(_rates(err_w) > 2.8), (err_u, err_w)
    assert err_u[-1] < 3e-6 and err_w[-1] < 6e-6
    assert np.all(_rates(err_traction) > 1.7) and err_traction[-1] < 1e-3, err_traction
    assert np.all(_rates(err_shear) > 1.8) and err_shear[-1] < 5e-4, err_shear

    # level 2: probes against the reference table, flow rate through the outlet, pressure drop G L
    values = probe(sim.locator, [sim.velocity, sim.micro_rotation, sim.pressure],
                   [[L / 2, h], [L / 2, h + 0.5], [0.0, h], [L, h]], sim.comm)
    u_c, w_c, p_in, p_out = values[0][0, 0], values[1][1, 0], values[2][2, 0], values[2][3, 0]
    assert abs(u_c - 0.28473571) < 1e-6 and abs(w_c - 0.05168046) < 1e-6, (u_c, w_c)
    Q = _integral(sim.comm, sim.velocity[0] * ds(2))
    assert abs(Q - 0.37072084) < 1e-6 and abs(exact.flow_rate() - 0.37072084) < 1e-8, Q
    observed = Observables(sim).evaluate()  # the run's `flow_rate` and `omega_max` columns
    assert abs(observed["flow_rate"] - Q) < 1e-12 * Q, observed
    assert observed["omega_max"] == pytest.approx(np.abs(sim.micro_rotation.x.array).max(), rel=1e-14)
    assert abs((p_in - p_out) - G * L) < 1e-5 * G * L, p_in - p_out


def test_poiseuille_steady_state_independent_of_scheme_and_dt():
    """The steady discrete solution hardly depends on the time scheme or δt (the feet stay on the same
    horizontal line; with a large δt the characteristic term is small). Measured on level 0 against BDF2,
    δt = 10: max nodal differences ≤ 3.4e-7 (u, ω) and 2.3e-6 (p) for characteristics1 δt = 10, 100 and
    characteristics2 δt = 1, 1000, i.e. ~300× below the discretisation error; ~10× less on level 1."""
    exact = MicropolarPoiseuille(G=1.0, h=1.0, mu=1.0, mu_r=1.0, lambda1=1.0, L=2.0)
    ref, _ = _poiseuille_run(0, exact, 2.0, 2.0, "characteristics2", dt=10.0, steps=5)
    for scheme, dt, steps in (("characteristics1", 100.0, 3), ("characteristics2", 1.0, 10)):
        other, _ = _poiseuille_run(0, exact, 2.0, 2.0, scheme, dt=dt, steps=steps)
        diffs = [np.abs(a.x.array - b.x.array).max()
                 for a, b in ((other.velocity, ref.velocity), (other.micro_rotation, ref.micro_rotation),
                              (other.pressure, ref.pressure))]
        assert diffs[0] < 1e-6 and diffs[1] < 1e-6 and diffs[2] < 1e-5, (scheme, dt, diffs)


class NewtonianPoiseuille(MicropolarPoiseuille):
    """With ω = ½ curl u on the walls the micropolar Poiseuille flow is Newtonian with viscosity μ:
    u = G (h² − y²)/(2μ), ω = G y/(2μ) (reference §1, y from mid-height), Q = 2 G h³/(3μ)."""

    def profiles(self, x, lib=NP):
        y = x[1] - self.h
        return self.G / (2 * self.mu) * (self.h**2 - y * y), self.G / (2 * self.mu) * y

    def flow_rate(self):
        return 2 * self.G * self.h**3 / (3 * self.mu)


def test_half_curl_wall_condition_gives_the_newtonian_poiseuille_flow():
    """micropolar.wall_condition: half_curl (Nitsche, ω = ½ curl u on the walls): u quadratic and ω linear
    are in the P2 space, so the discrete steady state is the exact one to solver precision, and the
    flow rate is the Newtonian one — larger than with ω = 0 on the walls, which adds the μ_r drag."""
    G, h, L = 1.0, 1.0, 2.0
    exact = NewtonianPoiseuille(G=G, h=h, mu=1.0, mu_r=1.0, lambda1=1.0, L=L)
    scene = _scene(geometry={"name": "channel", "level": 0, "length": L, "height": 2 * h},
                   fluid={"rho": 1.0, "mu": exact.mu, "viscous_form": "laplacian"},
                   micropolar={"mu_r": exact.mu_r, "lambda1": exact.lambda1, "inertia": 1.0,
                               "wall_condition": "half_curl"},
                   time={"dt": 10.0, "t_end": 50.0, "scheme": "characteristics2"})
    sim, ft = _run(scene, exact=exact)
    X = ufl.SpatialCoordinate(sim.mesh)
    assert _l2(sim, sim.velocity - exact.velocity(X, 0.0, UFL)) < 1e-9
    assert _l2(sim, sim.micro_rotation - exact.micro_rotation(X, 0.0, UFL)) < 1e-9
    Q = Observables(sim).evaluate()["flow_rate"]
    assert abs(Q - exact.flow_rate()) < 1e-9
    zero = MicropolarPoiseuille(G=G, h=h, mu=1.0, mu_r=1.0, lambda1=1.0, L=L)
    assert zero.flow_rate() < Q - 0.2  # 0.3707 against 0.6667
