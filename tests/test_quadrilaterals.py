"""An all-quadrilateral 2D mesh (``Recombine Surface``): Q2/Q1 spaces; the steady equations hold the Poiseuille
flow of a channel exactly (Q2 holds the parabola). What quadrilaterals cannot do is refused:
tests/faults/test_quad_refusals.py."""

from __future__ import annotations

import os

import numpy as np
from mpi4py import MPI

DATA = os.path.join(os.path.dirname(__file__), "data", "user_scene")


def test_poiseuille_on_quadrilaterals_is_exact(tmp_path):
    import dolfinx.mesh

    from cosserat_fsi.app.runner import load_mesh
    from cosserat_fsi.config import load_scene
    from cosserat_fsi.simulation import Simulation

    path = tmp_path / "scene.yaml"
    path.write_text(f"geometry: {{name: file, path: {DATA}/quad_channel.geo}}\n"
                    "fluid: {rho: 1.0, mu: 1.0}\n"
                    "time: {scheme: steady}\n"
                    "boundaries: {inlet: {type: velocity, value: ['6*y*(1 - y)', 0]}, outlet: {type: do_nothing}, "
                    "bottom: {type: no_slip}, top: {type: no_slip}}\n")
    scene, comm = load_scene(path), MPI.COMM_WORLD
    mesh, ct, ft, _ = load_mesh(scene, comm)
    assert mesh.topology.cell_type == dolfinx.mesh.CellType.quadrilateral
    sim = Simulation(scene, mesh, ct, ft, comm)
    sim.run(1)
    u = sim.velocity
    exact = u.copy()
    exact.interpolate(lambda x: np.vstack([6 * x[1] * (1 - x[1]), 0 * x[1]]))
    error = comm.allreduce(float(np.abs(u.x.array - exact.x.array).max()), op=MPI.MAX)
    assert error < 1e-8
    p = sim.pressure  # G = 12 μ: p = 12 (2 − x) with p = 0 at the outlet
    linear = p.copy()
    linear.interpolate(lambda x: 12 * (2 - x[0]))
    assert comm.allreduce(float(np.abs(p.x.array - linear.x.array).max()), op=MPI.MAX) < 1e-8
