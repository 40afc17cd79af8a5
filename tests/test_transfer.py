"""State.transfer_to through compat.interpolate_nonmatching (the groundwork of remeshing).

A micropolar state on the square (level 0) is carried to the square of level 1, another mesh of the same
domain. A resting state stays zero, and a translating free stream (u uniform, p linear, ω constant, the
BDF2 levels likewise) is reproduced exactly by P2/P1, so it must arrive to round-off (1e-12).
"""

from __future__ import annotations

import numpy as np
import pytest
from mpi4py import MPI

from cosserat_fsi.app.runner import load_mesh
from cosserat_fsi.config import validate_scene
from cosserat_fsi.mesh.transfer import interpolator
from cosserat_fsi.simulation import Simulation

FIELDS = {"u_n": lambda x: np.vstack([np.full(x.shape[1], 1.5), np.full(x.shape[1], -0.25)]),
          "u_nm1": lambda x: np.vstack([np.full(x.shape[1], 1.25), np.full(x.shape[1], -0.5)]),
          "p_n": lambda x: 3.0 - 2.0 * x[0] + 0.5 * x[1],
          "omega_n": lambda x: np.full(x.shape[1], 0.125),
          "omega_nm1": lambda x: np.full(x.shape[1], 0.25)}


def _simulation(level: int) -> Simulation:
    scene = validate_scene({"geometry": {"name": "square", "level": level}, "fluid": {"rho": 1.0, "mu": 0.01},
                            "inflow": {"u_mean": 1.0}, "micropolar": {"mu_r": 0.1, "lambda1": 0.01},
                            "time": {"dt": 0.1, "t_end": 0.2, "scheme": "characteristics2"}})
    comm = MPI.COMM_WORLD
    return Simulation(scene, *load_mesh(scene, comm)[:3], comm)


@pytest.mark.mpi
@pytest.mark.parametrize("moving", [False, True], ids=["resting", "free stream"])
def test_state_transfers_unchanged_to_another_mesh(moving):
    source, target = _simulation(0), _simulation(1)
    functions = source.state.functions()
    assert set(FIELDS) <= set(functions)
    for name, f in functions.items():
        f.x.array[:] = 0.0
        if moving and name in FIELDS:
            f.interpolate(FIELDS[name])
    for f in target.state.functions().values():
        f.x.array[:] = 7.0  # must be overwritten everywhere
    source.state.t, source.state.step_count = 0.3, 3
    source.state.transfer_to(target.state, interpolator(MPI.COMM_WORLD))
    assert (target.state.t, target.state.step_count) == (0.3, 3)
    for name, f in target.state.functions().items():
        expected = f.copy()
        expected.x.array[:] = 0.0
        if moving and name in FIELDS:
            expected.interpolate(FIELDS[name])
        error = MPI.COMM_WORLD.allreduce(float(np.abs(f.x.array - expected.x.array).max()), op=MPI.MAX)
        assert error < 1e-12, (name, error)
