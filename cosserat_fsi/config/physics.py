"""The physical sections: fluid, micropolar coefficients, solid (with its mesh motion) and inflow."""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Field, model_validator

from .base import NonNegFloat, PositiveFloat, _Section


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

    ``nodal_characteristics`` (characteristics schemes): interpolate ω^n∘X^n at the P2 nodes while u's
    history is evaluated at the quadrature points. A weakly damped ω (large micro-inertia, e.g. I = 1e-2 m²
    with μ_r = 0.1) makes the quadrature-point evaluation unstable (docs/seed_reproduction.md); the nodal
    interpolation is stable, at the price of more numerical diffusion of ω."""

    mu_r: NonNegFloat = 0.0
    lambda1: NonNegFloat = 0.0
    lambda2: NonNegFloat = 0.0
    inertia: NonNegFloat = 0.0
    body_couple: float | Annotated[list[float], Field(min_length=3, max_length=3)] = 0.0  # 3D: vector (a number: g_z)
    wall_condition: Literal["zero", "half_curl"] = "zero"
    nodal_characteristics: bool = False


class Remesh(_Section):
    """Automatic remeshing: gmsh meshes the fluid anew around the current solid when the minimum cell
    quality 4√3|K|/Σ|e|² falls below ``quality``; ``max_count`` bounds the number of remeshes."""

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


INCOMPRESSIBLE = "mooney_rivlin_incompressible"


class Solid(_Section):
    """The elastic body: its law, density, load and initial velocity.

    ``law``: ``mooney_rivlin_incompressible`` (default, the seed's eqs. 6–14: Cauchy stress
    −pI + μ_s (Dd − ∇d∇dᵀ), the seed's 2c₁ = μ_s, div u = 0 in the solid; it takes ``mu_s`` and ``c2``),
    or a compressible law (physics/materials.py), the Turek–Hron benchmarks' ``saint_venant_kirchhoff``
    or ``neo_hookean`` (ψ = μ/2 (I₁ − d) − μ ln J + λ/2 (ln J)²), with one pair of parameters: ``E``
    and ``nu`` (0 < ν < ½), or the Lamé pair ``mu_s`` and ``lambda_s``. In 2D the laws are those of plane
    strain. A compressible solid's pressure lives in the fluid (p = 0 at the solid's own pressure nodes);
    ``rho`` is its reference density (the inertia and the weight are ρ_s per current volume: exact for the
    incompressible law, O(J − 1) for a compressible one).
    ``c2``: the second Mooney–Rivlin constant; in 2D with det F = 1 it only shifts the pressure (seed
    eq. 14), so it does not change the motion.
    ``gravity``: acceleration (m/s²) in −y on the solid, switched on with the cosine ramp over
    ``gravity_ramp_time`` (a slow ramp reaches a static deflection without exciting the free
    oscillation). ``volume_correction`` (incompressible law; on unless false): make the next velocity undo
    the area drift J ≠ 1 that the seed's explicit node update x += δt u accumulates (off is the seed's
    scheme). ``volume_correction_time`` (s): undo it over max(δt/α, this) instead of in one step (0: one
    step); at small δt the one-step correction feeds back on itself (docs/performance.md). The correction
    is part of the discrete problem: for a δt study set this ≥ the largest δt/α, so that every run solves
    the same one (with the one-step correction FSI3's frequency drifts at first order in δt).
    ``initial_velocity``: uniform initial velocity of the solid (m/s), e.g. to start a free vibration.
    ``mesh_motion``: see :class:`MeshMotionSettings`.
    """

    law: Literal["mooney_rivlin_incompressible", "saint_venant_kirchhoff", "neo_hookean"] = INCOMPRESSIBLE
    rho: PositiveFloat
    mu_s: PositiveFloat | None = None
    lambda_s: PositiveFloat | None = None
    E: PositiveFloat | None = None
    nu: float | None = Field(default=None, gt=0, lt=0.5)
    c2: NonNegFloat = 0.0
    gravity: float = 0.0
    gravity_ramp_time: NonNegFloat = 0.0
    volume_correction: bool | None = None
    volume_correction_time: NonNegFloat = 0.0
    initial_velocity: list[float] = Field(default=[0.0, 0.0], min_length=2, max_length=3)  # 3 in 3D
    mesh_motion: MeshMotionSettings = Field(default_factory=MeshMotionSettings)

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
