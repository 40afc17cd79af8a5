"""Bad boundary conditions of a user's file scene (``boundaries: {NAME: {type, value, micro_rotation}}``):
expressions outside the grammar or not finite, a pressure given as a list, ω with the wrong number of
components or not named on a velocity boundary of a micropolar scene, t in a steady scene without
``time.steady_at``. Each is one line ``error: <key>: ...``, exit 2, the --out folder as it was (in-process: the
CLI's ``main``); most fail at validation, the ``setup_*`` ones on the mesh's boundary points. Data that turn
non-finite during the run: exit 3 naming the boundary and the time."""

from __future__ import annotations

import signal

import pytest

from cosserat_fsi.app import cli
from faultlib import snapshot

_SQUARE = """Point(1) = {0,0,0,0.5}; Point(2) = {1,0,0,0.5}; Point(3) = {1,1,0,0.5}; Point(4) = {0,1,0,0.5};
Line(1) = {1,2}; Line(2) = {2,3}; Line(3) = {3,4}; Line(4) = {4,1};
Curve Loop(1) = {1,2,3,4}; Plane Surface(1) = {1};
Physical Surface("fluid") = {1}; Physical Curve("inlet") = {4}; Physical Curve("outlet") = {2};
Physical Curve("walls") = {1,3};
"""  # the unit square: inlet x = 0, outlet x = 1, walls y = 0 and y = 1
_FLUID = "fluid: {rho: 1.0, mu: 0.01}\noutput: {progress: false}\n"
_STEP = "time: {scheme: characteristics1, dt: 0.1, t_end: 0.1}\n"
_STEADY = "time: {scheme: steady}\n"
_MICRO = "micropolar: {mu_r: 0.01, lambda1: 0.01}\n"
_REST = "outlet: {type: do_nothing}, walls: {type: no_slip}"


def _inlet(condition: str, rest: str = _REST) -> str:
    return f"boundaries: {{inlet: {condition}, {rest}}}\n"


CASES = {  # id: (scene sections besides geometry and fluid, the message's start after "error: ")
    "div_zero": (_STEP + _inlet("{type: velocity, value: ['1/0', 0]}"),
                 "boundaries.inlet.value[0]: '1/0' is not finite at t = 0.0"),
    "pow_overflow": (_STEP + _inlet("{type: velocity, value: ['10**400', 0]}"),
                     "boundaries.inlet.value[0]: '10**400' is not finite at t = 0.0"),
    "exp_overflow": (_STEP + _inlet("{type: velocity, value: [0, 'exp(1000)']}"),
                     "boundaries.inlet.value[1]: 'exp(1000)' is not finite at t = 0.0"),
    "pressure_log_zero": (_STEP + _inlet("{type: pressure, value: 'log(0)'}"),
                          "boundaries.inlet.value: 'log(0)' is not finite at t = 0.0"),
    "pressure_one_over_t": (_STEP + _inlet("{type: pressure, value: '1/t'}"),
                            "boundaries.inlet.value: '1/t' is not finite at t = 0.0"),
    "traction_overflow": (_STEP + _inlet("{type: traction, value: ['cosh(800)', 0]}"),
                          "boundaries.inlet.value[0]: 'cosh(800)' is not finite at t = 0.0"),
    "setup_one_over_x": (_STEP + _inlet("{type: velocity, value: ['1/x', 0]}"),
                         "boundaries.inlet.value[0]: '1/x' is not finite on the boundary at t = 0.0"),
    "setup_pressure_sqrt": (_STEP + _inlet("{type: do_nothing}", "outlet: {type: pressure, value: 'sqrt(x - 2)'}, "
                                                                 "walls: {type: no_slip}"),
                            "boundaries.outlet.value: 'sqrt(x - 2)' is not finite on the boundary at t = 0.0"),
    "setup_micro_value": (_STEP + _MICRO + _inlet("{type: velocity, value: [1, 0], micro_rotation: "
                                                  "{value: 'log(x)'}}"),
                          "boundaries.inlet.micro_rotation.value: 'log(x)' is not finite on the boundary"),
    "unknown_function": (_STEP + _inlet("{type: velocity, value: ['erf(y)', 0]}"),
                         "boundaries.inlet.value[0]: unknown function 'erf'"),
    "atan2_arity": (_STEP + _inlet("{type: velocity, value: ['atan2(y)', 0]}"),
                    "boundaries.inlet.value[0]: atan2 takes 2 argument(s)"),
    "where_arity": (_STEP + _inlet("{type: velocity, value: ['where(y < 1, 1)', 0]}"),
                    "boundaries.inlet.value[0]: where takes 3 argument(s)"),
    "where_not_boolean": (_STEP + _inlet("{type: velocity, value: ['where(y, 1, 2)', 0]}"),
                          "boundaries.inlet.value[0]: where(cond, a, b) needs a comparison"),
    "where_boolean_operator": (_STEP + _inlet("{type: velocity, value: ['where(y < 1 and x < 1, 1, 2)', 0]}"),
                               "boundaries.inlet.value[0]: where(cond, a, b) needs a comparison"),
    "where_chained": (_STEP + _inlet("{type: velocity, value: ['where(0 < y < 1, 1, 2)', 0]}"),
                      "boundaries.inlet.value[0]: where's cond is one comparison"),
    "comparison_outside_where": (_STEP + _inlet("{type: velocity, value: ['y < 1', 0]}"),
                                 "boundaries.inlet.value[0]: a comparison outside where(cond, a, b) is not allowed"),
    "pressure_list": (_STEP + _inlet("{type: pressure, value: [1, 0]}"),
                      "boundaries.inlet.value: must be one expression, the pressure p (got a list of 2)"),
    "pressure_missing": (_STEP + _inlet("{type: pressure}"),
                         "boundaries.inlet.value: missing key (type pressure needs value: EXPR"),
    "pressure_syntax": (_STEP + _inlet("{type: pressure, value: 'sin(x'}"),
                        "boundaries.inlet.value: syntax error in 'sin(x'"),
    "velocity_scalar": (_STEP + _inlet("{type: velocity, value: 1}"),
                        "boundaries.inlet.value: must be a list of expressions, [EXPR, EXPR] (got 1)"),
    "do_nothing_value": (_STEP + _inlet("{type: do_nothing, value: 1}"),
                         "boundaries.inlet.value: not used for type do_nothing"),
    "micro_value_three_in_2d": (_STEP + _MICRO + _inlet("{type: velocity, value: [1, 0], micro_rotation: "
                                                        "{value: [0, 0, 1]}}"),
                                "boundaries.inlet.micro_rotation.value: must be one expression (ω is a scalar in "
                                "2D) for a 2D mesh (got 3)"),
    "micro_value_unknown_symbol": (_STEP + _MICRO + _inlet("{type: velocity, value: [1, 0], micro_rotation: "
                                                           "{value: '2*q'}}"),
                                   "boundaries.inlet.micro_rotation.value: unknown symbol 'q'"),
    "micro_value_overflow": (_STEP + _MICRO + _inlet("{type: velocity, value: [1, 0], micro_rotation: "
                                                     "{value: 'exp(1000)'}}"),
                             "boundaries.inlet.micro_rotation.value: 'exp(1000)' is not finite at t = 0.0"),
    "micro_value_misspelt": (_STEP + _MICRO + _inlet("{type: velocity, value: [1, 0], micro_rotation: {valu: 0}}"),
                             "boundaries.inlet.micro_rotation.valu: unknown key (the mapping form is {value: EXPR})"),
    "micro_value_missing": (_STEP + _MICRO + _inlet("{type: velocity, value: [1, 0], micro_rotation: {}}"),
                            "boundaries.inlet.micro_rotation.value: missing key"),
    "micro_bad_word": (_STEP + _MICRO + _inlet("{type: velocity, value: [1, 0], micro_rotation: zeros}"),
                       "boundaries.inlet.micro_rotation: must be zero, half_curl, free or {value: EXPR} "
                       "(got 'zeros')"),
    "micro_value_newtonian": (_STEP + _inlet("{type: velocity, value: [1, 0], micro_rotation: {value: 0}}"),
                              "boundaries.inlet.micro_rotation: only with micropolar terms"),
    "velocity_without_micro": (_STEP + _MICRO + _inlet("{type: velocity, value: [1, 0]}"),
                               "boundaries.inlet.micro_rotation: required on a velocity boundary of a micropolar "
                               "scene (zero, half_curl, free or {value: EXPR})"),
    "moving_wall_without_micro": (_STEP + _MICRO + _inlet("{type: do_nothing}", "outlet: {type: do_nothing}, "
                                                          "walls: {type: velocity, value: [1, 0]}"),
                                  "boundaries.walls.micro_rotation: required on a velocity boundary"),
    "t_on_steady": (_STEADY + _inlet("{type: velocity, value: ['min(t, 1)', 0]}"),
                    "boundaries.inlet.value[0]: uses t in a steady scene: give the time as time.steady_at"),
    "t_on_steady_pressure": (_STEADY + _inlet("{type: pressure, value: 'where(t < 1, t, 1)'}"),
                             "boundaries.inlet.value: uses t in a steady scene"),
    "t_on_steady_micro": (_STEADY + _MICRO + _inlet("{type: velocity, value: [1, 0], micro_rotation: "
                                                    "{value: 't'}}"),
                          "boundaries.inlet.micro_rotation.value: uses t in a steady scene"),
    "steady_at_negative": ("time: {scheme: steady, steady_at: -1.0}\n" + _inlet("{type: pressure, value: 1}"),
                           "time.steady_at: must be >= 0"),
    "steady_at_nan": ("time: {scheme: steady, steady_at: .nan}\n" + _inlet("{type: pressure, value: 1}"),
                      "time.steady_at: must be a finite number"),
    "steady_at_inf": ("time: {scheme: steady, steady_at: .inf}\n" + _inlet("{type: pressure, value: 1}"),
                      "time.steady_at: must be a finite number"),
    "steady_at_not_steady": ("time: {scheme: characteristics1, dt: 0.1, t_end: 0.1, steady_at: 1.0}\n"
                             + _inlet("{type: pressure, value: 1}"), "time.steady_at: "),
    "steady_at_overflow": ("time: {scheme: steady, steady_at: 0.0}\n" + _inlet("{type: pressure, value: '1/t'}"),
                           "boundaries.inlet.value: '1/t' is not finite at t = 0.0"),
}


@pytest.fixture
def main(capsys, tmp_path):
    """``cli.main(argv)`` -> (exit code, stderr); signal handlers restored."""
    handlers = {s: signal.getsignal(s) for s in (signal.SIGTERM, signal.SIGINT)}

    def call(*argv):
        code = cli.main([str(a) for a in argv])
        return code, capsys.readouterr().err

    yield call
    for sig, handler in handlers.items():
        signal.signal(sig, handler)


def _scene(tmp_path, monkeypatch, sections: str):
    monkeypatch.setenv("COSSERAT_FSI_MESH_CACHE", str(tmp_path / "cache"))
    (tmp_path / "m.geo").write_text(_SQUARE)
    scene = tmp_path / "scene.yaml"
    scene.write_text("geometry: {name: file, path: m.geo}\n" + _FLUID + sections)
    return scene


@pytest.mark.parametrize("sections, expected", CASES.values(), ids=CASES)
def test_bad_condition_is_one_line(main, tmp_path, monkeypatch, sections, expected):
    scene = _scene(tmp_path, monkeypatch, sections)
    out = tmp_path / "out"
    out.mkdir()
    (out / "keep.txt").write_text("precious")
    before = snapshot(out)
    code, err = main("run", scene, "--out", out)
    lines = err.splitlines()
    assert code == 2 and len(lines) == 1 and "Traceback" not in err, (code, err)
    assert lines[0].startswith("error: " + expected), err
    assert snapshot(out) == before


def test_data_turning_non_finite_in_the_run(main, tmp_path, monkeypatch):
    """A pressure 1/(0.2 − t): finite at the start, inf at t = 0.2 (step 2): exit 3 naming the boundary
    and the time; the output of step 1 kept."""
    scene = _scene(tmp_path, monkeypatch, "time: {scheme: characteristics1, dt: 0.1, t_end: 0.3}\n"
                   + _inlet("{type: pressure, value: '1/(0.2 - t)'}"))
    code, err = main("run", scene, "--out", tmp_path / "out")
    lines = err.splitlines()
    assert code == 3 and 1 <= len(lines) <= 3 and "Traceback" not in err, (code, err)
    assert "boundaries.inlet.value: '1/(0.2 - t)' is not finite on the boundary at t = 0.2" in lines[-1], err
    assert (tmp_path / "out" / "timeseries.csv").exists()
