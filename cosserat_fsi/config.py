"""Scene configuration: the typed, validated form of ``configs/<case>.yaml``.

``load_scene(path, overrides)`` reads the YAML file, applies ``--set dotted.key=value`` overrides,
validates it against the schema of docs/architecture.md and returns a :class:`Scene`. Every problem
is raised as one :class:`~cosserat_fsi.errors.InputError` line ``"<dotted.key>: <problem>"``.

This module must stay light: no dolfinx, petsc4py or gmsh imports. It is above 350 lines on purpose: the
schema is one file whose section docstrings are the reference of the YAML keys, next to the code that turns
pydantic's errors into the one-line messages. (What each geometry accepts lives in geometry/, one model each.)
"""

from __future__ import annotations

import difflib
import re
from pathlib import Path
from typing import Annotated, Any, Literal, get_args, get_origin
from collections.abc import Sequence

import yaml
import numpy as np
from pydantic import (BaseModel, BeforeValidator, ConfigDict, Field, TypeAdapter, ValidationError, ValidationInfo,
                      field_validator, model_validator)

from cosserat_fsi.errors import InputError
from cosserat_fsi.expressions import ExpressionError, parse as parse_expression
from cosserat_fsi.safe_yaml import YamlLoader, describe_yaml_error, read_text_file, yaml_load  # noqa: F401
from cosserat_fsi.geometry import GEOMETRIES, MODELS, Geometry, GeometryBase

GEOMETRY_OF_BENCHMARK = {
    "schaefer_turek_2d1": ("schaefer_turek", None),
    "schaefer_turek_2d2": ("schaefer_turek", None),
    "schaefer_turek_3d1z": ("schaefer_turek_3d", None),
    "turek_hron_cfd1": ("turek_hron", "rigid"),
    "turek_hron_cfd2": ("turek_hron", "rigid"),
    "turek_hron_cfd3": ("turek_hron", "rigid"),
    "turek_hron_csm1": ("flag", None),
    "turek_hron_csm2": ("flag", None),
    "turek_hron_fsi1": ("turek_hron", "solid"),
    "turek_hron_fsi2": ("turek_hron", "solid"),
    "turek_hron_fsi3": ("turek_hron", "solid"),
    "seed_fsi3": ("turek_hron", "solid"),
    "micropolar_poiseuille": ("channel", None),
    "micropolar_taylor_green": ("square", None),
}
"""Benchmark name -> (required geometry.name, required geometry.flag or None)."""

Benchmark = Literal[
    "schaefer_turek_2d1", "schaefer_turek_2d2", "schaefer_turek_3d1z",
    "turek_hron_cfd1", "turek_hron_cfd2", "turek_hron_cfd3",
    "turek_hron_csm1", "turek_hron_csm2",
    "turek_hron_fsi1", "turek_hron_fsi2", "turek_hron_fsi3",
    "seed_fsi3",
    "micropolar_poiseuille", "micropolar_taylor_green",
]
MAX_STEPS = 100_000_000
"""Most time steps a scene may ask for (t_end / dt): beyond it a run would not end in a lifetime."""
MAX_COUNT = 1_000_000_000
"""Upper bound of every step-count setting (output.every, output.checkpoint_every, ...)."""


# --------------------------------------------------------------------------------------------- YAML
# yaml_load / YamlLoader live in safe_yaml (bounded, merge keys, one-line errors); re-exported here.

# ------------------------------------------------------------------------------------------- schema

class _Section(BaseModel):
    """Base of every section: unknown keys, loose types (a string for a number) and non-finite numbers
    (``.inf``, ``.nan``, ``1e999``) are errors: one setting for every float of every section."""

    model_config = ConfigDict(extra="forbid", strict=True, allow_inf_nan=False)


PositiveFloat = Annotated[float, Field(gt=0)]
NonNegFloat = Annotated[float, Field(ge=0)]


class Fluid(_Section):
    """Newtonian part of the fluid: density, dynamic viscosity, body force per unit volume (N/m³).

    ``viscous_form``: ``laplacian`` (μ ∇u:∇ũ; its natural outflow condition is the benchmarks' do-nothing
    μ ∂u/∂n − p n = 0) or ``symmetric`` (the seed's ½ μ Du:Dũ; natural condition (μ Du − p I) n = 0).
    Both give the same equations inside the domain when div u = 0.
    """

    rho: PositiveFloat
    mu: PositiveFloat
    body_force: list[float] = Field(default=[0.0, 0.0], min_length=2, max_length=3)  # one per dimension
    viscous_form: Literal["laplacian", "symmetric"] = "laplacian"


class Micropolar(_Section):
    """Cosserat (micropolar) coefficients; all zero gives a Newtonian fluid.

    ``nodal_characteristics``: interpolate ω^n∘X^n at the P2 nodes even when u's history is evaluated at
    the quadrature points (``time.characteristics: quadrature``). A weakly damped ω (large micro-inertia,
    e.g. I = 1e-2 m² with μ_r = 0.1) makes the quadrature-point evaluation unstable (docs/seed_reproduction.md);
    the nodal interpolation is stable, at the price of more numerical diffusion of ω."""

    mu_r: NonNegFloat = 0.0
    lambda1: NonNegFloat = 0.0
    lambda2: NonNegFloat = 0.0
    inertia: NonNegFloat = 0.0
    body_couple: float | Annotated[list[float], Field(min_length=3, max_length=3)] = 0.0  # 3D: vector (a number: g_z)
    wall_condition: Literal["zero", "half_curl"] = "zero"
    nodal_characteristics: bool = False


class Remesh(_Section):
    """Automatic remeshing (issue 13): gmsh meshes the fluid anew around the current solid when the minimum
    cell quality 4√3|K|/Σ|e|² falls below ``quality``; ``max_count`` bounds the number of remeshes."""

    quality: float = Field(gt=0, lt=1)
    max_count: int = Field(default=1000, ge=1)


class MeshMotionSettings(_Section):
    """How the fluid mesh follows the solid (scheme/mesh_motion.py; measured in docs/performance.md).

    ``method``: ``biharmonic`` (default: carries a bent flag furthest), ``elastic`` (linear elasticity) or
    ``harmonic`` (the seed's stiffened Laplace extension). ``stiffness_exponent`` χ: the operator is
    weighted by |K|^−χ so that small cells deform less; default the measured best of the method
    (harmonic 1, elastic 1, biharmonic 0). ``poisson_ratio`` ν of the elastic extension. ``wall_gap``: the
    run stops (exit 3) when the solid comes closer than this to the ``walls`` (default: a quarter of the
    shortest wall facet). ``remesh``: remesh the fluid when the minimum cell quality falls below
    ``remesh.quality`` (off by default; scheme/remesh.py).
    """

    method: Literal["harmonic", "elastic", "biharmonic"] = "biharmonic"
    stiffness_exponent: float | None = Field(default=None, ge=0, le=4)
    poisson_ratio: float = Field(default=0.0, gt=-1, lt=0.5)
    wall_gap: PositiveFloat | None = None
    remesh: Remesh | None = None

    def options(self) -> dict:
        """Keyword arguments of scheme.mesh_motion.MeshMotion."""
        exponent = {"harmonic": 1.0, "elastic": 1.0, "biharmonic": 0.0}[self.method]
        return {"method": self.method, "poisson_ratio": self.poisson_ratio, "wall_gap": self.wall_gap,
                "stiffness_exponent": exponent if self.stiffness_exponent is None else self.stiffness_exponent}


class Solid(_Section):
    """Incompressible Mooney–Rivlin body (seed eqs. 6–14).

    ``mu_s``: shear modulus (Pa); Cauchy stress −pI + μ_s (Dd − ∇d∇dᵀ), i.e. the seed's 2c₁ = μ_s
    (seed c₁ = 10⁶ ↔ mu_s = 2·10⁶, the Turek–Hron FSI3 value). ``c2``: the second Mooney–Rivlin constant;
    in 2D with det F = 1 it only shifts the pressure (seed eq. 14), so it does not change the motion.
    ``gravity``: acceleration (m/s²) in −y on the solid, switched on with the cosine ramp over
    ``gravity_ramp_time`` (a slow ramp reaches a static deflection without exciting the free
    oscillation). ``volume_correction``: make the next velocity undo the area drift J ≠ 1 that the
    seed's explicit node update x += δt u accumulates (on by default; off is the seed's scheme).
    ``volume_correction_time`` (s): undo it over max(δt/α, this) instead of in one step (0: one step, as
    before); at small δt the one-step correction feeds back on itself (docs/performance.md, issue 12).
    The correction is part of the discrete problem: for a δt study set this ≥ the largest δt/α, so that
    every run solves the same one (with the one-step correction FSI3's frequency drifts at first order
    in δt; docs/performance.md, issue 12, session 17).
    ``initial_velocity``: uniform initial velocity
    of the solid (m/s), e.g. to start a free vibration. ``mesh_motion``: see :class:`MeshMotionSettings`.
    """

    rho: PositiveFloat
    mu_s: PositiveFloat
    c2: NonNegFloat = 0.0
    gravity: float = 0.0
    gravity_ramp_time: NonNegFloat = 0.0
    volume_correction: bool = True
    volume_correction_time: NonNegFloat = 0.0
    initial_velocity: list[float] = Field(default=[0.0, 0.0], min_length=2, max_length=3)  # 3 in 3D
    mesh_motion: MeshMotionSettings = Field(default_factory=MeshMotionSettings)


class Inflow(_Section):
    """Inlet velocity: mean speed, cosine ramp duration, profile.

    ``asymmetry`` ε: during the ramp only, the inlet profile is tilted by ε sin(π t/T) (2y/H − 1), a
    perturbation that is gone once the inflow is established. It starts the vortex shedding of an
    unstable steady wake within seconds; without it a direct solver's round-off takes ~10 s of simulated
    time to grow. Results after the transient do not depend on it.
    """

    u_mean: NonNegFloat
    ramp_time: NonNegFloat = 0.0
    profile: Literal["parabolic", "uniform"] = "parabolic"
    asymmetry: float = Field(default=0.0, ge=-0.5, le=0.5)


class Time(_Section):
    """Time step, end time and time-stepping scheme.

    ``characteristics``: where u^n∘X^n is evaluated — at the quadrature points of the inertia term
    (default; as FreeFEM's ``convect``) or at the P2 nodes and interpolated (cheaper per step, but each
    interpolation damps the flow: at small δt it suppresses vortex shedding). ``quadrature_degree``: the
    rule for the inertia term. Quadrature of u^n∘X^n, which is not a polynomial on a cell, can make the
    Lagrange–Galerkin scheme unstable at Courant numbers below one (Morton, Priestley & Süli 1988): with
    degree 4 or 5 the steady CFD2 wake turned noisy at δt = 0.0025; degree 8 (16 points) kept it steady
    and within 0.5 % of the reference.

    ``scheme: generalized_alpha`` (with ``convection: ale``): the generalised-α method of Jansen, Whiting
    & Hulbert (2000) on the nodal values — second order, one linear solve per step, with the damping of
    the unresolved modes set by ``rho_infinity`` (ρ∞, default 0.5; the resolved ones are barely damped,
    unlike BDF2's 4.5 % per period at ωδt = 1/3). ρ∞ = 1 (no damping) is unstable for a solid: the
    linearised stress leaves a part of the solid's stiffest modes explicit (scheme/stepper.py). For flows:
    CFD3 at δt = 0.002 +1.8 % with one solve per step. For FSI with ``corrector_passes: 2`` (without
    passes FSI3 diverges at ρ∞ = 0.5; one pass is far from their fixed point): FSI3 at δt = 0.01, where
    BDF2 loses half the amplitude, +2.7 % / +0.49 % on the seed mesh (docs/performance.md, issue 12,
    session 16).

    ``scheme: steady`` solves the steady equations (no time derivative) by Newton's method
    (cosserat_fsi/scheme/steady.py); ``dt`` and ``t_end`` are then not used (one "step" at t = 1).
    ``newton_*``: its iteration limit, relative residual tolerance, and the continuation steps (fractions
    of the convection, or of the load for a solid) tried one after the other when Newton from the
    Stokes/unloaded state does not converge.

    ``solid_linearisation``: how the solid stress at t^{n+1} is linearised around d* on the configuration
    the step is solved on — the seed's eq. (28) (``seed``), or ``consistent``: with the change of
    configuration over the step and the initial-stress terms (physics/solid.py, issue 12).
    ``solve_configuration`` (BDF2 on a moving mesh): the mesh a step is solved on, the BDF2 base
    X + (4D^n − D^{n−1})/3 (``bdf_base``) or the extrapolation X + 2D^n − D^{n−1} of Ω^{n+1}
    (``extrapolated``: the solid's gradients and the interface of t^{n+1} to O(δt²), scheme/stepper.py).
    ``corrector_passes`` (BDF2 with a solid): after the solve, move the mesh to the predicted Ω^{n+1},
    back-track again from there, linearise the solid stress around the predicted d^{n+1} and solve again
    (the kept factorisation preconditions it); 0 = one solve per step. With ``convection: ale``: re-solve
    with the convection linearised around the last solution instead (Picard), on any BDF2 scene. With
    ``scheme: generalized_alpha`` and a moving solid: re-place the mesh at the predicted t^{n+α_f}, linearise
    the solid stress around the predicted d^{n+α_f} and the convection around the predicted u^{n+α_f}, and
    solve again (without a solid: Picard as with BDF2).
    ``foot`` (BDF2): the feet of the characteristics as straight lines x − δt u*, x − 2δt u* (``euler``)
    or by a midpoint (RK2) step with the velocity at the middle of each interval (``midpoint``:
    scheme/histories.py ``bdf2_feet``; three more point evaluations per point).
    ``convection``: how the material derivative of the fluid is discretised — along the characteristics
    (``characteristics``: the seed's §5, u^n∘X at the feet, no convection in the matrix) or along the moving
    mesh's nodes (``ale``: BDF of the nodal values plus the convection ((u* − w*)·∇)u^{n+1} in the matrix,
    u* and w* extrapolated to t^{n+1}, w* the mesh motion's extension of u*; none in solid cells, where
    the mesh is the material). ``ale`` needs no back-tracking; the matrix changes every step; BDF2 on a
    moving mesh then always solves on the extrapolated configuration (the nodes' places at t^{n+1}).
    """

    dt: PositiveFloat | None = None
    t_end: PositiveFloat | None = None
    scheme: Literal["characteristics1", "characteristics2", "generalized_alpha", "steady"] = "characteristics1"
    rho_infinity: float | None = Field(default=None, ge=0.0, le=1.0)
    characteristics: Literal["quadrature", "nodes"] = "quadrature"
    quadrature_degree: int = Field(default=8, ge=2, le=12)
    newton_max_iterations: int = Field(default=25, ge=1, le=1000)
    newton_rtol: float = Field(default=1e-10, gt=0, lt=1)
    newton_continuation: list[Annotated[float, Field(gt=0, le=1)]] = Field(default_factory=lambda: [0.25, 0.5, 1.0])
    solid_linearisation: Literal["seed", "consistent"] = "seed"
    solve_configuration: Literal["bdf_base", "extrapolated"] = "bdf_base"
    corrector_passes: int = Field(default=0, ge=0, le=5)
    foot: Literal["euler", "midpoint"] = "euler"
    convection: Literal["characteristics", "ale"] = "characteristics"

    @model_validator(mode="after")
    def _steady_defaults(self):
        if self.scheme == "generalized_alpha" and self.rho_infinity is None:
            self.rho_infinity = 0.5
        if self.scheme == "steady":
            self.dt = 1.0 if self.dt is None else self.dt
            self.t_end = self.dt if self.t_end is None else self.t_end
        return self


class Solver(_Section):
    """Linear solver: pressure penalty, MUMPS fill-reducing ordering, and LU reuse on moving meshes; or
    ``type: iterative``: FGMRES to ``krylov_rtol`` with a Schur fieldsplit preconditioner, ``amg`` on the
    velocity block (scheme/linear_solver.py).

    ``reuse_factorization``: when the matrix changes every step, keep the last MUMPS factorisation as the
    preconditioner of a GMRES solve (relative tolerance ``krylov_rtol``) and refactorise only when GMRES
    needs more than ``max_krylov_iterations`` iterations. Default (unset): on for the characteristics on a
    moving mesh (the geometry changes a little per step), off with ``time.convection: ale``, whose
    convection changes the matrix more: measured on FSI3 L1 at δt = 0.005 in the developed flow, GMRES
    needed 10.7 iterations per step and refactorised on 46 % of the steps anyway, a solve phase of 0.129 s
    per step against 0.062 s for a numeric refactorisation every step (docs/performance.md).
    """

    penalty: float = Field(default=1e-10, ge=0)
    mumps_ordering: Literal["metis", "pord", "amd", "auto"] = "auto"
    reuse_factorization: bool | None = None
    krylov_rtol: float = Field(default=1e-10, gt=0, lt=1)
    max_krylov_iterations: int = Field(default=12, ge=1, le=10_000)
    type: Literal["direct", "iterative"] = "direct"
    amg: Literal["gamg", "hypre"] = "gamg"  # the velocity block's multigrid (iterative); hypre: Debian PETSc only
    max_iterations: int = Field(default=1000, ge=1, le=100_000)  # FGMRES iterations (iterative)

    def reuses_factorization(self, moving_mesh: bool, convection: str) -> bool:
        """Whether the kept LU preconditions GMRES (``reuse_factorization``, or its default for the scheme)."""
        if self.reuse_factorization is not None:
            return self.reuse_factorization and (moving_mesh or convection == "ale")
        return moving_mesh and convection != "ale"


def _expression(value: Any) -> Any:
    """A number or an expression string in the grammar of cosserat_fsi/expressions.py (kept as given)."""
    try:
        parse_expression(value)
    except ExpressionError as exc:
        raise ValueError(str(exc)) from None
    return value


Expr = Annotated[Any, BeforeValidator(_expression)]


class BoundaryCondition(_Section):
    """The condition on one named facet group of a file scene (``boundaries: {NAME: {...}}``).

    ``type``: ``no_slip`` (u = 0), ``velocity`` (u = ``value``), ``do_nothing`` (the natural condition of
    the viscous form: μ ∂u/∂n − p n = 0 for ``laplacian``), ``traction`` (that natural condition = ``value``),
    ``slip`` (u·n = 0 on a straight boundary along x or y). ``value``: [EXPR, EXPR], each a number or a
    string in x, y, z, t (cosserat_fsi/expressions.py), e.g. the Turek–Hron inflow with its cosine ramp.
    ``micro_rotation`` (with micropolar terms): ``zero`` (ω = 0), ``half_curl`` (ω = ½ curl u, weakly) or
    ``free`` (natural); default: ``micropolar.wall_condition`` on no-slip boundaries, ``free`` elsewhere.
    """

    type: Literal["no_slip", "velocity", "do_nothing", "traction", "slip"]
    value: list[Expr] | None = Field(default=None, validate_default=True)
    micro_rotation: Literal["zero", "half_curl", "free"] | None = None

    @field_validator("value")
    @classmethod
    def _value(cls, value: Any, info: ValidationInfo) -> Any:
        kind = info.data.get("type")
        if kind in ("velocity", "traction"):
            if value is None:
                raise ValueError(f"missing key (type {kind} needs value: [EXPR, EXPR])")
            if len(value) not in (2, 3):
                raise ValueError(f"must have 2 components, x and y (3 in 3D; got {len(value)})")
        elif value is not None and kind is not None:
            raise ValueError(f"not used for type {kind} (only velocity and traction take a value)")
        return value

    def micro(self, wall_condition: str) -> str:
        """The micro-rotation condition here: given, or the default for this type."""
        if self.micro_rotation is not None:
            return self.micro_rotation
        return wall_condition if self.type == "no_slip" else "free"

    def expressions(self) -> list:
        """The parsed components of ``value``."""
        return [parse_expression(v) for v in self.value or ()]


Point = Annotated[list[float], Field(min_length=2, max_length=2)]


class ObservableSet(_Section):
    """What a file scene reports by name (``observables``), besides energies and flow rate.

    ``forces``: named boundaries whose force on the body (drag, lift: residual and surface forms) is
    reported; ``wetted_solid``: add the fluid–solid interface. ``points``: probes fixed in space
    (columns ``u_NAME``, ``v_NAME``, ``p_NAME``, with micropolar terms also ``omega_NAME``);
    ``solid_points``: material points of the solid, the solid node nearest to the given reference position,
    moving with it (``ux_NAME``, ``uy_NAME``: its displacement).
    """

    forces: list[str] = Field(default_factory=list)
    wetted_solid: bool = False
    points: dict[str, Point] = Field(default_factory=dict)
    solid_points: dict[str, Point] = Field(default_factory=dict)


class Output(_Section):
    """Output: field-output interval in steps, whether to write fields, progress bar, checkpoint interval."""

    every: int = Field(default=10, ge=1, le=MAX_COUNT)
    fields: bool = True
    progress: bool = True
    # steps between checkpoints; 0: only on SIGTERM/SIGINT
    checkpoint_every: int = Field(default=1000, ge=0, le=MAX_COUNT)


class Scene(_Section):
    """A complete, validated scene (one run)."""

    name: str = "scene"
    benchmark: Benchmark | None = None
    geometry: Geometry
    fluid: Fluid | None = None
    micropolar: Micropolar = Field(default_factory=Micropolar)
    solid: Solid | None = None
    inflow: Inflow | None = None
    boundaries: dict[str, BoundaryCondition] | None = None
    observables: ObservableSet | None = None
    time: Time
    solver: Solver = Field(default_factory=Solver)
    output: Output = Field(default_factory=Output)

    @field_validator("name")
    @classmethod
    def _name(cls, value):
        if not re.fullmatch(r"[A-Za-z0-9_][A-Za-z0-9_.-]{0,99}", value):
            raise ValueError(f"must use only letters, digits, '_', '-', '.' (1 to 100 of them; got {_short(value)})")
        return value

    @model_validator(mode="after")
    def _cross_checks(self):
        """Checks across sections; messages carry their full dotted key. (What each geometry accepts is
        its own model's business: cosserat_fsi/geometry/.)"""
        geo, time = self.geometry, self.time
        for key in ("dt", "t_end"):
            if getattr(time, key) is None:
                raise ValueError(f"time.{key}: field required (for scheme {time.scheme})")
        if time.solid_linearisation == "consistent" and time.solve_configuration == "extrapolated":
            raise ValueError("time.solid_linearisation: 'consistent' linearises around the BDF2 base "
                             "configuration; with time.solve_configuration 'extrapolated' use 'seed'")
        if time.scheme == "generalized_alpha" and time.convection != "ale":
            raise ValueError("time.scheme: 'generalized_alpha' needs time.convection 'ale' (got "
                             f"{time.convection!r})")
        if time.rho_infinity is not None and time.scheme != "generalized_alpha":
            raise ValueError("time.rho_infinity: only used with time.scheme 'generalized_alpha' "
                             f"(got scheme {time.scheme})")
        if time.corrector_passes and not (
                (time.scheme == "characteristics2" and (self.has_solid or time.convection == "ale"))
                or time.scheme == "generalized_alpha"):
            got = f"{time.scheme}{'' if self.has_solid else ', no solid'}"
            raise ValueError("time.corrector_passes: needs time.scheme 'characteristics2' and a solid or "
                             f"time.convection 'ale', or time.scheme 'generalized_alpha' (got scheme {got})")
        if time.foot != "euler" and time.scheme != "characteristics2":
            raise ValueError(f"time.foot: {time.foot!r} needs time.scheme 'characteristics2' (got {time.scheme})")
        if time.convection == "ale":
            if time.scheme == "steady":
                raise ValueError("time.convection: 'ale' needs a time-dependent scheme (got steady)")
            for key, default in (("foot", "euler"), ("characteristics", "quadrature"),
                                 ("solid_linearisation", "seed")):
                if getattr(time, key) != default:
                    raise ValueError(f"time.{key}: not used with time.convection 'ale' (got {getattr(time, key)!r})")
        if time.scheme != "steady" and time.t_end < time.dt:
            raise ValueError(f"time.t_end: must be >= time.dt (got {time.t_end!r} < {time.dt!r})")
        if not time.t_end / time.dt <= MAX_STEPS:  # also catches an overflow to inf
            raise ValueError(f"time.dt: time.t_end / time.dt must be at most {MAX_STEPS:,} steps "
                             f"(got {time.t_end!r} / {time.dt!r})")
        if geo.FLUID and self.fluid is None:
            raise ValueError(f"fluid: missing section (required for geometry {geo.name})")
        if not geo.FLUID and self.fluid is not None:
            raise ValueError(f"fluid: not used for geometry {geo.name} (a solid-only scene)")
        flag = getattr(geo, "flag", None)
        if geo.solid_cells and self.solid is None:
            hint = ("geometry.flag is solid; use geometry.flag: rigid for a fluid-only run" if flag == "solid"
                    else f"required for geometry {geo.name}")
            raise ValueError(f"solid: missing section ({hint})")
        if self.observables is not None:
            if geo.name != "file":
                raise ValueError(f"observables: only for geometry file (geometry {geo.name} has its own)")
            if self.observables.solid_points and self.solid is None:
                raise ValueError("observables.solid_points: the scene has no solid section")
        if self.boundaries is not None:
            if geo.name != "file":
                raise ValueError(f"boundaries: only for geometry file (geometry {geo.name} sets its own)")
            if self.inflow is not None:
                raise ValueError("inflow: not used with a boundaries section (give the inlet's velocity as "
                                 "boundaries.NAME: {type: velocity, value: [EXPR, EXPR]})")
            for name, bc in self.boundaries.items():
                if bc.value is not None and len(bc.value) != geo.DIM:
                    raise ValueError(f"boundaries.{name}.value: must have {geo.DIM} components for a {geo.DIM}D "
                                     f"mesh (got {len(bc.value)})")
                if bc.micro_rotation is not None and not self.has_micropolar:
                    raise ValueError(f"boundaries.{name}.micro_rotation: only with micropolar terms "
                                     "(micropolar.mu_r or lambda1 > 0)")
        if geo.INFLOW and self.inflow is None:
            raise ValueError(f"inflow: missing section (required for geometry {geo.name})")
        if self.benchmark is not None:
            need_name, need_flag = GEOMETRY_OF_BENCHMARK[self.benchmark]
            if geo.name != need_name:
                raise ValueError(f"benchmark: {self.benchmark} needs geometry.name {need_name} "
                                 f"(got {geo.name!r})")
            if need_flag is not None and flag != need_flag:
                raise ValueError(f"benchmark: {self.benchmark} needs geometry.flag {need_flag} (got {flag!r})")
        m = self.micropolar
        dim = geo.DIM
        if self.fluid is not None and len(self.fluid.body_force) != dim and (
                dim == 2 or "body_force" in self.fluid.model_fields_set):
            raise ValueError(f"fluid.body_force: needs {dim} components for the {dim}D geometry {geo.name} "
                             f"(got {len(self.fluid.body_force)})")
        if self.solid is not None and len(self.solid.initial_velocity) != dim and (
                dim == 2 or "initial_velocity" in self.solid.model_fields_set):
            raise ValueError(f"solid.initial_velocity: needs {dim} components for the {dim}D geometry {geo.name} "
                             f"(got {len(self.solid.initial_velocity)})")
        if dim == 3 and self.solid is not None and self.solid.mesh_motion.remesh is not None:
            raise ValueError("solid.mesh_motion.remesh: remeshing is 2D only (the 3D mesh motion runs without it)")
        if dim == 2 and isinstance(m.body_couple, list):
            raise ValueError("micropolar.body_couple: a number in 2D (the couple along e_z; got a list)")
        if self.benchmark == "micropolar_poiseuille" and not (m.mu_r > 0 and m.lambda1 > 0):
            raise ValueError("micropolar: micropolar_poiseuille needs mu_r > 0 and lambda1 > 0")
        if self.benchmark == "micropolar_taylor_green":
            if abs(geo.length - np.pi) > 1e-6:
                raise ValueError(f"geometry.length: micropolar_taylor_green is on a square of side pi "
                                 f"(3.14159265358979, got {geo.length!r})")
            if m.inertia <= 0 and self.has_micropolar:
                raise ValueError("micropolar.inertia: micropolar_taylor_green needs inertia > 0")
        return self

    def conditions(self, names=None, extent=None) -> dict[str, BoundaryCondition]:
        """The boundary conditions by facet name: the ``boundaries`` section, or for a built-in geometry its
        preset's defaults (geometry/presets.py) — the one mapping the boundary code reads. ``names``: the
        mesh's facet names and ``extent`` its box (a file scene without a ``boundaries`` section gets the
        defaults by name)."""
        if self.boundaries is not None:
            return self.boundaries
        from cosserat_fsi.geometry.presets import default_boundaries

        defaults = default_boundaries(self, names, extent)
        return {name: BoundaryCondition.model_validate(bc) for name, bc in defaults.items()}

    @property
    def has_micropolar(self) -> bool:
        """True if mu_r or lambda1 (in 3D also lambda2) is nonzero. In 2D the micro-rotation ω e_z has no
        divergence, so lambda2 alone has no effect and builds no ω field (it would be an equation with all
        coefficients zero)."""
        m = self.micropolar
        return m.mu_r != 0 or m.lambda1 != 0 or (self.geometry.DIM == 3 and m.lambda2 != 0)

    @property
    def has_solid(self) -> bool:
        """True if the mesh has solid cells (Turek–Hron with a solid flag, flag, box) and a solid section."""
        return self.solid is not None and (self.geometry.solid_cells or self.geometry.SOLID_FROM_FILE)

    @property
    def has_fluid(self) -> bool:
        """False for solid-only scenes (geometry flag): no fluid terms are built."""
        return self.fluid is not None

    @property
    def has_inflow(self) -> bool:
        """True if the scene prescribes an inlet velocity."""
        return self.inflow is not None

    def to_yaml(self) -> str:
        """The fully resolved scene (all defaults filled in) as YAML that ``load_scene`` accepts."""
        return yaml.safe_dump(self.model_dump(mode="json"), sort_keys=False, default_flow_style=False)


def dump_resolved(scene: Scene) -> str:
    """The fully resolved scene as YAML (same as ``scene.to_yaml()``)."""
    return scene.to_yaml()


# ----------------------------------------------------------------------------------------- loading

def _walk(parts: Sequence[str]) -> tuple[list[type[BaseModel]], bool]:
    """(model classes at dotted path ``parts``, whether it is a mapping of named sections such as
    ``boundaries``, whose next key is any name)."""
    models: list[type[BaseModel]] = [Scene]
    named = False
    for part in parts:
        if named:  # boundaries.NAME: the mapping's value model
            named = False
            continue
        fields = [m.model_fields[part] for m in models if part in m.model_fields]
        kinds = [a for f in fields for a in (f.annotation, *getattr(f.annotation, "__args__", ()))]
        models = [a for a in kinds if isinstance(a, type) and issubclass(a, BaseModel)]
        values = [get_args(a)[1] for a in kinds if get_origin(a) is dict and isinstance(get_args(a)[1], type)
                  and issubclass(get_args(a)[1], BaseModel)]
        if values and not models:
            models, named = values, True
    return models, named


def _models_at(parts: Sequence[str]) -> list[type[BaseModel]]:
    """The model classes at dotted path ``parts`` (``()`` is the Scene; a union such as ``geometry`` gives
    all its members; ``boundaries`` and ``boundaries.NAME`` give BoundaryCondition), or ``[]`` if it is not a
    section."""
    return _walk(parts)[0]


def _field_names(parts: Sequence[str]) -> list[str]:
    """Keys allowed in the section at ``parts`` (for a union: in any of its members)."""
    return list(dict.fromkeys(name for m in _models_at(parts) for name in m.model_fields))


def _unknown_key(parts: Sequence[str]) -> str:
    """``"a.b: unknown key (did you mean 'c'?)"`` for the last element of ``parts``."""
    names = _field_names(parts[:-1])
    close = difflib.get_close_matches(parts[-1], names, n=1)
    hint = f"did you mean {close[0]!r}?" if close else "allowed: " + ", ".join(names)
    if not names:  # inside a mapping of named sections (boundaries.NAME): no list to offer
        return f"{'.'.join(parts)}: unknown key"
    return f"{'.'.join(parts)}: unknown key ({hint})"


def _not_for_geometry(key: str, name: str) -> str:
    """A key of another geometry's model given to geometry ``name``."""
    owners = [g for g, model in MODELS.items() if key in model.model_fields]
    if not owners:
        return _unknown_key(["geometry", key])
    if len(owners) == 1:
        return f"geometry.{key}: only for geometry {owners[0]} (got geometry {name!r})"
    return f"geometry.{key}: not used for geometry {name!r} (only for {', '.join(owners)})"


def _dotted(loc: Sequence[str | int]) -> str:
    """Pydantic location -> ``fluid.body_force[0]``."""
    out = ""
    for part in loc:
        out += f"[{part}]" if isinstance(part, int) else (f".{part}" if out else part)
    return out


def _describe(err: dict) -> str:
    """One pydantic error -> ``"<dotted.key>: <problem>"``."""
    loc, kind, got, ctx = err["loc"], err["type"], err.get("input"), err.get("ctx", {})
    member = None
    if len(loc) > 1 and loc[0] == "geometry" and loc[1] in GEOMETRIES:  # the union's tag is not a key
        member, loc = loc[1], (loc[0], *loc[2:])
    if kind == "union_tag_invalid":
        return f"{_dotted(loc)}.name: must be one of {', '.join(GEOMETRIES)} (got {ctx.get('tag')!r})"
    if kind == "union_tag_not_found":
        return f"{_dotted(loc)}.name: missing key (one of {', '.join(GEOMETRIES)})"
    if kind == "extra_forbidden" and member is not None:
        return _not_for_geometry(str(loc[-1]), member)
    if kind == "value_error":
        message = str(ctx["error"])
        if not loc or message.startswith((_dotted(loc) + ".", _dotted(loc) + ":")):  # already names its key
            return message
        return f"{_dotted(loc)}: {message}"
    if kind == "extra_forbidden":
        return _unknown_key([str(p) for p in loc])
    if kind == "missing":
        what = "missing section" if _models_at([str(p) for p in loc]) else "missing key"
        return f"{_dotted(loc)}: {what}"
    problems = {
        "greater_than": lambda: f"must be > {ctx['gt']:g}",
        "greater_than_equal": lambda: f"must be >= {ctx['ge']:g}",
        "less_than": lambda: f"must be < {ctx['lt']:g}",
        "less_than_equal": lambda: f"must be <= {ctx['le']:g}",
        "finite_number": lambda: "must be a finite number",
        "literal_error": lambda: "must be one of " + ", ".join(re.findall(r"'([^']*)'", ctx["expected"])),
        "float_type": lambda: "must be a number",
        "int_type": lambda: "must be an integer",
        "bool_type": lambda: "must be true or false",
        "string_type": lambda: "must be a string",
        "list_type": lambda: "must be a list",
        "too_short": lambda: f"must have {ctx.get('min_length')} entries",
        "too_long": lambda: f"must have {ctx.get('max_length')} entries",
        "model_type": lambda: "must be a mapping of keys",
        "dict_type": lambda: "must be a mapping of keys",
        "model_attributes_type": lambda: "must be a mapping of keys",
    }
    problem = problems[kind]() if kind in problems else err["msg"].lower()
    return f"{_dotted(loc)}: {problem} (got {_short(got)})"


def _short(value: Any) -> str:
    """A bounded repr (an aliased YAML structure can be huge)."""
    import reprlib

    short = reprlib.Repr()
    short.maxstring, short.maxother, short.maxlong = 40, 40, 40
    return short.repr(value)


def _apply_override(data: dict, item: str) -> None:
    """Apply one ``dotted.key=value`` override to the raw config mapping (in place)."""
    key, sep, text = item.partition("=")
    parts = key.strip().split(".")
    if not sep or not all(re.fullmatch(r"\w+", p) for p in parts):
        raise InputError(f"--set {item}: expected dotted.key=value (e.g. time.dt=1e-3)")
    for i in range(len(parts)):
        if _walk(parts[:i])[1]:  # a name in a mapping of named sections (boundaries.NAME): any name
            continue
        if not _models_at(parts[:i]):
            raise InputError(f"{'.'.join(parts[:i])}: is a value, not a section (in --set {key})")
        if parts[i] not in _field_names(parts[:i]):
            raise InputError(_unknown_key(parts[:i + 1]))
    try:
        value = yaml_load(text)
    except yaml.YAMLError as exc:
        problem = describe_yaml_error(exc).split("could not parse YAML ", 1)[-1]
        raise InputError(f"{key}: could not parse value {_short(text)} as YAML {problem}") from None
    node = data
    for i, part in enumerate(parts[:-1]):
        if node.get(part) is None:
            node[part] = {}
        if not isinstance(node[part], dict):
            raise InputError(f"{'.'.join(parts[:i + 1])}: must be a mapping of keys to set {key}")
        node = node[part]
    node[parts[-1]] = value


_UNION_MEMBER = re.compile(r"(float|int|str|bool|none|(list|tuple|dict)\[.*\]|function-.*)")
"""Pydantic names the member of a union (``float | list[float]``) in the location: not a key."""


def _without_members(err: dict) -> dict:
    loc = tuple(p for p in err["loc"] if not (isinstance(p, str) and _UNION_MEMBER.fullmatch(p)))
    return {**err, "loc": loc}


def _one_line(exc: ValidationError, prefix: tuple = ()) -> str:
    """The first error of ``exc`` (an unknown key first: a misspelt key also shows up as a missing one);
    the errors of a union's members count once per key."""
    errors, seen = [], set()
    for err in sorted(exc.errors(include_url=False), key=lambda e: e["type"] != "extra_forbidden"):
        err = _without_members(err)
        if err["loc"] not in seen:
            seen.add(err["loc"])
            errors.append(err)
    more = f" (+{len(errors) - 1} more)" if len(errors) > 1 else ""
    return _describe({**errors[0], "loc": (*prefix, *errors[0]["loc"])}) + more


def validate_scene(data: Any, source: str = "config") -> Scene:
    """Validate a raw mapping into a Scene, raising a one-line InputError."""
    if not isinstance(data, dict):
        got = "empty file" if data is None else type(data).__name__
        raise InputError(f"{source}: top level must be a mapping of sections (got {got})")
    # top-level keys "x-..." are ignored: a place for YAML anchors (``x-water: &water {rho: 1000}``)
    data = {k: v for k, v in data.items() if not (isinstance(k, str) and k.startswith("x-"))}
    try:
        return Scene.model_validate(data)
    except ValidationError as exc:
        raise InputError(_one_line(exc)) from None


_GEOMETRY = TypeAdapter(Geometry)


def validate_geometry(data: Any) -> GeometryBase:
    """A ``geometry`` section on its own (e.g. ``{"name": "channel", "length": 2.0}``) as its model, raising
    a one-line InputError ``geometry.<key>: <problem>``."""
    try:
        return _GEOMETRY.validate_python(data)
    except ValidationError as exc:
        raise InputError(_one_line(exc, ("geometry",))) from None


def load_scene(path: str | Path, overrides: Sequence[str] = ()) -> Scene:
    """Read, override and validate a scene file. ``name`` defaults to the file stem."""
    path = Path(path)
    text = read_text_file(path, "scene file")
    try:
        data = yaml_load(text)
    except yaml.YAMLError as exc:
        raise InputError(f"{path}: {describe_yaml_error(exc)}") from None
    if isinstance(data, dict):
        data.setdefault("name", path.stem)
        geo = data.get("geometry")
        if isinstance(geo, dict) and geo.get("name") == "file" and isinstance(geo.get("path"), str):
            geo["path"] = str(path.parent / Path(geo["path"]).expanduser())  # relative to the scene file
        for item in overrides:
            _apply_override(data, item)
    return validate_scene(data, str(path))
