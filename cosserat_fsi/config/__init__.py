"""Scene configuration: the typed, validated form of ``configs/<case>.yaml``.

``load_scene(path, overrides)`` reads the YAML file, applies ``--set dotted.key=value`` overrides,
validates it against the schema of docs/architecture.md and returns a :class:`Scene`. Every problem
is raised as one :class:`~cosserat_fsi.errors.InputError` line ``"<dotted.key>: <problem>"``.

The models are the reference of the YAML keys, one docstring under each field: physics (fluid, micropolar,
solid, inflow), time (one model per ``scheme``), solver, sections (boundaries, observables, output), scene
(the whole scene and its checks across sections); loading turns pydantic's errors into the one-line
messages; reference walks the models into the documentation's "Scene reference" page. What each geometry
accepts lives in geometry/, one model each. No dolfinx, petsc4py or gmsh imports here.
"""

from __future__ import annotations

from cosserat_fsi.io.safe_yaml import YamlLoader, describe_yaml_error, read_text_file, yaml_load

from .base import GEOMETRY_OF_BENCHMARK, MAX_COUNT, MAX_STEPS, Benchmark, NonNegFloat, PositiveFloat
from .loading import as_scene, load_scene, validate_geometry, validate_scene
from .physics import Fluid, Inflow, MeshMotionSettings, Micropolar, Remesh, Solid
from .scene import Scene, dump_resolved
from .sections import BoundaryCondition, Expr, ObservableSet, Output, Point
from .solver import Solver
from .time import (NODAL_CONVECTION, TIME_SCHEMES, AleBdf2, Characteristics1, Characteristics2, GeneralizedAlpha,
                   Steady, Time)

__all__ = [
    "GEOMETRY_OF_BENCHMARK", "MAX_COUNT", "MAX_STEPS", "NODAL_CONVECTION", "TIME_SCHEMES", "AleBdf2", "Benchmark",
    "BoundaryCondition", "Characteristics1", "Characteristics2", "Expr", "Fluid", "GeneralizedAlpha", "Inflow",
    "MeshMotionSettings", "Micropolar", "NonNegFloat", "ObservableSet", "Output", "Point", "PositiveFloat",
    "Remesh", "Scene", "Solid", "Solver", "Steady", "Time", "YamlLoader", "describe_yaml_error", "dump_resolved",
    "as_scene", "load_scene", "read_text_file", "validate_geometry", "validate_scene", "yaml_load",
]
