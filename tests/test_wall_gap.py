"""The solid's distance to the walls (mesh/wall_gap.py): the compiled and numpy paths agree, and the numpy
path's passes over the points do not change its result."""

from __future__ import annotations

import numpy as np
import pytest

from cosserat_fsi.points import _kernels
from cosserat_fsi.mesh import wall_gap


def _walls_and_points(seed=3):
    """A floor z = 0 of 2 × 200 triangles on [0, 1]² and points above and beside it."""
    rng = np.random.default_rng(seed)
    n = 10
    x = np.linspace(0.0, 1.0, n + 1)
    triangles = []
    for i in range(n):
        for j in range(n):
            a, b, c, d = ([x[i], x[j], 0.0], [x[i + 1], x[j], 0.0], [x[i + 1], x[j + 1], 0.0], [x[i], x[j + 1], 0.0])
            triangles += [[a, b, c], [a, c, d]]
    triangles = np.array(triangles)
    points = rng.uniform([-0.3, -0.3, -0.5], [1.3, 1.3, 0.5], size=(500, 3))
    return triangles, points


def test_the_distance_above_a_floor_is_the_height():
    triangles, points = _walls_and_points()
    above = np.all((points[:, :2] > 0) & (points[:, :2] < 1), axis=1)
    dist, nearest = wall_gap.triangle_distance(points[above], triangles)
    assert np.allclose(dist, np.abs(points[above][:, 2]), rtol=0, atol=1e-14)
    centre = triangles[nearest].mean(axis=1)[:, :2]
    assert np.all(np.abs(centre - points[above][:, :2]) < 0.1)  # the triangle under the point


def test_compiled_and_numpy_paths_agree_in_passes(monkeypatch):
    triangles, points = _walls_and_points()
    compiled = wall_gap.triangle_distance(points, triangles)
    monkeypatch.setattr(_kernels, "ENABLED", False)
    whole = wall_gap.triangle_distance(points, triangles)
    monkeypatch.setattr(wall_gap, "PAIRS", 1000)  # 5 points per pass
    passes = wall_gap.triangle_distance(points, triangles)
    assert np.array_equal(whole[0], passes[0]) and np.array_equal(whole[1], passes[1])
    assert wall_gap.triangle_distance(points[:0], triangles)[0].shape == (0,)
    if _kernels.numba is None:
        pytest.skip("numba is not available: one path only")
    assert np.allclose(compiled[0], whole[0], rtol=1e-12, atol=1e-15)
    assert np.array_equal(compiled[1], whole[1])
