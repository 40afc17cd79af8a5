"""The problem of one scene, time-continuous: its fields, coefficients and the residual of seed eqs. (31)–(32).

``Problem`` knows *what* is solved (which fields and terms the scene needs, ρ/μ/f per cell, manufactured
sources) but not *how* time is discretised: :meth:`Problem.residual` takes the material accelerations as UFL
expressions. A time scheme (time_schemes/schemes.py) passes (α u − α h)/δt with trial functions and
splits the form; a steady solver passes grad(u) u with a Function and differentiates it.
"""

from __future__ import annotations

from dataclasses import dataclass
from collections.abc import Callable

import numpy as np
from mpi4py import MPI

from .. import compat
from ..physics import fluid, materials, solid
from ..tags import FACET_TAGS, FLUID, SOLID
from .data import weak_data
from .slip_normal import smoothed_normal
from .spaces import MixedSpace, mixed_space

import dolfinx
import ufl
from petsc4py import PETSc

WALL_TYPES = ("no_slip", "velocity", "slip")
"""The boundary types that prescribe the velocity (its normal part at least): the rest fix the pressure."""


@dataclass(frozen=True)
class Model:
    """Which fields and terms a scene needs ("model only what the scene requires")."""

    micro_rotation: bool
    solid: bool
    moving_mesh: bool

    @classmethod
    def from_scene(cls, scene) -> Model:
        solid = bool(scene.has_solid)
        return cls(micro_rotation=bool(scene.has_micropolar), solid=solid, moving_mesh=solid)

    def describe(self) -> str:
        fields = ["velocity (P2)"] + (["micro-rotation (P2)"] if self.micro_rotation else []) + ["pressure (P1)"]
        parts = ["fields: " + ", ".join(fields)]
        if not self.micro_rotation:
            parts.append("no micro-rotation (mu_r = lambda1 = lambda2 = 0)")
        parts.append("solid terms" if self.solid else "no solid terms")
        parts.append("moving mesh" if self.moving_mesh else "fixed mesh")
        return "; ".join(parts)


def ramp(t: float, ramp_time: float) -> float:
    """Turek–Hron inflow ramp (1 − cos(π t / T))/2 for t < T, then 1."""
    if ramp_time <= 0 or t >= ramp_time:
        return 1.0
    return 0.5 * (1.0 - np.cos(np.pi * t / ramp_time))


class Problem:
    """Fields, coefficients and residual forms of one scene on one mesh.

    Coefficients (UFL-ready, fixed for the run unless a source is time dependent): ``rho``, ``mu``,
    ``body_force`` (f), ``penalty`` (ζ), ``viscous_form``; with micro-rotation ``mu_r``, ``lambda1``,
    ``inertia`` (I), ``body_couple`` (g), in 3D ``lambda2`` (λ₂); with a solid ``mu_s`` (μ_s, the shear
    modulus) and for a compressible law ``lambda_s`` (λ_s); the others are None. ρ and f
    are DG0 fields (fluid/solid values) when the scene has a solid. :meth:`update_sources` sets the time-dependent ones.
    """

    def __init__(self, scene, mesh, cell_tags, facet_tags, space: MixedSpace | None = None, exact=None,
                 facet_ids: dict[str, int] | None = None):
        """``exact``: optional manufactured solution; its ``body_force(x, t)`` / ``body_couple(x, t)``,
        when present, replace f and g (or its ``sources(X)``: {"body_force": f, "body_couple": g} as UFL
        expressions of the spatial coordinate X, time independent; ``sources(X, t)`` with t the time
        Constant when ``exact.time_dependent``). ``facet_ids``: facet name -> tag of this
        mesh (default: the project's table, tags.FACET_TAGS; a file scene has its own, geometry.facet_ids)."""
        self.scene, self.mesh = scene, mesh
        self.cell_tags, self.facet_tags = cell_tags, facet_tags
        self.facet_ids = dict(facet_ids) if facet_ids is not None else dict(FACET_TAGS)
        self.model = Model.from_scene(scene)
        self.space = space if space is not None else mixed_space(mesh, self.model.micro_rotation)
        self.dx = ufl.dx(domain=mesh)
        self.dx_solid = ufl.dx(domain=mesh, subdomain_data=cell_tags)(SOLID) if self.model.solid else None
        self.solid_velocity_dofs = None  # the velocity (and displacement) dofs of the solid cells
        if self.model.solid:
            solid_cells = cell_tags.indices[cell_tags.values == SOLID]
            self.solid_velocity_dofs = dolfinx.fem.locate_dofs_topological(
                self.space.space("velocity"), mesh.topology.dim, solid_cells)
        # a compressible solid (solid.law): the pressure and the continuity equation live in the fluid cells
        # (``pressure_in_fluid``); its stress is rational in ∇d, integrated by a fixed rule (``dx_solid_law``)
        self.pressure_in_fluid = self.model.solid and scene.solid.compressible
        self.dx_continuity = self.dx
        self.dx_solid_law = None
        if self.pressure_in_fluid:
            self.dx_continuity = ufl.dx(domain=mesh, subdomain_data=cell_tags)(FLUID)
            self.dx_solid_law = ufl.dx(domain=mesh, subdomain_data=cell_tags,
                                       metadata={"quadrature_degree": 4})(SOLID)
        self._source_updates: list[Callable[[float], None]] = []
        self.time = self.constant(0.0)  # t of the time-dependent sources (update_sources)
        self._weak_data: dict = {}  # the tractions' and pressures' values by name (weak_data)
        self._coefficients(exact)
        # DG0: 1 in the fluid cells, 0 in the solid ones (a scene with a solid), else None
        self.fluid_cells = self.cellwise(1.0, 0.0) if self.model.solid else None
        self._pressure_penalty()

    # ------------------------------------------------------------------------------ coefficients
    def constant(self, value) -> dolfinx.fem.Constant:
        return dolfinx.fem.Constant(self.mesh, PETSc.ScalarType(value))

    def cellwise(self, fluid_value, solid_value, shape: tuple = ()) -> dolfinx.fem.Function:
        """A DG0 field: ``fluid_value`` on fluid cells, ``solid_value`` on solid cells."""
        Q = compat.function_space(self.mesh, "DG", 0, shape=shape or None)
        field = dolfinx.fem.Function(Q)
        values = field.x.array.reshape(-1, int(np.prod(shape)) if shape else 1)
        dofs = compat.cell_dofs(Q)[:, 0]
        tags = np.full(len(dofs), FLUID)
        ct = self.cell_tags
        inside = ct.indices < len(dofs)
        tags[ct.indices[inside]] = ct.values[inside]
        values[dofs[tags == FLUID]] = fluid_value
        values[dofs[tags == SOLID]] = solid_value
        field.x.scatter_forward()
        return field

    def _coefficients(self, exact):
        s, model = self.scene, self.model
        rho_f = s.fluid.rho if s.fluid is not None else 0.0
        self.mu = self.constant(s.fluid.mu if s.fluid is not None else 0.0)
        gdim = self.mesh.geometry.dim
        body = np.zeros(gdim, dtype=PETSc.ScalarType)
        if s.fluid is not None:
            body[:] = s.fluid.body_force  # one component per dimension (config/scene.py)
        self.mu_s = self.lambda_s = None
        if model.solid:
            self.rho = self.cellwise(rho_f, s.solid.rho)
            gravity = np.zeros(gdim)
            gravity[1] = -s.solid.rho * s.solid.gravity  # along −y in 2D and 3D
            self.body_force = self.cellwise(body, gravity, shape=(gdim,))
            if s.solid.gravity and s.solid.gravity_ramp_time > 0:
                fluid_part = self.cellwise(body, np.zeros(gdim), shape=(gdim,)).x.array.copy()
                full = self.body_force.x.array.copy()
                ramp_time, values = s.solid.gravity_ramp_time, self.body_force.x.array

                def gravity(t):
                    values[:] = fluid_part + ramp(t, ramp_time) * (full - fluid_part)

                self._source_updates.append(gravity)
            mu_s, lambda_s = s.solid.lame() if s.solid.compressible else (s.solid.mu_s, None)
            self.mu_s = self.constant(mu_s)
            self.lambda_s = self.constant(lambda_s) if lambda_s is not None else None
        else:
            self.rho = self.constant(rho_f)
            self.body_force = dolfinx.fem.Constant(self.mesh, body)
        self.viscous_form = s.fluid.viscous_form if s.fluid is not None else "laplacian"
        self.penalty = self.constant(0.0)  # set by _pressure_penalty once the boundary conditions are known
        self.mu_r = self.lambda1 = self.lambda2 = self.inertia = self.body_couple = None
        if model.micro_rotation:
            m = s.micropolar
            self.mu_r = self.constant(m.mu_r)
            self.lambda1 = self.constant(m.lambda1)
            self.inertia = self.constant(m.inertia)
            if gdim == 3:  # ω is a vector: λ₂ acts, the body couple has three components
                self.lambda2 = self.constant(m.lambda2)
                couple = m.body_couple if isinstance(m.body_couple, list) else [0.0, 0.0, m.body_couple]
                self.body_couple = dolfinx.fem.Constant(self.mesh, np.asarray(couple, dtype=PETSc.ScalarType))
            else:
                self.body_couple = self.constant(m.body_couple)
        sources = getattr(exact, "sources", None)
        if sources is not None:  # manufactured solutions: f and g as UFL expressions of x (and of the
            X = ufl.SpatialCoordinate(self.mesh)  # time constant t, update_sources, if they depend on it)
            given = sources(X, self.time) if getattr(exact, "time_dependent", False) else sources(X)
            for name, expression in given.items():
                setattr(self, name, expression)
        elif exact is not None:  # manufactured solutions: time-dependent f(x, t), g(x, t)
            for name, space in (("body_force", "velocity"), ("body_couple", "micro_rotation")):
                source = getattr(exact, name, None)
                if source is None or (space == "micro_rotation" and not model.micro_rotation):
                    continue
                field = dolfinx.fem.Function(self.space.space(space))
                self._source_updates.append(
                    lambda t, field=field, source=source: field.interpolate(lambda x: source(x, t)))
                setattr(self, name, field)

    def update_sources(self, t: float) -> None:
        """Set the time-dependent coefficients (gravity ramp, manufactured sources) to time ``t``."""
        self.time.value = t
        for data in self._weak_data.values():
            data.update(t)
        for update in self._source_updates:
            update(t)

    def pressure_determined(self) -> bool:
        """Whether the boundary fixes the pressure: some boundary where the velocity is not prescribed
        (do_nothing, traction, ...); False when no_slip, velocity and slip cover the whole boundary."""
        return any(bc.type not in WALL_TYPES for bc in self.conditions().values())

    def _pressure_penalty(self) -> None:
        """ζ of −ζ (p, p̃) (seed eq. 31): 0 when the boundary fixes the pressure; else the dimensionless
        ``solver.penalty`` over the viscosity μ + μ_r (p/μ ~ div u), in the fluid cells only (the solid's
        pressure scale is its modulus), to fix the pressure's constant."""
        s = self.scene
        if self.pressure_determined() or s.solver.penalty == 0:
            return
        viscosity = (s.fluid.mu if s.fluid is not None else 0.0) + (s.micropolar.mu_r if self.model.micro_rotation
                                                                    else 0.0)
        if viscosity <= 0:  # a solid-only scene: its shear modulus is the pressure scale
            viscosity = float(self.mu_s.value) if self.mu_s is not None else 1.0
        self.penalty.value = s.solver.penalty / viscosity
        if self.fluid_cells is not None and s.fluid is not None:
            self.penalty = self.penalty * self.fluid_cells

    # -------------------------------------------------------------------------------- boundaries
    def facets(self, *names: str) -> np.ndarray:
        """Local indices of the facets tagged with any of ``names`` (names the mesh lacks: none)."""
        ft = self.facet_tags
        return np.unique(ft.indices[np.isin(ft.values, self.facet_tag_values(*names))]).astype(np.int32)

    def facet_tag_values(self, *names: str) -> list[int]:
        """The tags of the facet groups ``names`` that this mesh's table has (``facet_ids``)."""
        return [self.facet_ids[n] for n in names if n in self.facet_ids]

    def conditions(self) -> dict:
        """The scene's boundary conditions by facet name (``Scene.conditions`` with this mesh's names)."""
        if self.scene.geometry.name != "file" or self.scene.boundaries is not None:
            return self.scene.conditions()
        if getattr(self, "_file_conditions", None) is None:  # collective once (the first call is __init__'s)
            from ..mesh.wall_gap import groups_inside

            inside = groups_inside(self.mesh, self.facet_tags, self.facet_ids)  # no condition by name there
            names = {name: tag for name, tag in self.facet_ids.items() if name not in inside}
            self._file_conditions = self.scene.conditions(names, self._inlet_extent())
        return self._file_conditions

    def _inlet_extent(self) -> dict:
        """{y0, height, z0, width}: the box of the ``inlet`` facets (the default inflow profile spans the
        inlet), of the whole mesh when there is no inlet."""
        from ..mesh.wall_gap import _facet_segments

        comm, x = self.mesh.comm, self.mesh.geometry.x
        inlet = self.facets("inlet") if "inlet" in self.facet_ids else np.zeros(0, dtype=np.int32)
        ends = _facet_segments(self.mesh, inlet) if len(inlet) else np.zeros((0, 2, 2))
        points = ends.reshape(-1, ends.shape[-1])
        if not comm.allreduce(len(points), op=MPI.SUM):
            points = x
        pad = np.zeros((len(points), 3))
        pad[:, :points.shape[1]] = points
        lo = [comm.allreduce(pad[:, i].min() if len(pad) else np.inf, op=MPI.MIN) for i in (1, 2)]
        hi = [comm.allreduce(pad[:, i].max() if len(pad) else -np.inf, op=MPI.MAX) for i in (1, 2)]
        return {"y0": lo[0], "height": hi[0] - lo[0], "z0": lo[1], "width": hi[1] - lo[1]}

    def wall_boundaries(self) -> tuple:
        """The names whose velocity is prescribed (no_slip, velocity, slip; the solid keeps its gap from
        them, mesh/wall_gap.py), whatever they are called."""
        return tuple(name for name, bc in self.conditions().items() if bc.type in WALL_TYPES)

    def no_slip_boundaries(self) -> tuple:
        """The names of type no_slip (``scene.conditions()``: the boundaries section or the preset's)."""
        return tuple(name for name, bc in self.conditions().items() if bc.type == "no_slip")

    def micro_rotation_boundaries(self, condition: str) -> tuple:
        """The names whose micro-rotation condition is ``condition`` (zero, half_curl, free)."""
        wall = self.scene.micropolar.wall_condition
        return tuple(name for name, bc in self.conditions().items() if bc.micro(wall) == condition)

    def half_curl_walls(self) -> tuple:
        """Boundaries where ω = ½ curl u is imposed weakly (micropolar.wall_condition: half_curl, or per
        boundary in a ``boundaries`` section)."""
        if not self.model.micro_rotation:
            return ()
        return self.micro_rotation_boundaries("half_curl")

    def traction(self, v) -> ufl.Form | None:
        """−∫ g·v ds over the boundaries of type traction (g their ``value``, expressions of x and t) and
        +∫ p̂ n·v ds over those of type pressure (the natural condition σn = −p̂ n, p̂ their ``value``), or
        None. g and p̂: their expressions interpolated into P2 (problem/data.py's weak_data)."""
        named = [(name, bc) for name, bc in self.conditions().items() if bc.type in ("traction", "pressure")]
        if not named:
            return None
        ds = ufl.Measure("ds", domain=self.mesh, subdomain_data=self.facet_tags)
        n = ufl.FacetNormal(self.mesh)
        form = None
        for name, bc in named:
            values = weak_data(self, name).g
            g = -values * n if bc.type == "pressure" else values
            term = -ufl.inner(g, v) * ds(self.facet_ids[name])
            form = term if form is None else form + term
        return form

    def slip_boundaries(self) -> tuple:
        """The names of type slip."""
        return tuple(name for name, bc in self.conditions().items() if bc.type == "slip")

    def slip(self, u, p, v, q) -> ufl.Form | None:
        """The Nitsche terms of u·n = 0 on the boundaries of type slip (fluid.nitsche_slip; the viscosity of
        the viscous form, μ + μ_r with micro-rotation), or None."""
        names = self.slip_boundaries()
        if not names:
            return None
        viscosity = self.mu + self.mu_r if self.model.micro_rotation else self.mu
        ds = ufl.Measure("ds", domain=self.mesh, subdomain_data=self.facet_tags)(tuple(self.facet_tag_values(*names)))
        return fluid.nitsche_slip(u, p, v, q, viscosity=viscosity, viscous_form=self.viscous_form, ds=ds,
                                  mesh=self.mesh, normal=smoothed_normal(self.mesh, ds))

    # ------------------------------------------------------------------------------------ forms
    def split(self, w) -> tuple:
        """(u, p, ω or None) of a mixed Function, TrialFunction or TestFunction (or their ``ufl.split``)."""
        parts = w if isinstance(w, (tuple, list)) else ufl.split(w)
        sp = self.space
        omega = parts[sp.index("micro_rotation")] if self.model.micro_rotation else None
        return parts[sp.index("velocity")], parts[sp.index("pressure")], omega

    def residual(self, trial, test, *, acceleration, micro_acceleration=None, dx_inertia=None,
                 at=None, divergence=None) -> ufl.Form:
        """Seed eq. (31) (fluid part, continuity) + eq. (32) + weak wall conditions, as one residual.

        ``trial``/``test``: mixed (Trial)Functions or their splits (see :meth:`split`); ``acceleration``
        (and ``micro_acceleration`` with micro-rotation) the material derivatives of u (and ω) as UFL
        expressions; ``dx_inertia`` the measure of the inertia terms (default dx); ``at``: the (u, ω) the
        viscous, couple and wall terms are evaluated at (generalised-α: u^{n+α_f}), default the trial's;
        the continuity equation is ``divergence`` = 0 (default: div of the trial's u). The solid terms are apart
        (:meth:`solid_residual`): they depend on how the displacement is discretised.
        """
        (u, p, omega), (v, q, tau) = self.split(trial), self.split(test)
        dx = self.dx
        continuity = fluid.continuity_residual(u, p, q, penalty=self.penalty, dx=self.dx_continuity,
                                               divergence=divergence)
        if self.pressure_in_fluid:  # a compressible solid: the pressure acts in the fluid only
            p = self.fluid_cells * p
        if at is not None:
            u, omega = at
        F = fluid.momentum_residual(u, p, v, rho=self.rho, acceleration=acceleration, mu=self.mu,
                                    body_force=self.body_force, dx=dx, viscous_form=self.viscous_form,
                                    dx_inertia=dx_inertia, omega=omega, mu_r=self.mu_r) + continuity
        traction = self.traction(v)
        if traction is not None:
            F = F + traction
        slip = self.slip(u, p, v, q)  # u: the stresses' velocity (``at``)
        if slip is not None:
            F = F + slip
        if self.model.micro_rotation:
            F = F + fluid.micro_rotation_residual(u, omega, tau, rho=self.rho, inertia=self.inertia,
                                                  acceleration=micro_acceleration, mu_r=self.mu_r,
                                                  lambda1=self.lambda1, body_couple=self.body_couple, dx=dx,
                                                  dx_inertia=dx_inertia, lambda2=self.lambda2)
            walls = self.half_curl_walls()
            if walls:
                ds = ufl.Measure("ds", domain=self.mesh, subdomain_data=self.facet_tags)
                F = F + fluid.half_curl_wall(u, omega, tau, lambda1=self.lambda1,
                                             ds=ds(tuple(self.facet_tag_values(*walls))), mesh=self.mesh)
        return F

    def solid_pressure_condition(self, space: MixedSpace):
        """A compressible solid: p = 0 at the pressure dofs of solid cells that no fluid cell shares (the
        pressure lives in the fluid; the dofs on the interface keep the fluid's continuity equation), as a
        Dirichlet condition on ``space``; None for the incompressible law."""
        if not (self.model.solid and self.scene.solid.compressible):
            return None
        sub, Q = space.sub("pressure"), space.space("pressure")
        ct, tdim = self.cell_tags, self.mesh.topology.dim
        in_solid = dolfinx.fem.locate_dofs_topological((sub, Q), tdim, ct.indices[ct.values == SOLID])
        in_fluid = dolfinx.fem.locate_dofs_topological((sub, Q), tdim, ct.indices[ct.values == FLUID])
        own = ~np.isin(in_solid[0], in_fluid[0])
        return dolfinx.fem.dirichletbc(dolfinx.fem.Function(Q), [in_solid[0][own], in_solid[1][own]], sub)

    def solid_residual(self, trial, test, d_star, dt, d_predicted=None, step=None) -> ufl.Form:
        """The solid terms of seed eq. (31), linearised around ``d_star`` with d = d* + ``dt`` u (eq. 28; a
        compressible law: physics/materials.py), or around ``d_predicted`` when given (a corrector pass,
        ``time.corrector_passes``), plus (the incompressible law) the volume
        correction when ``solid.volume_correction``, undone over max(``step``, τ) (``step`` default ``dt``;
        generalised-α passes δt: its ``dt`` is not the step's)."""
        (u, _, _), (v, q, _) = self.split(trial), self.split(test)
        law = self.scene.solid.law
        if self.scene.solid.compressible:  # σ(d) = J⁻¹FSFᵀ linearised around d* (or the prediction)
            return materials.linearised_stress_residual(law, u, v, d_star, mu=self.mu_s, lam=self.lambda_s, dt=dt,
                                                        dx_solid=self.dx_solid_law, around=d_predicted)
        if d_predicted is not None:
            F = solid.corrector_stress_residual(u, v, d_star, d_predicted, mu_s=self.mu_s, dt=dt,
                                                dx_solid=self.dx_solid)
        else:
            F = solid.linearised_stress_residual(u, v, d_star, mu_s=self.mu_s, dt=dt, dx_solid=self.dx_solid)
        if self.scene.solid.corrects_volume:
            tau = self.scene.solid.volume_correction_time
            step = dt if step is None else step
            rate_time = ufl.max_value(step, self.constant(tau)) if tau > 0 else step
            F = F + solid.volume_correction_residual(q, d_star, dt=rate_time, dx_solid=self.dx_solid)
        return F

    def num_dofs(self) -> dict:
        """Global number of dofs per field and in total."""
        out = {}
        for name in self.space.names:
            V = self.space.space(name)
            out[name] = V.dofmap.index_map.size_global * V.dofmap.index_map_bs
        out["total"] = sum(out.values())
        return out
