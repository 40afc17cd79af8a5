"""Published reference values of the benchmarks (data/benchmarks.yaml: a verbatim copy of
shared/reference/benchmarks.yaml; data/three_d_references.yaml: the 3D benchmarks, from
shared/reference/three_d_literature.md with their sources).

``reference_for(benchmark)`` gives the observables to compare for each ``Scene.benchmark`` name: a float,
a periodic ``{"mean", "amplitude", "frequency"}`` dict, or a ``{"min", "max"}`` range.
"""

from __future__ import annotations

import copy
import re
from functools import cache
from importlib import resources

from cosserat_fsi.config import GEOMETRY_OF_BENCHMARK, yaml_load

_PERIODIC = re.compile(r"^\s*(\S+)\s*\+-\s*(\S+)\s*\[\s*(\S+)\s*\]\s*$")


@cache
def _references() -> dict:
    text = resources.files("cosserat_fsi").joinpath("data/benchmarks.yaml").read_text(encoding="utf-8")
    return yaml_load(text)


@cache
def _references_3d() -> dict:
    text = resources.files("cosserat_fsi").joinpath("data/three_d_references.yaml").read_text(encoding="utf-8")
    return yaml_load(text)


def load_references() -> dict:
    """The whole reference file as a dict (a fresh copy; ``1e-3``-style numbers are floats)."""
    return copy.deepcopy(_references())


def parse_periodic(text: str) -> dict[str, float]:
    """``"439.45 +- 5.6183 [4.3956]"`` -> ``{"mean": 439.45, "amplitude": 5.6183, "frequency": 4.3956}``."""
    match = _PERIODIC.match(text)
    if not match:
        raise ValueError(f"not a periodic value 'mean +- amplitude [frequency]': {text!r}")
    mean, amplitude, frequency = map(float, match.groups())
    return {"mean": mean, "amplitude": amplitude, "frequency": frequency}


def _pick(case: dict, keys: tuple[str, ...]) -> dict:
    """The entries ``keys`` of ``case``, periodic strings parsed and ``[lo, hi]`` lists as ranges."""
    out = {}
    for key in keys:
        value = case[key]
        if isinstance(value, str):
            value = parse_periodic(value)
        elif isinstance(value, list):
            value = {"min": float(value[0]), "max": float(value[1])}
        else:
            value = float(value)
        out[key] = value
    return out


def reference_for(benchmark: str, source: str = "featflow_current") -> dict[str, float | dict]:
    """Reference observables of a benchmark (a ``Scene.benchmark`` name).

    ``source`` selects the FSI3 values: ``"featflow_current"`` (default: the benchmark authors' refined values,
    uy(A) 5.46 Hz, to which the benchmark's own solid converges here: docs/validation.md) or ``"paper_2006"``
    (Turek & Hron 2006, 5.3 Hz).
    ``turek_hron_fsi2`` has no values in the reference file and gives ``{}``; the exact-solution scenes
    (cosserat_fsi/exact.py) give zero errors.
    """
    if benchmark not in GEOMETRY_OF_BENCHMARK:
        raise ValueError(f"unknown benchmark {benchmark!r} (known: {', '.join(GEOMETRY_OF_BENCHMARK)})")
    if benchmark in ("micropolar_poiseuille", "micropolar_taylor_green"):
        return {"velocity": 0.0, "micro_rotation": 0.0}  # relative L² errors against the exact solution
    if benchmark == "schaefer_turek_3d1z":
        return _pick(_references_3d()["schaefer_turek_3d"]["cases"]["3D-1Z"], ("c_D", "c_L", "dp"))
    refs = _references()
    th, st = refs["turek_hron"]["cases"], refs["schaefer_turek_1996"]["cases"]
    if benchmark == "schaefer_turek_2d1":
        return _pick(st["2D-1"], ("c_D", "c_L", "dp"))
    if benchmark == "schaefer_turek_2d2":
        return _pick(st["2D-2"], ("c_D_max", "c_L_max", "St", "dp_at_half_period"))
    if benchmark in ("turek_hron_cfd1", "turek_hron_cfd2", "turek_hron_cfd3"):
        return _pick(th[benchmark[-4:].upper()], ("drag", "lift"))
    if benchmark in ("turek_hron_csm1", "turek_hron_csm2", "turek_hron_csm3"):
        return _pick(th[benchmark[-4:].upper()], ("ux_A", "uy_A"))
    if benchmark == "turek_hron_fsi1":
        return _pick(th["FSI1"], ("ux_A", "uy_A", "drag", "lift"))
    if benchmark == "turek_hron_fsi3":
        if source not in ("paper_2006", "featflow_current"):
            raise ValueError(f"unknown FSI3 source {source!r} (paper_2006 or featflow_current)")
        return _pick(th["FSI3"][source], ("ux_A", "uy_A", "drag", "lift"))
    if benchmark == "seed_fsi3":
        seed = refs["seed_paper"]
        return {"uy_A": {"amplitude": float(seed["uy_A_amplitude_m"]),
                         "frequency": float(seed["uy_A_frequency_hz"])}}
    return {}  # turek_hron_fsi2: no reference values stored
