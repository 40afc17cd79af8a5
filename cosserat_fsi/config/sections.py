"""The sections of a file scene's boundaries and observables, and the ``output`` section."""

from __future__ import annotations

from typing import Annotated, Any, Literal

from pydantic import BeforeValidator, Field, ValidationInfo, field_validator

from cosserat_fsi.expressions import ExpressionError, parse as parse_expression

from .base import MAX_COUNT, _Section


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

    ``forces``: named boundaries (each once) whose force on the body (drag, lift: residual and surface
    forms) is reported; ``wetted_solid``: add the fluid–solid interface. ``points``: probes fixed in space
    (columns ``u_NAME``, ``v_NAME``, ``p_NAME``, with micropolar terms also ``omega_NAME``);
    ``solid_points``: material points of the solid, the solid node nearest to the given reference position,
    moving with it (``ux_NAME``, ``uy_NAME``: its displacement).
    """

    forces: list[str] = Field(default_factory=list)
    wetted_solid: bool = False
    points: dict[str, Point] = Field(default_factory=dict)
    solid_points: dict[str, Point] = Field(default_factory=dict)

    @field_validator("forces")
    @classmethod
    def _forces_once(cls, value: list[str]) -> list[str]:
        twice = next((name for i, name in enumerate(value) if name in value[:i]), None)
        if twice is not None:
            raise ValueError(f'"{twice}" listed twice')
        return value


class Output(_Section):
    """Output: field-output interval in steps, whether to write fields, progress bar, checkpoint interval."""

    every: int = Field(default=10, ge=1, le=MAX_COUNT)
    fields: bool = True
    progress: bool = True
    # steps between checkpoints; 0: only on SIGTERM/SIGINT
    checkpoint_every: int = Field(default=1000, ge=0, le=MAX_COUNT)
