"""Turek–Hron FSI geometry extruded in z (3D): the square duct [0,2.5]×[0,0.41]×[0,width] of Schäfer–Turek 3D,
a cylinder (axis (0.2, 0.2), radius 0.05) spanning the duct in z, and an elastic flag [~0.249, 0.6]×[0.19, 0.21]
clamped to the cylinder and spanning ``flag_width`` of the duct's width in its middle (z ∈ [(W − b)/2, (W + b)/2]).

This is the project's own 3D variant: the 2D benchmark's cross-section (Turek & Hron 2006) and the
3D duct of Schäfer & Turek 1996 (width 0.41); no published reference values exist for it, so it is a
scene for robustness, parallel consistency and cost, not a validation case.

Tags: cells ``fluid`` (1) and ``solid`` (2), conforming (OCC fragment); inlet x = 0 (1), outlet x = 2.5 (2),
walls = the four other duct faces (3), cylinder (4, including the face where the flag is clamped), the flag's
five other faces ``interface`` (5, interior facets). A = (0.6, 0.2, width/2), the middle of the flag's tip.
Unstructured tetrahedra (Delaunay), size H_MIN on the flag and the cylinder growing linearly to H_MAX at
distance DIST_MAX, both halved per level (level 0: one tetrahedron across the flag's thickness).
"""

import math
from types import ModuleType
from typing import Any, ClassVar, Literal

from pydantic import Field, model_validator

from ...tags import CELL_TAGS, FACET_TAGS
from .._gmsh import add_physical, threshold_field
from .._model import GeometryBase

LENGTH, HEIGHT = 2.5, 0.41
CENTRE, RADIUS = (0.2, 0.2), 0.05
FLAG_END, FLAG_Y = 0.6, (0.19, 0.21)
FLAG_START = CENTRE[0] + math.sqrt(RADIUS**2 - (FLAG_Y[1] - CENTRE[1]) ** 2)  # 0.24899
H_MIN, H_MAX, DIST_MAX = 0.03, 0.15, 0.4
_EPS = 1e-7


class TurekHron3D(GeometryBase):
    """Square duct 2.5 × 0.41 × ``width`` with a cylinder across it and a flag of span ``flag_width``."""

    DIM: ClassVar[int] = 3
    INFLOW: ClassVar[bool] = True
    name: Literal["turek_hron_3d"] = "turek_hron_3d"
    """Turek–Hron extruded in z (the project's own 3D variant, no published reference): duct 2.5 × 0.41 ×
    width, a cylinder across it, an elastic flag in the middle; facets as turek_hron; point A (tip middle).
    Needs inflow and solid sections."""
    width: float = Field(default=0.41, gt=0.0, le=10.0)
    """Width of the duct in z (m)."""
    flag_width: float = Field(default=0.2, gt=0.0, le=10.0)
    """Span of the flag in z (m), centred in the duct; less than ``width``."""

    @model_validator(mode="after")
    def _flag_inside(self):
        if self.flag_width >= self.width:
            raise ValueError(f"geometry.flag_width: must be < width ({self.width!r}; got {self.flag_width!r})")
        return self

    @property
    def solid_cells(self) -> bool:
        return True

    def msh_params(self) -> dict[str, Any]:
        return {"width": float(self.width), "flag_width": float(self.flag_width)}


def _flag_z(params: dict[str, Any]) -> tuple[float, float]:
    W, b = params["width"], params["flag_width"]
    return (W - b) / 2, (W + b) / 2


def describe(params: dict[str, Any]) -> dict[str, Any]:
    """Tags, named points and dimensions of the geometry."""
    W = params["width"]
    return {
        "cell_tags": {k: CELL_TAGS[k] for k in ("fluid", "solid")},
        "facet_tags": {k: FACET_TAGS[k] for k in ("inlet", "outlet", "walls", "cylinder", "interface")},
        "points": {"A": (FLAG_END, CENTRE[1], W / 2)},
        "length": LENGTH,
        "height": HEIGHT,
        "width": W,
        "cylinder": {"centre": CENTRE, "radius": RADIUS},
        "flag": {"x": (FLAG_START, FLAG_END), "y": FLAG_Y, "z": _flag_z(params)},
    }


def _facet_name(gmsh: ModuleType, tag: int, params: dict[str, Any]) -> str:
    x, y, z = gmsh.model.occ.getCenterOfMass(2, tag)
    W = params["width"]
    if abs(x) < _EPS:
        return "inlet"
    if abs(x - LENGTH) < _EPS:
        return "outlet"
    if min(abs(y), abs(y - HEIGHT), abs(z), abs(z - W)) < _EPS:
        return "walls"
    lo, hi = gmsh.model.getBoundingBox(2, tag)[:3], gmsh.model.getBoundingBox(2, tag)[3:]
    z0, z1 = _flag_z(params)
    in_flag = (lo[0] > FLAG_START - 1e-3 and hi[0] < FLAG_END + 1e-3 and lo[1] > FLAG_Y[0] - 1e-3
               and hi[1] < FLAG_Y[1] + 1e-3 and lo[2] > z0 - 1e-3 and hi[2] < z1 + 1e-3)
    return "interface" if in_flag and x > FLAG_START + 1e-3 else "cylinder"


def build(gmsh: ModuleType, scale: float, params: dict[str, Any]) -> None:
    """Create and mesh the model in the current gmsh session; ``scale`` multiplies all element sizes."""
    occ = gmsh.model.occ
    W = params["width"]
    z0, z1 = _flag_z(params)
    duct = occ.addBox(0, 0, 0, LENGTH, HEIGHT, W)
    cylinder = occ.addCylinder(*CENTRE, 0, 0, 0, W, RADIUS)
    flag_box = occ.addBox(CENTRE[0], FLAG_Y[0], z0, FLAG_END - CENTRE[0], FLAG_Y[1] - FLAG_Y[0], z1 - z0)
    flag, _ = occ.cut([(3, flag_box)], [(3, cylinder)], removeTool=False)
    fluid, _ = occ.cut([(3, duct)], [(3, cylinder)])
    fluid, _ = occ.cut(fluid, flag, removeTool=False)
    _, children = occ.fragment(fluid, flag)
    n = len(fluid)
    fluid = [t for parts in children[:n] for _, t in parts]
    solid = [t for parts in children[n:] for _, t in parts]
    occ.synchronize()
    for name, tags in (("fluid", fluid), ("solid", solid)):
        add_physical(gmsh, 3, tags, name, tdim=3)
    groups: dict[str, list[int]] = {}
    for _, tag in gmsh.model.getEntities(2):
        groups.setdefault(_facet_name(gmsh, tag, params), []).append(tag)
    for name, tags in groups.items():
        add_physical(gmsh, 2, tags, name, tdim=3)
    tip = [t for t in groups["interface"] if abs(gmsh.model.occ.getCenterOfMass(2, t)[0] - FLAG_END) < _EPS]
    point_A = occ.addPoint(FLAG_END, CENTRE[1], W / 2)
    occ.synchronize()
    gmsh.model.mesh.embed(0, [point_A], 2, tip[0])  # A is a mesh vertex (observables: the tip displacement)
    threshold_field(gmsh, groups["cylinder"] + groups["interface"], H_MIN * scale, H_MAX * scale, 0.0, DIST_MAX,
                    dim=2, sampling=60)
    gmsh.option.setNumber("Mesh.Algorithm3D", 1)  # Delaunay (deterministic single-threaded)
    gmsh.model.mesh.generate(3)
