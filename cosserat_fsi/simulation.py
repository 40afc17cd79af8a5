"""The one owner of the time loop: a scene on a mesh, advanced step by step.

    sim = Simulation(scene, mesh, cell_tags, facet_tags, comm)
    sim.run(n_steps, observers=[lambda sim: ...], after_step=[lambda sim: ...])

The runner (app/runner.py), the bench (campaigns/bench.py) and the tests drive this same loop.
Observers see the solution on the mesh it was solved on (before the mesh moves on); ``after_step``
callbacks run once the step is complete (field output, checkpoints, progress).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from pathlib import Path

from mpi4py import MPI

from . import compat
from .problem.boundary import BoundaryConditions
from .mesh.motion import MeshMotion, PrescribedMotion
from .problem.model import Model, Problem
from .time_schemes.schemes import scheme_class
from .time_schemes.state import State
from .timers import Timers

Callback = Callable[["Simulation"], None]


def quadrilateral_limits(scene, mesh) -> None:
    """A quadrilateral mesh (Q2/Q1 spaces) takes the schemes with the convection in the matrix and the
    steady equations, a fluid only and no observables at points: the characteristics' back-tracking, the
    point location of probes and profiles, the mesh motion's quality and remeshing work in triangles.
    InputError naming the key of the first part a scene asks for that quadrilaterals cannot do."""
    import dolfinx.mesh

    from .errors import InputError

    if mesh.topology.cell_type != dolfinx.mesh.CellType.quadrilateral:
        return
    other = "mesh the file in triangles (no Recombine)"
    if scene.solid is not None:
        raise InputError(f"solid: a quadrilateral mesh takes no solid (the mesh motion, its quality and "
                         f"remeshing work in triangles); {other}")
    if scene.time.scheme.startswith("characteristics"):
        raise InputError(f"time.scheme: {scene.time.scheme} follows the characteristics in triangles; a "
                         f"quadrilateral mesh takes ale_bdf2, generalized_alpha or steady, or {other}")
    for key in ("points", "lines"):
        if scene.observables is not None and getattr(scene.observables, key):
            raise InputError(f"observables.{key}: a quadrilateral mesh takes no {key} (they are located in "
                             f"triangles); {other}")


class Simulation:
    """Problem + state + scheme of one scene.

    Public surface: ``scene``, ``mesh``, ``cell_tags``, ``facet_tags``, ``comm``, ``exact``, ``model``,
    ``problem`` (coefficients and residual), ``state`` (fields and levels), ``stepper`` (the scheme),
    ``motion`` (None on a fixed mesh), ``timers``; ``t``, ``step_count``, ``velocity``, ``pressure``,
    ``micro_rotation``, ``displacement``, ``locator`` (for probes on the current mesh), ``num_dofs()``,
    ``acceleration(u)``; ``step``, ``run``, ``checkpoint``, ``restore``.
    """

    def __init__(self, scene, mesh, cell_tags, facet_tags, comm=MPI.COMM_WORLD, exact=None,
                 prescribed_motion: Callable | None = None, facet_ids: dict[str, int] | None = None):
        """``exact``: optional exact solution (``velocity(x, t)``, with micro-rotation
        ``micro_rotation(x, t)``, optional sources ``body_force``/``body_couple``): the initial state,
        the Dirichlet data on every boundary but the outlet and the sources (verification tests).
        ``prescribed_motion(X, t)``: a displacement of the reference coordinates that the mesh follows
        instead of the material (ALE verification). ``facet_ids``: facet name -> tag of the mesh (default:
        the scene's, geometry.facet_ids: the project's table, or a file scene's own, read on rank 0)."""
        self.scene, self.mesh, self.comm, self.exact = scene, mesh, comm, exact
        self.cell_tags, self.facet_tags = cell_tags, facet_tags
        self.timers = Timers()
        compat.free_petsc_garbage(comm)  # what an earlier Simulation of this process let go of
        if facet_ids is None:
            from .geometry import facet_ids as scene_facet_ids
            from .parallel import on_root

            facet_ids = on_root(comm, scene_facet_ids, scene.geometry)
        self._prescribed_motion = prescribed_motion
        quadrilateral_limits(scene, mesh)
        self.problem = Problem(scene, mesh, cell_tags, facet_tags, exact=exact, facet_ids=facet_ids)
        self.motion = self._motion(prescribed_motion)
        self.state = self._new_state()
        self.state.set_initial(self.problem, exact)
        self.stepper = self._stepper()
        # automatic remeshing (solid.mesh_motion.remesh; mesh/remesh.py): the remeshes so far, where their
        # meshes go (rank 0; the runner sets the run folder), what is told of each
        self.remeshes: list[dict] = []
        self.mesh_file: Path | None = None  # the .msh of the current mesh when it is a remeshed one
        self.remesh_folder: Path | None = None
        self.on_remesh: list[Callable[[Simulation, dict], None]] = []

    def _new_state(self) -> State:
        """A State for the scene's scheme on the current problem and mesh motion (not set): the levels and
        rates the scheme keeps."""
        scheme = scheme_class(self.scene, self.problem.model)
        return State(self.problem, scheme.levels(self.scene.time), self.motion, rates=scheme.RATES,
                     adaptive=getattr(self.scene.time, "tolerance", None) is not None)

    def _stepper(self):
        """The scene's time scheme (time_schemes/schemes.py), with its boundary conditions."""
        boundary = BoundaryConditions(self.problem, self.comm, self.exact)
        return scheme_class(self.scene, self.problem.model).create(self.problem, self.state, boundary, self.motion,
                                                                   self.timers, self.comm)

    def _motion(self, prescribed_motion):
        """The mesh motion (pluggable: harmonic extension of the solid's displacement today)."""
        if prescribed_motion is not None:
            return PrescribedMotion(self.mesh, prescribed_motion, self.comm)
        if self.problem.model.moving_mesh:
            settings = self.scene.solid.mesh_motion
            return MeshMotion(self.mesh, self.cell_tags, self.comm, **settings.options(),
                              wall_facets=self.problem.facets(*self.problem.wall_boundaries()),
                              mesh_sizes=settings.remesh is not None)
        return None

    # ------------------------------------------------------------------------------- the loop
    def step(self, observers: Iterable[Callback] = (), dt: float | None = None) -> None:
        """One time step (of size ``dt`` if given: a prescribed sequence of steps; else the scene's or, with
        ``time.tolerance``, the controller's); ``observers(sim)`` after the solve, on the mesh it was solved on;
        then a remesh if the cells became too poor (``solid.mesh_motion.remesh``)."""
        observers = tuple(observers)
        observe = (lambda: [o(self) for o in observers]) if observers else None
        self.stepper.advance(observe) if dt is None else self.stepper.advance(observe, dt=dt)
        settings = self.scene.solid.mesh_motion.remesh if self.scene.solid is not None else None
        quality = getattr(self.motion, "min_fluid_quality", None)  # a remesh can only mend the fluid cells
        if (settings is not None and isinstance(self.motion, MeshMotion) and quality is not None
                and quality < settings.quality and len(self.remeshes) < settings.max_count):
            self.remesh(f"minimum fluid cell quality {quality:.3g} < {settings.quality:g}")

    def remesh(self, reason: str = "requested") -> dict:
        """A new fluid mesh around the current solid (mesh/remesh.py), every field and history level
        carried to it (State.transfer_to), the problem rebuilt; the mesh motion's reference is the new mesh.
        Returns (and appends to ``remeshes``) the record: t, step, reason, the minimum quality of the fluid
        cells before/after, seconds, the .msh file and its SHA-256 (a restart checks it)."""
        import shutil
        import tempfile
        import time

        from .io.checkpoint import mesh_digest
        from .mesh.remesh import remesh_msh
        from .mesh.transfer import interpolator

        start = time.perf_counter()
        before = self.motion.min_fluid_quality
        folder = self.remesh_folder
        scratch = folder is None  # no run folder (API use, tests): the .msh lives only until it is read
        if scratch:
            folder = self.comm.bcast(tempfile.mkdtemp(prefix="cosserat-fsi-remesh-") if self.comm.rank == 0
                                     else None, root=0)
        path = Path(folder) / f"remesh_{len(self.remeshes) + 1:03d}.msh"
        with self.timers("remesh"):
            remesh_msh(self.mesh, self.cell_tags, self.facet_tags, self._node_sizes(), self.problem.facet_ids,
                       path, self.comm)
            mesh, cell_tags, facet_tags = compat.read_msh(path, self.comm, gdim=self.mesh.geometry.dim)
            if scratch:
                self.comm.barrier()  # every rank has read it
                if self.comm.rank == 0:
                    shutil.rmtree(folder, ignore_errors=True)
            old = self.state
            lowest = self.motion.lowest_quality
            self._adopt(mesh, cell_tags, facet_tags)
            old.transfer_to(self.state, interpolator(self.comm))
            self._rereference()
            self.stepper.restored()
            self.motion.lowest_quality = lowest
            del old
            compat.free_petsc_garbage(self.comm)  # the old mesh's factorisations: freed now, on every rank
        self.mesh_file = None if scratch else path
        record = {"t": self.t, "step": self.step_count, "reason": reason, "quality_before": before,
                  "quality_after": self.motion.min_fluid_quality, "seconds": time.perf_counter() - start,
                  "cells": mesh.topology.index_map(mesh.topology.dim).size_global, "mesh": path.name,
                  "sha256": None if scratch else self.comm.bcast(mesh_digest(path) if self.comm.rank == 0 else None)}
        self.remeshes.append(record)
        for callback in self.on_remesh:
            callback(self, record)
        return record

    def _node_sizes(self):
        """Target cell size at the local geometry nodes: the kept ``mesh_size`` (carried from the scene's mesh
        through every remesh, so the cell count does not drift), else the mean reference edge length."""
        from .mesh.motion import _vertex_sizes

        m = self.motion
        if getattr(m, "mesh_size", None) is not None:
            return m.node_sizes()
        x = self.mesh.geometry.x[:, :m.dim].copy()
        self.mesh.geometry.x[:, :m.dim] = m.X0
        try:
            m.mesh_size = _vertex_sizes(self.mesh)
        finally:
            self.mesh.geometry.x[:, :m.dim] = x
        return m.node_sizes()

    def _adopt(self, mesh, cell_tags, facet_tags) -> None:
        """Problem, mesh motion, state and stepper on another mesh of the scene (state not set)."""
        self.mesh, self.cell_tags, self.facet_tags = mesh, cell_tags, facet_tags
        self.problem = Problem(self.scene, mesh, cell_tags, facet_tags, exact=self.exact,
                               facet_ids=self.problem.facet_ids)
        self.motion = self._motion(self._prescribed_motion)
        self.state = self._new_state()
        self.stepper = self._stepper()

    def _rereference(self) -> None:
        """After a transfer onto a new mesh, which is its own reference: the total mesh displacement D^n
        becomes zero and the earlier configurations D^{n−1}, Ω^n, Ω^{n−1} are relative to the new mesh
        (the carried values minus the carried D^n, so each earlier configuration is the image of the new
        nodes under the old mesh's piecewise-linear motion)."""
        m, state = self.motion, self.state
        D = m.displacement.x.array.copy()
        for level in (state.mesh_displacement_prev, state.configuration_n, state.configuration_nm1):
            if level is not None:
                level.x.array[:] -= D
        m.displacement.x.array[:] = 0.0
        m.solid_displacement.x.array[:] = 0.0
        m.measure_quality()

    def run(self, n_steps: int, observers: Iterable[Callback] = (), after_step: Iterable[Callback] = ()) -> None:
        """Step until ``step_count == n_steps`` (continuing from a restored state)."""
        observers, after_step = tuple(observers), tuple(after_step)
        while self.step_count < n_steps:
            self.step(observers)
            for callback in after_step:
                callback(self)

    def run_to(self, t_end: float, observers: Iterable[Callback] = (), after_step: Iterable[Callback] = ()) -> None:
        """Step until t = ``t_end`` (the scene's with ``time.tolerance``: the controller's steps end there)."""
        observers, after_step = tuple(observers), tuple(after_step)
        if self.time_control is not None:
            self.time_control.t_end = float(t_end)
        while not self.finished(t_end):
            self.step(observers)
            for callback in after_step:
                callback(self)

    def finished(self, t_end: float) -> bool:
        """Has the run reached ``t_end``?"""
        control = self.time_control
        if control is None:
            return self.step_count >= self.steps_to(t_end)
        return control.finished(self.state, t_end)

    @property
    def time_control(self):
        """The step size controller (time_schemes/time_control.py; None with a fixed step)."""
        return getattr(self.stepper, "control", None)

    def steps_to(self, t_end: float) -> int:
        """The number of steps of the run to ``t_end`` (a steady solve is one step: its dt and t_end are 1;
        with ``time.tolerance`` the number of steps of size ``time.dt``)."""
        return int(round(t_end / self.scene.time.dt))

    def check(self) -> None:
        """DivergenceError if the run failed without raising at once (a steady Newton that did not
        converge keeps its last iterate for the outputs)."""
        self.stepper.check()

    @property
    def report(self):
        """The Newton report of a steady solve (None when time stepping)."""
        return self.stepper.report

    # ------------------------------------------------------------------------- checkpoints
    def checkpoint(self) -> dict:
        """This rank's part of the state, independent of the partition (io/checkpoint.py writes it)."""
        return self.state.checkpoint()

    def restore(self, states: list[dict]) -> None:
        """Continue from the checkpoints of all ranks of an earlier run of the same scene."""
        self.state.restore(states, float(abs(self.mesh.geometry.x).max()))  # the reference mesh
        self.stepper.restored()

    # ------------------------------------------------------------------------------ surface
    @property
    def model(self) -> Model:
        return self.problem.model

    @property
    def t(self) -> float:
        return self.state.t

    @property
    def step_count(self) -> int:
        return self.state.step_count

    @property
    def order(self) -> int:
        return self.state.order

    @property
    def velocity(self):
        return self.state.velocity

    @property
    def pressure(self):
        return self.state.pressure

    @property
    def micro_rotation(self):
        return self.state.micro_rotation

    @property
    def displacement(self):
        return self.state.displacement

    @property
    def locator(self):
        """The point locator of the current mesh (characteristics.probe)."""
        return self.stepper.locator

    def acceleration(self, u):
        """The scheme's material acceleration of ``u`` in the last step (residual forces)."""
        return self.stepper.acceleration(u)

    @property
    def dx_inertia(self):
        return self.stepper.dx_inertia

    def split_solution(self) -> tuple:
        """(u, p, ω or None) of the last solution (the mixed Function), as UFL expressions."""
        return self.stepper.split_solution()

    def num_dofs(self) -> dict:
        return self.problem.num_dofs()
