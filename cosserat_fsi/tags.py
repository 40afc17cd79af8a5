"""The one table of physical tags written into every mesh (geometry/) and read by the solver.

Cells: fluid 1, solid 2. Facets: inlet 1, outlet 2, walls 3, cylinder 4, interface 5 (fluid-solid boundary),
lid 6 (driven cavity top), clamp 7 (clamped edge of a free flag). Each geometry's ``describe`` lists the
tags it uses.
"""

from __future__ import annotations

FLUID, SOLID = 1, 2
CELL_TAGS: dict[str, int] = {"fluid": FLUID, "solid": SOLID}
FACET_TAGS: dict[str, int] = {"inlet": 1, "outlet": 2, "walls": 3, "cylinder": 4, "interface": 5, "lid": 6,
                              "clamp": 7}
