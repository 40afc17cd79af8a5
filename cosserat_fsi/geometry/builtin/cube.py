"""Cube cavity [0,length]^3 (3D): walls = five sides (3), lid = top y = length (6).

Structured tetrahedra (6 per hexahedron, the diagonals mirrored hexahedron by hexahedron, written into
gmsh as a discrete mesh), 2 divisions per side at level 0, doubled
per level: L0: 27 vertices, 48 cells; L1: 125, 384; L2: 729, 3,072; ... The 3D analogue of ``square``
(a lid-driven cavity) and the domain of the 3D manufactured solutions.
"""

from types import ModuleType
from typing import Any, ClassVar, Literal

from ...tags import CELL_TAGS, FACET_TAGS
from .._model import GeometryBase, PositiveFloat


class Cube(GeometryBase):
    """Cube cavity of side ``length`` (default 1) with a lid at y = length."""

    DIM: ClassVar[int] = 3
    name: Literal["cube"] = "cube"
    """3D cube cavity [0, length]³, structured tetrahedra (2·2^level divisions per side); facets ``lid`` (the
    top y = length) and ``walls`` (the five other sides)."""
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


def _tetrahedra(nx: int, ny: int, nz: int):
    """Node coordinates (unit box, (nx+1)(ny+1)(nz+1) grid) and the tetrahedra: each hexahedron cut into the 6
    tetrahedra of its diagonal (Kuhn), mirrored in every direction with the parity of its index, so that the
    diagonal of each corner hexahedron passes through the box's corner (with an even number of divisions).
    (With one diagonal direction everywhere, two corner tetrahedra have all their edges on the boundary and
    their corner pressure is left free: two spurious P1 pressure modes of the Taylor–Hood pair.)"""
    import itertools

    import numpy as np

    X, Y, Z = np.meshgrid(*(np.linspace(0.0, 1.0, n + 1) for n in (nx, ny, nz)), indexing="ij")
    points = np.column_stack([X.ravel(), Y.ravel(), Z.ravel()])

    def node(i, j, k):
        return (i * (ny + 1) + j) * (nz + 1) + k

    cells = []
    for i, j, k in itertools.product(range(nx), range(ny), range(nz)):
        for order in itertools.permutations(range(3)):
            local, path = [0, 0, 0], [(0, 0, 0)]
            for axis in order:
                local[axis] = 1
                path.append(tuple(local))
            cells.append([node(*(c + (1 - a if c % 2 else a) for c, a in zip((i, j, k), vertex)))
                          for vertex in path])
    return points, np.array(cells)


def structured_box(gmsh: ModuleType, sides, divisions_xyz, face_name) -> None:
    """Write the structured tetrahedral mesh of [0, sides[0]] × [0, sides[1]] × [0, sides[2]] into the current
    gmsh session as discrete entities: the fluid volume and one surface per facet name; ``face_name(axis,
    at_end)`` names the face x_axis = 0 (``at_end`` False) or x_axis = side."""
    import numpy as np

    points, cells = _tetrahedra(*divisions_xyz)
    points = points * np.asarray(sides, dtype=float)
    volume = gmsh.model.addDiscreteEntity(3)
    gmsh.model.mesh.addNodes(3, volume, np.arange(1, len(points) + 1), points.ravel())
    gmsh.model.mesh.addElementsByType(volume, 4, [], (cells + 1).ravel())  # 4: 4-node tetrahedron
    faces = np.concatenate([cells[:, [0, 1, 2]], cells[:, [0, 1, 3]], cells[:, [0, 2, 3]], cells[:, [1, 2, 3]]])
    groups: dict[str, list] = {}
    for axis in range(3):
        for at_end in (False, True):
            value = sides[axis] if at_end else 0.0
            flat = np.all(np.abs(points[faces][:, :, axis] - value) < 1e-12 * max(sides), axis=1)
            groups.setdefault(face_name(axis, at_end), []).append(faces[flat])
    gmsh.model.addPhysicalGroup(3, [volume], CELL_TAGS["fluid"])
    gmsh.model.setPhysicalName(3, CELL_TAGS["fluid"], "fluid")
    for name, parts in groups.items():
        surface = gmsh.model.addDiscreteEntity(2)
        gmsh.model.mesh.addElementsByType(surface, 2, [], (np.concatenate(parts) + 1).ravel())  # 2: triangle
        gmsh.model.addPhysicalGroup(2, [surface], FACET_TAGS[name])
        gmsh.model.setPhysicalName(2, FACET_TAGS[name], name)


def build(gmsh: ModuleType, scale: float, params: dict[str, Any]) -> None:
    """Write the structured tetrahedral mesh (2 / ``scale`` divisions per side) into the current gmsh session."""
    n, size = divisions(scale), params["size"]
    structured_box(gmsh, (size, size, size), (n, n, n),
                   lambda axis, at_end: "lid" if (axis == 1 and at_end) else "walls")
