"""Bad slip boundaries (tests/test_slip.py has the good ones): one line ``error: boundaries.NAME...``, exit 2,
the output folder untouched (in-process, the CLI's ``main``; level-0 meshes of a few cells, no step taken)."""

from __future__ import annotations

import pytest

from test_input import _BLOCK, _SQUARE, _TWO_NAMES, _one_line, main  # noqa: F401 (main: the fixture)

_SCENE = "fluid: {rho: 1.0, mu: 0.01}\noutput: {progress: false}\n"
_STEPS = "time: {scheme: characteristics1, dt: 0.1, t_end: 0.1}\n"
_BLOCK_WALLS = ('Physical Surface("fluid") = {1}; Physical Surface("solid") = {2}; '
                'Physical Curve("walls") = {1,3,5}; Physical Curve("inlet") = {6}; Physical Curve("outlet") = {4};\n')
_SOLID = "solid: {rho: 1.0, mu_s: 100.0}\n"
_CLAMP = 'Physical Curve("clamp") = {2};\n'  # the block's foot: every boundary facet in a named group
_CUT = ('Point(5) = {0.5,0.2,0,0.25}; Point(6) = {0.5,0.8,0,0.25}; Line(5) = {5,6}; Line{5} In Surface{1};\n'
        'Physical Curve("cut") = {5};\n')
_FLOW = "inlet: {type: velocity, value: [1, 0]}, outlet: {type: do_nothing}"
CASES = {  # (geo, extra YAML, expected message)
    "slip_with_value": (_SQUARE + _TWO_NAMES, _STEPS + "boundaries: {walls: {type: slip, value: [0, 0]}, "
                        "outlet: {type: do_nothing}}\n", "boundaries.walls.value: not used for type slip"),
    "slip_misspelt": (_SQUARE + _TWO_NAMES, _STEPS + "boundaries: {walls: {type: slipp}, outlet: {type: do_nothing}}\n",
                      "boundaries.walls.type: must be one of no_slip, velocity, do_nothing, traction, pressure, slip"),
    "slip_micro_without_micropolar": (_SQUARE + _TWO_NAMES, _STEPS + "boundaries: {walls: {type: slip, "
                                      "micro_rotation: zero}, outlet: {type: do_nothing}}\n",
                                      "boundaries.walls.micro_rotation: only with micropolar terms"),
    "slip_steady_solid": (_BLOCK + _BLOCK_WALLS + _CLAMP, _SOLID + "time: {scheme: steady}\n"
                          f"boundaries: {{walls: {{type: slip}}, clamp: {{type: no_slip}}, {_FLOW}}}\n",
                          "boundaries.walls: type slip is not available with time.scheme: steady for a scene with "
                          "a solid"),
    "slip_on_solid_cells": (_BLOCK + _BLOCK_WALLS + _CLAMP, _SOLID + _STEPS +
                            f"boundaries: {{walls: {{type: no_slip}}, clamp: {{type: slip}}, {_FLOW}}}\n",
                            "boundaries.clamp: type slip on a side of solid cells is not supported"),
    "slip_inside_the_mesh": (_SQUARE + _TWO_NAMES + _CUT, _STEPS + "boundaries: {walls: {type: no_slip}, "
                             "outlet: {type: do_nothing}, cut: {type: slip}}\n",
                             "boundaries.cut: facet group cut of m.geo is inside the domain"),
}


@pytest.mark.parametrize("geo, extra, expected", CASES.values(), ids=CASES)
def test_bad_slip_boundary(main, tmp_path, monkeypatch, geo, extra, expected):  # noqa: F811 (the fixture)
    monkeypatch.setenv("COSSERAT_FSI_MESH_CACHE", str(tmp_path / "cache"))
    (tmp_path / "m.geo").write_text(geo)
    scene = tmp_path / "scene.yaml"
    scene.write_text(f"geometry: {{name: file, path: m.geo}}\n{_SCENE}{extra}")
    code, err = main("run", scene, "--out", main.out)
    _one_line(code, err, expected)
