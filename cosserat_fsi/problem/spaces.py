"""The mixed space of a scene: velocity P2 × micro-rotation P2 × pressure P1 (seed §5.2).

The micro-rotation is built only when the scene has micropolar effects: a scalar (ω e_z) in 2D, a vector
with three components in 3D.
"""

from __future__ import annotations

from dataclasses import dataclass

from .. import compat


@dataclass
class MixedSpace:
    """The monolithic space and its collapsed components (with their dof maps into W)."""

    W: object
    names: tuple  # field names in the order of W's sub-spaces
    collapsed: dict  # name -> (collapsed space, dofs in W)

    def index(self, name: str) -> int:
        return self.names.index(name)

    def sub(self, name: str):
        return self.W.sub(self.index(name))

    def space(self, name: str):
        return self.collapsed[name][0]

    def dofs(self, name: str):
        return self.collapsed[name][1]


def mixed_space(mesh, micro_rotation: bool) -> MixedSpace:
    gdim = mesh.geometry.dim
    elements = {"velocity": compat.element(mesh, "Lagrange", 2, shape=(gdim,))}
    if micro_rotation:
        elements["micro_rotation"] = compat.element(mesh, "Lagrange", 2, shape=(3,) if gdim == 3 else None)
    elements["pressure"] = compat.element(mesh, "Lagrange", 1)
    W = compat.function_space(mesh, compat.mixed_element(elements.values()))
    names = tuple(elements)
    collapsed = {name: compat.collapse(W.sub(i)) for i, name in enumerate(names)}
    return MixedSpace(W=W, names=names, collapsed=collapsed)
