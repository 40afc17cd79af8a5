"""The scene reference: every key of a scene file (and of a study file), walked from the pydantic models, so
that the documentation cannot drift from the code. The docs build writes :func:`scene_reference_markdown`
to docs/scene_reference.md.

Keys are dotted paths as in ``--set`` (``time.dt``). A member of a union chosen by a tag key is written
``section[tag=value]``: ``geometry[name=channel].length`` is the key ``geometry.length`` of a scene whose
geometry is ``{name: channel}``, ``time[scheme=steady].steady_at`` the key ``time.steady_at`` of a steady
scene. The free name of a mapping of sections is a capitalised placeholder: ``boundaries.NAME.type``,
``observables.lines.NAME.points``, ``reference.COLUMN.value``.
"""

from __future__ import annotations

import json
import textwrap
import types
from dataclasses import dataclass, field
from typing import Annotated, Any, Literal, Union, get_args, get_origin

from pydantic import BaseModel
from pydantic.fields import FieldInfo

PLACEHOLDERS = {"reference": "COLUMN", "petsc_options": "OPTION", "base": "KEY", "ladder": "KEY", "extra": "RUN"}
"""The placeholder of a mapping's free keys, by the mapping's key (default NAME; inside a value: KEY)."""
HEADER = "| key | type | default | bounds / allowed | meaning |\n|---|---|---|---|---|"


@dataclass(frozen=True)
class FieldRow:
    """One key of a scene (or study) file."""

    key: str  # dotted path, union members as section[tag=value]
    type: str  # float, int, bool, str, list[...], {NAME: ...}, section, EXPR, any; arms joined by " or "
    default: str  # as YAML, or "required"
    bounds: str  # "> 0", ">= 2, <= 12", "2 to 3 entries", "each > 0, <= 1"
    allowed: str  # the values of a Literal: "`a`, `b`" (in a union with other types: "str: `a`")
    description: str  # the field's docstring, on one line
    model: str  # the class the field belongs to
    member: str  # the union member it belongs to ("geometry: {name: channel}"), or ""
    group: str  # the key of that model's section: "" (top level), "solid.mesh_motion", "geometry[name=file]"
    depth: int  # that section's nesting below its top-level section (0: the top-level section itself)
    cls: type[BaseModel] | None = field(default=None, repr=False, compare=False)  # the class named by model


def _arms(annotation) -> list:
    """The members of a union (``X | None`` without None), or ``[annotation]``."""
    if get_origin(annotation) in (Union, types.UnionType):
        return [a for a in get_args(annotation) if a is not type(None)]
    return [annotation]


def _strip(annotation) -> tuple[Any, list]:
    """(the type under ``Annotated``, its constraint objects)."""
    metadata: list = []
    while get_origin(annotation) is Annotated:
        annotation, *extra = get_args(annotation)
        for item in extra:
            metadata += item.metadata if isinstance(item, FieldInfo) else [item]
    return annotation, metadata


def _is_model(annotation) -> bool:
    return isinstance(annotation, type) and issubclass(annotation, BaseModel)


def _is_expression(annotation) -> bool:
    """The ``Expr`` of config/sections.py: a number or an expression string, checked by its parser."""
    _, metadata = _strip(annotation)
    return any(getattr(getattr(m, "func", None), "__name__", "") == "_expression" for m in metadata)


def _type(annotation, placeholder: str = "KEY") -> str:
    """Readable type: float, list[float], {NAME: section}, int or str, EXPR."""
    if _is_expression(annotation):
        return "EXPR"
    annotation, _ = _strip(annotation)
    arms = _arms(annotation)
    if len(arms) > 1:
        return " or ".join(dict.fromkeys(_type(a, placeholder) for a in arms))
    annotation, _ = _strip(arms[0])
    origin = get_origin(annotation)
    if origin is Literal:
        return " or ".join(dict.fromkeys(type(v).__name__ for v in get_args(annotation)))
    if origin is list:
        return f"list[{_type(get_args(annotation)[0])}]"
    if origin is dict:
        return f"{{{placeholder}: {_type(get_args(annotation)[1])}}}"
    if _is_model(annotation):
        return "section"
    return "any" if annotation is Any else getattr(annotation, "__name__", str(annotation))


def _number(value) -> str:
    return f"{value:,}" if isinstance(value, int) and abs(value) >= 10_000 else f"{value:g}"


def _constraints(metadata, noun: str = "entries") -> list[str]:
    """Bounds as text; a length counts ``noun`` (entries of a list or mapping, characters of a string)."""
    out, length = [], {}
    for item in metadata:
        for name, sign in (("gt", ">"), ("ge", ">="), ("lt", "<"), ("le", "<=")):
            if getattr(item, name, None) is not None:
                out.append(f"{sign} {_number(getattr(item, name))}")
        for name in ("min_length", "max_length"):
            if getattr(item, name, None) is not None:
                length[name] = getattr(item, name)
        if getattr(item, "pattern", None) is not None:
            out.append(f"matches `{item.pattern}`")
    low, high = length.get("min_length"), length.get("max_length")
    if low is not None or high is not None:
        one = noun[:-3] + "y" if noun.endswith("ies") else noun[:-1]
        out.append(f"{low} {noun}" if low == high else f"{low} to {high} {noun}" if low is not None and high
                   else f"at least {low} {one if low == 1 else noun}" if low is not None else f"at most {high} {noun}")
    return out


def _bounds(annotation, metadata=()) -> list[str]:
    """The constraints of a field: its own, its union members', those of a list's entries ("each ...") and of
    a mapping's keys and values."""
    annotation, inner = _strip(annotation)
    arms = _arms(annotation)
    out = _constraints([*metadata, *inner], "characters" if arms == [str] else "entries")
    for arm in arms:
        arm, arm_metadata = _strip(arm)
        if _constraints(arm_metadata) and len(arms) > 1:
            out.append(f"{_type(arm)}: " + ", ".join(_constraints(arm_metadata)))
        elif arm_metadata:
            out += _constraints(arm_metadata, "characters" if arm is str else "entries")
        origin, args = get_origin(arm), get_args(arm)
        if origin is list and _bounds(args[0]):
            out.append("each " + ", ".join(_bounds(args[0])))
        if origin is dict:
            out += [f"keys: {', '.join(_bounds(args[0]))}"] if _bounds(args[0]) else []
            out += [f"each value: {', '.join(_bounds(args[1]))}"] if _bounds(args[1]) else []
    return out


def _allowed(annotation) -> str:
    annotation, _ = _strip(annotation)
    arms = _arms(annotation)
    values = [v for a in arms if get_origin(_strip(a)[0]) is Literal for v in get_args(_strip(a)[0])]
    if not values:
        return ""
    text = ", ".join(f"`{v}`" for v in values)
    mixed = any(get_origin(_strip(a)[0]) is not Literal for a in arms)
    return f"{type(values[0]).__name__}: {text}" if mixed else text


def _yaml(value) -> str:
    if isinstance(value, BaseModel):
        return "all defaults"
    if value is None or isinstance(value, (bool, list, dict)):
        return json.dumps(value, ensure_ascii=False)
    return repr(value) if isinstance(value, float) else str(value)


def _one_line(text: str | None) -> str:
    return " ".join((text or "").split())


def _row(model, name: str, info: FieldInfo, group: str, depth: int, member: str, tag: str | None) -> FieldRow:
    key = f"{group}.{name}" if group else name
    required = info.is_required() or name == tag  # a union's tag key must be given
    default = "required" if required else _yaml(info.get_default(call_default_factory=True))
    return FieldRow(key, _type(info.annotation, PLACEHOLDERS.get(name, "NAME")), default,
                    ", ".join(_bounds(info.annotation, info.metadata)), _allowed(info.annotation),
                    _one_line(info.description), model.__name__, member, group, depth, model)


def _sections(key: str, info: FieldInfo) -> list[tuple[str, type[BaseModel], str, str | None]]:
    """(group, model, member, tag) of the models below field ``key``: the members of a union chosen by a tag
    key, a section, or the sections of a mapping of named ones."""
    tag = info.discriminator if isinstance(info.discriminator, str) else None
    out = []
    for arm in _arms(_strip(info.annotation)[0]):
        arm, _ = _strip(arm)
        if tag is not None and _is_model(arm):
            value = arm.model_fields[tag].default
            out.append((f"{key}[{tag}={value}]", arm, f"{key}: {{{tag}: {value}}}", tag))
        elif _is_model(arm):
            out.append((key, arm, "", None))
        elif get_origin(arm) is dict and _is_model(_strip(get_args(arm)[1])[0]):
            out.append((f"{key}.{PLACEHOLDERS.get(key.rsplit('.', 1)[-1], 'NAME')}", _strip(get_args(arm)[1])[0],
                        "", None))
    return out


def field_rows(model: type[BaseModel], group: str = "", depth: int = 0, member: str = "",
               tag: str | None = None) -> list[FieldRow]:
    """The rows of ``model``'s fields, then those of every section below them, depth first (``group``: the
    model's key, ``depth``: its nesting below its top-level section, ``member``/``tag``: the union member it
    is and the union's tag key)."""
    fields = sorted(model.model_fields.items(), key=lambda item: item[0] != tag)  # a union's tag key first
    rows = [_row(model, name, info, group, depth, member, tag) for name, info in fields]
    for row, (_, info) in zip(list(rows), fields):
        top = not group
        for sub_group, sub_model, sub_member, sub_tag in _sections(row.key, info):
            sub_depth = 1 if top and sub_tag else 0 if top else depth + 1
            rows += field_rows(sub_model, sub_group, sub_depth, sub_member or member, sub_tag)
    return rows


def scene_fields() -> list[FieldRow]:
    """Every key of a scene file, union members included, in the order of the models."""
    from .scene import Scene

    return field_rows(Scene)


def scene_keys() -> set[str]:
    """The dotted paths of :func:`scene_fields`."""
    return {row.key for row in scene_fields()}


def study_fields() -> list[FieldRow]:
    """Every key of a study file (``cosserat-fsi study``)."""
    from cosserat_fsi.app.study import Study

    return field_rows(Study)


def _cell(text: str) -> str:
    return text.replace("|", "\\|").replace("\n", " ")


def _table(rows: list[FieldRow]) -> str:
    lines = [HEADER]
    for row in rows:
        limits = "; ".join(part for part in (row.bounds, row.allowed) if part)
        lines.append("| " + " | ".join(_cell(c) for c in (f"`{row.key}`", row.type, f"`{row.default}`"
                                                           if row.default != "required" else "required",
                                                           limits, row.description)) + " |")
    return "\n".join(lines)


def _docstring(model: type[BaseModel]) -> str:
    """The model's own docstring as markdown paragraphs."""
    text = model.__dict__.get("__doc__") or ""
    return "\n\n".join(_one_line(p) for p in textwrap.dedent(text).split("\n\n") if p.strip())


INTRO = """\
Every key a scene file (`configs/*.yaml`) accepts, generated from the models that validate it
(`cosserat_fsi/config/`, `cosserat_fsi/geometry/`), so it is the schema the program checks.

How to read it:

- A key is written as a dotted path: `time.dt` is `dt` in the section `time`. The same path changes it from
  the command line: `cosserat-fsi run SCENE --set time.dt=0.001` (the value is YAML; `null` removes the key,
  so that its default applies).
- Sections chosen by a tag key (`geometry` by `name`, `time` by `scheme`) have one table per member;
  `geometry[name=channel].length` is the key `geometry.length` of a scene with `geometry: {name: channel}`.
  A key of another member is an error naming the members that take it.
- A capitalised part is a name of your choice: `boundaries.NAME.type` (a facet group of the mesh),
  `reference.COLUMN.value` (a column of timeseries.csv).
- *default*: `required` keys must be given; `null` means absent (the meaning says what that does);
  `all defaults` is the section with each of its keys at its default. *bounds / allowed*: the accepted
  range or values. EXPR: a number or an expression string in x, y, z, t (pi, sin, exp, min, where(cond, a,
  b), ...).
- Unknown keys, wrong types (a string for a number), values out of range and non-finite numbers (`.inf`,
  `.nan`) are refused before anything runs, with one line naming the key, e.g.
  `error: time.dt: must be > 0 (got -0.1)` (exit code 2).
- A key the user sets is used or refused, never ignored: a key whose effect depends on another key's value
  (a scheme, the solver's type, the solid's law, micropolar terms, an inlet, the mesh motion) and is given a
  value other than its default where that other key makes it meaningless is refused the same way, e.g.
  `error: solver.amg: only for the iterative solver; solver.type is direct (MUMPS)`. The one exception
  changes only what is written: `output.every` and `output.checkpoint_every`, unused (a steady scene, the
  fields off), are one warning line on the terminal and in run.log (`cosserat_fsi/config/usage.py`)."""


def _section_markdown(rows: list[FieldRow], top: FieldRow) -> list[str]:
    """A top-level section: one table per model below it, each union member and nested section under its own
    heading (one level below the section that holds it)."""
    out = [f"## `{top.key}`", ""]
    groups = list(dict.fromkeys(row.group for row in rows))
    members = [group for group in groups if group.endswith("]")]
    if members and members[0].startswith(top.key + "["):
        tag = members[0][len(top.key) + 1:].split("=", 1)[0]
        names = ", ".join(f"`{group.rsplit('=', 1)[1][:-1]}`" for group in members)
        out += [f"One model per `{tag}`: {names}. A key of another member is an error naming the members that "
                "take it.", ""]
    for group in groups:
        mine = [row for row in rows if row.group == group]
        first = mine[0]
        if first.depth:
            title = first.member if group in members else group
            out += ["#" * (2 + first.depth) + f" `{title}`", ""]
        text = _docstring(first.cls)
        out += [text, ""] if text else []
        out += [_table(mine), ""]
    return out


def study_reference_markdown() -> str:
    """The section "Study files": the keys of a ``cosserat-fsi study`` file, with an example."""
    from cosserat_fsi.app import study

    blocks = [b for b in (study.__doc__ or "").split("\n\n") if b.strip() and all(
        line.startswith("    ") for line in b.strip("\n").splitlines())]  # the module docstring's example
    example = ["A study file:", "", "```yaml", textwrap.dedent(blocks[0]).strip("\n"), "```", ""] if blocks else []
    return "\n".join(["## Study files", "",
                      "`cosserat-fsi study STUDY.yaml` runs a ladder of scenes (the product of the listed "
                      "values) and writes a report of the error of every observable against wall time.", "",
                      *example, _table(study_fields()), ""])


def scene_reference_markdown() -> str:
    """The MyST page "Scene reference": how to read it, the top-level keys, one section per top-level section
    (one table per model, union members in their own subsections), then the study files."""
    rows = scene_fields()
    top = [row for row in rows if not row.group]
    out = ["# Scene reference", "", INTRO, "", "## Top-level keys", "", _table(top), ""]
    for section in top:
        below = [row for row in rows if row.group and (row.group == section.key or row.group.startswith(
            (section.key + ".", section.key + "[")))]
        if below:
            out += _section_markdown(below, section)
    return "\n".join(out) + "\n" + study_reference_markdown()
