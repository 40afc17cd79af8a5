"""Cube cavity [0,length]^3 (3D): walls = five sides (3), lid = top y = length (6).

Structured tetrahedra (gmsh transfinite volume: 6 per hexahedron), 2 divisions per side at level 0, doubled
per level: L0: 27 vertices, 48 cells; L1: 125, 384; L2: 729, 3,072; ... The 3D analogue of ``square``
(a lid-driven cavity) and the domain of the 3D manufactured solutions.
"""

from types import ModuleType
from typing import Any, ClassVar, Literal

from ..tags import CELL_TAGS, FACET_TAGS
from ._model import GeometryBase, PositiveFloat


class Cube(GeometryBase):
    """Cube cavity of side ``length`` (default 1) with a lid at y = length."""

    DIM: ClassVar[int] = 3
    name: Literal["cube"] = "cube"
    length: PositiveFloat = 1.0

    def msh_params(self) -> dict[str, Any]:
        return {"size": float(self.length)}


def describe(params: dict[str, Any]) -> dict[str, Any]:
    """Tags, named points and dimensions of the geometry."""
    size = params["size"]
    return {
        "cell_tags": {"fluid": CELL_TAGS["fluid"]},
        "facet_tags": {k: FACET_TAGS[k] for k in ("walls", "lid")},
        "points": {"centre": (size / 2, size / 2, size / 2)},
        "length": size,
        "height": size,
        "width": size,
    }


def divisions(scale: float) -> int:
    return max(1, round(2 / scale))


def estimate_cells(scale: float, params: dict[str, Any]) -> int:
    """Number of tetrahedra ``build`` makes (exact; cheap, before gmsh runs)."""
    return 6 * divisions(scale) ** 3


def build(gmsh: ModuleType, scale: float, params: dict[str, Any]) -> None:
    """Create and mesh the model in the current gmsh session; 2 / ``scale`` divisions per side."""
    n, size = divisions(scale), params["size"]
    occ = gmsh.model.occ
    volume = occ.addBox(0, 0, 0, size, size, size)
    occ.synchronize()
    for _, curve in gmsh.model.getEntities(1):
        gmsh.model.mesh.setTransfiniteCurve(curve, n + 1)
    groups: dict[str, list[int]] = {}
    for _, surface in gmsh.model.getEntities(2):
        gmsh.model.mesh.setTransfiniteSurface(surface)
        y = gmsh.model.occ.getCenterOfMass(2, surface)[1]
        groups.setdefault("lid" if abs(y - size) < 1e-8 * size else "walls", []).append(surface)
    gmsh.model.mesh.setTransfiniteVolume(volume)
    gmsh.model.addPhysicalGroup(3, [volume], CELL_TAGS["fluid"])
    gmsh.model.setPhysicalName(3, CELL_TAGS["fluid"], "fluid")
    for name, surfaces in groups.items():
        gmsh.model.addPhysicalGroup(2, sorted(surfaces), FACET_TAGS[name])
        gmsh.model.setPhysicalName(2, FACET_TAGS[name], name)
    gmsh.model.mesh.generate(3)
