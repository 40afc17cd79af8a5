"""The base of every section, the number types, the step bounds and the benchmark table."""

from __future__ import annotations

from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field

from .benchmarks import DEFINING

GEOMETRY_OF_BENCHMARK = {name: (keys["geometry.name"], keys.get("geometry.flag"))
                         for name, keys in DEFINING.items()}
"""Benchmark name -> (required geometry.name, required geometry.flag or None): the geometry part of
config/benchmarks.py's DEFINING, checked when the scene is read."""

Benchmark = Literal[
    "schaefer_turek_2d1", "schaefer_turek_2d2", "schaefer_turek_3d1z",
    "turek_hron_cfd1", "turek_hron_cfd2", "turek_hron_cfd3",
    "turek_hron_csm1", "turek_hron_csm2", "turek_hron_csm3",
    "turek_hron_fsi1", "turek_hron_fsi2", "turek_hron_fsi3",
    "seed_fsi3",
    "micropolar_poiseuille", "micropolar_taylor_green",
]
MAX_STEPS = 100_000_000
"""Most time steps a scene may ask for (t_end / dt): beyond it a run would not end in a lifetime."""
MAX_COUNT = 1_000_000_000
"""Upper bound of every step-count setting (output.every, output.checkpoint_every, ...)."""


class _Section(BaseModel):
    """Base of every section: unknown keys, loose types (a string for a number) and non-finite numbers
    (``.inf``, ``.nan``, ``1e999``) are errors: one setting for every float of every section. The string
    literal under a field is its description (the scene reference, config/reference.py)."""

    model_config = ConfigDict(extra="forbid", strict=True, allow_inf_nan=False, use_attribute_docstrings=True)


PositiveFloat = Annotated[float, Field(gt=0)]
NonNegFloat = Annotated[float, Field(ge=0)]


def _short(value: Any) -> str:
    """A bounded repr (an aliased YAML structure can be huge)."""
    import reprlib

    short = reprlib.Repr()
    short.maxstring, short.maxother, short.maxlong = 40, 40, 40
    return short.repr(value)
