"""Mesh motions: the default extension carries a bent flag that the harmonic one cannot.

The flag of the L0 turek_hron mesh is bent in pure bending (campaigns/mesh_motion.py) to a centreline tip
deflection of 12 cm. Measured (docs/perf_mesh_motion.md, "Mesh motion"): the seed's harmonic extension
drops below quality 0.1 at 11.5 cm and inverts a cell at 12.5 cm; the biharmonic one stays above 0.2 to
12.5 cm, the elastic one (ν = −0.2, χ = 1) to 13 cm.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest
from mpi4py import MPI

from cosserat_fsi.app.runner import load_mesh
from cosserat_fsi.config import validate_scene
from cosserat_fsi.errors import InputError

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "campaigns"))
import mesh_motion as campaign  # noqa: E402

SCENE = {"geometry": {"name": "turek_hron", "level": 0, "flag": "solid"}, "fluid": {"rho": 1.0, "mu": 1.0},
         "solid": {"rho": 1.0, "mu_s": 1.0}, "inflow": {"u_mean": 1.0},
         "time": {"scheme": "characteristics1", "dt": 0.1, "t_end": 1.0}}


def _min_quality(options: dict, delta: float) -> float:
    from cosserat_fsi.mesh.motion import MeshMotion

    comm = MPI.COMM_WORLD
    mesh, ct, _, _ = load_mesh(validate_scene(SCENE), comm)
    motion = MeshMotion(mesh, ct, comm, **options)
    points = np.zeros((len(motion.displacement.x.array) // 2, 2))
    points[motion.node_dof[: len(motion.X0)]] = motion.X0
    solid = campaign.bending(points, delta).ravel()
    total = motion.extend(solid)
    assert np.abs(total[motion._solid_entries] - solid[motion._solid_entries]).max() < 1e-12  # solid kept
    mesh.geometry.x[:, :2] = motion.X0 + total.reshape(-1, 2)[motion.node_dof]
    quality = comm.allreduce(float(motion.quality().min()), op=MPI.MIN)
    mesh.geometry.x[:, :2] = motion.X0
    return quality


@pytest.mark.mpi
def test_default_mesh_motion_carries_a_deflection_the_harmonic_one_cannot():
    default = validate_scene(SCENE).solid.mesh_motion.options()
    assert default["method"] == "biharmonic"
    assert _min_quality({"method": "harmonic"}, 0.12) < 0.1
    assert _min_quality(default, 0.12) > 0.2
    assert _min_quality({"method": "elastic", "poisson_ratio": -0.2, "stiffness_exponent": 1.0}, 0.12) > 0.2


def test_mesh_motion_settings_are_checked():
    for key, value, where in (("method", "spring", "solid.mesh_motion.method"),
                              ("poisson_ratio", 0.5, "solid.mesh_motion.poisson_ratio"),
                              ("stiffness_exponent", -1, "solid.mesh_motion.stiffness_exponent")):
        scene = {**SCENE, "solid": {**SCENE["solid"], "mesh_motion": {key: value}}}
        with pytest.raises(InputError, match=where):
            validate_scene(scene)
