"""Shared gmsh helpers for the geometry builders: session options, size field, curve tagging, shapes.

Every function here expects the ``gmsh`` module as first argument: the builders import gmsh lazily.
"""

import math

from ..tags import CELL_TAGS, FACET_TAGS

_EPS = 1e-8


def configure(gmsh):
    """Make the initialised gmsh session silent, single-threaded, deterministic, writing MSH 4.1 ASCII."""
    for key, value in {
        "General.Terminal": 0,
        "General.NumThreads": 1,
        "Mesh.Algorithm": 6,  # Frontal-Delaunay
        "Mesh.RandomSeed": 1,
        "Mesh.ElementOrder": 1,
        "Mesh.MshFileVersion": 4.1,
        "Mesh.Binary": 0,
        "Mesh.SaveAll": 0,
        "Mesh.MeshSizeFromPoints": 0,
        "Mesh.MeshSizeFromCurvature": 0,
        "Mesh.MeshSizeExtendFromBoundary": 0,
    }.items():
        gmsh.option.setNumber(key, value)
    gmsh.model.add("cosserat_fsi")


def threshold_field(gmsh, entities, size_min, size_max, dist_min, dist_max, dim=1, sampling=400):
    """Background size: ``size_min`` within ``dist_min`` of ``entities`` (curves, ``dim`` = 1, or surfaces,
    ``dim`` = 2), growing linearly to ``size_max``; ``sampling`` points per entity for the distance."""
    field = gmsh.model.mesh.field
    dist = field.add("Distance")
    if dim == 1:
        field.setNumbers(dist, "CurvesList", entities)
    else:
        try:  # gmsh >= 4.9 calls it SurfacesList, gmsh 4.8 (Debian) FacesList
            field.setNumbers(dist, "SurfacesList", entities)
        except Exception:
            field.setNumbers(dist, "FacesList", entities)
    try:  # gmsh >= 4.11 calls it Sampling, gmsh 4.8 (Debian) NumPointsPerCurve
        field.setNumber(dist, "Sampling", sampling)
    except Exception:
        field.setNumber(dist, "NumPointsPerCurve", sampling)
    thr = field.add("Threshold")
    field.setNumber(thr, "InField", dist)
    for key, value in (("SizeMin", size_min), ("SizeMax", size_max), ("DistMin", dist_min), ("DistMax", dist_max)):
        field.setNumber(thr, key, value)
    field.setAsBackgroundMesh(thr)


def curve_midpoint(gmsh, tag):
    """Point at the parametric middle of curve ``tag`` (x, y)."""
    lo, hi = gmsh.model.getParametrizationBounds(1, tag)
    x, y, _ = gmsh.model.getValue(1, tag, [0.5 * (lo[0] + hi[0])])
    return x, y


def classify_channel_curves(gmsh, length, height, circle=None):
    """Map every model curve to a facet name: inlet/outlet/walls on the box, cylinder on the circle
    ``(xc, yc, r)``, interface otherwise. Returns {name: [curve tags]}."""
    groups = {}
    for _, tag in gmsh.model.getEntities(1):
        x, y = curve_midpoint(gmsh, tag)
        if abs(x) < _EPS:
            name = "inlet"
        elif abs(x - length) < _EPS:
            name = "outlet"
        elif abs(y) < _EPS or abs(y - height) < _EPS:
            name = "walls"
        elif circle and abs(math.hypot(x - circle[0], y - circle[1]) - circle[2]) < 1e-6:
            name = "cylinder"
        else:
            name = "interface"
        groups.setdefault(name, []).append(tag)
    return groups


def add_physical(gmsh, dim, tags, name, tdim=2):
    """Physical group of entities ``tags`` of dimension ``dim`` with the project's tag for ``name`` (cells
    when ``dim`` is the mesh's dimension ``tdim``, else facets)."""
    value = (CELL_TAGS if dim == tdim else FACET_TAGS)[name]
    gmsh.model.addPhysicalGroup(dim, sorted(tags), value)
    gmsh.model.setPhysicalName(dim, value, name)


def transfinite_rectangle(gmsh, length, height, nx, ny, facets, cells="fluid", split_right=False, left_radius=None):
    """Structured triangle mesh of [0,length]x[0,height] with nx x ny divisions ("Left" diagonals).

    ``facets`` names the bottom, right, top and left sides (equal names are merged into one group);
    ``cells`` names the cells. ``split_right``: (length, height/2) is a vertex too (``ny`` must be even).
    ``left_radius`` r: the left side is the arc of the circle of radius r centred at (−r, height/2) (a flag
    clamped on a cylinder): it passes through (0, height/2), its corners at x = √(r² − height²/4) − r."""
    geo = gmsh.model.geo
    x0 = 0.0 if left_radius is None else math.sqrt(left_radius ** 2 - height ** 2 / 4) - left_radius
    pts = [geo.addPoint(x, y, 0) for x, y in ((x0, 0), (length, 0), (length, height), (x0, height))]
    if split_right:
        mid = geo.addPoint(length, height / 2, 0)
        ends = [(pts[0], pts[1]), (pts[1], mid), (mid, pts[2]), (pts[2], pts[3]), (pts[3], pts[0])]
        sides, counts = (0, 1, 1, 2, 3), (nx, ny // 2, ny // 2, nx, ny)
    else:
        ends = [(pts[i], pts[(i + 1) % 4]) for i in range(4)]
        sides, counts = (0, 1, 2, 3), (nx, ny, nx, ny)
    lines = [geo.addLine(a, b) for a, b in ends]
    if left_radius is not None:  # the last side, top-left → bottom-left, on the circle
        geo.remove([(1, lines[-1])])
        centre = geo.addPoint(-left_radius, height / 2, 0)
        lines[-1] = geo.addCircleArc(ends[-1][0], centre, ends[-1][1])
    surface = geo.addPlaneSurface([geo.addCurveLoop(lines)])
    for line, n in zip(lines, counts):
        geo.mesh.setTransfiniteCurve(line, n + 1)
    geo.mesh.setTransfiniteSurface(surface, "Left", pts)
    geo.synchronize()
    add_physical(gmsh, 2, [surface], cells)
    for name in dict.fromkeys(facets):
        add_physical(gmsh, 1, [ln for ln, side in zip(lines, sides) if facets[side] == name], name)


def occ_disk(gmsh, xc, yc, r):
    """OCC disk made of four quarter arcs, so that (xc +- r, yc) and (xc, yc +- r) are vertices."""
    occ = gmsh.model.occ
    centre = occ.addPoint(xc, yc, 0)
    angles = [k * math.pi / 2 for k in range(4)]
    pts = [occ.addPoint(xc + r * math.cos(a), yc + r * math.sin(a), 0) for a in angles]
    arcs = [occ.addCircleArc(pts[k], centre, pts[(k + 1) % 4]) for k in range(4)]
    surface = occ.addPlaneSurface([occ.addCurveLoop(arcs)])
    occ.remove([(0, centre)])
    return surface
