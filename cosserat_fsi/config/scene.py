"""The whole scene: its sections and the checks across them."""

from __future__ import annotations

import re

import numpy as np
import yaml
from pydantic import Field, field_validator, model_validator

from cosserat_fsi.geometry import Geometry

from .base import GEOMETRY_OF_BENCHMARK, MAX_STEPS, Benchmark, _Section, _short
from .physics import Fluid, Inflow, Micropolar, Solid
from .sections import (BoundaryCondition, ObservableSet, Output, Reference, check_boundary_data, coordinate_problem,
                       precheck_micro_values)
from .solver import Solver
from .time import Time
from .usage import check_usage


class Scene(_Section):
    """A complete, validated scene (one run)."""

    name: str = "scene"
    """The scene's name, in run.log and summary.json: 1 to 100 letters, digits, '_', '-', '.'; load_scene's
    default is the scene file's stem."""
    benchmark: Benchmark | None = None
    """Compare the run with a published benchmark's reference values (micropolar_*: with an exact solution,
    relative L² errors); the run ends with a PASS/FAIL table. Each needs its geometry (e.g. turek_hron_fsi3:
    turek_hron with flag solid; turek_hron_cfd3: flag rigid; turek_hron_csm1: flag)."""
    geometry: Geometry
    """The mesh: a built-in geometry or the user's gmsh file, chosen by ``name``."""
    fluid: Fluid | None = None
    """The Newtonian part of the fluid; required when the geometry has fluid cells, absent for geometry
    flag."""
    micropolar: Micropolar = Field(default_factory=Micropolar)
    """Cosserat (micropolar) coefficients of the fluid; the defaults (all zero) give a Newtonian fluid."""
    solid: Solid | None = None
    """The elastic solid; required when the mesh has solid cells (turek_hron with flag solid, turek_hron_3d,
    flag, box; a file with solid cell groups)."""
    inflow: Inflow | None = None
    """Inlet velocity; required for turek_hron, schaefer_turek and their 3D forms, optional for the other
    built-in geometries (moving lid of square and cube) and for a file scene without a boundaries section."""
    boundaries: dict[str, BoundaryCondition] | None = None
    """Geometry file only: the condition on each facet group of the mesh, by its physical name (every group
    but the computed ``interface`` needs one); not with an inflow section. null: the built-in conditions by
    name (no-slip on walls, cylinder, clamp; the inflow on inlet; do-nothing elsewhere)."""
    observables: ObservableSet | None = None
    """Geometry file only: forces, probes, solid points, line profiles and flow rates to report (the built-in
    geometries have their own); positions with the mesh's dimension."""
    reference: dict[str, Reference] | None = None
    """Pass/FAIL references for columns of timeseries.csv, by column name, checked at the end of the run like
    a benchmark's (not with benchmark)."""
    time: Time
    """Time stepping (or the steady state), chosen by ``scheme``; required."""
    solver: Solver = Field(default_factory=Solver)
    """The linear solver of every step."""
    output: Output = Field(default_factory=Output)
    """What the run writes, and how often."""

    @field_validator("name")
    @classmethod
    def _name(cls, value):
        if not re.fullmatch(r"[A-Za-z0-9_][A-Za-z0-9_.-]{0,99}", value):
            raise ValueError(f"must use only letters, digits, '_', '-', '.' (1 to 100 of them; got {_short(value)})")
        return value

    @model_validator(mode="before")
    @classmethod
    def _micro_values(cls, data):
        precheck_micro_values(data)
        precheck_path_length(data)
        return data

    @model_validator(mode="after")
    def _cross_checks(self):
        """Checks across sections; messages carry their full dotted key. (What each geometry accepts is
        its own model's business: cosserat_fsi/geometry/.)"""
        geo, time = self.geometry, self.time
        if time.scheme != "steady":
            if time.t_end < time.dt:
                raise ValueError(f"time.t_end: must be >= time.dt (got {time.t_end!r} < {time.dt!r})")
            if not time.t_end / time.dt <= MAX_STEPS:  # also catches an overflow to inf
                raise ValueError(f"time.dt: time.t_end / time.dt must be at most {MAX_STEPS:,} steps "
                                 f"(got {time.t_end!r} / {time.dt!r})")
        if time.scheme != "steady":
            _check_step_control(time)
        if time.scheme == "characteristics2" and time.corrector_passes and not self.has_solid:
            raise ValueError("time.corrector_passes: needs a solid with scheme characteristics2 (the passes "
                             "re-place the mesh; Picard passes: scheme ale_bdf2 or generalized_alpha)")
        if self.has_solid and self.solid.displacement == "linear" and time.scheme in ("generalized_alpha", "steady"):
            raise ValueError(f"solid.displacement: linear is for the BDF schemes (characteristics1, "
                             f"characteristics2, ale_bdf2; got time.scheme {time.scheme})")
        if geo.FLUID and self.fluid is None:
            raise ValueError(f"fluid: missing section (required for geometry {geo.name})")
        if not geo.FLUID and self.fluid is not None:
            raise ValueError(f"fluid: not used for geometry {geo.name} (a solid-only scene)")
        flag = getattr(geo, "flag", None)
        if geo.solid_cells and self.solid is None:
            hint = ("geometry.flag is solid; use geometry.flag: rigid for a fluid-only run" if flag == "solid"
                    else f"required for geometry {geo.name}")
            raise ValueError(f"solid: missing section ({hint})")
        if self.observables is not None:
            if geo.name != "file":
                raise ValueError(f"observables: only for geometry file (geometry {geo.name} has its own)")
            if self.observables.solid_points and self.solid is None:
                raise ValueError("observables.solid_points: the scene has no solid section")
            for key, x in self.observables.positions().items():
                problem = coordinate_problem(key, len(x), geo.DIM)
                if problem is not None:
                    raise ValueError(problem)
        for name, ref in (self.reference or {}).items():
            if not re.fullmatch(r"\w{1,100}", name):
                raise ValueError(f"reference.{name[:40]}: not a time-series column name")
            if time.scheme == "steady" and ref.value is None:
                raise ValueError(f"reference.{name}: a steady scene has one state, no periodic parts (give value)")
        if self.benchmark is not None and self.reference:
            raise ValueError("reference: not with benchmark (a benchmark brings its own references)")
        if self.boundaries is not None:
            if geo.name != "file":
                raise ValueError(f"boundaries: only for geometry file (geometry {geo.name} sets its own)")
            if self.inflow is not None:
                raise ValueError("inflow: not used with a boundaries section (give the inlet's velocity as "
                                 "boundaries.NAME: {type: velocity, value: [EXPR, EXPR]})")
            for name, bc in self.boundaries.items():
                if isinstance(bc.value, list) and len(bc.value) != geo.DIM:
                    raise ValueError(f"boundaries.{name}.value: must have {geo.DIM} components for a {geo.DIM}D "
                                     f"mesh (got {len(bc.value)})")
                if bc.micro_rotation is not None and not self.has_micropolar:
                    raise ValueError(f"boundaries.{name}.micro_rotation: only with micropolar terms "
                                     "(micropolar.mu_r or lambda1 > 0)")
            check_boundary_data(self)
        if geo.INFLOW and self.inflow is None:
            raise ValueError(f"inflow: missing section (required for geometry {geo.name})")
        if self.benchmark is not None:
            need_name, need_flag = GEOMETRY_OF_BENCHMARK[self.benchmark]
            if geo.name != need_name:
                raise ValueError(f"benchmark: {self.benchmark} needs geometry.name {need_name} "
                                 f"(got {geo.name!r})")
            if need_flag is not None and flag != need_flag:
                raise ValueError(f"benchmark: {self.benchmark} needs geometry.flag {need_flag} (got {flag!r})")
        m = self.micropolar
        dim = geo.DIM
        _resolve_vectors(self, dim)
        if self.fluid is not None and len(self.fluid.body_force) != dim:
            raise ValueError(f"fluid.body_force: needs {dim} components for the {dim}D geometry {geo.name} "
                             f"(got {len(self.fluid.body_force)})")
        if self.solid is not None and len(self.solid.initial_velocity) != dim:
            raise ValueError(f"solid.initial_velocity: needs {dim} components for the {dim}D geometry {geo.name} "
                             f"(got {len(self.solid.initial_velocity)})")
        if dim == 2 and isinstance(m.body_couple, list):
            raise ValueError("micropolar.body_couple: a number in 2D (the couple along e_z; got a list)")
        if self.benchmark == "micropolar_poiseuille" and not (m.mu_r > 0 and m.lambda1 > 0):
            raise ValueError("micropolar: micropolar_poiseuille needs mu_r > 0 and lambda1 > 0")
        if self.benchmark == "micropolar_taylor_green":
            if abs(geo.length - np.pi) > 1e-6:
                raise ValueError(f"geometry.length: micropolar_taylor_green is on a square of side pi "
                                 f"(3.14159265358979, got {geo.length!r})")
            if m.inertia <= 0 and self.has_micropolar:
                raise ValueError("micropolar.inertia: micropolar_taylor_green needs inertia > 0")
        check_usage(self)  # a set key the run would not use (config/usage.py)
        return self

    def conditions(self, names=None, extent=None) -> dict[str, BoundaryCondition]:
        """The boundary conditions by facet name: the ``boundaries`` section, or for a built-in geometry its
        preset's defaults (geometry/presets.py) — the one mapping the boundary code reads. ``names``: the
        mesh's facet names and ``extent`` its box (a file scene without a ``boundaries`` section gets the
        defaults by name)."""
        if self.boundaries is not None:
            return self.boundaries
        from cosserat_fsi.geometry.presets import default_boundaries

        defaults = default_boundaries(self, names, extent)
        return {name: BoundaryCondition.model_validate(bc) for name, bc in defaults.items()}

    @property
    def has_micropolar(self) -> bool:
        """True if mu_r or lambda1 (in 3D also lambda2) is nonzero. In 2D the micro-rotation ω e_z has no
        divergence, so lambda2 alone has no effect and builds no ω field (it would be an equation with all
        coefficients zero)."""
        m = self.micropolar
        return m.mu_r != 0 or m.lambda1 != 0 or (self.geometry.DIM == 3 and m.lambda2 != 0)

    @property
    def has_solid(self) -> bool:
        """True if the mesh has solid cells (Turek–Hron with a solid flag, flag, box) and a solid section."""
        return self.solid is not None and (self.geometry.solid_cells or self.geometry.SOLID_FROM_FILE)

    @property
    def has_fluid(self) -> bool:
        """False for solid-only scenes (geometry flag): no fluid terms are built."""
        return self.fluid is not None

    @property
    def has_inflow(self) -> bool:
        """True if the scene prescribes an inlet velocity."""
        return self.inflow is not None

    def to_yaml(self) -> str:
        """The fully resolved scene (all defaults filled in) as YAML that ``load_scene`` accepts."""
        return yaml.safe_dump(self.model_dump(mode="json"), sort_keys=False, default_flow_style=False)


NAME_MAX, PATH_MAX = 255, 4095
"""Bytes of one file name and of a whole path that Linux file systems take."""


def precheck_path_length(data) -> None:
    """``geometry.path`` of a raw scene within NAME_MAX / PATH_MAX, checked before the models so that the
    error names the key (the operating system refuses a longer name where the file is looked up)."""
    geometry = data.get("geometry") if isinstance(data, dict) else None
    path = geometry.get("path") if isinstance(geometry, dict) else None
    if not isinstance(path, str):
        return
    longest = max((len(part.encode("utf-8", "surrogateescape")) for part in path.split("/")), default=0)
    size = len(path.encode("utf-8", "surrogateescape"))
    if longest > NAME_MAX or size > PATH_MAX:
        what = (f"a name of {longest} bytes, at most {NAME_MAX}" if longest > NAME_MAX
                else f"{size} bytes, at most {PATH_MAX}")
        raise ValueError(f"geometry.path: file name too long ({what}; got {_short(path)})")


def condition_lines(scene: Scene, conditions: dict, micro: bool) -> list[str]:
    """One line per boundary, the condition it got: ``inlet: velocity ['4*y*(1 - y)', '0'], micro_rotation
    free (given)`` (the micro-rotation part, and where it comes from, with micropolar terms only)."""
    wall = scene.micropolar.wall_condition
    out = []
    for name, bc in conditions.items():
        value = ("" if bc.value is None else f" {[str(v) for v in bc.value]}" if isinstance(bc.value, list)
                 else f" {str(bc.value)!r}")
        omega = bc.micro(wall)
        if omega == "value":
            omega = "= " + ", ".join(repr(e.text) for e in bc.micro_rotation.expressions())
        source = ("given" if bc.micro_rotation is not None else
                  "micropolar.wall_condition" if bc.type == "no_slip" else "the default off no-slip walls")
        out.append(f"{name}: {bc.type}{value}" + (f", micro_rotation {omega} ({source})" if micro else ""))
    return out


def dump_resolved(scene: Scene, conditions: list[str] | None = None) -> str:
    """The fully resolved scene as YAML (``scene.to_yaml()``); ``conditions``: the lines of
    :func:`condition_lines`, appended as a comment block when the scene has no ``boundaries`` section (a
    built-in geometry's preset, or a file scene's defaults by name), so that the file still loads as it is."""
    text = scene.to_yaml()
    if conditions and scene.boundaries is None:
        text += ("# boundaries, as resolved from the geometry's preset (a comment: only a file scene takes a "
                 "boundaries section):\n" + "".join(f"#   {line}\n" for line in conditions))
    return text


def _resolve_vectors(scene: Scene, dim: int) -> None:
    """A vector left at its default (zero) gets one component per dimension of the scene: ``fluid.body_force``
    and ``solid.initial_velocity`` are [0, 0, 0] in 3D, so that the resolved scene (config.yaml) names the
    vector the scene runs with and loads again as it is."""
    for section, key in ((scene.fluid, "body_force"), (scene.solid, "initial_velocity")):
        if section is not None and key not in section.model_fields_set:
            setattr(section, key, [0.0] * dim)


def _check_step_control(time) -> None:
    """time.dt_min, dt_max, error_floor go with time.tolerance, and dt_min <= dt <= dt_max."""
    if time.tolerance is None:
        for key in ("dt_min", "dt_max", "error_floor"):
            if getattr(time, key) is not None:
                raise ValueError(f"time.{key}: needs time.tolerance (a fixed step is time.dt)")
        return
    if time.dt_min is not None and time.dt_min > time.dt:
        raise ValueError(f"time.dt_min: must be <= time.dt, the first step (got {time.dt_min!r} > {time.dt!r})")
    if time.dt_max is not None and time.dt_max < time.dt:
        raise ValueError(f"time.dt_max: must be >= time.dt, the first step (got {time.dt_max!r} < {time.dt!r})")
