"""The incompressible law that the campaigns pin where they measured it, in one place.

The shipped CSM and FSI scenes carry the benchmarks' own compressible St Venant–Kirchhoff solid; the seed's
incompressible Mooney–Rivlin law (c2 = 0) is stiffer in bending than it with ν = 0.4 (4 μ_s against
E/(1 − ν²) = 3.333 μ_s). The regression records, the extremes, the time-step ladders and the validation rows
marked "incompressible law" were measured with it, so they pin it over the scene file:

- ``INCOMPRESSIBLE``: the law, as scene overrides (dotted key -> value; None is YAML's null);
- ``FSI3_VOLUME_CORRECTION``: the volume correction's time the FSI3 cases used with it;
- :func:`as_set`: overrides as ``key=value`` strings for ``--set`` or ``load_scene``.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from cosserat_fsi.app.cases import override

INCOMPRESSIBLE: dict[str, Any] = {"solid.law": "mooney_rivlin_incompressible", "solid.lambda_s": None}
FSI3_VOLUME_CORRECTION: dict[str, Any] = {"solid.volume_correction_time": 0.002}


def as_set(overrides: Mapping[str, Any]) -> list[str]:
    """``["key=value", ...]`` as ``--set`` reads them back (None -> null)."""
    return [override(key, value) for key, value in overrides.items()]
