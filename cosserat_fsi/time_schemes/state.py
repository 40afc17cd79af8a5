"""The state of a run: every field the next steps depend on, its checkpoint and its transfer to another mesh.

A checkpoint stores this rank's owned dofs keyed by their coordinates on the reference mesh, so a restart
does not depend on the partition (dolfinx's is not deterministic). The keys are those of checkpoint
format 1 (io/checkpoint.py): ``u_n``, ``u_nm1``, ``p_n``, ``mesh_velocity``, ``omega_n``, ``omega_nm1``,
``d_n``, ``d_nm1`` (BDF2), ``mesh_displacement_prev``/``_n``/``_nm1`` (BDF2 on a moving mesh) and the
mesh motion's own ``mesh_displacement``, ``mesh_velocity_P1``, ``solid_displacement``.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ..errors import InputError
from ..problem.model import Problem

import dolfinx


class State:
    """u^n, p^n, ω^n (or None), d^n (or None), their BDF2 levels and the mesh displacement levels.

    Fields (dolfinx Functions on the collapsed spaces of ``problem.space``):
    ``velocity``, ``velocity_prev`` (u^{n−1}), ``pressure``, ``micro_rotation``/``micro_rotation_prev``
    (None without micro-rotation), ``displacement``/``displacement_prev`` (d^n, d^{n−1}; None without
    solid), ``mesh_velocity`` (P2, (x^n − x^{n−1})/δt). With BDF2 on a moving mesh (P1 vertex fields, else
    None): ``mesh_displacement_prev`` (D^{n−1}), ``configuration_n`` and ``configuration_nm1`` (the mesh
    displacements of the configurations u^n and u^{n−1} were computed on). With ``rates``
    (generalised-α): ``velocity_rate``, ``micro_rotation_rate`` (u̇^n, ω̇^n of the nodal values) and
    ``displacement_rate`` (ḋ^n), else None, and ``rates_prev`` (each rate's value of the step before).
    ``t`` and ``step_count``. ``steps``: the step sizes (t^n − t^{n−1}, t^{n−1} − t^{n−2}) and the step
    controller's state (time_control.py), in the checkpoint as ``steps``. With ``adaptive``
    (``time.tolerance``): ``velocity_prev2`` and ``displacement_prev2`` (u^{n−2}, d^{n−2}: the error
    estimate's predictor), else None.
    """

    def __init__(self, problem: Problem, order: int, motion=None, rates: bool = False, adaptive: bool = False):
        sp, model = problem.space, problem.model
        self.order, self.motion = order, motion
        V = sp.space("velocity")
        self.velocity = dolfinx.fem.Function(V, name="velocity")
        self.velocity_prev = dolfinx.fem.Function(V)
        self.pressure = dolfinx.fem.Function(sp.space("pressure"), name="pressure")
        self.micro_rotation = self.micro_rotation_prev = None
        if model.micro_rotation:
            S = sp.space("micro_rotation")
            self.micro_rotation = dolfinx.fem.Function(S, name="micro_rotation")
            self.micro_rotation_prev = dolfinx.fem.Function(S)
        self.displacement = self.displacement_prev = None
        if model.solid:
            self.displacement = dolfinx.fem.Function(V, name="displacement")
            self.displacement_prev = dolfinx.fem.Function(V)
        self.velocity_prev2 = dolfinx.fem.Function(V) if adaptive else None
        self.displacement_prev2 = dolfinx.fem.Function(V) if adaptive and model.solid else None
        self.steps = StepSizes()
        self.mesh_velocity = dolfinx.fem.Function(V, name="mesh_velocity")
        # generalised-α (``rates``): the time derivatives u̇^n, ω̇^n of the nodal values and ḋ^n of d
        self.velocity_rate = self.micro_rotation_rate = self.displacement_rate = None
        self.rates_prev = {}  # id(rate) -> the rate's value of the step before (a varying step's correction)
        if rates:
            self.velocity_rate = dolfinx.fem.Function(V)
            if model.micro_rotation:
                self.micro_rotation_rate = dolfinx.fem.Function(sp.space("micro_rotation"))
            if model.solid:
                self.displacement_rate = dolfinx.fem.Function(V)
            self.rates_prev = {id(f): dolfinx.fem.Function(f.function_space) for f in self.rates()}
        self.mesh_displacement_prev = self.configuration_n = self.configuration_nm1 = None
        if motion is not None and order == 2:
            self.mesh_displacement_prev = dolfinx.fem.Function(motion.M)
            self.configuration_n = dolfinx.fem.Function(motion.M)
            self.configuration_nm1 = dolfinx.fem.Function(motion.M)
        self.t = 0.0
        self.step_count = 0
        dim = problem.mesh.geometry.dim
        self._reference = {name: f.function_space.tabulate_dof_coordinates()[:, :dim].copy()
                           for name, f in self.functions().items()}  # before the mesh moves

    def functions(self) -> dict[str, dolfinx.fem.Function]:
        """Every function of the state, by its checkpoint name."""
        fns = {"u_n": self.velocity, "u_nm1": self.velocity_prev, "p_n": self.pressure,
               "mesh_velocity": self.mesh_velocity}
        if self.micro_rotation is not None:
            fns.update(omega_n=self.micro_rotation, omega_nm1=self.micro_rotation_prev)
        if self.displacement is not None:
            fns["d_n"] = self.displacement
            if self.order == 2 or self.displacement_prev2 is not None:
                fns["d_nm1"] = self.displacement_prev
        for name, f in (("u_nm2", self.velocity_prev2), ("d_nm2", self.displacement_prev2),
                        ("udot_n", self.velocity_rate), ("omegadot_n", self.micro_rotation_rate),
                        ("ddot_n", self.displacement_rate)):
            if f is not None:
                fns[name] = f
                if id(f) in self.rates_prev:
                    fns[name.replace("_n", "_nm1")] = self.rates_prev[id(f)]
        if self.configuration_n is not None:
            fns.update(mesh_displacement_prev=self.mesh_displacement_prev,
                       mesh_displacement_n=self.configuration_n, mesh_displacement_nm1=self.configuration_nm1)
        if self.motion is not None:
            fns.update(self.motion.state_functions())
        return fns

    def shift(self, solution, space) -> None:
        """New time level: the previous levels take the current values, the current ones ``solution``
        (the mixed Function of ``space``)."""
        x = solution.x.array
        if self.velocity_prev2 is not None:
            self.velocity_prev2.x.array[:] = self.velocity_prev.x.array
        self.velocity_prev.x.array[:] = self.velocity.x.array
        self.velocity.x.array[:] = x[space.dofs("velocity")]
        self.pressure.x.array[:] = x[space.dofs("pressure")]
        if self.micro_rotation is not None:
            self.micro_rotation_prev.x.array[:] = self.micro_rotation.x.array
            self.micro_rotation.x.array[:] = x[space.dofs("micro_rotation")]

    def rates(self) -> list:
        """The rates u̇^n, ω̇^n, ḋ^n the State keeps (generalised-α), in that order."""
        return [f for f in (self.velocity_rate, self.micro_rotation_rate, self.displacement_rate) if f is not None]

    def new_displacement_level(self) -> None:
        """d^{n−1} (and d^{n−2}) take the earlier levels before d^{n+1} is written into ``displacement``."""
        if self.displacement_prev2 is not None:
            self.displacement_prev2.x.array[:] = self.displacement_prev.x.array
        self.displacement_prev.x.array[:] = self.displacement.x.array

    def from_mixed(self, w, space) -> None:
        """Set u, p (and ω) from the mixed Function ``w`` of ``space`` (no new time level)."""
        self.velocity.x.array[:] = w.x.array[space.dofs("velocity")]
        self.pressure.x.array[:] = w.x.array[space.dofs("pressure")]
        if self.micro_rotation is not None:
            self.micro_rotation.x.array[:] = w.x.array[space.dofs("micro_rotation")]

    def to_mixed(self, w, space) -> None:
        """Write u, p (and ω) into the mixed Function ``w`` of ``space``."""
        w.x.array[space.dofs("velocity")] = self.velocity.x.array
        w.x.array[space.dofs("pressure")] = self.pressure.x.array
        if self.micro_rotation is not None:
            w.x.array[space.dofs("micro_rotation")] = self.micro_rotation.x.array

    def set_initial(self, problem: Problem, exact=None) -> None:
        """Rest (the solid with its initial velocity, the clamp at rest), or the exact solution at t = 0."""
        scene = problem.scene
        if problem.model.solid and any(scene.solid.initial_velocity):
            values = self.velocity.x.array.reshape(-1, problem.mesh.geometry.dim)
            given = np.zeros(values.shape[1])
            given[:] = scene.solid.initial_velocity  # one component per dimension (config/scene.py)
            values[problem.solid_velocity_dofs] = given
            fixed = dolfinx.fem.locate_dofs_topological(self.velocity.function_space,
                                                        problem.mesh.topology.dim - 1,
                                                        problem.facets(*problem.no_slip_boundaries()))
            values[fixed] = 0.0
        if exact is None:
            return
        self.velocity.interpolate(lambda x: exact.velocity(x, 0.0))
        if self.micro_rotation is not None:
            self.micro_rotation.interpolate(lambda x: exact.micro_rotation(x, 0.0))

    # ---------------------------------------------------------------------------- checkpoints
    def checkpoint(self) -> dict[str, np.ndarray]:
        """This rank's owned dofs keyed by their reference coordinates (+ t, step_count); copies, so the
        checkpoint does not follow the run on."""
        out = {"t": np.array(self.t), "step_count": np.array(self.step_count), "steps": self.steps.as_array()}
        for name, f in self.functions().items():
            n = f.function_space.dofmap.index_map.size_local
            bs = f.function_space.dofmap.index_map_bs
            out[name + ".x"] = self._reference[name][:n]
            out[name + ".v"] = f.x.array.reshape(-1, bs)[:n].copy()
        return out

    def restore(self, states: list[dict], scale_length: float) -> None:
        """Inverse of :meth:`checkpoint`, from the checkpoints of all ranks of the run that wrote them
        (``scale_length``: the largest coordinate of the mesh, to round the keys). InputError if they do
        not fit. The mesh itself is not moved here."""
        scale = 1e9 / max(1.0, scale_length)

        def keys(x):
            return [tuple(k) for k in np.rint(x * scale).astype(np.int64)]

        for name, f in self.functions().items():
            if any(name + ".v" not in s for s in states):
                raise InputError(f"--restart: the checkpoint has no {name!r} (another scene)")
            bs = f.function_space.dofmap.index_map_bs
            saved = dict(zip(keys(np.concatenate([s[name + ".x"] for s in states])),
                             np.concatenate([s[name + ".v"] for s in states]).reshape(-1, bs)))
            try:
                values = np.array([saved[k] for k in keys(self._reference[name])])
            except KeyError:
                raise InputError(f"--restart: checkpoint field {name!r} does not fit this mesh") from None
            f.x.array[:] = values.ravel()
        self.t, self.step_count = float(states[0]["t"]), int(states[0]["step_count"])
        if "steps" in states[0]:
            self.steps = StepSizes.from_array(states[0]["steps"])

    # ------------------------------------------------------------------------------ transfer
    def transfer_to(self, other: State,
                    interpolate: Callable[[dolfinx.fem.Function, dolfinx.fem.Function], None]) -> None:
        """Carry every field and history level to ``other``, a State of the same scene on another mesh
        (remeshing): ``interpolate(target, source)`` moves one Function between the meshes (e.g.
        dolfinx's non-matching interpolation). The mesh displacement levels are relative to each mesh's
        reference, so a transfer that re-references the mesh must reset them; that policy, and the
        choice of interpolation, belong to the remeshing and are not implemented here."""
        mine, theirs = self.functions(), other.functions()
        if set(mine) != set(theirs):
            raise ValueError(f"transfer between different states: {sorted(set(mine) ^ set(theirs))}")
        for name, f in mine.items():
            interpolate(theirs[name], f)
        other.t, other.step_count, other.steps = self.t, self.step_count, self.steps.copy()
        other.steps.transferred = float(self.step_count)  # the error estimate starts again (time_control.py)


class StepSizes:
    """The step sizes behind t^n and the step controller's memory (all plain floats, kept in checkpoints).

    ``last`` = t^n − t^{n−1}, ``before`` = t^{n−1} − t^{n−2} (0 until there are such levels); ``next``: the
    size the controller proposes for the coming step (0: the scene's ``time.dt``); ``error``: the last
    accepted step's scaled error estimate (0: none yet); ``rejected``: the steps rejected so far;
    ``smallest``/``largest``: the range of the accepted steps; ``transferred``: the step at which the fields
    were carried to another mesh (a remesh; 0: never): the error estimate's predictor does not reach back
    across that interpolation."""

    FIELDS = ("last", "before", "next", "error", "rejected", "smallest", "largest", "transferred")

    def __init__(self, values=None):
        for name, value in zip(self.FIELDS, values if values is not None else [0.0] * len(self.FIELDS)):
            setattr(self, name, float(value))

    def accepted(self, dt: float) -> None:
        """A step of size ``dt`` was taken."""
        self.before, self.last = self.last, dt
        self.smallest = dt if self.smallest == 0.0 else min(self.smallest, dt)
        self.largest = max(self.largest, dt)

    def as_array(self) -> np.ndarray:
        return np.array([getattr(self, name) for name in self.FIELDS])

    @classmethod
    def from_array(cls, values) -> StepSizes:
        return cls(list(np.asarray(values, dtype=float)) + [0.0] * (len(cls.FIELDS) - len(values)))

    def copy(self) -> StepSizes:
        return StepSizes(self.as_array())
