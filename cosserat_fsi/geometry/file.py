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
Every boundary facet (an edge of exactly one cell) must be in exactly one facet group; the ones in none become
the group ``default`` (reserved), whose condition the scene must give (``boundaries.default``). One physical name
per group, one group per facet (else _Refused, one line).
The name -> id table of the facets is written next to the mesh (``<mesh>.names.json``; :func:`facet_ids`).

A ``.geo`` builds a model and nothing else: commands that run programs, write files or read files outside
its folder are refused naming the file and line (geo_scan.py) unless ``trusted: true``; a ``.msh`` with
triangles and quadrilaterals together is refused (one cell type per mesh).
"""

from __future__ import annotations

import hashlib
import json
import os
import re
import pathlib
from types import ModuleType
from typing import Any, ClassVar, Literal

from pydantic import Field, field_validator, model_validator

from pydantic import BaseModel, ConfigDict

from ..errors import InputError
from ..files import read_regular
from ._model import MAX_LEVEL, GeometryBase

SUFFIXES = (".geo", ".msh")


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
    name: Literal["file"] = "file"
    """A user's own 2D gmsh mesh with physical names: the facet groups keep the file's names (the scene's
    ``boundaries`` give their conditions); boundary facets in no group become the group ``default``."""
    path: str
    """A gmsh ``.geo`` (meshed with Mesh.MeshSizeFactor × 2^-level) or ``.msh`` (read as it is) file,
    relative to the scene file's folder or absolute."""
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
        """A readable ``.geo`` or ``.msh`` file; a ``.msh`` must start as one (``$MeshFormat``)."""
        path = pathlib.Path(value)
        if path.suffix.lower() not in SUFFIXES:
            raise ValueError(f"must be a gmsh .geo or .msh file (got {value!r})")
        if not path.exists():
            raise ValueError(f"no such file: {value}")
        try:
            head = read_regular(path, f"gmsh {path.suffix.lower()} file", max_bytes=63)
        except InputError as exc:  # a FIFO, a device, a folder: refused without reading (no hang)
            raise ValueError(str(exc)) from None
        if path.suffix.lower() == ".msh" and not head.lstrip().startswith(b"$MeshFormat"):
            raise ValueError(f"not a gmsh mesh file (no $MeshFormat at its start): {value}")
        if path.suffix.lower() == ".geo" and b"\0" in head:
            raise ValueError(f"not a gmsh .geo text file: {value}")
        return str(path.resolve())

    @model_validator(mode="after")
    def _groups(self):
        if self.path.lower().endswith(".geo") and not self.trusted:
            from .geo_scan import scan_geo

            scan_geo(self.path)  # InputError "<file>:<line>: gmsh command X is not allowed in a scene"
        both = set(self.cells.fluid) & set(self.cells.solid)
        if both:
            raise ValueError(f"geometry.cells: {sorted(both)[0]!r} is both fluid and solid")
        return self

    @property
    def solid_cells(self) -> bool:
        return False  # not known before the file is read: the scene's solid section decides (runner checks)

    def content_digest(self) -> str:
        """sha256 of the file's content and of every file it ``Include``s or ``Merge``s (recursively, by
        the names written in it): the mesh's identity, whatever folder holds the case."""
        return content_digest(self.path)

    def msh_params(self) -> dict[str, Any]:
        """The content hash and the options: the cache key (without ``path``, which the builder reads)."""
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


def check_scene(scene, names: dict[str, Any]) -> None:
    """The scene against what its file holds (InputError, one line): fluid cells where the scene has a
    fluid, a solid section exactly when there are solid cells, an ``inlet`` group for an inflow section."""
    from ..errors import InputError

    shown = pathlib.Path(scene.geometry.path).name
    cells = names["cells"]
    if scene.fluid is not None and not cells.get("fluid"):
        raise InputError(f"geometry.path: {shown} has no fluid cells (cell groups "
                         f"{', '.join(scene.geometry.cells.fluid)}) but the scene has a fluid section")
    if cells.get("solid") and scene.solid is None:
        raise InputError(f"solid: missing section ({shown} has {cells['solid']} solid cells)")
    if scene.solid is not None and not cells.get("solid"):
        raise InputError(f"solid: {shown} has no solid cells (cell groups {', '.join(scene.geometry.cells.solid)})")
    facets = sorted(names["facets"])
    internal = {"interface"} if cells.get("solid") and cells.get("fluid") else set()
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
        for i, name in enumerate(scene.observables.flow_rates):  # the interface: inside, no outward normal
            if name not in names["facets"] or name in internal:
                raise InputError(f"observables.flow_rates[{i}]: {shown} has no boundary facet group {name!r} (it "
                                 f"has: {', '.join(n for n in facets if n not in internal) or 'none'})")
        if scene.observables.wetted_solid and not internal:
            raise InputError(f"observables.wetted_solid: {shown} has no fluid-solid interface")
    if scene.inflow is not None and "inlet" not in names["facets"]:
        raise InputError(f"inflow: {shown} has no facet group 'inlet' (it has: "
                         f"{', '.join(sorted(names['facets'])) or 'none'})")


def names_path(msh: str | os.PathLike) -> pathlib.Path:
    """The facet name -> id table written next to a cached file mesh."""
    return pathlib.Path(msh).with_suffix(".names.json")


def read_names(msh: str | os.PathLike) -> dict[str, Any]:
    """``{"facets": {name: id}, "cells": {"fluid": n, "solid": n}}`` of a cached file mesh."""
    return json.loads(names_path(msh).read_text())


class _Refused(Exception):
    """Bad input found while meshing (the child prints ``geometry.<key>: ...`` and exits 2)."""


def build(gmsh: ModuleType, scale: float, params: dict[str, Any]) -> dict[str, Any]:
    """Open (and for a ``.geo``, mesh) the file in the current gmsh session; make the physical groups the
    project's (cells fluid 1 / solid 2, facets as named, ``interface`` from the cells). Returns the names
    table. Raises :class:`_Refused` with a one-line ``geometry.path: ...`` message for bad input."""
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
                       "its boundaries with Physical Surface/Curve(\"name\"))")
    dims = {dim for dim, _ in groups}
    if 3 in dims or any(len(gmsh.model.mesh.getElements(3, e)[0]) for _, e in gmsh.model.getEntities(3)):
        raise _Refused(f"geometry.path: {shown} is a 3D mesh; scenes are 2D (physical surfaces for the cells, "
                       "physical curves for the boundaries)")
    for (dim, tag), name in named.items():
        if not name:
            raise _Refused(f"geometry.path: physical group {tag} of dimension {dim} in {shown} has no name")
    for (dim, _), name in named.items():
        twins = sorted(t for (d, t), n in named.items() if d == dim and n == name)
        if len(twins) > 1:
            raise _Refused(f"geometry.path: {shown}: physical name \"{name}\" is used by {len(twins)} groups (tags "
                           f"{', '.join(map(str, twins[:-1]))} and {twins[-1]}); give each group its own name")
        if dim == 1 and name == "default":
            raise _Refused(f"geometry.path: {shown}: physical name \"default\" is reserved (boundaries.default is "
                           "the condition of the boundary facets in no group); rename the group")
    cell_groups = {name: tag for (dim, tag), name in named.items() if dim == 2}
    facet_groups = {name: tag for (dim, tag), name in named.items() if dim == 1}
    fluid_names, solid_names = params["fluid"], params["solid"]
    for name in cell_groups:
        if name not in fluid_names and name not in solid_names:
            raise _Refused(f"geometry.cells: cell group {name!r} of {shown} is neither fluid nor solid "
                           f"(map it, e.g. geometry.cells.fluid: [{name}])")
    fluid = [cell_groups[n] for n in fluid_names if n in cell_groups]
    solid = [cell_groups[n] for n in solid_names if n in cell_groups]
    if not fluid and not solid:
        raise _Refused(f"geometry.path: {shown} has no cell group named {' or '.join(fluid_names + solid_names)} "
                       f"(its surface groups: {', '.join(cell_groups) or 'none'})")

    def entities(tags):
        return sorted({int(e) for t in tags for e in gmsh.model.getEntitiesForPhysicalGroup(2, t)})

    kinds = set()

    def edges(ents):
        found = []
        for e in ents:
            types, _, nodes = gmsh.model.mesh.getElements(2, e)
            for etype, enodes in zip(types, nodes):
                if etype not in (2, 3):  # 3-node triangles, 4-node quadrangles
                    raise _Refused(f"geometry.path: {shown} has {gmsh.model.mesh.getElementProperties(etype)[0]} "
                                   "elements; only first-order triangles and quadrangles are supported")
                k = 3 if etype == 2 else 4
                kinds.add(k)
                cells = np.asarray(enodes, dtype=np.int64).reshape(-1, k)
                found += [np.sort(np.stack([cells[:, i], cells[:, (i + 1) % k]], axis=1), axis=1) for i in range(k)]
        return np.unique(np.concatenate(found), axis=0) if found else np.zeros((0, 2), dtype=np.int64)

    fluid_ents, solid_ents = entities(fluid), entities(solid)
    if set(fluid_ents) & set(solid_ents):
        raise _Refused(f"geometry.cells: surface {sorted(set(fluid_ents) & set(solid_ents))[0]} of {shown} is in "
                       "a fluid and a solid group")
    interface = np.zeros((0, 2), dtype=np.int64)
    f_edges, s_edges = edges(fluid_ents), edges(solid_ents)  # (also refuses elements other than P1)
    if len(kinds) > 1:  # dolfinx reads one cell type per mesh
        raise _Refused(f"{path}: mixed cell types (triangle and quadrilateral) are not supported")
    if fluid_ents and solid_ents:
        both = np.concatenate([f_edges, s_edges])
        uniq, counts = np.unique(both, axis=0, return_counts=True)
        interface = uniq[counts > 1]
    if "interface" in facet_groups and len(interface):
        given = np.concatenate([_line_nodes(gmsh, e) for e in
                                gmsh.model.getEntitiesForPhysicalGroup(1, facet_groups["interface"])])
        if not np.array_equal(np.unique(np.sort(given, axis=1), axis=0), interface):
            raise _Refused(f"geometry.path: facet group 'interface' of {shown} is not the fluid-solid interface "
                           "(leave it out: it is found from the cells)")
    facet_entities = {tag: [int(e) for e in gmsh.model.getEntitiesForPhysicalGroup(1, tag)]
                      for tag in facet_groups.values()}
    unnamed = _unnamed_boundary(gmsh, shown, fluid_ents + solid_ents, facet_groups, facet_entities)
    gmsh.model.removePhysicalGroups()
    for ents, tag, name in ((fluid_ents, 1, "fluid"), (solid_ents, 2, "solid")):
        if ents:
            gmsh.model.addPhysicalGroup(2, ents, tag)
            gmsh.model.setPhysicalName(2, tag, name)
    facets = dict(facet_groups)
    if len(interface) and "interface" not in facets:
        entity = gmsh.model.addDiscreteEntity(1)
        gmsh.model.mesh.addElementsByType(entity, 1, [], interface.ravel().tolist())
        facets["interface"] = max(facets.values(), default=0) + 1
        gmsh.model.addPhysicalGroup(1, [entity], facets["interface"])
        gmsh.model.setPhysicalName(1, facets["interface"], "interface")
    for name, tag in facet_groups.items():
        gmsh.model.addPhysicalGroup(1, facet_entities[tag], tag)
        gmsh.model.setPhysicalName(1, tag, name)
    out: dict[str, Any] = {}
    if len(unnamed):  # the group ``default``: the scene must give it a condition (check_scene)
        entity = gmsh.model.addDiscreteEntity(1)
        gmsh.model.mesh.addElementsByType(entity, 1, [], unnamed.ravel().tolist())
        facets["default"] = max(facets.values(), default=0) + 1
        gmsh.model.addPhysicalGroup(1, [entity], facets["default"])
        gmsh.model.setPhysicalName(1, facets["default"], "default")
        ends = [gmsh.model.mesh.getNode(int(n))[0][:2] for n in unnamed[0]]
        out["unnamed"] = {"count": int(len(unnamed)), "near": [round(float(c), 6) for c in np.mean(ends, axis=0)]}
    counts = {"fluid": _count(gmsh, fluid_ents), "solid": _count(gmsh, solid_ents)}
    return {"facets": facets, "cells": counts, **out}


def _unnamed_boundary(gmsh, shown, cell_entities, facet_groups, facet_entities) -> Any:
    """The boundary facets (node pairs, sorted) in no named facet group; _Refused if a facet is in two
    groups. The boundary: the edges of exactly one cell."""
    import numpy as np

    found = []
    for e in cell_entities:
        types, _, nodes = gmsh.model.mesh.getElements(2, e)
        for etype, enodes in zip(types, nodes):
            k = 3 if etype == 2 else 4
            cells = np.asarray(enodes, dtype=np.int64).reshape(-1, k)
            found += [np.sort(np.stack([cells[:, i], cells[:, (i + 1) % k]], axis=1), axis=1) for i in range(k)]
    uniq, counts = np.unique(np.concatenate(found), axis=0, return_counts=True)
    boundary = uniq[counts == 1]
    owner: dict[tuple[int, int], str] = {}
    for name, tag in facet_groups.items():
        lines = [_line_nodes(gmsh, e) for e in facet_entities[tag]]
        rows = np.unique(np.sort(np.concatenate(lines), axis=1), axis=0) if lines else np.zeros((0, 2), np.int64)
        for a, b in rows.tolist():
            other = owner.setdefault((a, b), name)
            if other != name:
                x = np.mean([gmsh.model.mesh.getNode(a)[0][:2], gmsh.model.mesh.getNode(b)[0][:2]], axis=0)
                first, second = sorted((other, name))
                raise _Refused(f"geometry.path: {shown}: a facet near ({x[0]:.4g}, {x[1]:.4g}) is in two physical "
                               f"groups, \"{first}\" and \"{second}\"; put each boundary facet in one group")
    keep = [i for i, (a, b) in enumerate(boundary.tolist()) if (a, b) not in owner]
    return boundary[keep]


def _msh_names_once(path: str, shown: str) -> None:
    """_Refused if the ``$PhysicalNames`` of a .msh give one name (in one dimension) to two groups."""
    with open(path, "rb") as f:
        head = f.read(1 << 20)
    if b"$PhysicalNames" not in head:
        return
    block = head.split(b"$PhysicalNames", 1)[1].split(b"$EndPhysicalNames", 1)[0].decode("utf-8", "replace")
    tags: dict[tuple[str, str], list[int]] = {}
    for line in block.strip().splitlines()[1:]:
        parts = line.split(None, 2)
        if len(parts) == 3 and parts[0].isdigit() and parts[1].isdigit():
            tags.setdefault((parts[0], parts[2].strip().strip('"')), []).append(int(parts[1]))
    for (_, name), found in tags.items():
        if len(found) > 1:
            found = sorted(found)
            raise _Refused(f"geometry.path: {shown}: physical name \"{name}\" is used by {len(found)} groups (tags "
                           f"{', '.join(map(str, found[:-1]))} and {found[-1]}); give each group its own name")


def _line_nodes(gmsh, entity) -> Any:
    import numpy as np

    types, _, nodes = gmsh.model.mesh.getElements(1, entity)
    out = [np.asarray(n, dtype=np.int64).reshape(-1, 2) for t, n in zip(types, nodes) if t == 1]
    return np.concatenate(out) if out else np.zeros((0, 2), dtype=np.int64)


def _count(gmsh, ents) -> int:
    return int(sum(len(tags) for e in ents for tags in gmsh.model.mesh.getElements(2, e)[1]))
