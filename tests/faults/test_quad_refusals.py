"""A quadrilateral mesh with a part of the method that works in triangles only (the characteristics, probes
and profiles located in cells, a solid's mesh motion) is one line naming the key, exit 2, nothing written.
The Q2/Q1 flow itself: tests/test_quadrilaterals.py."""

from __future__ import annotations

import pytest

from faultlib import REPO, check, cli

GEO = REPO / "tests" / "data" / "user_scene" / "quad_channel.geo"

REFUSED = {  # scene lines -> the key the message starts with
    "characteristics": ("time: {scheme: characteristics1, dt: 0.1, t_end: 0.2}\n", "time.scheme"),
    "probes": ("time: {scheme: ale_bdf2, dt: 0.1, t_end: 0.2}\nobservables: {points: {B: [1.0, 0.5]}}\n",
               "observables.points"),
    "profiles": ("time: {scheme: steady}\nobservables: {lines: {mid: {from: [1, 0], to: [1, 1], points: 5}}}\n",
                 "observables.lines"),
}


@pytest.mark.parametrize("case", sorted(REFUSED))
def test_quadrilaterals_refuse_what_works_in_triangles_only(tmp_path, case):
    text, key = REFUSED[case]
    config = tmp_path / "quad.yaml"
    config.write_text(f"geometry: {{name: file, path: {GEO}}}\nfluid: {{rho: 1.0, mu: 1.0}}\n{text}"
                      "output: {progress: false}\n"
                      "boundaries: {inlet: {type: velocity, value: ['6*y*(1 - y)', 0]}, outlet: {type: do_nothing},"
                      " bottom: {type: no_slip}, top: {type: no_slip}}\n")
    check(cli("run", config, "--out", tmp_path / "out"), 2, f"error: {key}: ", "quadrilateral mesh")
    assert not (tmp_path / "out").exists()
