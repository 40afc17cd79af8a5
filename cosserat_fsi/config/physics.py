"""The physical sections: fluid, micropolar coefficients, solid (with its mesh motion) and inflow."""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Field, field_validator, model_validator

from .base import NonNegFloat, PositiveFloat, _Section


class Fluid(_Section):
    """Newtonian part of the fluid: density, viscosity, body force and the form of the viscous term."""

    rho: PositiveFloat
    """Density ρ (kg/m³)."""
    mu: PositiveFloat
    """Dynamic viscosity μ (Pa·s)."""
    body_force: list[float] = Field(default=[0.0, 0.0], min_length=2, max_length=3)  # one per dimension
    """Body force per unit volume f (N/m³), one component per dimension (3 in 3D); not given: zero, with the
    scene's dimension (the resolved scene, config.yaml, says [0.0, 0.0, 0.0] in 3D)."""
    viscous_form: Literal["laplacian", "symmetric"] = "laplacian"
    """``laplacian``: (μ + μ_r) ∇u:∇ũ, whose natural outflow condition is the benchmarks' do-nothing μ ∂u/∂n −
    p n = 0; ``symmetric``: the seed's ½ (μ + μ_r) Du:Dũ (eq. 23), natural condition (μ Du − p I) n = 0. Both
    give the same equations inside the domain when div u = 0."""


class Micropolar(_Section):
    """Cosserat (micropolar) coefficients of the fluid (seed eq. 32); all zero gives a Newtonian fluid."""

    mu_r: NonNegFloat = 0.0
    """Vortex viscosity μ_r (Pa·s): couples ω to the fluid's rotation (2μ_r curl ω in the momentum, 4μ_r ω −
    2μ_r curl u in eq. 32). Nonzero builds the micro-rotation ω."""
    lambda1: NonNegFloat = 0.0
    """Angular viscosity λ₁ (Pa·s·m²) of the term λ₁ ∇ω:∇τ̃. Nonzero builds the micro-rotation ω."""
    lambda2: NonNegFloat = 0.0
    """Angular viscosity λ₂ (Pa·s·m²) of the term λ₂ div ω div τ̃; acts in 3D only (in 2D ω e_z has no
    divergence)."""
    inertia: NonNegFloat = 0.0
    """Micro-inertia I (m²): the ω equation's inertia is ρ I Dω/Dt."""
    body_couple: float | Annotated[list[float], Field(min_length=3, max_length=3)] = 0.0  # 3D: vector (a number: g_z)
    """Body couple per unit volume g (N/m²): a number in 2D (along e_z); in 3D [g_x, g_y, g_z] or a number
    (g_z)."""
    wall_condition: Literal["zero", "half_curl"] = "zero"
    """ω on no-slip walls: ``zero`` (ω = 0, the seed's) or ``half_curl`` (ω = ½ curl u, weakly by Nitsche's
    method; micropolar Poiseuille flow is then Newtonian with viscosity μ)."""
    nodal_characteristics: bool = False
    """Characteristics schemes: interpolate ω^n∘X^n at the P2 nodes instead of evaluating it at the
    quadrature points like u's history. The quadrature-point evaluation is unstable for a weakly damped ω
    (large micro-inertia, e.g. I = 1e-2 m² with μ_r = 0.1; docs/seed_reproduction.md); the nodal one is
    stable, at the price of more numerical diffusion of ω."""


class Remesh(_Section):
    """Automatic remeshing: gmsh meshes the fluid anew around the current solid (2D and 3D; mesh/remesh.py)."""

    quality: float = Field(gt=0, lt=1)
    """Remesh when the minimum fluid cell quality falls below this: 4√3|K|/Σ|e|² for triangles,
    6√2|K|/(Σ|e|²/6)^(3/2) for tetrahedra (1: equilateral). gmsh's tetrahedra reach about 0.2 (the 3D flag's
    mesh: 0.24, a remesh of it 0.20–0.24), so a 3D threshold is lower than a 2D one (e.g. 0.1)."""
    max_count: int = Field(default=1000, ge=1)
    """Most remeshes in one run."""


class MeshMotionSettings(_Section):
    """How the fluid mesh follows the solid (mesh/motion.py; measured in docs/perf_mesh_motion.md, "Mesh motion")."""

    method: Literal["harmonic", "elastic", "biharmonic"] = "biharmonic"
    """The extension of the solid's displacement into the fluid: ``biharmonic`` (carries a bent flag
    furthest), ``elastic`` (linear elasticity) or ``harmonic`` (the seed's stiffened Laplace extension)."""
    stiffness_exponent: float | None = Field(default=None, ge=0, le=4)
    """χ: the operator is weighted by |K|^−χ so that small cells deform less; null: the measured best of the
    method (harmonic 1, elastic 1, biharmonic 0)."""
    poisson_ratio: float = Field(default=0.0, gt=-1, lt=0.5)
    """Poisson ratio ν of the ``elastic`` extension."""
    wall_gap: PositiveFloat | Literal["off"] | None = None
    """The run stops (exit 3) when the solid comes closer than this (m) to a wall or any boundary with a
    prescribed velocity; null: a quarter of the shortest wall facet; ``off`` (YAML reads it as false, also
    taken): no check (run.log says so). A gap
    that reaches every solid vertex from the walls at rest, so that none would be checked, is refused at
    setup."""
    remesh: Remesh | None = None
    """Remesh the fluid when the minimum cell quality falls below ``remesh.quality``; null: never."""

    @field_validator("wall_gap", mode="before")
    @classmethod
    def _off(cls, value):
        return "off" if value is False else value  # YAML 1.1 reads a bare off as false

    def options(self) -> dict:
        """Keyword arguments of mesh.motion.MeshMotion."""
        exponent = {"harmonic": 1.0, "elastic": 1.0, "biharmonic": 0.0}[self.method]
        return {"method": self.method, "poisson_ratio": self.poisson_ratio, "wall_gap": self.wall_gap,
                "stiffness_exponent": exponent if self.stiffness_exponent is None else self.stiffness_exponent}


INCOMPRESSIBLE = "mooney_rivlin_incompressible"


class Solid(_Section):
    """The elastic body: its law and parameters, density, load, initial velocity and mesh motion.

    A compressible solid's pressure lives in the fluid (p = 0 at the solid's own pressure nodes); the
    inertia and the weight are ρ_s per current volume (exact for the incompressible law, O(J − 1) for a
    compressible one)."""

    law: Literal["mooney_rivlin_incompressible", "saint_venant_kirchhoff", "neo_hookean"] = INCOMPRESSIBLE
    """``mooney_rivlin_incompressible``: the seed's law (eqs. 6–14), Cauchy stress −pI + μ_s (Dd − ∇d∇dᵀ)
    with div u = 0 in the solid; it takes ``mu_s`` (and ``c2``). ``saint_venant_kirchhoff`` (the Turek–Hron
    benchmarks' law) or ``neo_hookean`` (ψ = μ/2 (I₁ − d) − μ ln J + λ/2 (ln J)²): compressible
    (physics/materials.py), plane strain in 2D; they take ``E`` and ``nu``, or ``mu_s`` and ``lambda_s``."""
    rho: PositiveFloat
    """Reference density ρ_s (kg/m³)."""
    mu_s: PositiveFloat | None = None
    """Shear modulus μ_s (Pa); for the incompressible law the seed's 2c₁ (its c₁ = 1e6 is mu_s: 2.0e6)."""
    lambda_s: PositiveFloat | None = None
    """Lamé's first parameter λ_s (Pa) of a compressible law, with ``mu_s``."""
    E: PositiveFloat | None = None
    """Young's modulus E (Pa) of a compressible law, with ``nu``."""
    nu: float | None = Field(default=None, gt=0, lt=0.5)
    """Poisson ratio ν of a compressible law, with ``E``."""
    c2: NonNegFloat = 0.0
    """Second Mooney–Rivlin constant c₂ (Pa, incompressible law): not modelled (the stress has no c₂ term), so
    a nonzero value is refused; in 2D with det F = 1 it would only shift the pressure (seed eq. 14)."""
    gravity: float = 0.0
    """Acceleration (m/s²) in −y on the solid, switched on with a cosine ramp over ``gravity_ramp_time``."""
    gravity_ramp_time: NonNegFloat = 0.0
    """Duration (s) of the gravity's cosine ramp; a slow ramp reaches a static deflection without exciting the
    free oscillation."""
    volume_correction: bool | None = None
    """Incompressible law: make the next velocity undo the area drift J ≠ 1 that the seed's explicit node
    update x += δt u accumulates. null: on (false is the seed's scheme)."""
    volume_correction_time: NonNegFloat = 0.0
    """Undo the drift over max(δt/α, this) seconds instead of in one step (0: one step); at small δt the
    one-step correction feeds back on itself. Part of the discrete problem: for a δt study set it ≥ the
    largest δt/α, so that every run solves the same one."""
    initial_velocity: list[float] = Field(default=[0.0, 0.0], min_length=2, max_length=3)  # 3 in 3D
    """Uniform initial velocity of the solid (m/s), e.g. to start a free vibration; 3 components in 3D (not
    given: zero, with the scene's dimension)."""
    displacement: Literal["quadratic", "linear"] = "quadratic"
    """The displacement carried from step to step (BDF schemes): ``quadratic``, P2 like the velocity, its
    mid-edge nodes moved by their own velocity (eq. 28); ``linear``, after each step its interpolant linear
    on each cell, the degree of the mesh that moves with the solid. On a large-deformation compressible flag
    the P2 mid-edge nodes drift from the P1 mesh and the run stops; the linear one runs (and gives CSM3's
    first swing to 3e-5 of the quadratic one's). With ``time.tolerance`` cap the step (``time.dt_max``): a
    change of step can kick the linear flag (FSI3 at tolerance 1e-2 stops at t = 0.026), and on FSI3 its
    forces are further from the benchmark than the quadratic one's (docs/perf_adaptive_step.md)."""
    mesh_motion: MeshMotionSettings = Field(default_factory=MeshMotionSettings)
    """How the fluid mesh follows the solid."""

    @model_validator(mode="after")
    def _parameters(self):
        given = [k for k in ("mu_s", "lambda_s", "E", "nu") if getattr(self, k) is not None]
        if self.law == INCOMPRESSIBLE:
            for key in given:
                if key != "mu_s":
                    raise ValueError(f"solid.{key}: not used by solid.law {INCOMPRESSIBLE} (it takes mu_s)")
            if self.mu_s is None:
                raise ValueError(f"solid.mu_s: missing key (solid.law {INCOMPRESSIBLE})")
            return self
        if set(given) not in ({"E", "nu"}, {"mu_s", "lambda_s"}):
            raise ValueError(f"solid.law: {self.law} takes one pair of parameters, E and nu, or mu_s and lambda_s "
                             f"(got {', '.join(given) or 'none'})")
        if self.c2:
            raise ValueError(f"solid.c2: only for solid.law {INCOMPRESSIBLE}")
        for key in ("volume_correction", "volume_correction_time"):
            if getattr(self, key):
                raise ValueError(f"solid.{key}: only for solid.law {INCOMPRESSIBLE} (a compressible "
                                 "solid's volume follows its law)")
        return self

    @property
    def compressible(self) -> bool:
        return self.law != INCOMPRESSIBLE

    @property
    def corrects_volume(self) -> bool:
        """The volume correction is on: the incompressible law, unless ``volume_correction: false``."""
        return not self.compressible and self.volume_correction is not False

    def lame(self) -> tuple[float, float]:
        """(μ, λ) of a compressible law (from E, ν when given)."""
        if self.E is not None:
            return self.E / (2.0 * (1.0 + self.nu)), self.E * self.nu / ((1.0 + self.nu) * (1.0 - 2.0 * self.nu))
        return self.mu_s, self.lambda_s


class Inflow(_Section):
    """Inlet velocity (the ``inlet`` facets; the moving lid of square and cube): speed, cosine ramp, profile
    (geometry/presets.py writes it as the inlet's velocity expression)."""

    u_mean: NonNegFloat
    """Mean inlet speed U (m/s): the parabola 6U y(H − y)/H² peaks at 1.5 U (in 3D times 6 z(W − z)/W²: 2.25
    U); the lid's speed for square and cube."""
    ramp_time: NonNegFloat = 0.0
    """Duration T (s) of the cosine ramp from rest, (1 − cos(π t/T))/2; 0: the full inflow from the start."""
    profile: Literal["parabolic", "uniform"] = "parabolic"
    """The inlet profile across the channel: ``parabolic`` (no slip at the walls) or ``uniform``."""
    asymmetry: float = Field(default=0.0, ge=-0.5, le=0.5)
    """ε (with a ramp): during the ramp only, the profile is tilted by ε sin(π t/T) (2y/H − 1). It starts the vortex
    shedding of an unstable steady wake within seconds (without it a direct solver's round-off takes ~10 s of
    simulated time to grow); results after the transient do not depend on it."""
