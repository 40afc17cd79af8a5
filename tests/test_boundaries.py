"""Boundary conditions by name: the expression grammar, and the conditions on a user's
mesh against exact solutions and the built-in FSI3 preset. Bad sections: tests/faults/test_input.py."""

from __future__ import annotations

import os

import numpy as np
import pytest
from mpi4py import MPI

from cosserat_fsi.config.expressions import ExpressionError, parse

DATA = os.path.join(os.path.dirname(__file__), "data", "user_scene")


def test_expressions_evaluate_as_written():
    x = np.array([[0.0, 0.5, 1.0], [0.1, 0.2, 0.3], [0.0, 0.0, 0.0]])
    e = parse("-x**2 + 3*y/2 - sin(pi*x)*exp(-t) + max(x, 0.5) - abs(-y) + sqrt(4) + tanh(0) + log(1) + min(t, 1)")
    expected = (-x[0] ** 2 + 1.5 * x[1] - np.sin(np.pi * x[0]) * np.exp(-2.0) + np.maximum(x[0], 0.5) - x[1]
                + 2.0 + 1.0)
    assert np.allclose(e.evaluate(x, 2.0), expected, rtol=0, atol=1e-15)
    assert e.time_dependent and not parse("y*(1 - y)").time_dependent
    assert np.array_equal(parse(3).evaluate(x, 0.0), [3.0, 3.0, 3.0])


REFUSED = {
    "import": ("__import__('os').system('touch {marker}')", "only the functions"),
    "name_import": ("__import__", "unknown symbol '__import__'"),
    "attribute": ("x.real", "an attribute is not allowed"),
    "dunder": ("().__class__.__bases__[0].__subclasses__()", "only the functions"),
    "subscript": ("x[0]", "a subscript is not allowed"),
    "lambda": ("(lambda: 1)()", "only the functions"),
    "lambda_bare": ("lambda: 1", "a lambda is not allowed"),
    "string": ("'abc'", "a constant that is not a number"),
    "keyword": ("sin(x=1)", "sin takes 1 argument"),
    "comparison": ("x < 1", "a comparison outside where(cond, a, b) is not allowed"),
    "unknown_symbol": ("2*q", "unknown symbol 'q'"),
    "unknown_function": ("eval('1')", "unknown function 'eval'"),
    "syntax": ("(x +", "syntax error"),
    "walrus": ("(a := 1)", "is not allowed"),
    "bad_arity": ("min(x)", "min takes 2 argument"),
}


@pytest.mark.parametrize("text, expected", REFUSED.values(), ids=REFUSED)
def test_expressions_outside_the_grammar_are_refused_and_nothing_runs(tmp_path, text, expected):
    marker = tmp_path / "X"
    with pytest.raises(ExpressionError, match=None) as info:
        parse(text.format(marker=marker))
    assert expected in str(info.value) and "\n" not in str(info.value)
    assert not marker.exists()


def _channel_scene(tmp_path, boundaries: str, time: str = "{scheme: steady}"):
    from cosserat_fsi.config import load_scene

    path = tmp_path / "scene.yaml"
    path.write_text(f"geometry: {{name: file, path: {DATA}/channel.geo}}\n"
                    "fluid: {rho: 1.0, mu: 1.0}\n"
                    f"time: {time}\n"
                    f"boundaries: {boundaries}\n")
    return load_scene(path)


def _steady_velocity_at(scene, points):
    from cosserat_fsi.app.runner import load_mesh
    from cosserat_fsi.points.location import probe
    from cosserat_fsi.simulation import Simulation

    comm = MPI.COMM_WORLD
    mesh, ct, ft, _ = load_mesh(scene, comm)
    sim = Simulation(scene, mesh, ct, ft, comm)
    sim.run(1)
    return probe(sim.locator, [sim.velocity], points, comm)[0]


@pytest.mark.parametrize("top, u_top", [("no_slip", 0.0), ("slip", 0.5)])
def test_traction_drives_poiseuille_and_slip_halves_the_wall(tmp_path, top, u_top):
    """Traction [2, 0] at the inlet (p = 2), do-nothing outlet (p = 0) of a 2 x 1 channel, μ = 1: the
    pressure gradient G = 1 gives u = G/(2μ) y(1 − y) with no-slip on both walls (max 1/8 at y = 1/2); with
    slip on the top wall, u = G/(2μ) y(2 − y) (1/2 at the top). P2 holds both exactly: 1e-10."""
    scene = _channel_scene(tmp_path, "{inlet: {type: traction, value: [2, 0]}, outlet: {type: do_nothing}, "
                                     f"bottom: {{type: no_slip}}, top: {{type: {top}}}}}")
    y = np.array([0.25, 0.5, 0.75, 1.0])
    u = _steady_velocity_at(scene, np.column_stack([np.full_like(y, 1.0), y, 0 * y]))
    exact = 0.5 * y * (1 - y) if top == "no_slip" else 0.5 * y * (2 - y)
    assert np.allclose(u[:, 0], exact, atol=1e-10) and np.allclose(u[:, 1], 0.0, atol=1e-10)
    assert u_top == pytest.approx(exact[-1])


def test_velocity_expression_on_the_inlet(tmp_path):
    """An inlet velocity y(1 − y)·6·min(t, 1) (steady at t = 2) with no-slip walls: Poiseuille of mean 1."""
    scene = _channel_scene(tmp_path, "{inlet: {type: velocity, value: ['6*y*(1 - y)*min(t, 1)', 0]}, "
                                     "outlet: {type: do_nothing}, bottom: {type: no_slip}, top: {type: no_slip}}",
                           time="{scheme: steady, steady_at: 2.0}")
    y = np.array([0.25, 0.5])
    u = _steady_velocity_at(scene, np.column_stack([np.full_like(y, 1.5), y, 0 * y]))
    assert np.allclose(u[:, 0], 6 * y * (1 - y), atol=1e-8)


def test_micro_rotation_condition_per_boundary(tmp_path):
    """Micropolar Poiseuille driven by an inlet traction, ω = 0 on the bottom wall and ω = ½ curl u (weak)
    on the top one, in the same run: ω vanishes at the bottom only; at the top it is ½ curl u = −½ ∂u/∂y."""
    from cosserat_fsi.app.runner import load_mesh
    from cosserat_fsi.config import load_scene
    from cosserat_fsi.points.location import probe
    from cosserat_fsi.simulation import Simulation

    path = tmp_path / "scene.yaml"
    path.write_text(f"geometry: {{name: file, path: {DATA}/channel.geo, level: 1}}\n"
                    "fluid: {rho: 1.0, mu: 1.0}\nmicropolar: {mu_r: 1.0, lambda1: 1.0}\ntime: {scheme: steady}\n"
                    "boundaries: {inlet: {type: traction, value: [2, 0]}, outlet: {type: do_nothing},\n"
                    "             bottom: {type: no_slip, micro_rotation: zero},\n"
                    "             top: {type: no_slip, micro_rotation: half_curl}}\n")
    scene = load_scene(path)
    comm = MPI.COMM_WORLD
    mesh, ct, ft, _ = load_mesh(scene, comm)
    sim = Simulation(scene, mesh, ct, ft, comm)
    sim.run(1)
    points = np.array([[1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [1.0, 0.5, 0.0]])
    omega = probe(sim.locator, [sim.micro_rotation], points, comm)[0][:, 0]
    assert abs(omega[0]) < 1e-12  # Dirichlet ω = 0 on the bottom
    assert abs(omega[1]) > 1e-2 and abs(omega[2]) > 1e-3  # not imposed on the top, a rotation inside
