"""Base of the geometry models: each geometry module defines one pydantic model (its ``name`` is the tag of
the ``geometry.Geometry`` discriminated union, its fields are the YAML keys of the ``geometry`` section) and
the model is the only way its builder gets parameters (``msh_params``)."""

from __future__ import annotations

import importlib
from typing import Annotated, Any, ClassVar, Literal

from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator

MAX_LEVEL = 6
MIN_DIMENSION, MAX_DIMENSION = 1e-6, 1e6
"""Bounds of every length parameter (m): below, gmsh's geometric tolerance merges points."""
MAX_CELLS = 10_000_000
"""Largest mesh built (cells, estimated before gmsh runs): level 6 of turek_hron has about 6.5 M."""
SCENE_KEY = {"thickness": "height", "size": "length"}
"""Builder parameter -> the scene's geometry key it comes from (for messages)."""
PositiveFloat = Annotated[float, Field(gt=0)]


class GeometryBase(BaseModel):
    """A mesh level (0..MAX_LEVEL, each halving the element size; ``seed`` where the seed paper's mesh
    exists). ``null`` for any key means its default. The string literal under a field is its description."""

    model_config = ConfigDict(extra="forbid", strict=True, allow_inf_nan=False,
                              use_attribute_docstrings=True)  # as config._Section

    SEED: ClassVar[bool] = False  # has level "seed" (the seed paper's mesh size)
    FLUID: ClassVar[bool] = True  # has fluid cells: the scene needs a fluid section
    INFLOW: ClassVar[bool] = False  # has an inlet: the scene needs an inflow section
    SOLID_FROM_FILE: ClassVar[bool] = False  # solid cells are known only from the file (geometry file)
    DIM: ClassVar[int] = 2  # space dimension of the mesh (2: triangles, 3: tetrahedra; a file: read from it)

    name: str
    """The geometry (the tag of the union)."""
    level: int | Literal["seed"] = 0
    """Mesh level 0 to 6: each level halves the element size (about 4× the vertices in 2D, 8× in 3D);
    ``seed`` (turek_hron only): the seed paper's mesh size."""

    @model_validator(mode="before")
    @classmethod
    def _null_is_default(cls, data: Any) -> Any:
        return {k: v for k, v in data.items() if v is not None} if isinstance(data, dict) else data

    @field_validator("level", mode="before")
    @classmethod
    def _level(cls, value: Any) -> Any:
        if value == "seed":
            if cls.SEED:
                return value
            seeded = ", ".join(sub.model_fields["name"].default for sub in GeometryBase.__subclasses__() if sub.SEED)
            raise ValueError(f"'seed' only for geometry {seeded} (got {value!r})")
        if type(value) is int and 0 <= value <= MAX_LEVEL:
            return value
        raise ValueError(f"must be an integer 0..{MAX_LEVEL} or 'seed' (got {value!r})")

    @model_validator(mode="after")
    def _size(self):
        """Lengths within [MIN_DIMENSION, MAX_DIMENSION] m, and the mesh's cell count, estimated before gmsh
        runs (builders with an ``estimate_cells``), at most MAX_CELLS: the keys that cause it are named."""
        for key, value in self.msh_params().items():
            if isinstance(value, float) and not MIN_DIMENSION <= value <= MAX_DIMENSION:
                key = SCENE_KEY.get(key, key)
                raise ValueError(f"geometry.{key}: must be between {MIN_DIMENSION:g} and {MAX_DIMENSION:g} "
                                 f"(m; got {value!r})")
        module = importlib.import_module(type(self).__module__)
        if hasattr(module, "estimate_cells"):
            scale = getattr(module, "SEED_SCALE", 1.0) if self.level == "seed" else 2.0 ** -self.level
            cells = module.estimate_cells(scale, self.msh_params())
            if cells > MAX_CELLS:
                keys = ", ".join(f"geometry.{SCENE_KEY.get(k, k)}" for k in ("level", *self.msh_params()))
                raise ValueError(f"geometry: {keys} give about {cells:.3g} cells, more than {MAX_CELLS:,} "
                                 "(lower the level or make the sides less elongated)")
        return self

    @property
    def solid_cells(self) -> bool:
        """True if the mesh has solid cells (tag 2)."""
        return False

    def msh_params(self) -> dict[str, Any]:
        """The parameters of this geometry's gmsh builder (floats and strings, every default filled in)."""
        return {}

    def describe(self) -> dict[str, Any]:
        """Tags, named points and dimensions: the ``describe`` of the builder module defining this model."""
        return importlib.import_module(type(self).__module__).describe(self.msh_params())
