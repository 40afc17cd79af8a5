"""Reading a scene: YAML, ``--set`` overrides, validation, and pydantic's errors as one-line messages
``"<dotted.key>: <problem>"`` (raised as :class:`~cosserat_fsi.errors.InputError`)."""

from __future__ import annotations

import difflib
import re
from pathlib import Path
from typing import Any, NamedTuple, get_args, get_origin
from collections.abc import Sequence

import yaml
from pydantic import BaseModel, TypeAdapter, ValidationError

from cosserat_fsi.errors import InputError
from cosserat_fsi.geometry import MODELS, Geometry, GeometryBase
from cosserat_fsi.io.safe_yaml import describe_yaml_error, read_text_file, yaml_load

from .base import _short
from .scene import Scene
from .time import TIME_SCHEMES


class _Union(NamedTuple):
    """A section that is one model per value of its tag key."""

    tag: str
    members: dict[str, type[BaseModel]]
    noun: str  # "geometry": "only for geometry channel"
    unused: str  # for a key of other members; {path} {key} {member} {owners}


UNIONS = {
    "geometry": _Union("name", MODELS, "geometry",
                       "{path}.{key}: not used for geometry {member!r} (only for {owners})"),
    "time": _Union("scheme", TIME_SCHEMES, "scheme", "{path}.{key}: not used by scheme {member} (only for {owners})"),
}
"""Section name -> its union (the tag is not a key of the location pydantic reports)."""

REMOVED = {
    "time.convection": "removed: the scheme sets it, e.g. scheme ale_bdf2 for convection ale",
}
"""Hints for keys that no longer exist (any other unknown key gets the closest match)."""


def _walk(parts: Sequence[str]) -> tuple[list[type[BaseModel]], bool]:
    """(model classes at dotted path ``parts``, whether it is a mapping of named sections such as
    ``boundaries``, whose next key is any name)."""
    models: list[type[BaseModel]] = [Scene]
    named = False
    for part in parts:
        if named:  # boundaries.NAME: the mapping's value model
            named = False
            continue
        fields = [m.model_fields[part] for m in models if part in m.model_fields]
        kinds = [a for f in fields for a in (f.annotation, *getattr(f.annotation, "__args__", ()))]
        models = [a for a in kinds if isinstance(a, type) and issubclass(a, BaseModel)]
        values = [get_args(a)[1] for a in kinds if get_origin(a) is dict and isinstance(get_args(a)[1], type)
                  and issubclass(get_args(a)[1], BaseModel)]
        if values and not models:
            models, named = values, True
    return models, named


def _models_at(parts: Sequence[str]) -> list[type[BaseModel]]:
    """The model classes at dotted path ``parts`` (``()`` is the Scene; a union such as ``geometry`` gives
    all its members; ``boundaries`` and ``boundaries.NAME`` give BoundaryCondition), or ``[]`` if it is not a
    section."""
    return _walk(parts)[0]


def _free_mapping(parts: Sequence[str]) -> bool:
    """Whether dotted path ``parts`` is a mapping of free keys to values (``solver.petsc_options``)."""
    if not parts:
        return False
    fields = [m.model_fields[parts[-1]] for m in _models_at(parts[:-1]) if parts[-1] in m.model_fields]
    return any(get_origin(f.annotation) is dict and not _models_at(parts) for f in fields)


def _field_names(parts: Sequence[str]) -> list[str]:
    """Keys allowed in the section at ``parts`` (for a union: in any of its members)."""
    return list(dict.fromkeys(name for m in _models_at(parts) for name in m.model_fields))


def _unknown_key(parts: Sequence[str], names: Sequence[str] | None = None) -> str:
    """``"a.b: unknown key (did you mean 'c'?)"`` for the last element of ``parts``, among ``names`` (default:
    the keys of the section ``parts[:-1]``)."""
    names = _field_names(parts[:-1]) if names is None else list(names)
    if not names:  # inside a mapping of named sections (boundaries.NAME): no list to offer
        return f"{'.'.join(parts)}: unknown key"
    close = difflib.get_close_matches(parts[-1], names, n=1)
    hint = REMOVED.get(".".join(parts)) or (f"did you mean {close[0]!r}?" if close else "allowed: " + ", ".join(names))
    return f"{'.'.join(parts)}: unknown key ({hint})"


def _not_for_member(path: str, key: str, member: str) -> str:
    """A key of another member of the union at ``path`` given to member ``member``."""
    union = UNIONS[path]
    owners = [name for name, model in union.members.items() if key in model.model_fields]
    if not owners:
        return _unknown_key([path, key], union.members[member].model_fields)
    if len(owners) == 1:
        return f"{path}.{key}: only for {union.noun} {owners[0]} (got {union.noun} {member!r})"
    return union.unused.format(path=path, key=key, member=member, owners=", ".join(owners))


def _dotted(loc: Sequence[str | int]) -> str:
    """Pydantic location -> ``fluid.body_force[0]``."""
    out = ""
    for part in loc:
        out += f"[{part}]" if isinstance(part, int) else (f".{part}" if out else part)
    return out


def _describe(err: dict) -> str:
    """One pydantic error -> ``"<dotted.key>: <problem>"``."""
    loc, kind, got, ctx = err["loc"], err["type"], err.get("input"), err.get("ctx", {})
    member = None
    union = UNIONS.get(str(loc[0])) if loc else None
    if len(loc) > 1 and union is not None and loc[1] in union.members:  # the union's tag is not a key
        member, loc = loc[1], (loc[0], *loc[2:])
    if kind in ("union_tag_invalid", "union_tag_not_found") and loc and str(loc[-1]) in UNIONS:
        union = UNIONS[str(loc[-1])]
        if kind == "union_tag_not_found":
            return f"{_dotted(loc)}.{union.tag}: missing key (one of {', '.join(union.members)})"
        return f"{_dotted(loc)}.{union.tag}: must be one of {', '.join(union.members)} (got {ctx.get('tag')!r})"
    if kind == "extra_forbidden" and member is not None:
        return _not_for_member(str(loc[0]), str(loc[-1]), member)
    if kind == "value_error":
        message = str(ctx["error"])
        if not loc or message.startswith((_dotted(loc) + ".", _dotted(loc) + ":")):  # already names its key
            return message
        return f"{_dotted(loc)}: {message}"
    if kind == "extra_forbidden":
        return _unknown_key([str(p) for p in loc])
    if kind == "missing":
        what = "missing section" if _models_at([str(p) for p in loc]) else "missing key"
        return f"{_dotted(loc)}: {what}"
    problems = {
        "greater_than": lambda: f"must be > {ctx['gt']:g}",
        "greater_than_equal": lambda: f"must be >= {ctx['ge']:g}",
        "less_than": lambda: f"must be < {ctx['lt']:g}",
        "less_than_equal": lambda: f"must be <= {ctx['le']:g}",
        "finite_number": lambda: "must be a finite number",
        "literal_error": lambda: "must be one of " + ", ".join(re.findall(r"'([^']*)'", ctx["expected"])),
        "float_type": lambda: "must be a number",
        "int_type": lambda: "must be an integer",
        "bool_type": lambda: "must be true or false",
        "string_type": lambda: "must be a string",
        "list_type": lambda: "must be a list",
        "too_short": lambda: f"must have {ctx.get('min_length')} entries",
        "too_long": lambda: f"must have {ctx.get('max_length')} entries",
        "model_type": lambda: "must be a mapping of keys",
        "dict_type": lambda: "must be a mapping of keys",
        "model_attributes_type": lambda: "must be a mapping of keys",
    }
    problem = problems[kind]() if kind in problems else err["msg"].lower()
    return f"{_dotted(loc)}: {problem} (got {_short(got)})"


def _apply_override(data: dict, item: str) -> None:
    """Apply one ``dotted.key=value`` override to the raw config mapping (in place). The value is YAML;
    ``null`` removes the key (its default applies), e.g. ``time.corrector_passes=null`` when switching
    ``time.scheme`` to one without that key."""
    key, sep, text = item.partition("=")
    parts = key.strip().split(".")
    if not sep or not all(re.fullmatch(r"\w+", p) for p in parts):
        raise InputError(f"--set {item}: expected dotted.key=value (e.g. time.dt=1e-3)")
    for i in range(len(parts)):
        if _walk(parts[:i])[1]:  # a name in a mapping of named sections (boundaries.NAME): any name
            continue
        if _free_mapping(parts[:i]):  # solver.petsc_options.KEY: any key, holding a value
            if i != len(parts) - 1:
                raise InputError(f"{'.'.join(parts[:i + 1])}: is a value, not a section (in --set {key})")
            break
        if not _models_at(parts[:i]):
            raise InputError(f"{'.'.join(parts[:i])}: is a value, not a section (in --set {key})")
        if parts[i] not in _field_names(parts[:i]):
            raise InputError(_unknown_key(parts[:i + 1]))
    try:
        value = yaml_load(text)
    except yaml.YAMLError as exc:
        problem = describe_yaml_error(exc).split("could not parse YAML ", 1)[-1]
        raise InputError(f"{key}: could not parse value {_short(text)} as YAML {problem}") from None
    node = data
    for i, part in enumerate(parts[:-1]):
        if value is None and not isinstance(node.get(part), dict):
            return  # nothing to remove
        if node.get(part) is None:
            node[part] = {}
        if not isinstance(node[part], dict):
            raise InputError(f"{'.'.join(parts[:i + 1])}: must be a mapping of keys to set {key}")
        node = node[part]
    if value is None:
        node.pop(parts[-1], None)
    else:
        node[parts[-1]] = value


_UNION_MEMBER = re.compile(r"(float|int|str|bool|none|(list|tuple|dict)\[.*\]|function-.*)")
"""Pydantic names the member of a union (``float | list[float]``) in the location: not a key."""


def _without_members(err: dict) -> dict:
    loc = tuple(p for p in err["loc"] if not (isinstance(p, str) and _UNION_MEMBER.fullmatch(p)))
    return {**err, "loc": loc}


def _one_line(exc: ValidationError, prefix: tuple = ()) -> str:
    """The first error of ``exc`` (an unknown key first: a misspelt key also shows up as a missing one);
    the errors of a union's members count once per key."""
    errors, seen = [], set()
    for err in sorted(exc.errors(include_url=False), key=lambda e: e["type"] != "extra_forbidden"):
        err = _without_members(err)
        if err["loc"] not in seen:
            seen.add(err["loc"])
            errors.append(err)
    more = f" (+{len(errors) - 1} more)" if len(errors) > 1 else ""
    return _describe({**errors[0], "loc": (*prefix, *errors[0]["loc"])}) + more


def validate_scene(data: Any, source: str = "config") -> Scene:
    """Validate a raw mapping into a Scene, raising a one-line InputError."""
    if not isinstance(data, dict):
        got = "empty file" if data is None else type(data).__name__
        raise InputError(f"{source}: top level must be a mapping of sections (got {got})")
    # top-level keys "x-..." are ignored: a place for YAML anchors (``x-water: &water {rho: 1000}``)
    data = {k: v for k, v in data.items() if not (isinstance(k, str) and k.startswith("x-"))}
    try:
        return Scene.model_validate(data)
    except ValidationError as exc:
        raise InputError(_one_line(exc)) from None


def as_scene(value: Any, caller: str) -> Scene:
    """A Scene as it is, a mapping validated (:func:`validate_scene`, InputError if it is no scene); TypeError
    for anything else, naming ``caller``."""
    if isinstance(value, Scene):
        return value
    if isinstance(value, dict):
        return validate_scene(value, "scene")
    raise TypeError(f"{caller}: the scene must be a Scene (load_scene, validate_scene) or a dict, not "
                    f"{type(value).__name__}")


_GEOMETRY = TypeAdapter(Geometry)


def validate_geometry(data: Any) -> GeometryBase:
    """A ``geometry`` section on its own (e.g. ``{"name": "channel", "length": 2.0}``) as its model, raising
    a one-line InputError ``geometry.<key>: <problem>``."""
    try:
        return _GEOMETRY.validate_python(data)
    except ValidationError as exc:
        raise InputError(_one_line(exc, ("geometry",))) from None


def load_scene(path: str | Path, overrides: Sequence[str] = ()) -> Scene:
    """Read, override and validate a scene file. ``name`` defaults to the file stem."""
    path = Path(path)
    text = read_text_file(path, "scene file")
    try:
        data = yaml_load(text)
    except yaml.YAMLError as exc:
        raise InputError(f"{path}: {describe_yaml_error(exc)}") from None
    if isinstance(data, dict):
        data.setdefault("name", path.stem)
        geo = data.get("geometry")
        if isinstance(geo, dict) and geo.get("name") == "file" and isinstance(geo.get("path"), str):
            geo["path"] = str(path.parent / Path(geo["path"]).expanduser())  # relative to the scene file
        for item in overrides:
            _apply_override(data, item)
    return validate_scene(data, str(path))
