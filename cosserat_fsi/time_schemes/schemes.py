"""The time schemes by name (``time.scheme``): each one class behind the interface of time_step.py.

| scheme | class | module |
|---|---|---|
| characteristics1, characteristics2 | :class:`Characteristics` | characteristics.py (seed §5 and its BDF2) |
| ale_bdf2 | :class:`AleBdf2` | ale_bdf.py (BDF2 of the nodal values, convection relative to the mesh) |
| generalized_alpha | :class:`GeneralizedAlpha` | generalized_alpha.py |
| steady | :class:`SteadyFluid` or :class:`SteadySolid` | steady.py, steady_solid.py (Newton) |
"""

from __future__ import annotations

from .ale_bdf import AleBdf2
from .characteristics import Characteristics
from .generalized_alpha import GeneralizedAlpha
from .steady import SteadyFluid
from .steady_solid import SteadySolid

TIME_STEPPING = {"characteristics1": Characteristics, "characteristics2": Characteristics,
                 "ale_bdf2": AleBdf2, "generalized_alpha": GeneralizedAlpha}


def scheme_class(scene, model):
    """The class of the scene's scheme (``model``: the Problem's; a steady solid needs its own solver)."""
    if scene.time.scheme == "steady":
        return SteadySolid if model.solid else SteadyFluid
    return TIME_STEPPING[scene.time.scheme]
