"""Schäfer–Turek 3D flow around a cylinder (benchmarks 3D-1Z/2Z/3Z): duct [0,2.5]×[0,0.41]×[0,0.41], a
cylinder of diameter 0.1 spanning the duct in z, axis at (x, y) = (0.5, 0.2) (Schäfer & Turek 1996; the
setup of Bayraktar, Mierka & Turek 2012 and John 2002, shared/reference/three_d_literature.md §A).

Facets: inlet x = 0 (1), outlet x = 2.5 (2), walls = the four other duct faces (3), cylinder (4).
Unstructured tetrahedra (gmsh OCC box minus cylinder, Delaunay), size h = H_MIN on the cylinder growing
linearly to H_MAX at distance DIST_MAX, both halved per level. Vertex counts (gmsh 4.8; 4.15 differs
slightly): docs/validation_3d.md, "Schäfer–Turek 3D-1Z".
"""

from types import ModuleType
from typing import Any, ClassVar, Literal

from ...tags import CELL_TAGS, FACET_TAGS
from .._gmsh import add_physical, threshold_field
from .._model import GeometryBase

LENGTH, HEIGHT = 2.5, 0.41
CENTRE, RADIUS = (0.5, 0.2), 0.05
H_MIN, H_MAX, DIST_MAX = 0.025, 0.1, 0.4
_EPS = 1e-8


class SchaeferTurek3D(GeometryBase):
    """Square duct 2.5 × 0.41 × 0.41 with a cylinder across it (no parameters)."""

    DIM: ClassVar[int] = 3
    INFLOW: ClassVar[bool] = True
    name: Literal["schaefer_turek_3d"] = "schaefer_turek_3d"
    """Schäfer–Turek 3D (3D-1Z/2Z/3Z): duct 2.5 × 0.41 × 0.41, a cylinder of diameter 0.1 across it at (0.5,
    0.2); facets ``inlet``, ``outlet``, ``walls``, ``cylinder``. Needs an inflow section."""


def describe(params: dict[str, Any]) -> dict[str, Any]:
    """Tags, named points and dimensions of the geometry."""
    z = HEIGHT / 2 + 0.005  # the benchmark's Δp points: mid-height + 0.005
    return {
        "cell_tags": {"fluid": CELL_TAGS["fluid"]},
        "facet_tags": {k: FACET_TAGS[k] for k in ("inlet", "outlet", "walls", "cylinder")},
        "points": {"a1": (CENTRE[0] - RADIUS, CENTRE[1], z), "a2": (CENTRE[0] + RADIUS, CENTRE[1], z)},
        "length": LENGTH,
        "height": HEIGHT,
        "width": HEIGHT,
        "cylinder": {"centre": CENTRE, "radius": RADIUS},
    }


def _facet_name(gmsh: ModuleType, tag: int) -> str:
    x, y, z = gmsh.model.occ.getCenterOfMass(2, tag)
    if abs(x) < _EPS:
        return "inlet"
    if abs(x - LENGTH) < _EPS:
        return "outlet"
    if min(abs(y), abs(y - HEIGHT), abs(z), abs(z - HEIGHT)) < _EPS:
        return "walls"
    return "cylinder"


def build(gmsh: ModuleType, scale: float, params: dict[str, Any]) -> None:
    """Create and mesh the model in the current gmsh session; ``scale`` multiplies all element sizes."""
    occ = gmsh.model.occ
    box = occ.addBox(0, 0, 0, LENGTH, HEIGHT, HEIGHT)
    cylinder = occ.addCylinder(*CENTRE, 0, 0, 0, HEIGHT, RADIUS)
    fluid, _ = occ.cut([(3, box)], [(3, cylinder)])
    occ.synchronize()
    add_physical(gmsh, 3, [t for _, t in fluid], "fluid", tdim=3)
    groups: dict[str, list[int]] = {}
    for _, tag in gmsh.model.getEntities(2):
        groups.setdefault(_facet_name(gmsh, tag), []).append(tag)
    for name, tags in groups.items():
        add_physical(gmsh, 2, tags, name, tdim=3)
    threshold_field(gmsh, groups["cylinder"], H_MIN * scale, H_MAX * scale, 0.0, DIST_MAX, dim=2, sampling=100)
    gmsh.option.setNumber("Mesh.Algorithm3D", 1)  # Delaunay (deterministic single-threaded)
    gmsh.model.mesh.generate(3)
