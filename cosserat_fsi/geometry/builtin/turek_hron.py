"""Turek-Hron FSI benchmark: channel [0,2.5]x[0,0.41], cylinder (0.2,0.2) r=0.05, flag [~0.249,0.6]x[0.19,0.21].

``flag: solid``: the flag is its own surface (cells tag 2), conforming with the fluid (OCC fragment);
its top, bottom and right edges are interior facets tagged ``interface`` (5), the arc where it is clamped
to the cylinder is tagged ``cylinder`` (4) like the rest of the circle. ``flag: rigid``: the flag is a hole
in the fluid, its three free edges are exterior facets tagged 5. A = (0.6, 0.2) and B = (0.15, 0.2) are
mesh vertices. Sizes: Threshold on the distance to cylinder and flag, h = 0.014 on them growing to
0.07 at distance 0.3, both halved per level ("seed" scales level 0 by ``SEED_SCALE``). ``flag_mesh:
structured``: the flag's triangles transfinite, 2, 4, 8, 16 across on levels 0-3 (or ``flag_cells_across``) and
square along it (the fluid's sizes unchanged); its tip deflection converges more regularly under refinement
(docs/validation.md).

Vertex counts (gmsh 4.8; 4.15 differs by < 0.3 %), L0 / L1 / L2 / L3 / seed:
solid flag 784 / 2,843 / 10,916 / 42,416 / 2,179 (seed paper: 2,199); rigid 758 / 2,723 / 10,378 / 40,211 / 2,087.
"""

from types import ModuleType
from typing import Any, ClassVar, Literal

import math

from ...tags import CELL_TAGS, FACET_TAGS
from pydantic import model_validator

from .. import _gmsh
from .._model import GeometryBase

LENGTH, HEIGHT = 2.5, 0.41
CENTRE, RADIUS = (0.2, 0.2), 0.05
FLAG_END, FLAG_Y = 0.6, (0.19, 0.21)
FLAG_START = CENTRE[0] + math.sqrt(RADIUS**2 - (FLAG_Y[1] - CENTRE[1]) ** 2)  # 0.24899
SEED_SCALE = 0.575
MAX_FLAG_CELLS_ACROSS = 128  # level 6's structured flag (the levels stop at 6)
H_MIN, H_MAX, DIST_MAX = 0.014, 0.07, 0.3


class TurekHron(GeometryBase):
    """Channel 2.5 x 0.41 with a cylinder and a flag: ``flag: solid`` (an elastic flag, FSI) or ``rigid`` (a hole
    in the fluid, CFD); ``flag_mesh``: ``unstructured`` (default) or ``structured`` (transfinite, 2·2^level
    cells across the flag)."""

    SEED: ClassVar[bool] = True
    INFLOW: ClassVar[bool] = True
    name: Literal["turek_hron"] = "turek_hron"
    """Turek–Hron: channel 2.5 × 0.41, cylinder at (0.2, 0.2) of radius 0.05, flag [0.249, 0.6] × [0.19,
    0.21]; facets ``inlet``, ``outlet``, ``walls``, ``cylinder``, ``interface``; points A (flag tip), B. Needs
    an inflow section."""
    flag: Literal["solid", "rigid"] = "solid"
    """``solid``: an elastic flag (FSI; needs a solid section); ``rigid``: a hole in the fluid (CFD)."""
    flag_mesh: Literal["unstructured", "structured"] = "unstructured"
    """The flag's triangles (flag solid): ``unstructured`` or ``structured`` (transfinite, 2·2^level cells
    across); the tip deflection converges more regularly on the structured one."""
    flag_cells_across: int | None = None
    """With ``flag_mesh: structured``: the cells across the flag (even, 2 to 128 = level 6's; default
    2·2^level), square cells along it; the fluid's sizes stay the level's, graded from the flag's edges. A
    finer flag at a level's fluid cost (FSI3's ux(A): docs/fsi3_table.md)."""

    @property
    def solid_cells(self) -> bool:
        return self.flag == "solid"

    @model_validator(mode="after")
    def _flag_mesh(self):
        if self.flag_mesh == "structured" and self.flag != "solid":
            raise ValueError("geometry.flag_mesh: structured needs geometry.flag solid")
        if self.flag_cells_across is not None:
            if self.flag_mesh != "structured":
                raise ValueError("geometry.flag_cells_across: only with geometry.flag_mesh structured")
            if not 2 <= self.flag_cells_across <= MAX_FLAG_CELLS_ACROSS or self.flag_cells_across % 2:
                raise ValueError(f"geometry.flag_cells_across: must be even, 2 to {MAX_FLAG_CELLS_ACROSS} "
                                 f"(level 6's flag; got {self.flag_cells_across})")
        return self

    def msh_params(self) -> dict[str, Any]:
        params = {"flag": self.flag}
        if self.flag_mesh == "structured":  # (unstructured meshes keep their cache key)
            params["flag_mesh"] = self.flag_mesh
        if self.flag_cells_across is not None:
            params["flag_cells_across"] = self.flag_cells_across
        return params


def describe(params: dict[str, Any]) -> dict[str, Any]:
    """Tags, named points and dimensions of the geometry."""
    cells = ["fluid", "solid"] if params["flag"] == "solid" else ["fluid"]
    return {
        "cell_tags": {k: CELL_TAGS[k] for k in cells},
        "facet_tags": {k: FACET_TAGS[k] for k in ("inlet", "outlet", "walls", "cylinder", "interface")},
        "points": {"A": (FLAG_END, CENTRE[1]), "B": (CENTRE[0] - RADIUS, CENTRE[1])},
        "length": LENGTH,
        "height": HEIGHT,
        "cylinder": {"centre": CENTRE, "radius": RADIUS},
        "flag": {"x": (FLAG_START, FLAG_END), "y": FLAG_Y},
    }


def build(gmsh: ModuleType, scale: float, params: dict[str, Any]) -> None:
    """Create and mesh the model in the current gmsh session; ``scale`` multiplies all element sizes."""
    occ = gmsh.model.occ
    box = occ.addRectangle(0, 0, 0, LENGTH, HEIGHT)
    disk = _gmsh.occ_disk(gmsh, *CENTRE, RADIUS)
    (y0, y1), ym = FLAG_Y, CENTRE[1]
    # the flag rectangle from the cylinder centre, its tip split at A; the disk is cut out of it below
    corners = [(CENTRE[0], y0), (FLAG_END, y0), (FLAG_END, ym), (FLAG_END, y1), (CENTRE[0], y1)]
    pts = [occ.addPoint(x, y, 0) for x, y in corners]
    flag = occ.addPlaneSurface([occ.addCurveLoop([occ.addLine(pts[i], pts[(i + 1) % 5]) for i in range(5)])])
    fluid, _ = occ.cut([(2, box)], [(2, disk), (2, flag)], removeTool=False)
    if params["flag"] == "solid":
        solid, _ = occ.cut([(2, flag)], [(2, disk)])
        _, children = occ.fragment(fluid, solid)
        n = len(fluid)
        fluid = [t for parts in children[:n] for _, t in parts]
        solid = [t for parts in children[n:] for _, t in parts]
    else:
        occ.remove([(2, disk), (2, flag)], recursive=True)
        fluid, solid = [t for _, t in fluid], []
    occ.synchronize()
    _gmsh.add_physical(gmsh, 2, fluid, "fluid")
    if solid:
        _gmsh.add_physical(gmsh, 2, solid, "solid")
    curves = _gmsh.classify_channel_curves(gmsh, LENGTH, HEIGHT, (*CENTRE, RADIUS))
    for name, tags in curves.items():
        _gmsh.add_physical(gmsh, 1, tags, name)
    if params.get("flag_mesh") == "structured":
        _structured_flag(gmsh, solid, curves, scale, params.get("flag_cells_across"))
    near = curves["cylinder"] + curves["interface"]
    _gmsh.threshold_field(gmsh, near, H_MIN * scale, H_MAX * scale, 0.0, DIST_MAX)
    gmsh.model.mesh.generate(2)


def _structured_flag(gmsh, solid: list[int], curves: dict, scale: float, across: int | None = None) -> None:
    """Transfinite triangles in the flag: ``across`` cells across (default 2/``scale``: 2, 4, 8, ... on levels
    0, 1, 2), square cells along it; its corners the arc's ends and the tip's two corners (A splits the tip)."""
    across = across or 2 * max(1, round(1.0 / scale))
    thickness = FLAG_Y[1] - FLAG_Y[0]
    along = round((FLAG_END - FLAG_START) / (thickness / across))
    (surface,) = solid
    mesh = gmsh.model.mesh
    boundary = [abs(t) for _, t in gmsh.model.getBoundary([(2, surface)], oriented=False)]
    arc = [c for c in boundary if c in curves.get("cylinder", [])]  # the clamp (split at y = 0.2 or not)
    tip = [c for c in boundary if abs(_gmsh.curve_midpoint(gmsh, c)[0] - FLAG_END) < 1e-9]  # split at A
    for curve in boundary:  # the clamp and the tip share the cells across; the top and bottom are along
        side = arc if curve in arc else tip if curve in tip else None
        mesh.setTransfiniteCurve(curve, (across // len(side) if side else along) + 1)
    points = {abs(t): gmsh.model.getValue(0, abs(t), [])[:2]
              for _, t in gmsh.model.getBoundary([(2, surface)], oriented=False, recursive=True)}
    corners = [t for t, (x, y) in points.items() if abs(y - CENTRE[1]) > 1e-9]  # not A nor the arc's middle
    middle = (0.5 * (FLAG_START + FLAG_END), CENTRE[1])  # the corners in order around the flag
    corners.sort(key=lambda t: math.atan2(points[t][1] - middle[1], points[t][0] - middle[0]))
    mesh.setTransfiniteSurface(surface, "Left", corners)
