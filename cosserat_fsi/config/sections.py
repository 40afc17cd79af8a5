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

    ``forces``: named boundaries whose force on the body (drag, lift: residual and surface forms) is
    reported; ``wetted_solid``: add the fluid–solid interface. ``points``: probes fixed in space
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
