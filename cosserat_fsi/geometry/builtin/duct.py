"""Rectangular duct [0,length] × [0,height] × [0,width] (3D): inlet x = 0 (1), outlet x = length (2), walls
the four other faces (3).

Structured tetrahedra as ``cube`` (6 per hexahedron, mirrored diagonals) of size height / (2·2^level):
divisions round(side / size) per side (at least 1). With exact data on the side faces z = 0 and z = width it
is the 3D slab of the 2D ``channel`` (tests/test_three_d.py: micropolar Poiseuille).
"""

from types import ModuleType
from typing import Any, ClassVar, Literal

from ...tags import CELL_TAGS, FACET_TAGS
from .._model import GeometryBase, PositiveFloat
from .cube import structured_box


class Duct(GeometryBase):
    """Duct of ``length`` (x), ``height`` (y) and ``width`` (z); the flow enters at x = 0."""

    DIM: ClassVar[int] = 3
    name: Literal["duct"] = "duct"
    """3D rectangular duct [0, length] × [0, height] × [0, width], structured tetrahedra; facets ``inlet``
    (x = 0), ``outlet`` (x = length), ``walls`` (the four other faces)."""
    length: PositiveFloat = 2.0
    """Length in x (m), the flow direction."""
    height: PositiveFloat = 1.0
    """Height in y (m); the cells' size is height / (2·2^level)."""
    width: PositiveFloat = 1.0
    """Width in z (m)."""

    def msh_params(self) -> dict[str, Any]:
        return {"length": float(self.length), "height": float(self.height), "width": float(self.width)}


def describe(params: dict[str, Any]) -> dict[str, Any]:
    """Tags, named points and dimensions of the geometry."""
    L, H, W = params["length"], params["height"], params["width"]
    return {
        "cell_tags": {"fluid": CELL_TAGS["fluid"]},
        "facet_tags": {k: FACET_TAGS[k] for k in ("inlet", "outlet", "walls")},
        "points": {"centre": (L / 2, H / 2, W / 2)},
        "length": L,
        "height": H,
        "width": W,
    }


def divisions(scale: float, params: dict[str, Any]) -> tuple[int, int, int]:
    size = params["height"] * scale / 2
    return tuple(max(1, round(params[key] / size)) for key in ("length", "height", "width"))


def estimate_cells(scale: float, params: dict[str, Any]) -> int:
    """Number of tetrahedra ``build`` makes (exact; cheap, before gmsh runs)."""
    nx, ny, nz = divisions(scale, params)
    return 6 * nx * ny * nz


def build(gmsh: ModuleType, scale: float, params: dict[str, Any]) -> None:
    """Write the structured tetrahedral mesh into the current gmsh session."""
    sides = (params["length"], params["height"], params["width"])
    structured_box(gmsh, sides, divisions(scale, params),
                   lambda axis, at_end: ("outlet" if at_end else "inlet") if axis == 0 else "walls")
