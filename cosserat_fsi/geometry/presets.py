"""The built-in geometries as presets of the user-file path: their default ``boundaries``.

A built-in geometry is a generator of a mesh with physical names (its builder module) plus the conditions
this module writes for it in the language of a ``boundaries:`` section, so that the boundary code has one
path (problem/boundary.py reads only a ``boundaries`` mapping). By name:

- ``walls``, ``cylinder``, ``clamp``: no-slip; ``interface``: no-slip where the flag is a rigid hole in the
  fluid, nothing where it is the inside fluid–solid interface, the natural (traction-free) condition where
  there is no fluid (geometry flag);
- ``inlet``: the ``inflow`` section as a velocity expression — the parabola 6 U y (H − y)/H² (in 3D times
  6 z (W − z)/W²) or U, times the cosine ramp (1 − cos(π min(t, T)/T))/2, plus the start-up tilt
  ε sin(π min(t, T)/T) (2y/H − 1) when ``inflow.asymmetry`` is set; do-nothing without an inflow section;
- ``outlet``: do-nothing; ``lid`` (square, cube): the moving lid U × ramp with an inflow section (its
  micro-rotation condition that of the walls), else no-slip.

The expressions repeat the arithmetic of the former hand-written inflow (same operations in the same
order), so the presets' numbers are those recorded before (campaigns/regression.py, to 1e-10).
"""

from __future__ import annotations

from typing import Any

NO_SLIP_ORDER = ("walls", "cylinder", "clamp", "interface", "lid", "inlet", "outlet")
"""The order of the conditions (the ω = ½ curl u wall terms are summed in this order)."""


def _ramp(ramp_time: float) -> str:
    """The cosine ramp as an expression factor ('' when there is none)."""
    if ramp_time <= 0:
        return ""
    T = repr(float(ramp_time))
    return f" * (0.5*(1.0 - cos(pi*min(t, {T})/{T})))"


def _inflow_value(inflow, describe: dict[str, Any], dim: int) -> list[str]:
    """The inlet velocity of an ``inflow`` section as expressions in x, y, z, t (channels start at y = z = 0)."""
    U, H = repr(float(inflow.u_mean)), repr(float(describe["height"]))
    y0, z0 = float(describe.get("y0", 0.0)), float(describe.get("z0", 0.0))
    y = "y" if y0 == 0 else f"(y - {y0!r})"
    z = "z" if z0 == 0 else f"(z - {z0!r})"
    if inflow.profile == "parabolic":
        profile = f"6.0*{U}*{y}*({H} - {y})/{H}**2"
        if dim == 3:
            W = repr(float(describe["width"]))
            profile = f"{profile}*6.0*{z}*({W} - {z})/{W}**2"  # the former ux * 6 z (W - z)/W², same order
    else:
        profile = U
    value = f"({profile}){_ramp(inflow.ramp_time)}"
    if inflow.asymmetry and inflow.ramp_time > 0:
        T, eps = repr(float(inflow.ramp_time)), repr(float(inflow.asymmetry))
        value += f" + {eps}*sin(pi*min(t, {T})/{T})*(({profile})*(2.0*{y}/{H} - 1.0))"
    return [value] + ["0"] * (dim - 1)


def default_boundaries(scene, names=None, extent=None) -> dict[str, dict[str, Any]]:
    """The ``boundaries`` mapping (plain data, for config.BoundaryCondition) of a built-in geometry's scene;
    ``names``, ``extent`` ({y0, height, z0, width}): the mesh's facet names and bounding box (for a file
    scene without a ``boundaries`` section, which gets the same defaults by name)."""
    geometry = scene.geometry
    info = {**geometry.describe(), **(extent or {})}
    names = info["facet_tags"] if names is None else names
    dim = geometry.DIM
    micro = scene.has_micropolar
    wall = scene.micropolar.wall_condition
    moving_lid = scene.inflow is not None and "lid" in names and geometry.name in ("square", "cube")
    out: dict[str, dict[str, Any]] = {}
    for name in NO_SLIP_ORDER:
        if name not in names:
            continue
        if name in ("walls", "cylinder", "clamp"):
            out[name] = {"type": "no_slip"}
        elif name == "interface":
            if not scene.has_solid:
                out[name] = {"type": "no_slip"}
            elif not scene.has_fluid:
                out[name] = {"type": "do_nothing"}
        elif name == "lid":
            if moving_lid:
                ramp = _ramp(scene.inflow.ramp_time)
                out[name] = {"type": "velocity", "value": [f"({float(scene.inflow.u_mean)!r}){ramp}"]
                             + ["0"] * (dim - 1)}
                if micro:
                    out[name]["micro_rotation"] = wall
            else:
                out[name] = {"type": "no_slip"}
        elif name == "inlet":
            out[name] = ({"type": "velocity", "value": _inflow_value(scene.inflow, info, dim)}
                         if scene.inflow is not None else {"type": "do_nothing"})
        else:
            out[name] = {"type": "do_nothing"}
    return out
