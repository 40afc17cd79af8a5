"""``solver.type: iterative``: FGMRES with the fieldsplit Schur preconditioner of scheme/block_preconditioner.py
(Cahouet–Chabard for a time step), its counts, and ``solver.petsc_options`` through PETSc's options database."""

from __future__ import annotations

import numpy as np
import pytest
from mpi4py import MPI

from cosserat_fsi import compat
from cosserat_fsi.app.runner import load_mesh
from cosserat_fsi.config import load_scene, validate_scene
from cosserat_fsi.config.loading import _apply_override
from cosserat_fsi.errors import InputError
from cosserat_fsi.simulation import Simulation

import dolfinx
import ufl


def _channel(level: int, solver: dict) -> dict:
    """Schäfer–Turek 2D-1 (cylinder in a channel, do-nothing outlet) from rest, two characteristics steps."""
    return validate_scene({"name": "st2d1", "geometry": {"name": "schaefer_turek", "level": level},
                           "fluid": {"rho": 1.0, "mu": 0.001}, "inflow": {"u_mean": 0.2, "profile": "parabolic"},
                           "time": {"dt": 0.05, "t_end": 0.1, "scheme": "characteristics2"}, "solver": solver})


def _run(scene, comm=MPI.COMM_WORLD, mesh=None):
    """(the Simulation, the linear solver's counts) after the scene's steps (on ``mesh``: load_mesh's tuple)."""
    mesh, ct, ft, _ = mesh or load_mesh(scene, comm)
    sim = Simulation(scene, mesh, ct, ft, comm)
    sim.run(sim.steps_to(scene.time.t_end))
    return sim, sim.stepper.solver.counts()


def _relative(comm, a, b) -> float:
    """‖a − b‖ / ‖a‖ in L²."""
    mesh = a.function_space.mesh

    def norm(expr):
        value = dolfinx.fem.assemble_scalar(compat.form(ufl.inner(expr, expr) * ufl.dx(domain=mesh)))
        return np.sqrt(comm.allreduce(value, op=MPI.SUM))

    return norm(a - b) / norm(a)


def test_cahouet_chabard_time_step_matches_mumps_with_flat_iterations():
    """The time step's solution equals MUMPS's to the Krylov tolerance, and the FGMRES iterations per solve
    do not grow with the mesh: 2D-1 levels 0 and 1 (measured 17.5 and 18.5 per solve with GAMG; the
    pressure-mass Schur it replaces needed about 400 on level 1)."""
    comm = MPI.COMM_WORLD
    mesh = load_mesh(_channel(0, {}), comm)
    direct, _ = _run(_channel(0, {"type": "direct"}), mesh=mesh)
    iterative, counts = _run(_channel(0, {"type": "iterative", "krylov_rtol": 1e-10}), mesh=mesh)
    assert counts["type"].startswith("iterative") and "Cahouet-Chabard" in counts["type"]
    assert counts["solves"] == 2 and counts["factorisations"] == 0
    assert _relative(comm, direct.velocity, iterative.velocity) < 1e-7
    assert _relative(comm, direct.pressure, iterative.pressure) < 1e-7
    _, finer = _run(_channel(1, {"type": "iterative", "krylov_rtol": 1e-10}))
    mean0, mean1 = counts["krylov_iterations"]["mean"], finer["krylov_iterations"]["mean"]
    print("iterations per solve, levels 0 and 1:", mean0, mean1)
    assert mean0 < 30 and mean1 <= 1.3 * mean0


def test_petsc_options_reach_the_sub_solvers():
    """An option under ``solver.petsc_options`` reaches the velocity block's multigrid: PETSc's default GAMG
    threshold (−1, no graph dropping) instead of ours (0.02) costs measurably more iterations on level 1;
    the options leave the database after the first solve."""
    from petsc4py import PETSc

    _, ours = _run(_channel(1, {"type": "iterative"}))
    sim, default = _run(_channel(1, {"type": "iterative",
                                     "petsc_options": {"fieldsplit_primal_pc_gamg_threshold": -1.0}}))
    print("iterations per solve, threshold 0.02 and -1:", ours["krylov_iterations"], default["krylov_iterations"])
    assert default["krylov_iterations"]["mean"] > 1.2 * ours["krylov_iterations"]["mean"]
    prefix = sim.stepper.solver.prefix
    assert not PETSc.Options().hasName(prefix + "fieldsplit_primal_pc_gamg_threshold")


@pytest.mark.parametrize("solver, message", [
    ({"type": "iterative", "petsc_options": {"fieldsplit_primal_pc_gamg_treshold": 0.1}},
     "solver.petsc_options.fieldsplit_primal_pc_gamg_treshold: PETSc did not use this option"),
    ({"type": "direct", "petsc_options": {"fieldsplit_primal_pc_type": "jacobi"}},
     "solver.petsc_options.fieldsplit_primal_pc_type: PETSc did not use this option"),
    ({"type": "iterative", "petsc_options": {"fieldsplit_pressure_pc_type": "nonesuch"}},
     "solver.petsc_options: PETSc could not apply them"),
])
def test_petsc_options_that_do_nothing_are_input_errors(solver, message):
    """A misspelt option, one for the other solver type, or a type PETSc does not have: one-line input
    errors, not a silently default solve."""
    with pytest.raises(InputError, match=message.replace(".", r"\.")):
        _run(_channel(0, solver))


def test_mumps_options_reach_the_factorisation():
    """``mat_mumps_*`` options reach the direct solver's factor matrix (its ICNTL), over the defaults."""
    sim, _ = _run(_channel(0, {"type": "direct", "petsc_options": {"mat_mumps_icntl_14": 250}}))
    assert sim.stepper.solver.ksp.getPC().getFactorMatrix().getMumpsIcntl(14) == 250


def test_petsc_options_from_the_command_line(tmp_path):
    """``--set solver.petsc_options.KEY=VALUE``: any key, one level deep; the key's spelling is checked."""
    path = tmp_path / "scene.yaml"
    path.write_text("geometry: {name: square, level: 0}\nfluid: {rho: 1.0, mu: 0.1}\ninflow: {u_mean: 1.0}\n"
                    "time: {dt: 0.1, t_end: 0.2, scheme: characteristics2}\n")
    scene = load_scene(path, ["solver.type=iterative", "solver.petsc_options.fieldsplit_primal_pc_type=hypre",
                              "solver.petsc_options.ksp_gmres_restart=50"])
    assert scene.solver.petsc_options == {"fieldsplit_primal_pc_type": "hypre", "ksp_gmres_restart": 50}
    with pytest.raises(InputError, match=r"solver\.petsc_options\.ksp_type: is a value, not a section"):
        _apply_override({}, "solver.petsc_options.ksp_type.x=1")
    with pytest.raises(InputError, match=r"solver\.petsc_options\.-ksp_type|solver\.petsc_options"):
        load_scene(path, ["solver.petsc_options.Ksp_type=gmres"])
