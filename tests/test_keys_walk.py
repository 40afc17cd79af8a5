"""The walk of the scene reference: no key of it can be set to a value that the run then ignores without a
word. For each representative shipped scene, every key of the reference that applies to it (its geometry's
and its scheme's members) is set to a valid value other than the scene's; the scene is validated as
``--set`` does. Refused (config/usage.py and the sections' checks): fine. Accepted: the key must be one the
run reads, recorded by logging the attribute reads of the scene's sections during a 1-step run of the scene
(mesh, setup, one step, summary: app/runner.py ``run_scene``), or a warned output key the run reports
(config/usage.py ``WARNED``).

Scenes (level 0, one step each, about 1-4 s): a 2D CFD (schaefer_turek_2d2, characteristics2), an FSI
(turek_hron_fsi3, ale_bdf2 with time.tolerance), a steady solid (turek_hron_csm1), a micropolar scene
(micropolar_taylor_green: a lid, characteristics2), a 3D FSI (turek_hron_3d_fsi, characteristics2), a file
scene (examples/sudden_expansion: steady, micropolar, boundaries and observables). The walk sets every
applicable key of the reference: 287 (scene, key) pairs over the 6 scenes (46 to 50 a scene;
``test_the_walk_covers_the_reference`` checks that at least 280 are walked);
the keys of free mappings (``boundaries.NAME``, ``observables``, ``reference.COLUMN``,
``solver.petsc_options``, checked by their own tests) and free strings (``name``, ``geometry.path``) are
not.
"""

from __future__ import annotations

import copy
import functools
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
SCENES = {
    "cfd_2d": (REPO / "configs/schaefer_turek_2d2.yaml", ["geometry.level=0"]),
    "fsi": (REPO / "configs/turek_hron_fsi3.yaml", ["geometry.level=0"]),
    "steady_solid": (REPO / "configs/turek_hron_csm1.yaml", ["geometry.level=0"]),
    "micropolar": (REPO / "configs/micropolar_taylor_green.yaml", ["geometry.level=0"]),
    "fsi_3d": (REPO / "configs/turek_hron_3d_fsi.yaml", []),
    "file": (REPO / "examples/sudden_expansion/expansion.yaml", []),
}
READ_ELSEWHERE = {"output.progress": "app/cli.py (the progress bar, with --no-progress)",
                  "geometry.trusted": "geometry/file.py, when the scene is read (which gmsh commands a .geo may use)"}
"""Keys the run reads outside run_scene."""
SIZE_DEPENDENT = {"solver.amg", "solver.max_iterations", "solver.reuse_factorization", "solver.max_krylov_iterations"}
"""With ``solver.type: auto`` in 3D the solver is chosen by the unknowns at setup (and run.log says which):
these keys act from AUTO_ITERATIVE_FROM unknowns on (or below them), which a level-0 scene does not reach."""
SKIPPED_TYPES = ("section", "EXPR", "{")
SKIPPED_KEYS = ("name", "geometry.path")


def _raw(name):
    """The scene's raw mapping with its overrides, as load_scene reads it (a file's path made absolute)."""
    from cosserat_fsi.config.loading import _apply_override
    from cosserat_fsi.io.safe_yaml import yaml_load

    path, overrides = SCENES[name]
    data = yaml_load(path.read_text())
    data.setdefault("name", path.stem)
    geo = data["geometry"]
    if geo.get("name") == "file":
        geo["path"] = str(path.parent / geo["path"])
    for item in overrides:
        _apply_override(data, item)
    return data


def _paths(scene) -> dict[int, str]:
    """id(section object) -> its dotted key, for every section of a validated scene."""
    from pydantic import BaseModel

    out = {id(scene): ""}

    def walk(node, key):
        for field in type(node).model_fields:
            value = getattr(node, field)
            sub = f"{key}.{field}" if key else field
            if isinstance(value, BaseModel):
                out[id(value)] = sub
                walk(value, sub)
    walk(scene, "")
    return out


@functools.cache
def _reads(name) -> tuple[frozenset, tuple[str, ...]]:
    """(the dotted keys the 1-step run of scene ``name`` reads, the warning lines it writes): cached."""
    from mpi4py import MPI
    from pydantic import BaseModel

    from cosserat_fsi.app.runner import run_scene
    from cosserat_fsi.config.loading import validate_scene
    from cosserat_fsi.config.usage import usage_warnings
    import tempfile

    data = _raw(name)
    time = data["time"]
    if time["scheme"] != "steady":
        time["t_end"] = time["dt"]
    scene = validate_scene(data)
    paths, reads = _paths(scene), set()
    original = BaseModel.__getattribute__

    def logged(self, attr):
        value = original(self, attr)
        if not attr.startswith("_"):
            key = paths.get(id(self))
            if key is not None and attr in type(self).model_fields:
                caller = sys._getframe(1).f_code.co_filename
                if not caller.endswith(("config/usage.py", "pydantic/main.py")):
                    reads.add(f"{key}.{attr}" if key else attr)
        return value

    BaseModel.__getattribute__ = logged
    try:
        with tempfile.TemporaryDirectory() as out:
            run_scene(scene, Path(out), MPI.COMM_WORLD, progress=False)
    finally:
        BaseModel.__getattribute__ = original
    return frozenset(reads), tuple(usage_warnings(scene))


def _applies(row, scene) -> str | None:
    """The dotted key of reference row ``row`` in ``scene`` (union members resolved), or None when the row is
    another member's, a free mapping's or not a value."""
    key = row.key
    for section, tag in (("geometry", "name"), ("time", "scheme")):
        prefix = f"{section}[{tag}="
        if key.startswith(prefix):
            member, rest = key[len(prefix):].split("]", 1)
            if getattr(getattr(scene, section), tag) != member:
                return None
            key = section + rest
    if any(part.isupper() for part in key.split(".")) or key in SKIPPED_KEYS or key.endswith((".name", ".scheme")):
        return None
    if row.type.startswith(SKIPPED_TYPES) or row.type == "str":
        return None
    return key


def _candidates(row, current, dim):
    """Valid-looking values other than ``current`` for reference row ``row``, most plausible first."""
    out = []
    if row.allowed:
        out += [v.strip("`") for v in row.allowed.split(": ")[-1].split(", ")]
        out = [("off" if v == "off" else v) for v in out]
    if "bool" in row.type:
        out.append(not current)
    if "int" in row.type:
        base = current if isinstance(current, int) and not isinstance(current, bool) else 1
        out += [base + 1, base - 1, 2, 1]
    if "float" in row.type and not row.type.startswith("list"):
        base = current if isinstance(current, (int, float)) and not isinstance(current, bool) else None
        out += ([base * 0.5, base * 1.5] if base else []) + [0.3, 0.01, 1.0, 2.0, 0.45, 1e-3]
    if "list" in row.type:
        out += [[0.5] * dim, [0.5] * 3, [0.5] * 2, [0.5, 1.0]]
    return [v for v in out if v != current]


@functools.cache
def _walk(name):
    """(walked pairs, the keys accepted but not read)."""
    import yaml

    from cosserat_fsi.config.loading import _apply_override, validate_scene
    from cosserat_fsi.config.reference import scene_fields
    from cosserat_fsi.config.usage import _get
    from cosserat_fsi.errors import InputError

    base = validate_scene(_raw(name))
    reads, warnings = _reads(name)
    walked, ignored = 0, []
    for row in scene_fields():
        key = _applies(row, base)
        if key is None:
            continue
        walked += 1
        current = _get(base, key)
        accepted = None
        for value in _candidates(row, current, base.geometry.DIM):
            data = copy.deepcopy(_raw(name))
            try:
                _apply_override(data, f"{key}={yaml.safe_dump(value, default_flow_style=True).strip()}"
                                .replace("\n...", ""))
                scene = validate_scene(data)
            except InputError:
                continue
            if _get(scene, key) != current:
                accepted = value
                break
        if accepted is None:
            continue  # refused (every candidate)
        if key in reads or key in READ_ELSEWHERE:
            continue
        section = key.rsplit(".", 1)[0]
        if "." in key and _get(base, section) is None and section in reads:
            continue  # a section the scene has not: the run reads whether it is there (one run, not two)
        if key in SIZE_DEPENDENT and base.solver.type == "auto" and base.geometry.DIM == 3:
            continue
        if any(line.startswith(key + ":") for line in warnings):
            continue
        ignored.append(f"{key}={accepted!r}")
    return walked, ignored


@pytest.mark.parametrize("name", SCENES)
def test_every_set_key_is_read_by_the_run_or_refused(name):
    walked, ignored = _walk(name)
    assert not ignored, f"{name}: set, accepted, not read by the run: {ignored}"


def test_the_walk_covers_the_reference():
    assert sum(_walk(name)[0] for name in SCENES) >= 280
