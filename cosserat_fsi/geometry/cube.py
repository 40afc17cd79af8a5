"""Cube cavity [0,length]^3 (3D): walls = five sides (3), lid = top y = length (6).

Structured tetrahedra (6 per hexahedron, the diagonals mirrored hexahedron by hexahedron, written into
gmsh as a discrete mesh), 2 divisions per side at level 0, doubled
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


def _tetrahedra(n: int):
    """Node coordinates (unit cube, (n+1)³ grid) and the tetrahedra: each hexahedron cut into the 6 tetrahedra
    of its diagonal (Kuhn), mirrored in every direction with the parity of its index, so that the diagonal
    of each corner hexahedron passes through the cube's corner. (With one diagonal direction everywhere, two
    corner tetrahedra have all their edges on the boundary, and their corner pressure is left free: two
    spurious P1 pressure modes of the Taylor–Hood pair.)"""
    import itertools

    import numpy as np

    grid = np.linspace(0.0, 1.0, n + 1)
    X, Y, Z = np.meshgrid(grid, grid, grid, indexing="ij")
    points = np.column_stack([X.ravel(), Y.ravel(), Z.ravel()])

    def node(i, j, k):
        return (i * (n + 1) + j) * (n + 1) + k

    cells = []
    for i, j, k in itertools.product(range(n), repeat=3):
        for order in itertools.permutations(range(3)):
            local, path = [0, 0, 0], [(0, 0, 0)]
            for axis in order:
                local[axis] = 1
                path.append(tuple(local))
            cells.append([node(*(c + (1 - a if c % 2 else a) for c, a in zip((i, j, k), vertex)))
                          for vertex in path])
    return points, np.array(cells)


def build(gmsh: ModuleType, scale: float, params: dict[str, Any]) -> None:
    """Write the structured tetrahedral mesh (2 / ``scale`` divisions per side) into the current gmsh
    session as discrete entities: the volume, the walls and the lid."""
    import numpy as np

    n, size = divisions(scale), params["size"]
    points, cells = _tetrahedra(n)
    points = points * size
    volume = gmsh.model.addDiscreteEntity(3)
    surfaces = {name: gmsh.model.addDiscreteEntity(2) for name in ("walls", "lid")}
    tags = np.arange(1, len(points) + 1)
    gmsh.model.mesh.addNodes(3, volume, tags, points.ravel())
    gmsh.model.mesh.addElementsByType(volume, 4, [], (cells + 1).ravel())  # 4: 4-node tetrahedron
    faces = np.concatenate([cells[:, [0, 1, 2]], cells[:, [0, 1, 3]], cells[:, [0, 2, 3]], cells[:, [1, 2, 3]]])
    on_boundary = {}
    for axis in range(3):
        for value in (0.0, size):
            flat = np.all(np.abs(points[faces][:, :, axis] - value) < 1e-12 * size, axis=1)
            name = "lid" if (axis == 1 and value == size) else "walls"
            on_boundary.setdefault(name, []).append(faces[flat])
    for name, groups in on_boundary.items():
        triangles = np.concatenate(groups)
        gmsh.model.mesh.addElementsByType(surfaces[name], 2, [], (triangles + 1).ravel())  # 2: triangle
    gmsh.model.addPhysicalGroup(3, [volume], CELL_TAGS["fluid"])
    gmsh.model.setPhysicalName(3, CELL_TAGS["fluid"], "fluid")
    for name, surface in surfaces.items():
        gmsh.model.addPhysicalGroup(2, [surface], FACET_TAGS[name])
        gmsh.model.setPhysicalName(2, FACET_TAGS[name], name)
