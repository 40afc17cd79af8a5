"""A user's own mesh: ``geometry: {name: file, path: my.geo | my.msh, level: 0, cells: {...}}``.

``path`` is relative to the scene file's folder (config.load_scene resolves it) or absolute. A ``.geo`` is
meshed through gmsh's API with ``Mesh.MeshSizeFactor`` multiplied by 2^-level; a ``.msh`` is read as it is
(its nodes and elements are kept; gmsh rewrites it as MSH 4.1 ASCII). Both are cached like the built-in
geometries, keyed by a hash of the content of the file and of the files it ``Include``s or ``Merge``s, and the
options (not by its path: a copied case folder reuses the mesh; the checkpoint's fingerprint holds the hash).

Regions and boundaries come from the **physical names** of the file: cell groups named ``fluid`` and,
optionally, ``solid`` (``cells: {fluid: [names], solid: [names]}`` maps other names); facet groups are named
freely and keep the file's ids. In the cached mesh the cells are renumbered to the project's fluid 1 /
solid 2 (tags.py) and, when there are solid cells, the fluid–solid interface is found from the cells and
added as the facet group ``interface`` (a group of that name in the file must be exactly those facets).
Every boundary facet (a facet of exactly one cell) must be in exactly one facet group; the ones in none become
the group ``default`` (reserved), whose condition the scene must give (``boundaries.default``). A facet group
inside the domain (an interior curve in 2D, surface in 3D) takes no condition. One physical name per group,
one group per facet (else _Refused, one line).
The name -> id table of the facets is written next to the mesh (``<mesh>.names.json``; :func:`facet_ids`).

The dimension D comes from the file: physical volumes name 3D cells (tetrahedra; physical surfaces are then
the facet groups), else physical surfaces name 2D cells (triangles or quadrangles, in the plane z = 0) and
physical curves the facet groups. ``FileGeometry.DIM`` reads it from the file's text when the scene is
validated (geo_scan.file_dimension); the names table records the mesh's own (``"dim"``), checked against it.
An ``.xdmf`` (``cosserat-fsi mesh SCENE --format xdmf``) is not meshed nor cached: its table gives the
dimension, and it is read distributed (xdmf_file.py).

A ``.geo`` builds a model and nothing else: commands that run programs, write files or read files outside
its folder are refused naming the file and line (geo_scan.py) unless ``trusted: true``; a ``.msh`` with
triangles and quadrilaterals together is refused (one cell type per mesh); what a quadrilateral mesh cannot
do (the characteristics, a solid, probes and profiles) is refused at setup (simulation.quadrilateral_limits).
"""

from __future__ import annotations

import hashlib
import json
import os
import re
import pathlib
from types import ModuleType
from typing import Any, ClassVar, Literal

from pydantic import BaseModel, ConfigDict, Field, PrivateAttr, field_validator, model_validator

from ..errors import InputError
from ..files import read_regular
from . import file_topology as topo
from ._model import MAX_LEVEL, GeometryBase
from .geo_scan import file_dimension, msh_physical_names

_Refused = topo.Refused

SUFFIXES = (".geo", ".msh", ".xdmf")


class CellNames(BaseModel):
    """Physical names of the cell groups that are fluid and solid."""

    model_config = ConfigDict(extra="forbid", strict=True, use_attribute_docstrings=True)

    fluid: list[str] = Field(default_factory=lambda: ["fluid"], min_length=1)
    """Physical names of the file's fluid cell groups."""
    solid: list[str] = Field(default_factory=lambda: ["solid"])
    """Physical names of the file's solid cell groups (those present make the solid cells)."""


class FileGeometry(GeometryBase):
    """A user's gmsh ``.geo`` or ``.msh`` file with physical names (the module docstring says how it is read)."""

    SOLID_FROM_FILE: ClassVar[bool] = True  # solid cells if the file has them (checked when it is read)
    _dim: int = PrivateAttr(default=2)
    name: Literal["file"] = "file"
    """A user's own 2D or 3D gmsh mesh with physical names: the facet groups keep the file's names (the scene's
    ``boundaries`` give their conditions); boundary facets in no group become the group ``default``."""
    path: str
    """A gmsh ``.geo`` (meshed with Mesh.MeshSizeFactor × 2^-level) or ``.msh`` (read as it is) file, or an
    ``.xdmf`` written by ``cosserat-fsi mesh SCENE --format xdmf`` (read distributed; with its .h5 and
    .names.json beside it), relative to the scene file's folder or absolute."""
    cells: CellNames = Field(default_factory=CellNames)
    """Which physical cell groups are fluid and which solid."""
    trusted: bool = False
    """``true``: the .geo may run programs and reach files outside its folder (geo_scan.py; refused else)."""

    @field_validator("level", mode="before")
    @classmethod
    def _level(cls, value: Any) -> Any:
        if type(value) is int and 0 <= value <= MAX_LEVEL:
            return value
        raise ValueError(f"must be an integer 0..{MAX_LEVEL} (got {value!r})")

    @field_validator("path")
    @classmethod
    def _path(cls, value: str) -> str:
        """A readable ``.geo``, ``.msh`` or ``.xdmf`` file; a ``.msh`` must start as one (``$MeshFormat``), an
        ``.xdmf`` as XML."""
        path = pathlib.Path(value)
        if path.suffix.lower() not in SUFFIXES:
            raise ValueError(f"must be a gmsh .geo or .msh file, or an .xdmf written by `cosserat-fsi mesh "
                             f"--format xdmf` (got {value!r})")
        if not path.exists():
            raise ValueError(f"no such file: {value}")
        try:
            head = read_regular(path, f"gmsh {path.suffix.lower()} file", max_bytes=63)
        except InputError as exc:  # a FIFO, a device, a folder: refused without reading (no hang)
            raise ValueError(str(exc)) from None
        if path.suffix.lower() == ".msh" and not head.lstrip().startswith(b"$MeshFormat"):
            raise ValueError(f"not a gmsh mesh file (no $MeshFormat at its start): {value}")
        if path.suffix.lower() == ".xdmf" and not head.lstrip().startswith((b"<?xml", b"<Xdmf", b"<!DOCTYPE")):
            raise ValueError(f"not an XDMF file (no XML at its start): {value}")
        if path.suffix.lower() == ".geo" and b"\0" in head:
            raise ValueError(f"not a gmsh .geo text file: {value}")
        return str(path.resolve())

    @model_validator(mode="after")
    def _groups(self):
        if self.path.lower().endswith(".geo") and not self.trusted:
            from .geo_scan import scan_geo

            scan_geo(self.path)  # InputError "<file>:<line>: gmsh command X is not allowed in a scene"
        if self.path.lower().endswith(".xdmf"):  # not meshed: the dimension from its names table
            from .xdmf_file import dimension

            if self.level != 0 or self.cells != CellNames() or self.trusted:
                key = "level" if self.level != 0 else "cells" if self.cells != CellNames() else "trusted"
                raise InputError(f"geometry.{key}: not for an .xdmf mesh (read as it was converted, with the "
                                 "project's cell tags; give it to `cosserat-fsi mesh --format xdmf`)")
            self._dim = dimension(self.path)
            return self
        self._dim = file_dimension(self.path)
        both = set(self.cells.fluid) & set(self.cells.solid)
        if both:
            raise ValueError(f"geometry.cells: {sorted(both)[0]!r} is both fluid and solid")
        return self

    @property
    def DIM(self) -> int:  # noqa: N802 (the name of GeometryBase.DIM)
        """3 if the file names cells with a physical volume (geo_scan.file_dimension, without meshing), else 2;
        the mesh's own dimension is checked against it (check_scene)."""
        return self._dim

    @property
    def solid_cells(self) -> bool:
        return False  # not known before the file is read: the scene's solid section decides (runner checks)

    def content_digest(self) -> str:
        """sha256 of the file's content and of every file it ``Include``s or ``Merge``s (recursively, by
        the names written in it): the mesh's identity, whatever folder holds the case."""
        if self.path.lower().endswith(".xdmf"):
            from .xdmf_file import digest

            return digest(self.path)  # the .xdmf, its .h5 and its names table
        return content_digest(self.path)

    def msh_params(self) -> dict[str, Any]:
        """The content hash and the options: the cache key (without ``path``, which the builder reads); an
        .xdmf is not meshed, so not cached (no hash here)."""
        if self.path.lower().endswith(".xdmf"):
            return {"path": os.path.abspath(self.path), "format": "xdmf"}
        return {"path": os.path.abspath(self.path), "sha256": self.content_digest(), "fluid": list(self.cells.fluid),
                "solid": list(self.cells.solid)}


_INCLUDE = re.compile(rb'\b(?:Include|Merge)\s*"([^"]+)"')


def content_digest(path: str | os.PathLike) -> str:
    """sha256 over ``path`` and the files it Includes/Merges (a missing one counts by its name)."""
    digest, seen, todo = hashlib.sha256(), set(), [pathlib.Path(path).resolve()]
    while todo:
        file = todo.pop(0)
        if file in seen:
            continue
        seen.add(file)
        if not file.exists():
            digest.update(b"missing:" + file.name.encode())
            continue
        data = read_regular(file, "gmsh file")  # never blocks on a FIFO
        digest.update(hashlib.sha256(data).digest())
        if file.suffix.lower() == ".geo":
            todo += [(file.parent / os.fsdecode(m)).resolve() for m in _INCLUDE.findall(data)]
    return digest.hexdigest()


def describe(params: dict[str, Any]) -> dict[str, Any]:
    """What is known before the file is meshed (the names come with the mesh: :func:`facet_ids`)."""
    return {"cell_tags": {"fluid": 1, "solid": 2}, "facet_tags": {}, "points": {}, "path": params["path"]}


_ANY_EXTENT = {"y0": 0.0, "height": 1.0, "z0": 0.0, "width": 1.0}  # the condition types do not depend on it


def check_scene(scene, names: dict[str, Any]) -> None:
    """The scene against what its file holds (InputError, one line): fluid cells where the scene has a
    fluid, a solid section exactly when there are solid cells, an ``inlet`` group for an inflow section, and
    ``solver.penalty`` only where the conditions by name leave the pressure's constant free."""
    from ..config.usage import given as set_by_user, penalty_unused
    from ..errors import InputError
    from .presets import default_boundaries

    shown = pathlib.Path(scene.geometry.path).name
    dim = names.get("dim", 2)
    if dim != scene.geometry.DIM:
        raise InputError(f"geometry.path: {shown} holds a {dim}D mesh but its physical names declare "
                         f"{scene.geometry.DIM}D (3D: the cells in a Physical Volume, in the file or one it "
                         "Includes or Merges)")
    cells = names["cells"]
    if scene.fluid is not None and not cells.get("fluid"):
        raise InputError(f"geometry.path: {shown} has no fluid cells (cell groups "
                         f"{', '.join(scene.geometry.cells.fluid)}) but the scene has a fluid section")
    if cells.get("solid") and scene.solid is None:
        raise InputError(f"solid: missing section ({shown} has {cells['solid']} solid cells)")
    if scene.solid is not None and not cells.get("solid"):
        raise InputError(f"solid: {shown} has no solid cells (cell groups {', '.join(scene.geometry.cells.solid)})")
    interior = set(names.get("interior", ()))
    internal = ({"interface"} if cells.get("solid") and cells.get("fluid") else set()) | interior
    facets = sorted(names["facets"])
    unnamed, given = names.get("unnamed"), scene.boundaries or {}
    if unnamed and "default" not in given:
        near = ", ".join(f"{c:.4g}" for c in unnamed["near"])
        raise InputError(f"{shown}: {unnamed['count']} boundary facets are in no physical group (the first near "
                         f"({near})); name them or give boundaries.default")
    if "default" in given and not unnamed:
        raise InputError(f"boundaries.default: every boundary facet of {shown} is in a named group (default is the "
                         "condition of the facets in none); remove it")
    if scene.boundaries is not None:
        for name in scene.boundaries:
            if name in interior:
                raise InputError(f"boundaries.{name}: facet group {name} of {shown} is inside the domain (not on "
                                 "its boundary); it takes no condition")
            if name in internal:
                raise InputError(f"boundaries.{name}: the fluid-solid interface is inside the domain; it takes "
                                 "no condition")
            if name not in names["facets"]:
                raise InputError(f"boundaries.{name}: {shown} has no facet group {name!r} (it has: "
                                 f"{', '.join(n for n in facets if n not in internal) or 'none'})")
        for name in facets:
            if name not in internal and name not in scene.boundaries:
                raise InputError(f"boundaries: facet group {name!r} of {shown} has no condition (add "
                                 f"boundaries.{name}: {{type: no_slip | velocity | do_nothing | traction | slip}})")
    if scene.observables is not None:
        for i, name in enumerate(scene.observables.forces):
            if name not in names["facets"] or name in internal:
                raise InputError(f"observables.forces[{i}]: {shown} has no boundary {name!r} (it has: "
                                 f"{', '.join(n for n in facets if n not in internal) or 'none'}; the interface: "
                                 "observables.wetted_solid)")
        for i, name in enumerate(scene.observables.flow_rates):  # inside: no outward normal
            if name not in names["facets"] or name in internal:
                raise InputError(f"observables.flow_rates[{i}]: {shown} has no boundary facet group {name!r} (it "
                                 f"has: {', '.join(n for n in facets if n not in internal) or 'none'})")
        if scene.observables.wetted_solid and not (cells.get("solid") and cells.get("fluid")):
            raise InputError(f"observables.wetted_solid: {shown} has no fluid-solid interface")
    if scene.inflow is not None and "inlet" in interior:
        raise InputError(f"inflow: facet group inlet of {shown} is inside the domain (not on its boundary)")
    if scene.inflow is not None and "inlet" not in names["facets"]:
        raise InputError(f"inflow: {shown} has no facet group 'inlet' (it has: "
                         f"{', '.join(sorted(names['facets'])) or 'none'})")
    if scene.boundaries is None and set_by_user(scene, "solver.penalty"):  # the conditions by name, from the mesh
        named = {name: tag for name, tag in names["facets"].items() if name not in internal}
        why = penalty_unused(bc["type"] for bc in default_boundaries(scene, named, _ANY_EXTENT).values())
        if why is not None:
            raise InputError(f"solver.penalty: {why}")


def names_path(msh: str | os.PathLike) -> pathlib.Path:
    """The facet name -> id table written next to a cached file mesh."""
    return pathlib.Path(msh).with_suffix(".names.json")


def read_names(msh: str | os.PathLike) -> dict[str, Any]:
    """``{"dim": D, "facets": {name: id}, "cells": {"fluid": n, "solid": n}, "interior": [names]}`` (and
    ``"unnamed"``: the boundary facets in no group) of a cached file mesh; ``interior``: the facet groups
    inside the domain (no boundary facet), which take no condition."""
    return json.loads(names_path(msh).read_text())


def build(gmsh: ModuleType, scale: float, params: dict[str, Any]) -> dict[str, Any]:
    """Open (and for a ``.geo``, mesh) the file in the current gmsh session; make the physical groups the
    project's (cells fluid 1 / solid 2, facets as named, ``interface`` from the cells). Returns the names
    table. Raises :class:`_Refused` with a one-line ``geometry.path: ...`` message for bad input. Generic in
    the dimension D of the file's cells (2: triangles or quadrangles, 3: tetrahedra; file_topology.py)."""
    import numpy as np

    path = params["path"]
    shown = pathlib.Path(path).name
    for key, value in {"General.Terminal": 0, "General.NumThreads": 1, "Mesh.RandomSeed": 1}.items():
        gmsh.option.setNumber(key, value)
    if path.lower().endswith(".msh"):  # gmsh keeps one group per name: refuse a file that has two
        _msh_names_once(path, shown)
    try:
        gmsh.open(path)
    except Exception as exc:  # noqa: BLE001 (gmsh's parser message, one line)
        raise _Refused(f"geometry.path: gmsh cannot read {shown} ({' '.join(str(exc).split())[:160]})") from None
    if path.lower().endswith(".geo"):
        gmsh.option.setNumber("Mesh.MeshSizeFactor", gmsh.option.getNumber("Mesh.MeshSizeFactor") * scale)
        try:
            gmsh.model.mesh.generate(gmsh.model.getDimension())
        except Exception as exc:  # noqa: BLE001
            raise _Refused(f"geometry.path: gmsh could not mesh {shown} "
                           f"({' '.join(str(exc).split())[:160]})") from None
    for key, value in {"Mesh.MshFileVersion": 4.1, "Mesh.Binary": 0, "Mesh.SaveAll": 0}.items():
        gmsh.option.setNumber(key, value)
    groups = gmsh.model.getPhysicalGroups()
    named = {(dim, tag): gmsh.model.getPhysicalName(dim, tag) for dim, tag in groups}
    if not groups or not any(named.values()):
        raise _Refused(f"geometry.path: {shown} has no physical names (name its cell groups fluid/solid and "
                       "its boundaries with Physical Surface/Curve(\"name\"), in 3D Physical Volume/Surface)")
    D = 3 if any(dim == 3 for dim, _ in groups) else 2
    if D == 2 and any(len(gmsh.model.mesh.getElements(3, e)[0]) for _, e in gmsh.model.getEntities(3)):
        raise _Refused(f"geometry.path: {shown} is a 3D mesh without physical volumes (name its cells with "
                       "Physical Volume(\"fluid\") and its boundaries with Physical Surface)")
    for (dim, tag), name in named.items():
        if not name:
            raise _Refused(f"geometry.path: physical group {tag} of dimension {dim} in {shown} has no name")
    for (dim, _), name in named.items():
        twins = sorted(t for (d, t), n in named.items() if d == dim and n == name)
        if len(twins) > 1:
            raise _Refused(f"geometry.path: {shown}: physical name \"{name}\" is used by {len(twins)} groups (tags "
                           f"{', '.join(map(str, twins[:-1]))} and {twins[-1]}); give each group its own name")
        if dim == D - 1 and name == "default":
            raise _Refused(f"geometry.path: {shown}: physical name \"default\" is reserved (boundaries.default is "
                           "the condition of the boundary facets in no group); rename the group")
    cell_groups = {name: tag for (dim, tag), name in named.items() if dim == D}
    facet_groups = {name: tag for (dim, tag), name in named.items() if dim == D - 1}
    fluid_names, solid_names = params["fluid"], params["solid"]
    for name in cell_groups:
        if name not in fluid_names and name not in solid_names:
            raise _Refused(f"geometry.cells: cell group {name!r} of {shown} is neither fluid nor solid "
                           f"(map it, e.g. geometry.cells.fluid: [{name}])")
    fluid = [cell_groups[n] for n in fluid_names if n in cell_groups]
    solid = [cell_groups[n] for n in solid_names if n in cell_groups]
    if not fluid and not solid:
        raise _Refused(f"geometry.path: {shown} has no cell group named {' or '.join(fluid_names + solid_names)} "
                       f"(its {'volume' if D == 3 else 'surface'} groups: {', '.join(cell_groups) or 'none'})")

    def entities(tags, dim=D):
        return sorted({int(e) for t in tags for e in gmsh.model.getEntitiesForPhysicalGroup(dim, t)})

    fluid_ents, solid_ents = entities(fluid), entities(solid)
    if set(fluid_ents) & set(solid_ents):
        raise _Refused(f"geometry.cells: {'volume' if D == 3 else 'surface'} "
                       f"{sorted(set(fluid_ents) & set(solid_ents))[0]} of {shown} is in a fluid and a solid group")
    f_facets, f_kinds = topo.cell_facets(gmsh, D, fluid_ents, shown)  # (also refuses elements other than P1)
    s_facets, s_kinds = topo.cell_facets(gmsh, D, solid_ents, shown)
    if not len(f_facets) and not len(s_facets):  # (gmsh may leave a volume it failed on empty)
        raise _Refused(f"geometry.path: gmsh could not mesh {shown} (no cells in its fluid and solid groups)")
    if len(f_kinds | s_kinds) > 1:  # dolfinx reads one cell type per mesh
        raise _Refused(f"{path}: mixed cell types (triangle and quadrilateral) are not supported")
    topo.check_nodes(gmsh, shown)
    if D == 2:
        topo.check_plane(gmsh, shown)
    topo.check_cells(gmsh, D, fluid_ents + solid_ents, shown)
    boundary, inside, interface = topo.split_facets(f_facets, s_facets)
    rows = {name: topo.facet_rows(gmsh, D, entities([tag], D - 1)) for name, tag in facet_groups.items()}
    if "interface" in facet_groups and len(interface) and not np.array_equal(rows["interface"], interface):
        raise _Refused(f"geometry.path: facet group 'interface' of {shown} is not the fluid-solid interface "
                       "(leave it out: it is found from the cells)")
    unnamed, interior = topo.check_groups(gmsh, D, shown, rows, boundary, inside)
    interior = [n for n in interior if not (n == "interface" and len(interface))]  # the computed one: its own
    facet_entities = {tag: entities([tag], D - 1) for tag in facet_groups.values()}
    gmsh.model.removePhysicalGroups()
    for ents, tag, name in ((fluid_ents, 1, "fluid"), (solid_ents, 2, "solid")):
        if ents:
            gmsh.model.addPhysicalGroup(D, ents, tag)
            gmsh.model.setPhysicalName(D, tag, name)
    facets = dict(facet_groups)
    if len(interface) and "interface" not in facets:
        facets["interface"] = max(facets.values(), default=0) + 1
        topo.add_facet_group(gmsh, D, interface, facets["interface"], "interface")
    for name, tag in facet_groups.items():
        gmsh.model.addPhysicalGroup(D - 1, facet_entities[tag], tag)
        gmsh.model.setPhysicalName(D - 1, tag, name)
    out: dict[str, Any] = {}
    if len(unnamed):  # the group ``default``: the scene must give it a condition (check_scene)
        facets["default"] = max(facets.values(), default=0) + 1
        topo.add_facet_group(gmsh, D, unnamed, facets["default"], "default")
        out["unnamed"] = topo.summary(gmsh, D, unnamed)
    counts = {"fluid": topo.count_cells(gmsh, D, fluid_ents), "solid": topo.count_cells(gmsh, D, solid_ents)}
    return {"dim": D, "facets": facets, "cells": counts, "interior": sorted(interior), **out}


def _msh_names_once(path: str, shown: str) -> None:
    """_Refused if the ``$PhysicalNames`` of a .msh give one name (in one dimension) to two groups."""
    tags: dict[tuple[int, str], list[int]] = {}
    for dim, tag, name in msh_physical_names(path):
        tags.setdefault((dim, name), []).append(tag)
    for (_, name), found in tags.items():
        if len(found) > 1:
            found = sorted(found)
            raise _Refused(f"geometry.path: {shown}: physical name \"{name}\" is used by {len(found)} groups (tags "
                           f"{', '.join(map(str, found[:-1]))} and {found[-1]}); give each group its own name")
