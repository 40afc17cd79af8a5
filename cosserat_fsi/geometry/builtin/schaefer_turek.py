"""Schaefer-Turek 2D flow around a cylinder: channel [0,2.2]x[0,0.41], cylinder (0.2,0.2) r=0.05.

The circle is split into quarter arcs so that a1 = (0.15, 0.2) and a2 = (0.25, 0.2) (front and back of
the cylinder, pressure-difference points) are mesh vertices. Sizes: Threshold on the distance to the
cylinder, h = 0.01 on it growing to 0.06 at distance 0.3, both halved per level.

Vertex counts (gmsh 4.8; 4.15 differs by < 0.3 %): L0 687, L1 2,517, L2 9,700, L3 38,064.
"""

from types import ModuleType
from typing import Any, ClassVar, Literal

from ...tags import CELL_TAGS, FACET_TAGS
from .. import _gmsh
from .._model import GeometryBase

LENGTH, HEIGHT = 2.2, 0.41
CENTRE, RADIUS = (0.2, 0.2), 0.05
H_MIN, H_MAX, DIST_MAX = 0.01, 0.06, 0.3


class SchaeferTurek(GeometryBase):
    """Channel 2.2 x 0.41 with a cylinder (no parameters)."""

    INFLOW: ClassVar[bool] = True
    name: Literal["schaefer_turek"] = "schaefer_turek"
    """Schäfer–Turek 2D flow around a cylinder: channel 2.2 × 0.41, cylinder at (0.2, 0.2) of radius 0.05;
    facets ``inlet``, ``outlet``, ``walls``, ``cylinder``; points a1, a2 (the pressure difference). Needs an
    inflow section."""


def describe(params: dict[str, Any]) -> dict[str, Any]:
    """Tags, named points and dimensions of the geometry."""
    return {
        "cell_tags": {"fluid": CELL_TAGS["fluid"]},
        "facet_tags": {k: FACET_TAGS[k] for k in ("inlet", "outlet", "walls", "cylinder")},
        "points": {"a1": (CENTRE[0] - RADIUS, CENTRE[1]), "a2": (CENTRE[0] + RADIUS, CENTRE[1])},
        "length": LENGTH,
        "height": HEIGHT,
        "cylinder": {"centre": CENTRE, "radius": RADIUS},
    }


def build(gmsh: ModuleType, scale: float, params: dict[str, Any]) -> None:
    """Create and mesh the model in the current gmsh session; ``scale`` multiplies all element sizes."""
    occ = gmsh.model.occ
    box, disk = occ.addRectangle(0, 0, 0, LENGTH, HEIGHT), _gmsh.occ_disk(gmsh, *CENTRE, RADIUS)
    fluid, _ = occ.cut([(2, box)], [(2, disk)])
    occ.synchronize()
    _gmsh.add_physical(gmsh, 2, [t for _, t in fluid], "fluid")
    curves = _gmsh.classify_channel_curves(gmsh, LENGTH, HEIGHT, (*CENTRE, RADIUS))
    for name, tags in curves.items():
        _gmsh.add_physical(gmsh, 1, tags, name)
    _gmsh.threshold_field(gmsh, curves["cylinder"], H_MIN * scale, H_MAX * scale, 0.0, DIST_MAX)
    gmsh.model.mesh.generate(2)
