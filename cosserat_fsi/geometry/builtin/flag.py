"""Turek-Hron flag alone (CSM1/CSM2, free vibration): the rectangle [0,length]x[0,thickness], solid cells.

Tags: cells ``solid`` (2) everywhere; left edge x = 0 ``clamp`` (7); bottom, right and top edges
``interface`` (5, the free surface). The right edge is split at A = (length, thickness/2), a mesh vertex.
Defaults ``length`` 0.35, ``thickness`` 0.02 (the Turek-Hron flag, 0.6 - 0.25 by 0.02). ``clamp: arc``: the
left edge is the arc of the Turek–Hron cylinder (radius 0.05) the flag is clamped on, as in the benchmark
(it passes through (0, thickness/2); its corners are 1.0 mm further left); default ``straight``.

Structured (transfinite) triangles, "Left" diagonals: 4 divisions across the thickness at level 0, doubled
per level; along the flag max(1, round(4 * length / thickness)) times the same factor (70 for the defaults,
square 0.005 x 0.005 cells). Defaults: L0 355 vertices (71x5), L1 1,269 (141x9), L2 4,777 (281x17), ...
"""

from types import ModuleType
from typing import Any, ClassVar, Literal

from ...tags import CELL_TAGS, FACET_TAGS
from .. import _gmsh
from .._model import GeometryBase, PositiveFloat

CYLINDER_RADIUS = 0.05  # the Turek–Hron cylinder the flag is clamped on (``clamp: arc``)


class Flag(GeometryBase):
    """The Turek–Hron flag alone, ``length`` x ``height`` (defaults 0.35 x 0.02): a solid-only scene."""

    FLUID: ClassVar[bool] = False
    name: Literal["flag"] = "flag"
    """The Turek–Hron flag alone (CSM tests, free vibration), solid cells only (no fluid section); facets
    ``clamp`` (the left edge) and ``interface`` (the free edges); point A = (length, height/2)."""
    length: PositiveFloat = 0.35
    """Length of the flag in x (m)."""
    height: PositiveFloat = 0.02
    """Thickness of the flag in y (m)."""
    clamp: Literal["straight", "arc"] = "straight"
    """The clamped left edge: ``straight`` (x = 0) or ``arc``, the arc of the Turek–Hron cylinder (radius
    0.05) through (0, height/2), as in the benchmark."""

    @property
    def solid_cells(self) -> bool:
        return True

    def msh_params(self) -> dict[str, Any]:
        params = {"length": float(self.length), "thickness": float(self.height)}
        if self.clamp == "arc":  # (straight meshes keep their cache key)
            params["clamp_radius"] = CYLINDER_RADIUS
        return params


def describe(params: dict[str, Any]) -> dict[str, Any]:
    """Tags, named points and dimensions of the geometry."""
    length, thickness = params["length"], params["thickness"]
    return {
        "cell_tags": {"solid": CELL_TAGS["solid"]},
        "facet_tags": {k: FACET_TAGS[k] for k in ("interface", "clamp")},
        "points": {"A": (length, thickness / 2)},
        "length": length,
        "height": thickness,
        "thickness": thickness,
    }


def estimate_cells(scale: float, params: dict[str, Any]) -> int:
    """Number of triangles ``build`` makes (exact; cheap, before gmsh runs)."""
    ny = round(4 / scale)
    return 2 * max(1, round(4 * params["length"] / params["thickness"])) * ny // 4 * ny


def build(gmsh: ModuleType, scale: float, params: dict[str, Any]) -> None:
    """Create and mesh the model in the current gmsh session; 4 / ``scale`` divisions across the flag."""
    length, thickness = params["length"], params["thickness"]
    ny = round(4 / scale)
    nx = max(1, round(4 * length / thickness)) * ny // 4
    facets = ("interface", "interface", "interface", "clamp")
    _gmsh.transfinite_rectangle(gmsh, length, thickness, nx, ny, facets, cells="solid", split_right=True,
                                left_radius=params.get("clamp_radius"))
    gmsh.model.mesh.generate(2)
