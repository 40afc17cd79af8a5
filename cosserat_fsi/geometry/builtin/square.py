"""Square cavity [0,size]^2: walls = left, right, bottom (3), lid = top (6).

Structured (transfinite) triangles, "Left" diagonals, 8x8 divisions at level 0, doubled per level:
L0: 81 vertices, L1: 289, L2: 1,089, ... ((8*2^L + 1)^2).
"""

from types import ModuleType
from typing import Any, Literal

from ...tags import CELL_TAGS, FACET_TAGS
from .. import _gmsh
from .._model import GeometryBase, PositiveFloat


class Square(GeometryBase):
    """Square cavity of side ``length`` (default 1) with a moving lid."""

    name: Literal["square"] = "square"
    """Square cavity [0, length]², structured triangles (8 × 8 at level 0); facets ``lid`` (the top, moving
    with an inflow section) and ``walls`` (left, right, bottom)."""
    length: PositiveFloat = 1.0
    """Side (m)."""

    def msh_params(self) -> dict[str, Any]:
        return {"size": float(self.length)}


def describe(params: dict[str, Any]) -> dict[str, Any]:
    """Tags, named points and dimensions of the geometry."""
    size = params["size"]
    return {
        "cell_tags": {"fluid": CELL_TAGS["fluid"]},
        "facet_tags": {k: FACET_TAGS[k] for k in ("walls", "lid")},
        "points": {"centre": (size / 2, size / 2)},
        "length": size,
        "height": size,
    }


def estimate_cells(scale: float, params: dict[str, Any]) -> int:
    """Number of triangles ``build`` makes (exact; cheap, before gmsh runs)."""
    return 2 * round(8 / scale) ** 2


def build(gmsh: ModuleType, scale: float, params: dict[str, Any]) -> None:
    """Create and mesh the model in the current gmsh session; 8 / ``scale`` divisions per side."""
    n = round(8 / scale)
    _gmsh.transfinite_rectangle(gmsh, params["size"], params["size"], n, n, ("walls", "walls", "lid", "walls"))
    gmsh.model.mesh.generate(2)
