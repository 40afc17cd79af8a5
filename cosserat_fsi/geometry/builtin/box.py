"""Closed box [0,1]x[0,1] (energy test): fluid (1) around a solid disk (2) of ``radius`` (default 0.2)
centred at (0.5, 0.5).

Tags: cells ``fluid`` (1) and ``solid`` (2), conforming (OCC fragment); the four sides ``walls`` (3); the
circle ``interface`` (5, interior facets). The circle is four quarter arcs, so (0.5 +- r, 0.5) and
(0.5, 0.5 +- r) are vertices. ``radius`` must be < 0.5. Sizes: Threshold on the distance to the circle,
h = 0.04 on it growing to 0.06 at distance 0.1, both halved per level (unstructured, Frontal-Delaunay).

Vertex counts (defaults, gmsh 4.8; 4.15 differs by < 0.4 %), L0 / L1 / L2 / L3: 452 / 1,602 / 6,089 / 23,808.
"""

from types import ModuleType
from typing import Any, Literal


from ...tags import CELL_TAGS, FACET_TAGS
from .. import _gmsh
from pydantic import Field

from .._model import GeometryBase

SIZE, CENTRE = 1.0, (0.5, 0.5)
H_MIN, H_MAX, DIST_MAX = 0.04, 0.06, 0.1
_EPS = 1e-8


class Box(GeometryBase):
    """Closed unit box around a solid disk of ``radius`` (default 0.2, below 0.5)."""

    name: Literal["box"] = "box"
    """Closed box [0, 1] × [0, 1], fluid around a solid disk centred at (0.5, 0.5) (an energy test); facets
    ``walls`` (the four sides) and ``interface`` (the circle)."""
    radius: float = Field(default=0.2, ge=0.01, lt=0.5)  # below 0.01 the disk is smaller than its cells
    """Radius of the solid disk (m)."""

    @property
    def solid_cells(self) -> bool:
        return True

    def msh_params(self) -> dict[str, Any]:
        return {"radius": float(self.radius)}


def describe(params: dict[str, Any]) -> dict[str, Any]:
    """Tags, named points and dimensions of the geometry."""
    return {
        "cell_tags": {k: CELL_TAGS[k] for k in ("fluid", "solid")},
        "facet_tags": {k: FACET_TAGS[k] for k in ("walls", "interface")},
        "points": {"centre": CENTRE},
        "length": SIZE,
        "height": SIZE,
        "disk": {"centre": CENTRE, "radius": params["radius"]},
    }


def build(gmsh: ModuleType, scale: float, params: dict[str, Any]) -> None:
    """Create and mesh the model in the current gmsh session; ``scale`` multiplies all element sizes."""
    occ = gmsh.model.occ
    box, disk = occ.addRectangle(0, 0, 0, SIZE, SIZE), _gmsh.occ_disk(gmsh, *CENTRE, params["radius"])
    fluid, _ = occ.cut([(2, box)], [(2, disk)], removeTool=False)
    _, children = occ.fragment(fluid, [(2, disk)])
    n = len(fluid)
    fluid = [t for parts in children[:n] for _, t in parts]
    solid = [t for parts in children[n:] for _, t in parts]
    occ.synchronize()
    _gmsh.add_physical(gmsh, 2, fluid, "fluid")
    _gmsh.add_physical(gmsh, 2, solid, "solid")
    curves = {}
    for _, tag in gmsh.model.getEntities(1):
        x, y = _gmsh.curve_midpoint(gmsh, tag)
        on_side = min(abs(x), abs(x - SIZE), abs(y), abs(y - SIZE)) < _EPS
        curves.setdefault("walls" if on_side else "interface", []).append(tag)
    for name in ("walls", "interface"):
        _gmsh.add_physical(gmsh, 1, curves[name], name)
    _gmsh.threshold_field(gmsh, curves["interface"], H_MIN * scale, H_MAX * scale, 0.0, DIST_MAX)
    gmsh.model.mesh.generate(2)
