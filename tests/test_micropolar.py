"""Micropolar (Cosserat) fluid on a fixed mesh: exact solutions of shared/reference/micropolar_exact.md.

Equations (seed eqs. 22-24, 2D, scalar micro-rotation ω):

    ρ (∂u/∂t + u·∇u) = −∇p + (μ + μ_r) Δu + 2 μ_r curl ω + f,          div u = 0,
    ρ I (∂ω/∂t + u·∇ω) = λ₁ Δω − 4 μ_r ω + 2 μ_r curl u + g,

curl ω = (∂ω/∂y, −∂ω/∂x), curl u = ∂u₂/∂x − ∂u₁/∂y. The tests drive ``Simulation`` with an ``exact`` object
(initial state, Dirichlet data on every boundary but the outlet, and for manufactured solutions the body
force f and couple g). Each exact solution is first checked against the strong equations by finite
differences, so a wrong formula (reference or hand derivation) fails here and not as a "bad rate".
The Poiseuille channel's tests are in tests/test_micropolar_poiseuille.py (importing the helpers here).
"""

from __future__ import annotations

import numpy as np
import pytest
from mpi4py import MPI

from cosserat_fsi import compat
from cosserat_fsi.config import validate_scene
from cosserat_fsi.exact import NP, UFL, MicropolarPoiseuille, MicropolarTaylorGreen
from cosserat_fsi.app.runner import load_mesh
from cosserat_fsi.simulation import Simulation

import dolfinx
import ufl


# ------------------------------------------------------------------------------------------ helpers
def _scene(**sections):
    return validate_scene(sections)


def _run(scene, comm=MPI.COMM_WORLD, exact=None, mesh_data=None):
    mesh, ct, ft, _ = mesh_data or load_mesh(scene, comm)
    sim = Simulation(scene, mesh, ct, ft, comm, exact=exact)
    sim.run(sim.steps_to(scene.time.t_end))
    return sim, ft


def _integral(comm, integrand):
    return comm.allreduce(dolfinx.fem.assemble_scalar(compat.form(integrand)), op=MPI.SUM)


def _l2(sim, expr):
    return np.sqrt(_integral(sim.comm, ufl.inner(expr, expr) * ufl.dx(domain=sim.mesh)))


def _rates(errors):
    errors = np.asarray(errors)
    return np.log2(errors[:-1] / errors[1:])


def _residuals(exact, params, x, t, h1=1e-5, h2=1e-3):
    """Max-norm residuals (momentum, micro-rotation, div u) of the strong equations at points x (3, n),
    by central differences (4th order for the Laplacians)."""
    rho, mu, mu_r, lam, inertia = (params[k] for k in ("rho", "mu", "mu_r", "lambda1", "inertia"))
    u = lambda y, s=t: exact.velocity(y, s)  # noqa: E731
    w = lambda y, s=t: exact.micro_rotation(y, s)  # noqa: E731
    p = lambda y, s=t: exact.pressure(y, s)  # noqa: E731

    def d(fun, i, h=h1):
        e = np.zeros((3, 1))
        e[i] = h
        return (fun(x + e) - fun(x - e)) / (2 * h)

    def lap(fun, h=h2):
        out = 0.0
        for i in (0, 1):
            e = np.zeros((3, 1))
            e[i] = h
            out = out + (-fun(x + 2 * e) + 16 * fun(x + e) - 30 * fun(x) + 16 * fun(x - e)
                         - fun(x - 2 * e)) / (12 * h * h)
        return out

    U, ux, uy = u(x), d(u, 0), d(u, 1)
    wx, wy = d(w, 0), d(w, 1)
    ut = (u(x, t + h1) - u(x, t - h1)) / (2 * h1)
    wt = (w(x, t + h1) - w(x, t - h1)) / (2 * h1)
    zero = np.zeros(x.shape[1])
    f = exact.body_force(x, t) if hasattr(exact, "body_force") else np.vstack([zero, zero])
    g = exact.body_couple(x, t) if hasattr(exact, "body_couple") else zero
    momentum = (rho * (ut + U[0] * ux + U[1] * uy) + np.vstack([d(p, 0), d(p, 1)])
                - (mu + mu_r) * lap(u) - 2 * mu_r * np.vstack([wy, -wx]) - f)
    micro = (rho * inertia * (wt + U[0] * wx + U[1] * wy) - lam * lap(w) + 4 * mu_r * w(x)
             - 2 * mu_r * (ux[1] - uy[0]) - g)
    return np.abs(momentum).max(), np.abs(micro).max(), np.abs(ux[0] + uy[1]).max()


TG_PARAMS = {"rho": 1.0, "inertia": 0.5, "mu": 1.0, "mu_r": 0.5, "lambda1": 0.2}


MMS_PARAMS = {"rho": 1.0, "inertia": 1.0, "mu": 1.0, "mu_r": 1.0, "lambda1": 1.0}


class Manufactured:
    """Reference §3 on [0, 1]², steady: ψ = sin²(πx) sin²(πy) scaled by ``a``, u = a (∂ψ/∂y, −∂ψ/∂x),
    ω = sin(πx) sin(πy), p = cos(πx) cos(πy) (zero mean); f and g derived by hand for the steady equations
    with convection (checked by finite differences in test_exact_solutions_satisfy_the_equations)."""

    def __init__(self, a, rho, inertia, mu, mu_r, lambda1):
        self.a, self.rho, self.inertia, self.mu, self.mu_r, self.lambda1 = a, rho, inertia, mu, mu_r, lambda1

    def velocity(self, x, t, lib=NP):
        a, X, Y = self.a, np.pi * x[0], np.pi * x[1]
        return lib.vec(a * np.pi * lib.sin(X)**2 * lib.sin(2 * Y), -a * np.pi * lib.sin(2 * X) * lib.sin(Y)**2)

    def micro_rotation(self, x, t, lib=NP):
        return lib.sin(np.pi * x[0]) * lib.sin(np.pi * x[1])

    def pressure(self, x, t, lib=NP):
        return lib.cos(np.pi * x[0]) * lib.cos(np.pi * x[1])

    def _sources(self, x):
        a, pi, rho, mu, mu_r, lam = self.a, np.pi, self.rho, self.mu, self.mu_r, self.lambda1
        X, Y = pi * x[0], pi * x[1]
        sx, cx, sy, cy = np.sin(X), np.cos(X), np.sin(Y), np.cos(Y)
        s2x, c2x, s2y, c2y = np.sin(2 * X), np.cos(2 * X), np.sin(2 * Y), np.cos(2 * Y)
        u1, u2 = a * pi * sx**2 * s2y, -a * pi * s2x * sy**2
        u1x, u1y = a * pi**2 * s2x * s2y, 2 * a * pi**2 * sx**2 * c2y
        u2x, u2y = -2 * a * pi**2 * c2x * sy**2, -a * pi**2 * s2x * s2y
        lap1, lap2 = 2 * a * pi**3 * s2y * (2 * c2x - 1), 2 * a * pi**3 * s2x * (1 - 2 * c2y)
        w = sx * sy
        wx, wy = pi * cx * sy, pi * sx * cy
        px, py = -pi * sx * cy, -pi * cx * sy
        f1 = rho * (u1 * u1x + u2 * u1y) - (mu + mu_r) * lap1 - 2 * mu_r * wy + px
        f2 = rho * (u1 * u2x + u2 * u2y) - (mu + mu_r) * lap2 + 2 * mu_r * wx + py
        g = (rho * self.inertia * (u1 * wx + u2 * wy) + lam * 2 * pi**2 * w + 4 * mu_r * w
             - 2 * mu_r * (u2x - u1y))
        return np.vstack([f1, f2]), g

    def body_force(self, x, t):
        return self._sources(x)[0]

    def body_couple(self, x, t):
        return self._sources(x)[1]


# -------------------------------------------------------------------------------------------- tests
def test_exact_solutions_satisfy_the_equations():
    """The reference formulas (Poiseuille, Taylor–Green with its ODE, tabulated values) and the hand-derived
    manufactured sources satisfy the strong equations (finite differences, no FEM)."""
    rng = np.random.default_rng(1)
    pois = MicropolarPoiseuille(G=1.0, h=1.0, mu=1.0, mu_r=1.0, lambda1=1.0, L=2.0)
    # reference table, G = h = mu = 1
    for mu_r, lam, k, u0, u5, Q, w5 in ((1.0, 1.0, 1.4142136, 0.28473571, 0.20734808, 0.37072084, 0.05168046),
                                        (0.5, 0.1, 3.6514837, 0.41333132, 0.29868786, 0.53384637, 0.17148853)):
        ex = MicropolarPoiseuille(G=1.0, h=1.0, mu=1.0, mu_r=mu_r, lambda1=lam, L=2.0)
        pts = np.array([[0.0, 0.0], [1.0, 1.5], [0.0, 0.0]])  # y − h = 0 and 0.5
        u, w = ex.profiles(pts)
        assert abs(ex.k - k) < 1e-7
        assert np.allclose([u[0], u[1], ex.flow_rate(), w[1]], [u0, u5, Q, w5], atol=1e-8, rtol=0)
    tg = MicropolarTaylorGreen(**TG_PARAMS)
    assert np.allclose(np.sort(tg.eigenvalues.real), [-6.09317122, -1.70682878], atol=1e-8)
    assert np.allclose(tg.amplitudes(0.5), [0.31438810, 0.34510498], atol=1e-8)
    assert np.allclose(tg.amplitudes(1.0), [0.12861424, 0.16339995], atol=1e-8)
    mms = Manufactured(a=1.0, **MMS_PARAMS)
    cases = [(pois, {"rho": 1.0, "inertia": 1.0, "mu": 1.0, "mu_r": 1.0, "lambda1": 1.0}, [2.0, 2.0], 0.0),
             (tg, TG_PARAMS, [np.pi, np.pi], 0.3), (mms, MMS_PARAMS, [1.0, 1.0], 0.0)]
    for exact, params, size, t in cases:
        x = np.vstack([rng.uniform(0.05, 0.95, (2, 20)) * np.array(size)[:, None], np.zeros((1, 20))])
        scale = np.abs(exact.body_force(x, t)).max() if hasattr(exact, "body_force") else 1.0
        res = _residuals(exact, params, x, t)
        assert max(res) < 1e-6 * max(scale, 1.0), (type(exact).__name__, res)


@pytest.mark.parametrize("scheme, level", [("characteristics1", 1), ("characteristics2", 2)])
def test_taylor_green_time_order(scheme, level):
    """Micropolar Taylor–Green vortex on [0, π]² to T = 0.5 (δt = 0.1, 0.05, 0.025; spatial error ≪ time
    error on these levels). Measured rates: characteristics1 u 1.08, 1.06, ω 0.98, 1.00 (level 1);
    characteristics2 u 1.95, 2.08, ω 1.36, 2.48 (level 2: BDF2 with a first-order start step and the stiff
    ω mode λ = −6.09, so only the mean ω rate, 1.92, is asserted)."""
    T = 0.5
    exact = MicropolarTaylorGreen(**TG_PARAMS)
    err_u, err_w = [], []
    for dt in (0.1, 0.05, 0.025):
        scene = _scene(geometry={"name": "square", "level": level, "length": float(np.pi)},
                       fluid={"rho": TG_PARAMS["rho"], "mu": TG_PARAMS["mu"]},
                       micropolar={k: TG_PARAMS[k] for k in ("mu_r", "lambda1", "inertia")},
                       time={"dt": dt, "t_end": T, "scheme": scheme})
        sim, _ = _run(scene, exact=exact)
        X = ufl.SpatialCoordinate(sim.mesh)
        err_u.append(_l2(sim, sim.velocity - exact.velocity(X, T, UFL)))
        err_w.append(_l2(sim, sim.micro_rotation - exact.micro_rotation(X, T, UFL)))
    rate_u, rate_w = _rates(err_u), _rates(err_w)
    mean_w = np.log2(err_w[0] / err_w[-1]) / 2
    if scheme == "characteristics1":
        assert np.all(np.abs(rate_u - 1) < 0.2) and np.all(np.abs(rate_w - 1) < 0.2), (err_u, err_w)
    else:
        assert np.all(np.abs(rate_u - 2) < 0.3) and abs(mean_w - 2) < 0.3, (err_u, err_w)
        assert err_u[-1] < 1e-3 and err_w[-1] < 3e-4


@pytest.mark.parametrize("viscous_form", ["laplacian", "symmetric"])
def test_manufactured_steady_convergence(viscous_form):
    """Manufactured steady solution with convection (u scaled by a = 0.1), BDF2 characteristics, δt = 0.05,
    8 steps from the exact state (steady to < 1 %). Levels 0/1/2, laplacian form: ‖u − u_ex‖ 1.2e-3,
    1.4e-4, 1.7e-5 (rates 3.10, 3.04), ‖ω − ω_ex‖ 6.3e-4, 7.3e-5, 8.9e-6 (3.11, 3.05), ‖p − p_ex‖ 9.6e-3,
    1.7e-3, 4.1e-4 (2.49, 2.05). With a = 1 the time error of the characteristics dominates at δt = 0.01
    (u rate 2.4 then saturating); with characteristics1 the O(δt) steady error saturates u and ω at level 2."""
    a, dt, steps = 0.1, 0.05, 8
    exact = Manufactured(a=a, **MMS_PARAMS)
    errors = {"u": [], "w": [], "p": []}
    for level in (0, 1, 2):
        scene = _scene(geometry={"name": "square", "level": level, "length": 1.0},
                       fluid={"rho": MMS_PARAMS["rho"], "mu": MMS_PARAMS["mu"], "viscous_form": viscous_form},
                       micropolar={k: MMS_PARAMS[k] for k in ("mu_r", "lambda1", "inertia")},
                       time={"dt": dt, "t_end": steps * dt, "scheme": "characteristics2"})
        sim, _ = _run(scene, exact=exact)
        X = ufl.SpatialCoordinate(sim.mesh)
        p_mean = _integral(sim.comm, sim.pressure * ufl.dx(domain=sim.mesh))  # exact mean is 0
        errors["u"].append(_l2(sim, sim.velocity - exact.velocity(X, 0.0, UFL)))
        errors["w"].append(_l2(sim, sim.micro_rotation - exact.micro_rotation(X, 0.0, UFL)))
        errors["p"].append(_l2(sim, sim.pressure - p_mean - exact.pressure(X, 0.0, UFL)))
    assert np.all(_rates(errors["u"]) > 2.8) and np.all(_rates(errors["w"]) > 2.8), errors
    assert np.all(_rates(errors["p"]) > 1.8), errors
    assert errors["u"][-1] < 3e-5 and errors["w"][-1] < 1.5e-5 and errors["p"][-1] < 1e-3, errors


def test_classical_limit_mu_r_to_zero():
    """Lid-driven cavity (level 0, μ = 0.1, lid speed 1, 5 BDF2 steps of 0.1): with λ₁ = 1 the micropolar
    velocity and pressure differ from the Navier–Stokes run (no ω field) by a multiple of μ_r. Measured
    ‖Δu‖/μ_r = 0.220, 0.243, 0.246, 0.246 and ‖Δp‖/μ_r = 4.33 (μ_r = 1e-2, 1e-3, 1e-4, 1e-8; at 1e-8
    ‖Δp‖ = 7e-8 is at round-off), ‖ω‖/μ_r = 0.079."""

    def scene(micropolar):
        return _scene(geometry={"name": "square", "level": 0}, fluid={"rho": 1.0, "mu": 0.1},
                      micropolar=micropolar, inflow={"u_mean": 1.0},
                      time={"dt": 0.1, "t_end": 0.5, "scheme": "characteristics2"})

    mesh_data = load_mesh(scene({}), MPI.COMM_WORLD)  # one mesh: the fields are compared in one space
    ns, _ = _run(scene({}), mesh_data=mesh_data)
    assert "micro_rotation" not in ns.problem.space.names
    ratios_u, ratios_w, diffs_p = [], [], []
    for mu_r in (1e-2, 1e-4, 1e-8):
        mp, _ = _run(scene({"mu_r": mu_r, "lambda1": 1.0}), mesh_data=mesh_data)
        ratios_u.append(_l2(mp, mp.velocity - ns.velocity) / mu_r)
        ratios_w.append(_l2(mp, mp.micro_rotation) / mu_r)
        diffs_p.append(_l2(mp, mp.pressure - ns.pressure))
    assert 0.05 < ratios_u[-1] < 1.0, ratios_u  # a nonzero O(μ_r) effect ...
    assert np.allclose(ratios_u, ratios_u[-1], rtol=0.15), ratios_u  # ... linear in μ_r
    assert np.allclose(ratios_w, ratios_w[-1], rtol=0.05), ratios_w
    assert abs(diffs_p[1] / diffs_p[0] - 1e-2) < 1e-3 and diffs_p[-1] < 1e-6, diffs_p


@pytest.mark.parametrize("micropolar, built", [({}, False), ({"mu_r": 0.1}, True), ({"lambda1": 0.1}, True)])
def test_micro_rotation_field_only_when_needed(micropolar, built):
    """ω is in the mixed space iff one of μ_r, λ₁ (in 3D λ₂) is nonzero; inertia and body couple alone, or λ₂ in
    2D, build nothing and are refused (test_keys_used_or_refused.py)."""
    scene = _scene(geometry={"name": "square", "level": 0}, fluid={"rho": 1.0, "mu": 1.0},
                   micropolar=micropolar,
                   time={"scheme": "characteristics1", "dt": 0.1, "t_end": 0.1})
    mesh, ct, ft, _ = load_mesh(scene, MPI.COMM_WORLD)
    sim = Simulation(scene, mesh, ct, ft, MPI.COMM_WORLD)
    sim.step()  # every model solves (λ₂ alone: an ω block with no coefficient; MUMPS gives ω = 0)
    solution = sim.stepper.solution
    assert np.isfinite(solution.x.array).all()
    assert ("micro_rotation" in sim.problem.space.names) is built
    assert (sim.micro_rotation is not None) is built
    assert sim.model.micro_rotation is built
    n_fields = 3 if built else 2
    assert len(sim.problem.space.names) == n_fields and solution.function_space.num_sub_spaces == n_fields


@pytest.mark.parametrize("config, rate", [("micropolar_poiseuille.yaml", (2.8, 2.8)),
                                          ("micropolar_taylor_green.yaml", (1.8, 1.2))])
def test_exact_solution_scenes_report_converging_errors(repo_root, tmp_path, config, rate):
    """The exact-solution scenes (what `cosserat-fsi study` ladders) report relative L² errors of u and ω
    in summary.json that converge: Poiseuille over mesh levels 0 → 1 (P2: rate ≈ 3; measured u 2.98,
    ω 3.0), Taylor–Green over δt 0.1 → 0.05 on level 1 (BDF2; measured u 1.94, ω 1.37: the stiff ω mode
    λ = −6.09 and the first-order start step, see test_taylor_green_time_order)."""
    from cosserat_fsi.app.runner import run_scene
    from cosserat_fsi.config import load_scene

    errors = []
    for i, overrides in enumerate((["geometry.level=0"], ["geometry.level=1"]) if "poiseuille" in config
                                  else (["geometry.level=1", "time.dt=0.1"], ["geometry.level=1", "time.dt=0.05"])):
        scene = load_scene(repo_root / "configs" / config, overrides + ["output.fields=false"])
        (tmp_path / str(i)).mkdir()
        summary = run_scene(scene, tmp_path / str(i), MPI.COMM_WORLD, progress=False)
        errors.append([summary["benchmark"][k]["error"] for k in ("velocity", "micro_rotation")])
    rates = np.log2(np.array(errors[0]) / np.array(errors[1]))
    assert np.all(rates > np.array(rate)), (errors, rates)


def test_nodal_characteristics_for_the_micro_rotation():
    """``micropolar.nodal_characteristics``: ω's history interpolated at the P2 nodes while u's stays at
    the quadrature points. Micropolar Taylor–Green, first order, level 1, δt = 0.1, 0.05, 0.025: both
    fields first order (measured rates u 1.08, 1.06, ω 0.98, 1.00, as with the quadrature points)."""
    T, exact = 0.5, MicropolarTaylorGreen(**TG_PARAMS)

    def run(dt):
        scene = _scene(geometry={"name": "square", "level": 1, "length": float(np.pi)},
                       fluid={"rho": TG_PARAMS["rho"], "mu": TG_PARAMS["mu"]},
                       micropolar={**{k: TG_PARAMS[k] for k in ("mu_r", "lambda1", "inertia")},
                                   "nodal_characteristics": True},
                       time={"dt": dt, "t_end": T, "scheme": "characteristics1"})
        return _run(scene, exact=exact)[0]

    err_u, err_w = [], []
    for dt in (0.1, 0.05, 0.025):
        sim = run(dt)
        X = ufl.SpatialCoordinate(sim.mesh)
        err_u.append(_l2(sim, sim.velocity - exact.velocity(X, T, UFL)))
        err_w.append(_l2(sim, sim.micro_rotation - exact.micro_rotation(X, T, UFL)))
    assert np.all(np.abs(_rates(err_u) - 1) < 0.2) and np.all(np.abs(_rates(err_w) - 1) < 0.2), (err_u, err_w)
