"""Boundary conditions of a file scene against closed forms: a micropolar Couette flow (a moving top wall,
``velocity`` + ``micro_rotation: {value: EXPR}``) and a micropolar Poiseuille flow driven by ``pressure``
boundaries; the expression grammar's functions, ``where``, and the refusals (non-finite data, t without a
time in a steady scene, ω not named on a velocity boundary). Fault cases: tests/faults/test_scene_conditions.py.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from mpi4py import MPI

from cosserat_fsi.errors import DivergenceError, InputError
from cosserat_fsi.config.expressions import parse

STRIP = Path(__file__).parent / "data" / "user_scene" / "strip.geo"
MU, MU_R, LAMBDA1 = 1.0, 1.0, 0.5  # k = sqrt(4 μ μ_r / (λ₁ (μ + μ_r))) = 2


def _scene_text(boundaries: str, time: str = "{scheme: steady}", micropolar: bool = True, level: int = 1,
                extra: str = "") -> str:
    return (f"geometry: {{name: file, path: {STRIP}, level: {level}}}\n"
            f"fluid: {{rho: 1.0, mu: {MU}}}\n"
            + (f"micropolar: {{mu_r: {MU_R}, lambda1: {LAMBDA1}}}\n" if micropolar else "")
            + f"time: {time}\nboundaries: {boundaries}\n" + extra)


def _scene(tmp_path, boundaries: str, time: str = "{scheme: steady}", micropolar: bool = True, level: int = 1):
    from cosserat_fsi.config import load_scene

    path = tmp_path / "scene.yaml"
    path.write_text(_scene_text(boundaries, time, micropolar, level))
    return load_scene(path)


def _simulation(scene):
    from cosserat_fsi.app.runner import load_mesh
    from cosserat_fsi.simulation import Simulation

    mesh, ct, ft, _ = load_mesh(scene, MPI.COMM_WORLD)
    return Simulation(scene, mesh, ct, ft, MPI.COMM_WORLD)


def _profiles(run_cli, tmp_path, boundaries: str, time: str = "{scheme: steady}", x=1.0, n=41):
    """A run of the scene (``cosserat-fsi run``) with the line sampler across the channel at x = const
    (``observables.lines``): y, u (n, 2), ω (n,) and p (n,) from its line_across.csv."""
    path = tmp_path / "scene.yaml"
    path.write_text(_scene_text(boundaries, time, extra=(
        f"observables: {{lines: {{across: {{from: [{x}, 0.0], to: [{x}, 1.0], points: {n}}}}}}}\n"
        "output: {progress: false, fields: false}\n")))
    result = run_cli("run", path, "--out", tmp_path / "out")
    assert result.returncode == 0, result.stderr
    with open(tmp_path / "out" / "line_across.csv") as f:
        header = f.readline().strip().split(",")
    rows = np.loadtxt(tmp_path / "out" / "line_across.csv", delimiter=",", skiprows=1, ndmin=2)
    column = {name: rows[:, i] for i, name in enumerate(header)}
    return column["y"], np.column_stack([column["u"], column["v"]]), column["omega"], column["p"]


def couette(y, U, a, b):
    """u, ω of the micropolar Couette flow (cosserat_fsi/exact.py) with this module's coefficients."""
    from cosserat_fsi.exact import MicropolarCouette

    return MicropolarCouette(U, a, b, MU, MU_R, LAMBDA1).profiles(y)


def _relative(computed, exact):
    return float(np.max(np.abs(computed - exact)) / np.max(np.abs(exact)))


def test_couette_closed_form_solves_its_equations():
    """The closed form itself: its ODEs by finite differences, its boundary values."""
    y = np.linspace(0.0, 1.0, 2001)
    u, w = couette(y, 1.0, 0.0, 0.3)
    d = y[1] - y[0]
    du, dw = np.gradient(u, d), np.gradient(w, d)
    inner = slice(5, -5)
    assert np.allclose(((MU + MU_R) * np.gradient(du, d) + 2 * MU_R * dw)[inner], 0.0, atol=1e-4)
    assert np.allclose((LAMBDA1 * np.gradient(dw, d) - 4 * MU_R * w - 2 * MU_R * du)[inner], 0.0, atol=1e-4)
    assert (u[0], u[-1], w[0], w[-1]) == pytest.approx((0.0, 1.0, 0.0, 0.3), abs=1e-12)


def test_micropolar_couette_moving_wall(run_cli, tmp_path):
    """Top wall moving at U = 1 with ω = 0.3 there ({value: EXPR}), bottom at rest with ω = 0; both ends
    natural (pressure 0 at the inlet, do-nothing outlet, ω free): the developed profile is exact there. P2 on
    level 1 (h = 0.04): u and ω within 1e-4 of the closed form (relative max error)."""
    y, u, omega, _ = _profiles(run_cli, tmp_path,
                               "{top: {type: velocity, value: [1, 0], micro_rotation: {value: '0.1 + 0.2'}},"
                               " bottom: {type: no_slip, micro_rotation: zero}, inlet: {type: pressure, value: 0},"
                               " outlet: {type: do_nothing}}")
    u_exact, w_exact = couette(y, 1.0, 0.0, 0.3)
    assert _relative(u[:, 0], u_exact) < 1e-4 and np.max(np.abs(u[:, 1])) < 1e-4
    assert _relative(omega, w_exact) < 1e-4
    assert omega[-1] == pytest.approx(0.3, abs=1e-12) and omega[0] == pytest.approx(0.0, abs=1e-12)


def test_micropolar_poiseuille_between_pressures(run_cli, tmp_path):
    """Inlet ``pressure: 2``, outlet ``pressure: 0`` over the length 2 (G = 1), no-slip walls with ω = 0:
    micropolar Poiseuille flow (cosserat_fsi/exact.py, reference §1) to 1e-4 on level 1; p = p̂ at both ends
    (the do-nothing sense of the pressure condition with the laplacian form)."""
    from cosserat_fsi.exact import MicropolarPoiseuille

    walls = ("{inlet: {type: pressure, value: 2}, outlet: {type: pressure, value: '0*t'}, bottom: {type: no_slip,"
             " micro_rotation: zero}, top: {type: no_slip, micro_rotation: zero}}")
    steady = "{scheme: steady, steady_at: 0.0}"
    y, u, omega, p = _profiles(run_cli, tmp_path, walls, steady, x=1.0)
    exact = MicropolarPoiseuille(1.0, 0.5, MU, MU_R, LAMBDA1, 2.0)
    u_exact, w_exact = exact.profiles(np.vstack([np.ones_like(y), y]))
    assert _relative(u[:, 0], u_exact) < 1e-4 and np.max(np.abs(u[:, 1])) < 1e-4
    assert _relative(omega, w_exact) < 1e-4
    assert np.allclose(p, 1.0, atol=1e-4)  # half way along: p = 1
    for x, expected in ((0.0, 2.0), (2.0, 0.0)):  # the pressure condition's do-nothing sense: p = p̂ at the ends
        (tmp_path / f"x{x}").mkdir()
        assert np.allclose(_profiles(run_cli, tmp_path / f"x{x}", walls, steady, x=x, n=5)[3], expected, atol=1e-4)


def test_grammar_functions_and_where():
    x = np.array([[0.0, 0.25, 0.5, 1.0], [0.5, -0.2, 0.3, 1.0], [0.0, 0.0, 0.0, 0.0]])
    e = parse("sinh(x) + cosh(y) + asin(x) + acos(x/2) + atan(y) + atan2(y, x - 2)")
    expected = (np.sinh(x[0]) + np.cosh(x[1]) + np.arcsin(x[0]) + np.arccos(x[0] / 2) + np.arctan(x[1])
                + np.arctan2(x[1], x[0] - 2))
    assert np.allclose(e.evaluate(x, 0.0), expected, rtol=0, atol=1e-15)
    assert parse("atan2(1, -1)").evaluate(x, 0.0)[0] == pytest.approx(0.75 * np.pi, abs=1e-15)
    cases = {"where(x < 0.5, 1, 2)": [1, 1, 2, 2], "where(x <= 0.5, 1, 2)": [1, 1, 1, 2],
             "where(x > 0.25, y, -y)": [-0.5, 0.2, 0.3, 1.0], "where(x >= 0.25, 1, 0)": [0, 1, 1, 1],
             "where(x == 0.5, 1, 0)": [0, 0, 1, 0], "where(x != 0.5, 1, 0)": [1, 1, 0, 1],
             "where(t < 1, t, where(x < 1, 7, 8))": [7, 7, 7, 8]}
    for text, values in cases.items():
        assert np.array_equal(parse(text).evaluate(x, 2.0), values), text
    assert parse("where(t < 1, t, 1)").time_dependent and parse("where(x < 1, 0, y)").symbols == {"x", "y"}
    for text in ("1/0", "10**400", "exp(1000)", "log(0)", "sqrt(-1)"):
        assert not parse(text).finite_at(x, 0.0), text


def test_non_finite_data_on_the_mesh_is_refused_at_setup(tmp_path):
    """1/x is finite in validation's sense (it uses x) but not on the inlet x = 0: exit 2 at setup."""
    scene = _scene(tmp_path, "{inlet: {type: velocity, value: ['1/x', 0]}, outlet: {type: do_nothing},"
                             " bottom: {type: no_slip}, top: {type: no_slip}}", micropolar=False, level=0)
    with pytest.raises(InputError, match=r"boundaries\.inlet\.value\[0\]: '1/x' is not finite on the boundary"):
        _simulation(scene)


def test_data_turning_non_finite_in_the_run_is_a_divergence(tmp_path):
    """A pressure 1/(0.2 − t) at t = 0.2, the second step: exit 3 naming the boundary and the time."""
    scene = _scene(tmp_path, "{inlet: {type: pressure, value: '1/(0.2 - t)'}, outlet: {type: do_nothing},"
                             " bottom: {type: no_slip}, top: {type: no_slip}}",
                   time="{scheme: characteristics1, dt: 0.1, t_end: 0.3}", micropolar=False, level=0)
    sim = _simulation(scene)
    with pytest.raises(DivergenceError, match=r"boundaries\.inlet\.value: '1/\(0.2 - t\)' is not finite on the "
                                              r"boundary at t = 0.2"):
        sim.run(3)


BAD = {
    "t_on_steady": ("{inlet: {type: velocity, value: ['min(t, 1)', 0], micro_rotation: free}}",
                    "boundaries.inlet.value[0]: uses t in a steady scene: give the time as time.steady_at"),
    "omega_required": ("{top: {type: velocity, value: [1, 0]}}",
                       "boundaries.top.micro_rotation: required on a velocity boundary of a micropolar scene "
                       "(zero, half_curl, free or {value: EXPR})"),
    "constant_overflow": ("{inlet: {type: pressure, value: 'exp(1000)'}}",
                          "boundaries.inlet.value: 'exp(1000)' is not finite at t = 0.0"),
}


@pytest.mark.parametrize("boundaries, message", BAD.values(), ids=BAD)
def test_refused_at_validation(tmp_path, boundaries, message):
    with pytest.raises(InputError) as info:
        _scene(tmp_path, boundaries)
    assert str(info.value).startswith(message), str(info.value)


def test_steady_at_evaluates_the_data_there(run_cli, tmp_path):
    """min(t, 1)·p̂ with steady_at 0.5: half the pressure drop of t = 1, half the flow."""
    from cosserat_fsi.problem.boundary import steady_time

    walls = "bottom: {type: no_slip, micro_rotation: zero}, top: {type: no_slip, micro_rotation: zero}"
    boundaries = "{inlet: {type: pressure, value: '4*min(t, 1)'}, outlet: {type: do_nothing}, " + walls + "}"
    time = "{scheme: steady, steady_at: 0.5}"
    assert steady_time(_scene(tmp_path, boundaries, time=time, level=0)) == 0.5
    y, u, _, _ = _profiles(run_cli, tmp_path, boundaries, time, n=3)
    exact = MicropolarPoiseuilleAt(G=1.0)
    assert u[1, 0] == pytest.approx(exact, rel=2e-3)


def MicropolarPoiseuilleAt(G):  # noqa: N802 - the centre velocity of the exact profile for gradient G
    from cosserat_fsi.exact import MicropolarPoiseuille

    return float(MicropolarPoiseuille(G, 0.5, MU, MU_R, LAMBDA1, 2.0).profiles(np.array([[1.0], [0.5]]))[0][0])
