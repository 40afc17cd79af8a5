"""The Simulation and its parts: one loop, a State that checkpoints and transfers, a solver that
re-solves with its factorisation, a residual that serves both the step and a Newton solve."""

from __future__ import annotations

import numpy as np
import pytest
from mpi4py import MPI

from cosserat_fsi import compat
from cosserat_fsi.app.runner import load_mesh
from cosserat_fsi.config import validate_scene
from cosserat_fsi.simulation import Simulation

import dolfinx.fem.petsc as fem_petsc
import ufl
from petsc4py import PETSc


def _scene(scheme="characteristics2", **extra):
    return validate_scene({"geometry": {"name": "turek_hron", "level": 0, "flag": "solid"},
                           "fluid": {"rho": 1000.0, "mu": 1.0}, "solid": {"rho": 1000.0, "mu_s": 0.5e5},
                           "inflow": {"u_mean": 1.0, "ramp_time": 0.05},
                           "time": {"dt": 0.01, "t_end": 0.04, "scheme": scheme}, **extra})


def _fields(sim):
    return {name: f.x.array.copy() for name, f in sim.state.functions().items()}


SERIAL = pytest.mark.skipif(MPI.COMM_WORLD.size > 1, reason="two reads of a mesh are partitioned differently")


@SERIAL
def test_run_is_step_by_step_and_restore_continues_exactly():
    """A Simulation restored from the in-memory checkpoint of step 2 (FSI, BDF2 on a moving mesh: every
    level and configuration) continues to the same fields, bit for bit (with a fresh LU every step: the
    reused factorisation would differ after the restore by GMRES's tolerance)."""
    scene = _scene(solver={"reuse_factorization": False})
    comm = MPI.COMM_WORLD
    a = Simulation(scene, *load_mesh(scene, comm)[:3], comm)
    a.run(2)
    checkpoint = a.checkpoint()
    a.run(4)
    b = Simulation(scene, *load_mesh(scene, comm)[:3], comm)
    b.restore(comm.allgather(checkpoint))
    assert (b.step_count, b.t) == (2, pytest.approx(0.02))
    observed = []
    b.run(4, observers=[lambda sim: observed.append(sim.step_count)])
    assert observed == [3, 4] and b.step_count == 4
    fa, fb = _fields(a), _fields(b)
    assert set(fa) == set(fb) and {"d_nm1", "mesh_displacement_n", "mesh_displacement_nm1"} <= set(fa)
    for name in fa:
        assert np.array_equal(fa[name], fb[name]), name


@SERIAL
def test_state_transfer_to_a_copy_of_the_mesh_carries_every_field():
    """State.transfer_to with an interpolation between identical meshes reproduces every field and level."""
    scene = _scene()
    comm = MPI.COMM_WORLD
    a = Simulation(scene, *load_mesh(scene, comm)[:3], comm)
    a.run(2)
    b = Simulation(scene, *load_mesh(scene, comm)[:3], comm)

    def copy(target, source):  # same mesh layout: the identity "interpolation"
        target.x.array[:] = source.x.array

    a.state.transfer_to(b.state, copy)
    assert b.step_count == 2 and b.t == a.t
    for name, f in a.state.functions().items():
        assert np.array_equal(b.state.functions()[name].x.array, f.x.array), name


def test_linear_solver_resolves_with_the_kept_factorisation():
    """A second solve with the same operator (a corrector pass) reuses the factorisation and agrees."""
    scene = _scene(scheme="characteristics1")
    comm = MPI.COMM_WORLD
    sim = Simulation(scene, *load_mesh(scene, comm)[:3], comm)
    sim.run(2)
    stepper, solver = sim.stepper, sim.stepper.solver
    x = compat.petsc_vec(stepper.solution).copy()
    factorisations = solver.factorisations
    solver.solve(stepper.b, x)
    assert solver.factorisations == factorisations
    reference = stepper.solution.x.array[: len(x.array)]
    assert np.allclose(x.array, reference, rtol=0, atol=1e-8 * np.abs(reference).max())


def test_one_residual_for_the_linear_step_and_for_a_function():
    """Problem.residual assembled with the step's solution (a Function) and the scheme's acceleration equals
    A w − b of the step's split forms (no boundary rows): the same residual serves the characteristics
    step (ufl.lhs/rhs with trial functions) and a Newton solve or the residual forces (with a Function)."""
    scene = validate_scene({"geometry": {"name": "square", "level": 0}, "fluid": {"rho": 1.0, "mu": 0.01},
                            "inflow": {"u_mean": 1.0},
                            "micropolar": {"mu_r": 0.1, "lambda1": 0.01},
                            "time": {"scheme": "characteristics1", "dt": 0.1, "t_end": 0.2}})
    comm = MPI.COMM_WORLD
    sim = Simulation(scene, *load_mesh(scene, comm)[:3], comm)
    sim.run(2)
    problem, stepper = sim.problem, sim.stepper
    w = stepper.solution
    u, _, omega = problem.split(w)
    h = stepper.histories
    F = problem.residual(w, ufl.TestFunctions(problem.space.W), acceleration=stepper.acceleration(u),
                         micro_acceleration=h.acceleration(omega, h.micro_rotation, stepper.alpha, stepper.inv_dt),
                         dx_inertia=h.dx_inertia)
    residual = fem_petsc.assemble_vector(compat.form(F))
    A = fem_petsc.assemble_matrix(stepper.a_form)
    A.assemble()
    b = fem_petsc.assemble_vector(stepper.L_form)
    Aw = A.createVecLeft()
    A.mult(compat.petsc_vec(w), Aw)
    for v in (residual, b):
        v.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
    Aw.axpy(-1.0, b)
    Aw.axpy(-1.0, residual)
    assert residual.norm() > 1e-3 * b.norm()  # not trivially zero: the boundary rows are in it
    assert Aw.norm() < 1e-12 * b.norm()


def _petsc_garbage(comm, capfd) -> str:
    """PETSc's list of the objects Python has let go of but PETSc has not destroyed (its own print)."""
    capfd.readouterr()
    PETSc.garbage_view(comm)
    return capfd.readouterr().out


@SERIAL
def test_a_dropped_simulation_leaves_no_petsc_objects(capfd):
    """petsc4py 3.18 (Debian) keeps every PETSc object that the garbage collector frees until
    ``PETSc.garbage_cleanup`` (a dropped 3D flag Simulation kept 0.45 GB, a remesh the old mesh's
    factorisations): a Mat let go of is listed until ``compat.free_petsc_garbage``, and building a Simulation
    clears what the previous one, stepped and dropped, left (the wheel's petsc4py lists nothing at all)."""
    comm = MPI.COMM_WORLD
    A = PETSc.Mat().createAIJ((10, 10), comm=comm)
    A.setUp()
    A.assemble()
    del A
    import gc

    gc.collect()
    compat.free_petsc_garbage(comm)
    assert "Total entries: 0" in _petsc_garbage(comm, capfd)
    scene = _scene(scheme="characteristics1")
    mesh, ct, ft, _ = load_mesh(scene, comm)
    first = Simulation(scene, mesh, ct, ft, comm)
    first.run(1)
    del first
    gc.collect()
    second = Simulation(scene, mesh, ct, ft, comm)
    assert "Total entries: 0" in _petsc_garbage(comm, capfd)
    assert second.step_count == 0
