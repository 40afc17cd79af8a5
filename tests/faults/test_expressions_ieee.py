"""Expressions that are finite but pass through an overflow, a division by zero or a domain error on the way,
on every condition that takes a value (a velocity component, a traction component, a pressure, ω's value):
each condition gets the IEEE value (config/expressions.py: ``atan(1/0)`` is π/2, an untaken ``where`` branch
is discarded), the same flow as the plain number, or a literal that is no double is refused with one line
naming the key; under ``mpirun -n 2`` a value that is not finite on the boundary is one line, printed once."""

from __future__ import annotations

import math

import numpy as np
import pytest

from faultlib import MPI_TIMEOUT, check, cli, snapshot

_SQUARE = """Point(1) = {0,0,0,0.5}; Point(2) = {1,0,0,0.5}; Point(3) = {1,1,0,0.5}; Point(4) = {0,1,0,0.5};
Line(1) = {1,2}; Line(2) = {2,3}; Line(3) = {3,4}; Line(4) = {4,1};
Curve Loop(1) = {1,2,3,4}; Plane Surface(1) = {1};
Physical Surface("fluid") = {1}; Physical Curve("inlet") = {4}; Physical Curve("outlet") = {2};
Physical Curve("walls") = {1,3};
"""  # the unit square: inlet x = 0, outlet x = 1, walls y = 0 and y = 1
_HEAD = ("geometry: {name: file, path: m.geo}\nfluid: {rho: 1.0, mu: 0.01}\n"
         "time: {scheme: characteristics1, dt: 0.1, t_end: 0.1}\n"
         "observables: {points: {c: [0.5, 0.5], d: [0.8, 0.3]}}\noutput: {progress: false, fields: false}\n")
_MICRO = "micropolar: {mu_r: 0.01, lambda1: 0.01}\n"

CONDITIONS = {  # condition type -> (scene sections with E for the expression, the key the expression is at)
    "velocity": ("boundaries: {inlet: {type: velocity, value: [E, '0.2*y']}, outlet: {type: do_nothing}, "
                 "walls: {type: no_slip}}\n", "boundaries.inlet.value[0]"),
    "traction": ("boundaries: {inlet: {type: velocity, value: [1, 0]}, outlet: {type: traction, value: [E, 0.5]},"
                 " walls: {type: no_slip}}\n", "boundaries.outlet.value[0]"),
    "pressure": ("boundaries: {inlet: {type: pressure, value: E}, outlet: {type: do_nothing}, "
                 "walls: {type: no_slip}}\n", "boundaries.inlet.value"),
    "micro_rotation": (_MICRO + "boundaries: {inlet: {type: velocity, value: [1, 0], micro_rotation: {value: E}}, "
                       "outlet: {type: do_nothing}, walls: {type: no_slip, micro_rotation: zero}}\n",
                       "boundaries.inlet.micro_rotation.value"),
}
IEEE = {  # expression -> the number it is in IEEE arithmetic
    "atan(1/0)": math.pi / 2,
    "min(0, 2.0**5000)": 0.0,
    "where(t < 1000, 0, exp(1000))": 0.0,
    "where(t > 1000, log(0), 0)": 0.0,
    "where(x > 100, sqrt(-1), 1)": 1.0,
}
LONG = "1" + "0" * 399  # a 400-digit integer literal: no double


def _scene(tmp_path, condition: str, expression: str, name: str) -> object:
    sections, _ = CONDITIONS[condition]
    (tmp_path / "m.geo").write_text(_SQUARE)
    path = tmp_path / f"{name}.yaml"
    path.write_text(_HEAD + sections.replace("E", repr(expression) if isinstance(expression, str) else
                                             str(expression)))
    return path


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """The probes of a run with a plain number in place of the expression, by (condition, number)."""
    cache: dict = {}

    def get(main, condition, number):
        if (condition, number) not in cache:
            folder = tmp_path_factory.mktemp("reference")
            cache[condition, number] = _probes(main, folder, _scene(folder, condition, number, "plain"))
        return cache[condition, number]

    return get


def _probes(main, folder, scene):
    code, err = main("run", scene, "--out", folder / "out")
    assert code == 0 and not err.strip(), err
    with open(folder / "out" / "timeseries.csv") as f:
        header = f.readline().strip().split(",")
    rows = np.loadtxt(folder / "out" / "timeseries.csv", delimiter=",", skiprows=1, ndmin=2)
    return {k: rows[:, i] for i, k in enumerate(header) if k.endswith(("_c", "_d"))}


@pytest.fixture(scope="module")
def square():
    """The unit square (4 x 4 cells), the facets of x = 0 and the P2 spaces of the conditions' data."""
    import dolfinx
    from mpi4py import MPI

    from cosserat_fsi import compat

    mesh = dolfinx.mesh.create_unit_square(MPI.COMM_WORLD, 4, 4)
    facets = dolfinx.mesh.locate_entities_boundary(mesh, 1, lambda x: np.isclose(x[0], 0.0))
    vector, scalar = (compat.function_space(mesh, "Lagrange", 2, shape=shape) for shape in ((2,), None))
    return mesh, facets, {"velocity": vector, "traction": vector, "pressure": scalar, "micro_rotation": scalar}


@pytest.fixture
def main(capsys, monkeypatch, tmp_path):
    import signal

    from cosserat_fsi.app import cli as cli_module

    monkeypatch.setenv("COSSERAT_FSI_MESH_CACHE", str(tmp_path / "cache"))
    handlers = {s: signal.getsignal(s) for s in (signal.SIGTERM, signal.SIGINT)}

    def call(*argv):
        code = cli_module.main([str(a) for a in argv])
        return code, capsys.readouterr().err

    yield call
    for sig, handler in handlers.items():
        signal.signal(sig, handler)


@pytest.mark.parametrize("expression", IEEE)
@pytest.mark.parametrize("condition", CONDITIONS)
def test_ieee_value_of_every_condition(square, condition, expression):
    """The values a condition gets (problem/data.py, the same code for every condition, on its space): those of
    the IEEE number, digit for digit, on the boundary x = 0."""
    from mpi4py import MPI

    from cosserat_fsi.config.expressions import parse
    from cosserat_fsi.errors import InputError
    from cosserat_fsi.problem.data import BoundaryData

    mesh, facets, spaces = square
    V = spaces[condition]
    second = ["0.2*y"] if V.dofmap.index_map_bs == 2 else []
    values = []
    for first in (expression, IEEE[expression]):
        data = BoundaryData(V, facets, {f"value[{i}]": parse(e) for i, e in enumerate([first, *second])},
                            MPI.COMM_WORLD)
        data.fill(0.0, InputError)
        values.append(data.g.x.array.copy())
    assert np.array_equal(values[0], values[1]) and np.isfinite(values[0]).all()
    assert np.any(values[0] != 0) or IEEE[expression] == 0


RUNS = {"velocity": "where(x > 100, sqrt(-1), 1)", "traction": "where(t < 1000, 0.5, exp(1000))",
        "pressure": "atan(1/0)", "micro_rotation": "min(0.3, 2.0**5000)"}
NUMBERS = {"where(t < 1000, 0.5, exp(1000))": 0.5, "min(0.3, 2.0**5000)": 0.3}


@pytest.mark.slow
@pytest.mark.parametrize("condition", CONDITIONS)
def test_ieee_value_in_a_run(main, reference, tmp_path, condition):
    """A run with such an expression on each condition: the flow of the run with its IEEE value, digit for
    digit (probes of timeseries.csv)."""
    expression = RUNS[condition]
    ours = _probes(main, tmp_path, _scene(tmp_path, condition, expression, "scene"))
    plain = reference(main, condition, NUMBERS.get(expression, IEEE.get(expression)))
    assert ours.keys() == plain.keys() and len(ours) >= 6
    for key in ours:
        assert np.array_equal(ours[key], plain[key]), (key, ours[key], plain[key])


@pytest.mark.parametrize("condition", CONDITIONS)
def test_not_finite_on_the_boundary_is_one_line(main, tmp_path, condition):
    """sqrt(-1) in the branch that the boundary takes: nan where it is used, one line naming the key."""
    _, key = CONDITIONS[condition]
    scene = _scene(tmp_path, condition, "where(x < 2, sqrt(x - 2), 1)", "scene")
    code, err = main("run", scene, "--out", tmp_path / "out")
    lines = err.splitlines()
    assert code == 2 and len(lines) == 1 and "Traceback" not in err, (code, err)
    assert lines[0].startswith(f"error: {key}: 'where(x < 2, sqrt(x - 2), 1)' is not finite on the boundary"), err


@pytest.mark.slow
@pytest.mark.parametrize("expression, code, start", [
    ("atan(1/0)", 0, None),
    ("1/x", 2, "error: boundaries.inlet.value: '1/x' is not finite on the boundary at t = 0.0"),
    (LONG, 2, "error: boundaries.inlet.value: number out of range"),
], ids=["ieee", "not_finite_on_one_rank", "literal"])
def test_pressure_under_two_ranks(mpi_launcher, tmp_path, expression, code, start):
    """Under ``mpirun -n 2``: the IEEE value runs; a value not finite on the inlet x = 0 (seen by the ranks
    that hold inlet dofs) or a literal refused at parse: one line, printed once, exit 2."""
    scene = _scene(tmp_path, "pressure", expression, "scene")
    out = tmp_path / "out"
    if code == 0:
        result = cli("run", scene, "--out", out, launcher=mpi_launcher, timeout=MPI_TIMEOUT,
                     COSSERAT_FSI_MESH_CACHE=tmp_path / "cache")
        assert result.returncode == 0 and "Traceback" not in result.stderr, result
        return
    out.mkdir()
    (out / "keep.txt").write_text("precious")
    before = snapshot(out)
    result = cli("run", scene, "--out", out, launcher=mpi_launcher, timeout=MPI_TIMEOUT,
                 COSSERAT_FSI_MESH_CACHE=tmp_path / "cache")
    line = check(result, code, start)
    assert result.stderr.count(line) == 1 and len(result.stderr.splitlines()) == 1, result
    assert snapshot(out) == before
