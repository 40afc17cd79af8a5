"""The sections of a file scene's boundaries and observables, and the ``output`` section."""

from __future__ import annotations

import re
from typing import Annotated, Any, Literal

from pydantic import BeforeValidator, Field, ValidationInfo, create_model, field_validator, model_validator

from cosserat_fsi.expressions import ExpressionError, parse as parse_expression

from .base import MAX_COUNT, NonNegFloat, PositiveFloat, _Section


def _expression(value: Any) -> Any:
    """A number or an expression string in the grammar of cosserat_fsi/expressions.py (kept as given)."""
    try:
        parse_expression(value)
    except ExpressionError as exc:
        raise ValueError(str(exc)) from None
    return value


Expr = Annotated[Any, BeforeValidator(_expression)]


MICRO_CONDITIONS = ("zero", "half_curl", "free")


def _scalar_or_list(value: Any, scalar: bool, what: str) -> Any:
    """A before-check of ``value``: one expression (parsed here, so that its error names the key itself) when
    ``scalar``, else a list (its components are parsed by the type, each error naming its index)."""
    if scalar:
        if isinstance(value, list):
            raise ValueError(f"must be one expression, {what} (got a list of {len(value)})")
        return _expression(value)
    if value is not None and not isinstance(value, list):
        raise ValueError(f"must be a list of expressions, {what} (got {value!r})")
    return value


class MicroRotationValue(_Section):
    """``micro_rotation: {value: EXPR}``: ω = EXPR on the boundary (Dirichlet); in 3D three components."""

    value: list[Expr] | Expr

    @field_validator("value", mode="before")
    @classmethod
    def _shape(cls, value: Any) -> Any:
        return value if isinstance(value, list) else _expression(value)

    def expressions(self) -> list:
        """The parsed components of ``value`` (one in 2D)."""
        return [parse_expression(v) for v in (self.value if isinstance(self.value, list) else [self.value])]


class BoundaryCondition(_Section):
    """The condition on one named facet group of a file scene (``boundaries: {NAME: {...}}``).

    ``type``: ``no_slip`` (u = 0), ``velocity`` (u = ``value``), ``do_nothing`` (the natural condition of
    the viscous form: (μ + μ_r) ∂u/∂n − p n = 0 for ``laplacian``), ``traction`` (that natural condition =
    ``value``), ``pressure`` (the normal traction −p̂ n with p̂ = ``value``, one expression: the natural
    condition = −p̂ n; with ``laplacian`` (μ + μ_r) ∂u/∂n − p n = −p̂ n, so p = p̂ where the flow is developed
    (∂u/∂n = 0), the do-nothing sense: a pressure drop between an inlet and an outlet drives Poiseuille flow;
    with ``symmetric`` the tangential stress (μ + μ_r)(∇u + ∇uᵀ)n·t is set to 0 as well, which a developed
    profile does not satisfy), ``slip`` (u·n = 0 and no tangential traction of the viscous form, on any
    boundary, straight, oblique or curved: weakly by Nitsche's method, the polygon's normals averaged at its
    vertices; ω keeps its ``micro_rotation``; not with the steady solid solve, nor on a side of solid cells).
    ``value``: [EXPR, EXPR]
    (velocity, traction; 3 in 3D) or EXPR (pressure), each a number or a string in x, y, z, t
    (cosserat_fsi/expressions.py), e.g. the Turek–Hron inflow with its cosine ramp. A value must be finite on
    the boundary (exit 2 at setup, exit 3 if it turns non-finite during the run); one that uses t needs a
    time in a steady scene (``time.steady_at``).
    ``micro_rotation`` (with micropolar terms): ``zero`` (ω = 0), ``half_curl`` (ω = ½ curl u, weakly),
    ``free`` (natural: λ₁ ∂ω/∂n = 0) or ``{value: EXPR}`` (ω = EXPR; in 3D [EXPR, EXPR, EXPR]). Default:
    ``micropolar.wall_condition`` on no_slip boundaries, ``free`` on do_nothing, traction, pressure and slip
    ones; a velocity boundary of a micropolar scene must name it (a moving wall and an inflow want different
    ones). run.log lists the condition each boundary got.
    """

    type: Literal["no_slip", "velocity", "do_nothing", "traction", "pressure", "slip"]
    value: list[Expr] | Expr | None = Field(default=None, validate_default=True)
    micro_rotation: MicroRotationValue | Literal["zero", "half_curl", "free"] | None = None

    @field_validator("value", mode="before")
    @classmethod
    def _value_shape(cls, value: Any, info: ValidationInfo) -> Any:
        kind = info.data.get("type")
        if kind == "pressure" and value is not None:
            return _scalar_or_list(value, True, "the pressure p")
        if kind in ("velocity", "traction"):
            return _scalar_or_list(value, False, "[EXPR, EXPR]")
        return value

    @field_validator("value")
    @classmethod
    def _value(cls, value: Any, info: ValidationInfo) -> Any:
        kind = info.data.get("type")
        if kind in ("velocity", "traction"):
            if value is None:
                raise ValueError(f"missing key (type {kind} needs value: [EXPR, EXPR])")
            if len(value) not in (2, 3):
                raise ValueError(f"must have 2 components, x and y (3 in 3D; got {len(value)})")
        elif kind == "pressure":
            if value is None:
                raise ValueError("missing key (type pressure needs value: EXPR, the pressure)")
        elif value is not None and kind is not None:
            raise ValueError(f"not used for type {kind} (only velocity, traction and pressure take a value)")
        return value

    @field_validator("micro_rotation", mode="before")
    @classmethod
    def _micro_kind(cls, value: Any) -> Any:
        if value is not None and not isinstance(value, dict) and value not in MICRO_CONDITIONS:
            raise ValueError(f"must be zero, half_curl, free or {{value: EXPR}} (got {value!r})")
        return value

    def micro(self, wall_condition: str) -> str:
        """The micro-rotation condition here: given (``value`` for {value: EXPR}), or the default for this
        type."""
        if isinstance(self.micro_rotation, MicroRotationValue):
            return "value"
        if self.micro_rotation is not None:
            return self.micro_rotation
        return wall_condition if self.type == "no_slip" else "free"

    def expressions(self) -> list:
        """The parsed components of ``value`` (one for pressure)."""
        value = self.value if isinstance(self.value, list) or self.value is None else [self.value]
        return [parse_expression(v) for v in value or ()]

    def all_expressions(self) -> dict:
        """Every expression of this condition by its key below ``boundaries.NAME`` (``value[0]``, ``value``,
        ``micro_rotation.value[2]``, ...)."""
        out = {}
        for prefix, value in (("value", self.value), ("micro_rotation.value",
                                                      getattr(self.micro_rotation, "value", None))):
            if isinstance(value, list):
                out.update({f"{prefix}[{i}]": parse_expression(v) for i, v in enumerate(value)})
            elif value is not None:
                out[prefix] = parse_expression(value)
        return out


Point = Annotated[list[float], Field(min_length=2, max_length=2)]


MAX_LINE_POINTS = 10_000
"""Most sample points of one ``observables.lines`` profile."""


class _Line(_Section):
    """A profile along a segment (``observables.lines.NAME``): ``from: [x, y]``, ``to: [x, y]``, ``points: N``
    (2 to 10000 equally spaced samples, both ends included). (``from`` is a Python keyword: the class is made
    by ``create_model`` below, and the start is ``line.start``.)"""

    @field_validator("to", check_fields=False)
    @classmethod
    def _length(cls, value: list, info: ValidationInfo) -> list:
        if value == info.data.get("from"):
            raise ValueError("must differ from 'from' (a segment of length 0)")
        return value

    @property
    def start(self) -> list:
        return getattr(self, "from")

    def samples(self):
        """(s, x): arc lengths (N,) and positions (N, 2) of the samples."""
        import numpy as np

        a, b = np.asarray(self.start, dtype=float), np.asarray(self.to, dtype=float)
        lam = np.linspace(0.0, 1.0, self.points)
        return lam * float(np.linalg.norm(b - a)), a + lam[:, None] * (b - a)


Line = create_model("Line", __base__=_Line, __module__=__name__, **{
    "from": (Point, ...), "to": (Point, ...), "points": (int, Field(ge=2, le=MAX_LINE_POINTS))})


class ObservableSet(_Section):
    """What a file scene reports by name (``observables``), besides energies and flow rate.

    ``forces``: named boundaries (each once) whose force on the body (drag, lift: residual and surface
    forms) is reported; ``wetted_solid``: add the fluid–solid interface. ``points``: probes fixed in space
    (columns ``u_NAME``, ``v_NAME``, ``p_NAME``, with micropolar terms also ``omega_NAME``; a point outside
    the mesh is an error at setup); ``solid_points``: material points of the solid, the solid node nearest to
    the given reference position, moving with it (``ux_NAME``, ``uy_NAME``: its displacement; run.log says
    which node and how far from the asked position). ``lines``: profiles along segments fixed in space,
    ``{NAME: {from: [x, y], to: [x, y], points: N}}``, written at every field-output step (``output.every``;
    the initial state too on a time-dependent run) to ``line_NAME.csv``: long format, header
    ``t,s,x,y,u,v,p`` (``omega`` appended with micropolar terms), N rows per output time, ``s`` the arc
    length from ``from`` (pandas: ``read_csv`` then ``groupby("t")``; ParaView's CSV reader reads it as a
    table). Every sample must lie in the mesh (an error at setup names the line).
    """

    forces: list[str] = Field(default_factory=list)
    wetted_solid: bool = False
    points: dict[str, Point] = Field(default_factory=dict)
    solid_points: dict[str, Point] = Field(default_factory=dict)
    lines: dict[str, Line] | None = None

    @field_validator("points", "solid_points", "lines")
    @classmethod
    def _names(cls, value: dict | None) -> dict | None:
        for name in value or ():
            if not re.fullmatch(r"[A-Za-z0-9_]{1,40}", name):
                raise ValueError(f"{name[:40]!r}: names are 1 to 40 letters, digits or '_' (they name columns/files)")
        return value

    @field_validator("forces")
    @classmethod
    def _forces_once(cls, value: list[str]) -> list[str]:
        twice = next((name for i, name in enumerate(value) if name in value[:i]), None)
        if twice is not None:
            raise ValueError(f'"{twice}" listed twice')
        return value


class Reference(_Section):
    """A reference for one time-series column (``reference: {COLUMN: {...}}``): the run ends with a pass/FAIL
    verdict per entry (app/verdict.py), like a built-in benchmark's.

    ``value``: the column's final value; or, for a periodic column, any of ``mean``, ``amplitude``,
    ``frequency`` (the periodic analysis of summary.json over the run; a column that is not periodic by the
    end FAILs). ``tolerance``: the allowed relative error |computed − reference| / |reference|, or
    ``abs_tolerance``: the allowed absolute error (needed for a reference of 0); exactly one of them.
    COLUMN must be a column of the scene's timeseries.csv (checked at setup).
    """

    value: float | None = None
    mean: float | None = None
    amplitude: NonNegFloat | None = None
    frequency: PositiveFloat | None = None
    tolerance: PositiveFloat | None = None
    abs_tolerance: PositiveFloat | None = None

    @model_validator(mode="after")
    def _parts(self):
        periodic = [k for k in ("mean", "amplitude", "frequency") if getattr(self, k) is not None]
        if self.value is not None and periodic:
            raise ValueError(f"{periodic[0]}: not with value (a final value, or the periodic parts mean, "
                             "amplitude, frequency)")
        if self.value is None and not periodic:
            raise ValueError("missing key (value, or mean/amplitude/frequency for a periodic column)")
        if (self.tolerance is None) == (self.abs_tolerance is None):
            raise ValueError("give exactly one of tolerance (relative) and abs_tolerance")
        if self.tolerance is not None and any(v == 0 for v in self.parts().values()):
            raise ValueError("tolerance: relative to a reference of 0; give abs_tolerance instead")
        return self

    def parts(self) -> dict:
        """{"value" | "mean" | "amplitude" | "frequency": reference} of what is given."""
        given = {k: getattr(self, k) for k in ("value", "mean", "amplitude", "frequency")}
        return {k: v for k, v in given.items() if v is not None}


class Output(_Section):
    """Output: field-output interval in steps, whether to write fields, progress bar, checkpoint interval.

    ``checkpoint_every``: steps between checkpoints (default 1000); a time-dependent run also writes one at
    its last step, so ``cosserat-fsi run SCENE --restart OUT --set time.t_end=LATER`` extends a finished run
    without recomputing it; 0: checkpoints only on SIGTERM/SIGINT (none at the end)."""

    every: int = Field(default=10, ge=1, le=MAX_COUNT)
    fields: bool = True
    progress: bool = True
    checkpoint_every: int = Field(default=1000, ge=0, le=MAX_COUNT)


def check_boundary_data(scene) -> None:
    """The checks of a ``boundaries`` section across sections (keys in full): ω's components for the mesh's
    dimension, ω named on the velocity boundaries of a micropolar scene, t only with a time (steady scenes:
    ``time.steady_at``), and the data that do not depend on x, y, z finite at the start time."""
    import numpy as np

    steady = scene.time.scheme == "steady"
    start = (scene.time.steady_at or 0.0) if steady else 0.0
    dim = scene.geometry.DIM
    for name, bc in scene.boundaries.items():
        key = f"boundaries.{name}"
        micro = bc.micro_rotation
        if isinstance(micro, MicroRotationValue) and scene.has_micropolar:
            n = len(micro.value) if isinstance(micro.value, list) else None
            if (dim == 2 and n is not None) or (dim == 3 and n != 3):
                want = "one expression (ω is a scalar in 2D)" if dim == 2 else "3 components [EXPR, EXPR, EXPR]"
                raise ValueError(f"{key}.micro_rotation.value: must be {want} for a {dim}D mesh"
                                 f"{'' if n is None else f' (got {n})'}")
        if bc.type == "velocity" and micro is None and scene.has_micropolar:
            raise ValueError(f"{key}.micro_rotation: required on a velocity boundary of a micropolar scene "
                             "(zero, half_curl, free or {value: EXPR})")
        for sub, expression in bc.all_expressions().items():
            if steady and expression.time_dependent and scene.time.steady_at is None:
                raise ValueError(f"{key}.{sub}: uses t in a steady scene: give the time as time.steady_at "
                                 f"(got {expression.text!r})")
            if not expression.symbols & {"x", "y", "z"} and not expression.finite_at(np.zeros((3, 1)), start):
                raise ValueError(f"{key}.{sub}: {expression.text!r} is not finite at t = {start!r} "
                                 "(an overflow or a division by zero)")


def precheck_micro_values(data: Any) -> None:
    """``boundaries.NAME.micro_rotation: {value: ...}`` of a raw scene checked before the models, so that an
    error names its full key (the field is a union of a word and this mapping)."""
    boundaries = data.get("boundaries") if isinstance(data, dict) else None
    for name, bc in (boundaries or {}).items() if isinstance(boundaries, dict) else ():
        micro = bc.get("micro_rotation") if isinstance(bc, dict) else None
        if not isinstance(micro, dict):
            continue
        key = f"boundaries.{name}.micro_rotation"
        for extra in micro:
            if extra != "value":
                raise ValueError(f"{key}.{extra}: unknown key (the mapping form is {{value: EXPR}})")
        if "value" not in micro:
            raise ValueError(f"{key}.value: missing key (ω on the boundary: EXPR, in 3D [EXPR, EXPR, EXPR])")
        value = micro["value"]
        for sub, text in ([(f"value[{i}]", v) for i, v in enumerate(value)] if isinstance(value, list)
                          else [("value", value)]):
            try:
                parse_expression(text)
            except ExpressionError as exc:
                raise ValueError(f"{key}.{sub}: {exc}") from None
