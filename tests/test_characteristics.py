"""Point location and the vectorised P2 evaluation used by the characteristics."""

import numpy as np
from mpi4py import MPI

from cosserat_fsi import compat
from cosserat_fsi.geometry import SchaeferTurek, build_msh
from cosserat_fsi.scheme.characteristics import PointLocator, eval_at

import dolfinx


def test_vectorised_p2_evaluation_equals_function_eval(tmp_path):
    """eval_at (barycentric P2 basis) = dolfinx's Function.eval to round-off, scalar and vector."""
    path = build_msh(SchaeferTurek(), cache_dir=tmp_path) if MPI.COMM_WORLD.rank == 0 else None
    mesh, _, _ = compat.read_msh(MPI.COMM_WORLD.bcast(path), MPI.COMM_WORLD)
    locator = PointLocator(mesh)
    rng = np.random.default_rng(0)
    points = np.zeros((400, 3))
    points[:, 0], points[:, 1] = rng.uniform(0, 2.2, 400), rng.uniform(0, 0.41, 400)
    cells = locator.locate(points)
    found = cells >= 0
    assert found.sum() > 0
    for shape, expr in (((2,), lambda x: np.vstack([np.sin(3 * x[0]) * x[1], x[0] ** 2 - x[1]])),
                        (None, lambda x: np.cos(2 * x[0] + x[1]))):
        f = dolfinx.fem.Function(compat.function_space(mesh, "Lagrange", 2, shape=shape))
        f.interpolate(expr)
        ours = eval_at(locator, f, points[found], cells[found])
        theirs = f.eval(points[found], cells[found]).reshape(found.sum(), -1)
        assert np.abs(ours - theirs).max() < 1e-12
