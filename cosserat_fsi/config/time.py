"""The ``time`` section: one model per time-stepping scheme, chosen by ``scheme`` (required).

A key of another scheme is an error naming the schemes that take it (config/loading.py)."""

from __future__ import annotations

from typing import Annotated, Literal, get_args

from pydantic import Field

from .base import PositiveFloat, _Section

QuadratureDegree = Annotated[int, Field(ge=2, le=12)]
CorrectorPasses = Annotated[int, Field(ge=0, le=5)]


class _Stepping(_Section):
    """A time-stepping scheme: a step and an end time, or with ``tolerance`` an accuracy instead of a step."""

    dt: PositiveFloat
    """Time step δt (s); with ``tolerance`` the first steps' size."""
    t_end: PositiveFloat
    """End time (s); the run starts at t = 0 (≥ dt, at most 100,000,000 steps)."""
    tolerance: float | None = Field(default=None, gt=0, lt=1)
    """Adaptive step: each step's size is chosen from an embedded estimate of its error (the step's solution
    against an explicit predictor; time_schemes/time_control.py), so that the error the run delivers is proportional
    to it (a relative error of the velocity and, in the solid, the displacement); the δt of each step is the
    ``dt`` column of timeseries.csv. After a remesh the next p + 1 steps (p the scheme's order) keep the step
    proposed before it; an incompressible solid's volume correction acts over ``dt`` instead of each step.
    null: the fixed step ``dt``."""
    dt_min: PositiveFloat | None = None
    """With ``tolerance``: the smallest step (s; ≤ dt); a step rejected there stops the run (exit 3). null:
    dt/1000."""
    dt_max: PositiveFloat | None = None
    """With ``tolerance``: the largest step (s; ≥ dt); null: no bound."""
    error_floor: float | None = Field(default=None, gt=0, le=1)
    """With ``tolerance``: the absolute floor of the relative error's weights, as a fraction of the field's
    largest value, so that a field's near-zero values do not decide the step; null: 0.01."""


class Characteristics1(_Stepping):
    """The seed's first-order Lagrange–Galerkin scheme (§5): u^n∘X^n at the feet of the characteristics, no
    convection in the matrix."""

    scheme: Literal["characteristics1"] = "characteristics1"
    """First-order characteristics (the seed's scheme)."""
    quadrature_degree: QuadratureDegree = 8
    """Degree of the quadrature rule of the inertia term, where u^n∘X^n is evaluated. u^n∘X^n is not a
    polynomial on a cell, and a low degree can make the scheme unstable at Courant numbers below one (Morton,
    Priestley & Süli 1988): with degree 4 or 5 the steady CFD2 wake turned noisy at δt = 0.0025; degree 8
    (16 points) kept it steady and within 0.5 % of the reference."""


class Characteristics2(_Stepping):
    """BDF2 along the characteristics (feet x − δt u*, x − 2δt u*)."""

    scheme: Literal["characteristics2"] = "characteristics2"
    """Second-order characteristics (BDF2)."""
    quadrature_degree: QuadratureDegree = 8
    """Degree of the quadrature rule of the inertia term, as for characteristics1."""
    corrector_passes: CorrectorPasses = 0
    """Needs a solid: after the solve, move the mesh to the predicted Ω^{n+1}, back-track again from there,
    linearise the solid stress around the predicted d^{n+1} and solve again (the kept factorisation
    preconditions it); 0: one solve a step."""


class AleBdf2(_Stepping):
    """BDF2 of the nodal values along the moving mesh, with the convection ((u* − w*)·∇)u^{n+1} in the matrix
    (u*, w* extrapolated to t^{n+1}, w* the mesh motion's extension of u*; none in solid cells, where the mesh
    is the material). No back-tracking; the matrix changes every step; on a moving mesh each step is solved on
    the extrapolated configuration (the nodes at t^{n+1})."""

    scheme: Literal["ale_bdf2"] = "ale_bdf2"
    """BDF2 with the convection relative to the mesh in the matrix."""
    corrector_passes: CorrectorPasses = 0
    """Re-solve with the convection linearised around the last solution (Picard passes); 0: one solve a
    step."""


class GeneralizedAlpha(_Stepping):
    """The generalised-α method of Jansen, Whiting & Hulbert (2000) on the nodal values, convection relative
    to the mesh as ale_bdf2: second order, one linear solve a step."""

    scheme: Literal["generalized_alpha"] = "generalized_alpha"
    """Generalised-α with the convection relative to the mesh."""
    rho_infinity: float = Field(default=0.5, ge=0.0, le=1.0)
    """ρ∞: the damping of the unresolved modes (the resolved ones are barely damped, unlike BDF2's 4.5 % per
    period at ωδt = 1/3); ρ∞ = 1 (no damping) is unstable for a solid (time_schemes/generalized_alpha.py)."""
    corrector_passes: CorrectorPasses = 0
    """Re-place the mesh at the predicted t^{n+α_f}, linearise the solid stress and the convection around the
    predicted values there and solve again (without a solid: Picard). FSI3 diverges without passes at ρ∞ =
    0.5; with 2 at δt = 0.01 it is within 2.7 % (docs/perf_generalized_alpha.md,
    "The corrector's fixed point: two passes, and the solid's area kept in Ω^{n+1}")."""


class Steady(_Section):
    """The steady equations (no time derivative) by Newton's method (time_schemes/steady.py): one "step" of length 1
    at t = 1 (``dt`` and ``t_end`` are not keys: both read 1)."""

    scheme: Literal["steady"] = "steady"
    """The steady state by Newton's method."""
    newton_max_iterations: int = Field(default=25, ge=1, le=1000)
    """Most Newton iterations (at each continuation step)."""
    newton_rtol: float = Field(default=1e-10, gt=0, lt=1)
    """Newton's tolerance on the residual relative to the first one."""
    newton_continuation: list[Annotated[float, Field(gt=0, le=1)]] = Field(default_factory=lambda: [0.25, 0.5, 1.0])
    """Fractions of the convection (of the load for a solid) tried one after the other, from the Stokes
    solution (the unloaded state), when Newton at full scale does not converge."""
    steady_at: float | None = Field(default=None, ge=0, allow_inf_nan=False)
    """The time t (s) at which the boundary data and sources are evaluated (and the step ends). A
    ``boundaries`` section whose data use t needs it; null: a built-in scene's inflow after its ramp (t =
    max(1, ramp times))."""

    @property
    def dt(self) -> float:
        """The one step's length."""
        return 1.0

    @property
    def t_end(self) -> float:
        """The end of the one step."""
        return 1.0


Time = Annotated[Characteristics1 | Characteristics2 | AleBdf2 | GeneralizedAlpha | Steady,
                 Field(discriminator="scheme")]
"""The ``time`` section of a scene: one model per scheme, chosen by ``scheme``."""
TIME_SCHEMES: dict[str, type[_Section]] = {m.model_fields["scheme"].default: m for m in get_args(get_args(Time)[0])}
"""Scheme name -> its model class."""
NODAL_CONVECTION = frozenset({"ale_bdf2", "generalized_alpha"})
"""The schemes with the convection in the matrix (nodal values along the mesh; no back-tracking)."""
