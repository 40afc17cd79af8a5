"""Rectangular channel [0,length]x[0,height]: inlet (x=0), outlet (x=length), walls (y=0, y=height).

Structured (transfinite) triangles, "Left" diagonals: 8 divisions across the height at level 0, doubled per
level; along the channel round(8 * length / height) (at least 1) times the same factor. Defaults 1 x 1:
L0: 81 vertices (8x8), L1: 289, L2: 1,089, ... ((8*2^L + 1)^2).
"""

from types import ModuleType
from typing import Any, Literal

from ...tags import CELL_TAGS, FACET_TAGS
from .. import _gmsh
from .._model import GeometryBase, PositiveFloat


class Channel(GeometryBase):
    """Rectangular channel ``length`` x ``height`` (defaults 1 x 1)."""

    name: Literal["channel"] = "channel"
    """Rectangular channel [0, length] × [0, height], structured triangles (8 across at level 0); facets
    ``inlet`` (x = 0), ``outlet`` (x = length), ``walls`` (y = 0 and y = height)."""
    length: PositiveFloat = 1.0
    """Length in x (m)."""
    height: PositiveFloat = 1.0
    """Height in y (m)."""

    def msh_params(self) -> dict[str, Any]:
        return {"length": float(self.length), "height": float(self.height)}


def describe(params: dict[str, Any]) -> dict[str, Any]:
    """Tags and dimensions of the geometry."""
    return {
        "cell_tags": {"fluid": CELL_TAGS["fluid"]},
        "facet_tags": {k: FACET_TAGS[k] for k in ("inlet", "outlet", "walls")},
        "points": {},
        "length": params["length"],
        "height": params["height"],
    }


def estimate_cells(scale: float, params: dict[str, Any]) -> int:
    """Number of triangles ``build`` makes (exact; cheap, before gmsh runs)."""
    ny = round(8 / scale)
    return 2 * max(1, round(8 * params["length"] / params["height"])) * ny // 8 * ny


def build(gmsh: ModuleType, scale: float, params: dict[str, Any]) -> None:
    """Create and mesh the model in the current gmsh session; divisions are 8 / ``scale`` across."""
    length, height = params["length"], params["height"]
    ny = round(8 / scale)
    nx = max(1, round(8 * length / height)) * ny // 8
    _gmsh.transfinite_rectangle(gmsh, length, height, nx, ny, ("walls", "outlet", "walls", "inlet"))
    gmsh.model.mesh.generate(2)
