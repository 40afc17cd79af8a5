"""The sections of a file scene's boundaries and observables, and the ``output`` section."""

from __future__ import annotations

import re
from typing import Annotated, Any, Literal

from pydantic import BeforeValidator, Field, ValidationInfo, create_model, field_validator, model_validator

from cosserat_fsi.config.expressions import ExpressionError, parse as parse_expression

from .base import MAX_COUNT, NonNegFloat, PositiveFloat, _Section


def _expression(value: Any) -> Any:
    """A number or an expression string in the grammar of cosserat_fsi/config/expressions.py (kept as given)."""
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
    """``micro_rotation: {value: EXPR}``: ω = EXPR on the boundary (Dirichlet)."""

    value: list[Expr] | Expr
    """ω on the boundary (rad/s): EXPR in 2D, [EXPR, EXPR, EXPR] in 3D."""

    @field_validator("value", mode="before")
    @classmethod
    def _shape(cls, value: Any) -> Any:
        return value if isinstance(value, list) else _expression(value)

    def expressions(self) -> list:
        """The parsed components of ``value`` (one in 2D)."""
        return [parse_expression(v) for v in (self.value if isinstance(self.value, list) else [self.value])]


class BoundaryCondition(_Section):
    """The condition on one named facet group of a file scene (``boundaries: {NAME: {...}}``). run.log lists
    the condition each boundary got."""

    type: Literal["no_slip", "velocity", "do_nothing", "traction", "pressure", "slip"]
    """``no_slip``: u = 0. ``velocity``: u = ``value``. ``do_nothing``: the natural condition of the viscous
    form ((μ + μ_r) ∂u/∂n − p n = 0 for ``laplacian``). ``traction``: that natural condition = ``value``.
    ``pressure``: the normal traction −p̂ n with p̂ = ``value``; with ``laplacian`` p = p̂ where the flow is
    developed (∂u/∂n = 0), so a pressure drop between an inlet and an outlet drives Poiseuille flow (with
    ``symmetric`` the tangential stress is set to 0 as well, which a developed profile does not satisfy).
    ``slip``: u·n = 0 and no tangential traction, on any boundary, straight, oblique or curved (weakly by
    Nitsche's method, the polygon's normals averaged at its vertices; not with the steady solid solve, nor on
    a side of solid cells)."""
    value: list[Expr] | Expr | None = Field(default=None, validate_default=True)
    """``velocity`` and ``traction``: [EXPR, EXPR] (3 in 3D; m/s, Pa); ``pressure``: EXPR (Pa). EXPR: a
    number or a string in x, y, z, t (cosserat_fsi/config/expressions.py), finite on the boundary (exit 2 at setup,
    exit 3 if it turns non-finite during the run); one that uses t needs ``time.steady_at`` in a steady
    scene."""
    micro_rotation: MicroRotationValue | Literal["zero", "half_curl", "free"] | None = None
    """With micropolar terms: ``zero`` (ω = 0), ``half_curl`` (ω = ½ curl u, weakly), ``free`` (natural: λ₁
    ∂ω/∂n = 0) or ``{value: EXPR}``. null: ``micropolar.wall_condition`` on no_slip boundaries, ``free`` on
    do_nothing, traction, pressure and slip ones; a velocity boundary of a micropolar scene must name it (a
    moving wall and an inflow want different ones)."""

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


def _coordinates(value: Any) -> Any:
    """2 or 3 coordinates (checked first, for its message; the numbers then by the type); which of the two the
    scene's dimension wants: :func:`coordinate_problem`."""
    if isinstance(value, list) and len(value) not in (2, 3):
        raise ValueError(f"must have 2 or 3 coordinates ([x, y] in a 2D scene, [x, y, z] in 3D; got {len(value)})")
    return value


Point = Annotated[list[float], Field(min_length=2, max_length=3), BeforeValidator(_coordinates)]


def coordinate_problem(key: str, count: int, dim: int) -> str | None:
    """The one-line error for a point with ``count`` coordinates in a ``dim``-D scene (None if it fits)."""
    if count == dim:
        return None
    want = "[x, y]" if dim == 2 else "[x, y, z]"
    return f"{key}: must have {dim} coordinates {want} in a {dim}D scene (got {count})"


MAX_LINE_POINTS = 10_000
"""Most sample points of one ``observables.lines`` profile."""


class _Line(_Section):
    """A profile along a segment fixed in space (``observables.lines.NAME``), written at every field-output
    step to ``line_NAME.csv``. (``from`` is a Python keyword: the class is made by ``create_model`` below, its
    fields described there, and the start is ``line.start``.)"""

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
        """(s, x): arc lengths (N,) and positions (N, dim) of the samples (dim: the coordinates given)."""
        import numpy as np

        a, b = np.asarray(self.start, dtype=float), np.asarray(self.to, dtype=float)
        lam = np.linspace(0.0, 1.0, self.points)
        return lam * float(np.linalg.norm(b - a)), a + lam[:, None] * (b - a)


Line = create_model("Line", __base__=_Line, __module__=__name__, __doc__=(
    "A profile along a segment fixed in space, written at every field-output step to ``line_NAME.csv``."), **{
    "from": (Point, Field(description="Start [x, y] (3D: [x, y, z]) of the segment (m); the arc length s counts "
                                      "from it.")),
    "to": (Point, Field(description="End [x, y] (3D: [x, y, z]) of the segment (m); not the start.")),
    "points": (int, Field(ge=2, le=MAX_LINE_POINTS, description="Number N of equally spaced samples, both ends "
                                                                "included; each must lie in the mesh."))})


class ObservableSet(_Section):
    """What a file scene reports by name (``observables``), besides energies and flow rate: columns of
    timeseries.csv and line profiles. NAME: 1 to 40 letters, digits or '_'. A position has the scene's
    dimension: [x, y] in 2D, [x, y, z] in 3D."""

    forces: list[str] = Field(default_factory=list)
    """Named boundaries (each once) that make up the body whose force is reported: columns ``drag``, ``lift``
    (residual form) and ``drag_surface``, ``lift_surface`` (−∫ T n), summed over them (N, per unit depth in
    2D); in 3D also ``side`` and ``side_surface`` (the z component; drag along x, lift along y)."""
    wetted_solid: bool = False
    """Add the fluid–solid interface to the body of ``forces``."""
    points: dict[str, Point] = Field(default_factory=dict)
    """Probes fixed in space, ``{NAME: [x, y]}`` (3D: ``[x, y, z]``; m): columns ``u_NAME``, ``v_NAME``,
    ``p_NAME``, with micropolar terms also ``omega_NAME``; in 3D ``u_NAME``, ``v_NAME``, ``w_NAME``,
    ``p_NAME`` and ``omega_x_NAME``, ``omega_y_NAME``, ``omega_z_NAME``. A point outside the mesh is an error
    at setup."""
    solid_points: dict[str, Point] = Field(default_factory=dict)
    """Material points of the solid, ``{NAME: [x, y]}`` (3D: ``[x, y, z]``; m): the solid node nearest to the
    given reference position, moving with it; columns ``ux_NAME``, ``uy_NAME`` (3D: and ``uz_NAME``; its
    displacement; run.log says which node and how far from the asked position)."""
    lines: dict[str, Line] | None = None
    """Profiles along segments fixed in space, ``{NAME: {from: [x, y], to: [x, y], points: N}}``, written at
    every field-output step (``output.every``; the initial state too on a time-dependent run) to
    ``line_NAME.csv``: long format, header ``t,s,x,y,u,v,p`` (``omega`` appended with micropolar terms; 3D:
    ``t,s,x,y,z,u,v,w,p`` and ``omega_x,omega_y,omega_z``), N rows per output time, ``s`` the arc length from
    ``from`` (pandas: ``read_csv`` then ``groupby("t")``; ParaView's CSV reader reads it as a table)."""
    flow_rates: list[str] = Field(default_factory=list)
    """Named boundary facet groups (each once; 1 to 40 letters, digits or '_'): column ``flow_rate_NAME`` =
    ∫ u·n ds over the group, n its outward normal (m³/s; per unit depth in 2D). A group inside the mesh
    (between two cells, e.g. the fluid–solid interface) has no outward side and is refused."""

    @field_validator("points", "solid_points", "lines", "flow_rates")
    @classmethod
    def _names(cls, value: dict | list | None) -> dict | list | None:
        for name in value or ():
            if not re.fullmatch(r"[A-Za-z0-9_]{1,40}", name):
                raise ValueError(f"{name[:40]!r}: names are 1 to 40 letters, digits or '_' (they name columns/files)")
        return value

    @field_validator("forces", "flow_rates")
    @classmethod
    def _once(cls, value: list[str]) -> list[str]:
        twice = next((name for i, name in enumerate(value) if name in value[:i]), None)
        if twice is not None:
            raise ValueError(f'"{twice}" listed twice')
        return value

    def positions(self) -> dict:
        """{full key: coordinates} of every position given (points, solid points, the ends of the lines)."""
        out = {f"observables.points.{name}": x for name, x in self.points.items()}
        out.update({f"observables.solid_points.{name}": x for name, x in self.solid_points.items()})
        for name, line in (self.lines or {}).items():
            out.update({f"observables.lines.{name}.from": line.start, f"observables.lines.{name}.to": line.to})
        return out


class Reference(_Section):
    """A reference for one time-series column (``reference: {COLUMN: {...}}``; COLUMN a column of the scene's
    timeseries.csv, checked at setup): the run ends with a pass/FAIL verdict per entry (app/verdict.py), like
    a built-in benchmark's. Give ``value``, or any of the periodic parts ``mean``, ``amplitude``,
    ``frequency``; and exactly one of ``tolerance`` and ``abs_tolerance``."""

    value: float | None = None
    """The column's final value."""
    mean: float | None = None
    """The column's mean (max + min)/2 over its last full period (the periodic analysis of summary.json; a
    column that is not periodic by the end FAILs)."""
    amplitude: NonNegFloat | None = None
    """The column's amplitude (max − min)/2 over its last full period."""
    frequency: PositiveFloat | None = None
    """The column's frequency (Hz) over its last full periods."""
    tolerance: PositiveFloat | None = None
    """Allowed relative error |computed − reference| / |reference|."""
    abs_tolerance: PositiveFloat | None = None
    """Allowed absolute error |computed − reference| (needed for a reference of 0)."""

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
    """What a run writes besides timeseries.csv and summary.json, and how often."""

    every: int = Field(default=10, ge=1, le=MAX_COUNT)
    """Steps between field outputs (fields.xdmf and the ``observables.lines`` profiles)."""
    fields: bool = True
    """Write the fields (velocity, pressure, micro-rotation, displacement) to fields.xdmf + fields.h5."""
    progress: bool = True
    """Show a progress bar on the terminal (``--no-progress`` turns it off too)."""
    checkpoint_every: int = Field(default=1000, ge=0, le=MAX_COUNT)
    """Steps between checkpoints; a time-dependent run also writes one at its last step, so ``cosserat-fsi run
    SCENE --restart OUT --set time.t_end=LATER`` extends a finished run without recomputing it. 0: checkpoints
    only on SIGTERM/SIGINT (none at the end)."""


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
