"""The physical problem each benchmark defines: the scene keys that make a scene that benchmark's problem.

``DEFINING[name]`` maps dotted scene keys to the benchmark's value: geometry (name, flag, dimensions, clamp),
fluid (ρ, μ, body force, the viscous form whose natural condition is the do-nothing outflow), inflow (mean
speed, profile), micropolar coefficients, solid (law, ρ_s, moduli, gravity), and the initial state where the
reference depends on it. The numerical choices (mesh level, flag mesh, time step and scheme, tolerances,
solver, mesh motion, output) are not among them: they are what a run varies to converge to the reference.
A scene whose values differ in any defining key solves another problem: its numbers are shown beside the
reference without a verdict (app/verdict.py).

Conventions of the values:

- a :class:`OneOf` admits each of its values (a benchmark defined for a family of laws);
- a number against a vector (``fluid.body_force: 0.0``) holds for every component;
- floats agree to a relative 1e-9 (``E``/``nu`` given instead of ``mu_s``/``lambda_s`` agree with them);
- ``solid.mu_s`` and ``solid.lambda_s`` of a compressible law are its Lamé parameters, however given.

Sources: cosserat_fsi/data/benchmarks.yaml (Schäfer & Turek 1996; Turek & Hron 2006: St Venant–Kirchhoff,
plane strain, ν_s = 0.4, so λ_s = 2 μ_s ν_s / (1 − 2 ν_s) = 4 μ_s; FSI2 from the 2006 paper: ρ_s = 10⁴, μ_s =
0.5e6, Ū = 1), data/three_d_references.yaml (3D-1Z), the seed paper (seed_fsi3) and
shared/reference/micropolar_exact.md. The exact-solution benchmarks (micropolar_*) take ρ, μ, μ_r, λ₁, I and
the channel's size from the scene (cosserat_fsi/exact.py), so those are not defining for them: what the exact
solution assumes is (no body force or couple, ω = 0 on the walls, the do-nothing outlet's form).
seed_fsi3 admits any micropolar coefficients: the seed reports the same oscillation for its Cosserat runs
without printing their coefficients (configs/seed_cosserat_fsi3.yaml).
"""

from __future__ import annotations

import math
from typing import Any


class OneOf(tuple):
    """The values a benchmark admits for a key (a family of laws)."""

    def __repr__(self) -> str:
        return " or ".join(map(str, self))


SVK = OneOf(("saint_venant_kirchhoff",))
SEED_LAW = OneOf(("mooney_rivlin_incompressible",))

_NEWTONIAN_2D = {"fluid.body_force": 0.0, "fluid.viscous_form": "laplacian", "micropolar.mu_r": 0.0,
                 "micropolar.lambda1": 0.0}


def _schaefer_turek(geometry: str, u_mean: float, dim: int = 2) -> dict[str, Any]:
    extra = {"micropolar.lambda2": 0.0} if dim == 3 else {}
    return {"geometry.name": geometry, "fluid.rho": 1.0, "fluid.mu": 1.0e-3, **_NEWTONIAN_2D, **extra,
            "inflow.u_mean": u_mean, "inflow.profile": "parabolic"}


def _cfd(u_mean: float) -> dict[str, Any]:
    return {"geometry.name": "turek_hron", "geometry.flag": "rigid", "fluid.rho": 1000.0, "fluid.mu": 1.0,
            **_NEWTONIAN_2D, "inflow.u_mean": u_mean, "inflow.profile": "parabolic"}


def _csm(mu_s: float, **extra) -> dict[str, Any]:
    return {"geometry.name": "flag", "geometry.length": 0.35, "geometry.height": 0.02, "geometry.clamp": "arc",
            "solid.law": SVK, "solid.rho": 1000.0, "solid.mu_s": mu_s, "solid.lambda_s": 4.0 * mu_s,
            "solid.gravity": 2.0, **extra}


def _fsi(u_mean: float, rho_s: float, mu_s: float) -> dict[str, Any]:
    return {"geometry.name": "turek_hron", "geometry.flag": "solid", "fluid.rho": 1000.0, "fluid.mu": 1.0,
            **_NEWTONIAN_2D, "inflow.u_mean": u_mean, "inflow.profile": "parabolic", "solid.law": SVK,
            "solid.rho": rho_s, "solid.mu_s": mu_s, "solid.lambda_s": 4.0 * mu_s, "solid.gravity": 0.0}


_EXACT = {"fluid.body_force": 0.0, "fluid.viscous_form": "laplacian", "micropolar.body_couple": 0.0,
          "micropolar.wall_condition": "zero"}

DEFINING: dict[str, dict[str, Any]] = {
    "schaefer_turek_2d1": _schaefer_turek("schaefer_turek", 0.2),
    "schaefer_turek_2d2": _schaefer_turek("schaefer_turek", 1.0),
    "schaefer_turek_3d1z": _schaefer_turek("schaefer_turek_3d", 0.2, dim=3),
    "turek_hron_cfd1": _cfd(0.2),
    "turek_hron_cfd2": _cfd(1.0),
    "turek_hron_cfd3": _cfd(2.0),
    "turek_hron_csm1": _csm(0.5e6),
    "turek_hron_csm2": _csm(2.0e6),
    # dynamic: released at rest, the full gravity from t = 0 (a ramp would not excite the oscillation)
    "turek_hron_csm3": _csm(0.5e6, **{"solid.gravity_ramp_time": 0.0, "solid.initial_velocity": 0.0}),
    "turek_hron_fsi1": _fsi(0.2, 1000.0, 0.5e6),
    "turek_hron_fsi2": _fsi(1.0, 10000.0, 0.5e6),
    "turek_hron_fsi3": _fsi(2.0, 1000.0, 2.0e6),
    "seed_fsi3": {"geometry.name": "turek_hron", "geometry.flag": "solid", "fluid.rho": 1000.0, "fluid.mu": 1.0,
                  "fluid.body_force": 0.0, "inflow.u_mean": 2.0, "inflow.profile": "parabolic",
                  "solid.law": SEED_LAW, "solid.rho": 1000.0, "solid.mu_s": 2.0e6, "solid.gravity": 0.0},
    "micropolar_poiseuille": {"geometry.name": "channel", **_EXACT},
    "micropolar_taylor_green": {"geometry.name": "square", **_EXACT},
}
"""Benchmark name -> {dotted scene key: the benchmark's value}, in the order differences are reported."""


def scene_value(scene, key: str) -> Any:
    """The scene's value at a dotted key (None where its section is absent); a compressible solid's
    ``mu_s``/``lambda_s`` are its Lamé parameters (also when given as ``E`` and ``nu``)."""
    section, _, name = key.partition(".")
    obj = getattr(scene, section, None)
    if obj is None:
        return None
    if section == "solid" and name in ("mu_s", "lambda_s") and obj.compressible:
        return obj.lame()[name == "lambda_s"]
    value = getattr(obj, name, None)
    return list(value) if isinstance(value, (list, tuple)) else value


def _same(value: Any, expected: Any) -> bool:
    if isinstance(expected, OneOf):
        return any(_same(value, e) for e in expected)
    if isinstance(value, list):
        items = expected if isinstance(expected, list) else [expected] * len(value)
        return len(items) == len(value) and all(_same(v, e) for v, e in zip(value, items))
    if isinstance(expected, float) and isinstance(value, (int, float)) and not isinstance(value, bool):
        return math.isclose(value, expected, rel_tol=1e-9, abs_tol=0.0)
    return value == expected


def differences(scene) -> dict[str, dict[str, Any]]:
    """{key: {"scene": value, "benchmark": value}} of each defining key where the scene differs from its
    benchmark (in DEFINING's order); empty for a scene that is the benchmark's problem or names none."""
    defining = DEFINING.get(scene.benchmark or "", {})
    out = {}
    for key, expected in defining.items():
        value = scene_value(scene, key)
        if not _same(value, expected):
            shown = " or ".join(expected) if isinstance(expected, OneOf) else expected
            out[key] = {"scene": value, "benchmark": shown}
    return out


def applicability(scene) -> dict[str, Any]:
    """summary.json's benchmark keys: ``{"applicable": True}``, or ``{"applicable": False, "differs": [keys],
    "differences": {key: {"scene", "benchmark"}}}``."""
    found = differences(scene)
    if not found:
        return {"applicable": True}
    return {"applicable": False, "differs": list(found), "differences": found}
