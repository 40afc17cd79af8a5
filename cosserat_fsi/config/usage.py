"""Keys whose effect depends on another key's value: a key the user sets is used by the run or refused.

One rule for every such key (docs/reliability.md, "A set key is used or refused"): a key given in a scene
where the other keys make it meaningless is refused when the scene is read (exit 2, one line naming it and
why), with one exception, keys that change only what is written (``WARNED``: ``output.every``,
``output.checkpoint_every``), which a scene file commonly keeps while a ``--set`` switches the fields off or
the scheme to ``steady``: the run writes one line ``<key>: not used: <why>`` to the terminal and run.log.

``RULES`` is the table: (key, why it is not used in a scene, or None). A key counts as set when the scene
gives it a value other than its default (the default is what the run does without the key). The checks
that need the mesh are where the mesh is read: a user file's facet groups (geometry/file.py
``check_scene``), the wall gap against the solid's distance to the walls (mesh/wall_gap.py).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from .time import NODAL_CONVECTION

WARNED = ("output.every", "output.checkpoint_every")
"""Keys that change only what is written: unused, they are warned about instead of refused."""

MICROPOLAR_TERMS = "micropolar terms (micropolar.mu_r or lambda1 > 0; in 3D also lambda2)"
LID_GEOMETRIES = ("square", "cube")


def _get(scene, key: str) -> Any:
    node = scene
    for part in key.split("."):
        node = getattr(node, part, None)
        if node is None:
            return None
    return node


def given(scene, key: str) -> bool:
    """Whether the scene gives ``key`` (a dotted path) a value other than its default: a fully resolved scene
    (config.yaml) writes every key, the unused ones at their defaults, and loads again."""
    node = scene
    for part in key.split("."):
        fields = getattr(node, "model_fields_set", None)
        if fields is None or part not in fields:
            return False
        default = type(node).model_fields[part].get_default(call_default_factory=True)
        node = getattr(node, part)
        if node is None or node == default or _zero_vector(node) and _zero_vector(default):
            return False  # (a zero vector in any dimension: the default, resolved to the scene's dimension)
    return True


def _zero_vector(value) -> bool:
    return isinstance(value, list) and not any(value)


def _steady(scene) -> bool:
    return scene.time.scheme == "steady"


def _iterative_possible(scene) -> str | None:
    """Why no solve of the scene can take the iterative solver (None: some can)."""
    kind = scene.solver.type
    if _steady(scene) and scene.has_solid:
        return "the steady solid solve (time.scheme steady with a solid) is direct (MUMPS)"
    if kind == "direct":
        return "solver.type is direct (MUMPS)"
    if kind == "auto" and scene.geometry.DIM == 2:
        return "solver.type auto takes MUMPS at every size in 2D"
    return None


def _reuse_possible(scene) -> str | None:
    """Why no solve of the scene keeps a MUMPS factorisation as a GMRES preconditioner (None: some can)."""
    if _steady(scene):
        return "a steady scene's Newton refactorises at every iteration"
    if scene.solver.type == "iterative":
        return "solver.type is iterative (no MUMPS factorisation to keep)"
    if not scene.solver.reuses_factorization(scene.has_solid, scene.time.scheme in NODAL_CONVECTION):
        if scene.solver.reuse_factorization is False:
            return "solver.reuse_factorization is false"
        if not scene.has_solid and scene.time.scheme not in NODAL_CONVECTION:
            return (f"the matrix of scheme {scene.time.scheme} on a fixed mesh is constant: one factorisation "
                    "serves every step")
        return f"scheme {scene.time.scheme} refactorises every step (solver.reuse_factorization: true keeps it)"
    return None


def _amg(scene) -> str | None:
    why = _iterative_possible(scene)
    return None if why is None else f"only for the iterative solver; {why}"


def _solver_type(scene) -> str | None:
    if scene.solver.type == "iterative" and _steady(scene) and scene.has_solid:
        return ("iterative: not available for the steady solid solve (time.scheme steady with a solid), which is "
                "direct (MUMPS); use type direct or auto, or a time-stepping scheme")
    return None


def _reuse(scene) -> str | None:
    if _steady(scene):
        return "not used by a steady scene (Newton refactorises at every iteration)"
    if scene.solver.type == "iterative":
        return "not with solver.type iterative (it keeps a MUMPS factorisation)"
    if not scene.has_solid and scene.time.scheme not in NODAL_CONVECTION:
        return (f"not used: the matrix of scheme {scene.time.scheme} on a fixed mesh is constant (one factorisation "
                "serves every step)")
    return None


def _kept(scene) -> str | None:
    why = _reuse_possible(scene)
    return None if why is None else f"only with a kept factorisation; {why}"


def _krylov_rtol(scene) -> str | None:
    if _reuse_possible(scene) is None or _iterative_possible(scene) is None:
        return None
    return f"only for the Krylov solves (a kept factorisation, or the iterative solver); {_iterative_possible(scene)}"


def _mumps(scene) -> str | None:
    if scene.solver.type == "iterative" and not (_steady(scene) and scene.has_solid):
        return "not with solver.type iterative (no MUMPS factorisation)"
    return None


def penalty_unused(kinds) -> str | None:
    """Why ``solver.penalty`` does nothing given the boundary condition types ``kinds``, or None."""
    natural = sorted(set(kinds) - {"no_slip", "velocity", "slip"})
    if natural:
        return (f"not used: a boundary of type {natural[0]} determines the pressure (the penalty only fixes the "
                "pressure's constant where the velocity is prescribed on the whole boundary)")
    return None


def _penalty(scene) -> str | None:
    if scene.geometry.name == "file" and scene.boundaries is None:
        return None  # the conditions by name come with the mesh: checked where it is read (file.check_scene)
    return penalty_unused(bc.type for bc in scene.conditions().values())


def _c2(scene) -> str | None:
    return "not used: the solid's stress has no c₂ term (in 2D, with det F = 1, c₂ would only shift the pressure)"


def _no_solid_cells(scene) -> str | None:
    geo = scene.geometry
    if geo.solid_cells or geo.SOLID_FROM_FILE:
        return None
    flag = getattr(geo, "flag", None)
    hint = " (geometry.flag: solid for a flexible flag)" if flag == "rigid" else ""
    what = f"geometry {geo.name}" + (f" with flag {flag}" if flag else "")
    return f"not used: {what} has no solid cells{hint}"


def _steady_only(what: str) -> Callable:
    def rule(scene) -> str | None:
        return f"not used by a steady scene ({what})" if _steady(scene) else None
    return rule


def _gravity_ramp(scene) -> str | None:
    if not scene.solid.gravity:
        return "needs solid.gravity (it ramps the weight; gravity is 0)"
    return _solved_after(scene, scene.solid.gravity_ramp_time)


def _inflow_ramp(scene) -> str | None:
    return _solved_after(scene, scene.inflow.ramp_time)


def _solved_after(scene, ramp_time: float) -> str | None:
    """A ramp does nothing in a steady scene solved at or after its end (problem/boundary.py steady_time)."""
    at = scene.time.steady_at if _steady(scene) else None
    if _steady(scene) and (at is None or at >= ramp_time):
        return (f"not used: this steady scene is solved at the end of every ramp (time.steady_at: "
                f"{'null' if at is None else repr(at)}; give an earlier time.steady_at to solve during it)")
    return None


def _volume_correction(scene) -> str | None:
    if _steady(scene):
        return "not used by a steady scene (the static solve has no node update to correct)"
    return None


def _volume_correction_time(scene) -> str | None:
    if _steady(scene):
        return _volume_correction(scene)
    if scene.solid.volume_correction is False:
        return "needs the volume correction (solid.volume_correction is false)"
    return None


def _mesh_motion(scene) -> str | None:
    if _steady(scene):
        return ("not used by a steady scene (its Newton solve extends the displacement into the fluid itself and "
                "moves the mesh once)")
    if not scene.has_fluid:
        return f"not used: geometry {scene.geometry.name} has no fluid mesh to move (the mesh is the solid)"
    return None


def _poisson_ratio(scene) -> str | None:
    method = scene.solid.mesh_motion.method
    return _mesh_motion(scene) or (None if method == "elastic" else
                                   f"only for solid.mesh_motion.method elastic (got {method})")


def _no_fluid(scene) -> str | None:
    return None if scene.has_fluid else f"not used: geometry {scene.geometry.name} has no fluid"


def _micro_terms(scene) -> str | None:
    return _no_fluid(scene) or (None if scene.has_micropolar else f"only with {MICROPOLAR_TERMS}")


def _lambda2(scene) -> str | None:
    if scene.geometry.DIM == 2:
        return "acts in 3D only (in 2D the micro-rotation ω e_z has no divergence)"
    return _no_fluid(scene)


def _nodal_characteristics(scene) -> str | None:
    if scene.time.scheme not in ("characteristics1", "characteristics2"):
        return f"only for the characteristics schemes (got time.scheme {scene.time.scheme})"
    return _micro_terms(scene)


def _inertia(scene) -> str | None:
    return _micro_terms(scene)  # a steady scene too: its micro-acceleration ρ I (u·∇)ω


def _inlet_or_lid(scene) -> str | None:
    geo = scene.geometry
    if scene.benchmark in ("micropolar_poiseuille", "micropolar_taylor_green"):
        return f"not used: benchmark {scene.benchmark} takes its boundary data from its exact solution"
    if geo.name == "file" or geo.INFLOW:
        return None
    names = geo.describe().get("facet_tags", {})
    if "inlet" in names or "lid" in names:
        return None
    return f"not used: geometry {geo.name} has no inlet (nor a lid)"


def _inflow_shape(scene) -> str | None:
    if scene.geometry.name in LID_GEOMETRIES:
        return f"not used: the lid of geometry {scene.geometry.name} moves as a whole (inflow.u_mean, ramp_time)"
    return _inlet_or_lid(scene)


def _asymmetry(scene) -> str | None:
    why = _inflow_shape(scene)
    if why:
        return why
    inflow = scene.inflow
    if inflow.ramp_time <= 0:
        return "acts during the ramp only (inflow.ramp_time is 0)"
    if _steady(scene):
        at = scene.time.steady_at  # null: after every ramp (problem/boundary.py steady_time)
        if at is None or at >= inflow.ramp_time:
            return (f"acts during the ramp only; this steady scene is solved after it (time.steady_at: "
                    f"{'null' if at is None else repr(at)})")
    return None


def _every(scene) -> str | None:
    if _steady(scene):
        return "a steady scene writes its one state"
    lines = scene.observables is not None and scene.observables.lines
    if not scene.output.fields and not lines and not scene.has_solid:
        return ("output.fields is false and nothing else is written every N steps (no observables.lines, no "
                "moving mesh's quality line)")
    return None


def _checkpoint_every(scene) -> str | None:
    return "a steady scene writes no checkpoint" if _steady(scene) else None


RULES: tuple[tuple[str, Callable[[Any], str | None]], ...] = (
    ("solver.type", _solver_type),
    ("solver.amg", _amg),
    ("solver.max_iterations", _amg),
    ("solver.reuse_factorization", _reuse),
    ("solver.max_krylov_iterations", _kept),
    ("solver.krylov_rtol", _krylov_rtol),
    ("solver.mumps_ordering", _mumps),
    ("solver.penalty", _penalty),
    ("solid", _no_solid_cells),
    ("solid.c2", _c2),
    ("solid.initial_velocity", _steady_only("no time derivative: the solid starts at rest and stays static")),
    ("solid.gravity_ramp_time", _gravity_ramp),
    ("solid.volume_correction", _volume_correction),
    ("solid.volume_correction_time", _volume_correction_time),
    ("solid.mesh_motion.method", _mesh_motion),
    ("solid.mesh_motion.stiffness_exponent", _mesh_motion),
    ("solid.mesh_motion.poisson_ratio", _poisson_ratio),
    ("solid.mesh_motion.wall_gap", _mesh_motion),
    ("solid.mesh_motion.remesh", _mesh_motion),
    ("micropolar.mu_r", _no_fluid),
    ("micropolar.lambda1", _no_fluid),
    ("micropolar.lambda2", _lambda2),
    ("micropolar.inertia", _inertia),
    ("micropolar.body_couple", _micro_terms),
    ("micropolar.wall_condition", _micro_terms),
    ("micropolar.nodal_characteristics", _nodal_characteristics),
    ("inflow", _inlet_or_lid),
    ("inflow.ramp_time", _inflow_ramp),
    ("inflow.profile", _inflow_shape),
    ("inflow.asymmetry", _asymmetry),
    ("output.every", _every),
    ("output.checkpoint_every", _checkpoint_every),
)
"""(key, why it is not used in a scene or None): checked in this order when the key is set (:func:`given`)."""


def unused(scene) -> list[tuple[str, str]]:
    """(key, why) of every set key of the table that the scene would not use."""
    out = []
    for key, rule in RULES:
        if given(scene, key):
            why = rule(scene)
            if why is not None:
                out.append((key, why))
    return out


def check_usage(scene) -> None:
    """ValueError ``<key>: <why>`` for the first set key the run would not use (``WARNED`` keys aside)."""
    for key, why in unused(scene):
        if key not in WARNED:
            raise ValueError(f"{key}: {why}")


def usage_warnings(scene) -> list[str]:
    """The lines the run writes for its set ``WARNED`` keys that it does not use."""
    return [f"{key}: not used: {why}" for key, why in unused(scene) if key in WARNED]
