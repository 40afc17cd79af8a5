"""The scene reference (config/reference.py): every key described, the page's tables complete against an
independent walk of the JSON schema, the rendering of types, defaults and bounds, valid MyST structure."""

from __future__ import annotations

import re

import pytest

from cosserat_fsi.app.study import Study
from cosserat_fsi.config import Scene
from cosserat_fsi.config.reference import (scene_fields, scene_keys, scene_reference_markdown, study_fields,
                                           study_reference_markdown)


def _resolve(schema: dict, node: dict) -> dict:
    while "$ref" in node:
        node = schema["$defs"][node["$ref"].rsplit("/", 1)[1]]
    return node


def _schema_keys(schema: dict, node: dict, prefix: str = "") -> dict[str, dict]:
    """{dotted key: its property} of every property reached from ``node``: union members chosen by a tag as
    ``key[tag=value]``, a mapping's free names as NAME (COLUMN under ``reference``)."""
    out = {}
    for name, prop in _resolve(schema, node).get("properties", {}).items():
        key = f"{prefix}.{name}" if prefix else name
        out[key] = prop
        if "discriminator" in prop:
            tag = prop["discriminator"]["propertyName"]
            for value, ref in prop["discriminator"]["mapping"].items():
                out.update(_schema_keys(schema, {"$ref": ref}, f"{key}[{tag}={value}]"))
            continue
        for alternative in [prop, *prop.get("anyOf", [])]:
            alternative = _resolve(schema, alternative)
            if "properties" in alternative:
                out.update(_schema_keys(schema, alternative, key))
            values = alternative.get("additionalProperties")
            if isinstance(values, dict) and "properties" in _resolve(schema, values):
                out.update(_schema_keys(schema, values, f"{key}.{'COLUMN' if name == 'reference' else 'NAME'}"))
    return out


def _table_keys(markdown: str) -> list[str]:
    """The first cell of every table row (a key in backticks)."""
    return re.findall(r"^\| `([^`]+)` \|", markdown, flags=re.M)


def _scene_part(markdown: str) -> str:
    return markdown.split("\n## Study files\n", 1)[0]


def test_every_field_has_a_description():
    missing = [row.key for row in [*scene_fields(), *study_fields()] if not row.description.strip()]
    assert not missing, f"fields without a description (a docstring under the field): {missing}"
    schema = Scene.model_json_schema()
    undescribed = [key for key, prop in _schema_keys(schema, schema).items() if not prop.get("description")]
    assert not undescribed, f"schema properties without a description: {undescribed}"


def test_the_page_lists_every_key_once():
    page = scene_reference_markdown()
    keys = _table_keys(_scene_part(page))
    assert len(keys) == len(set(keys)), [k for k in keys if keys.count(k) > 1]
    schema = Scene.model_json_schema()
    independent = set(_schema_keys(schema, schema))
    assert set(keys) == scene_keys() == independent, (set(keys) ^ independent, scene_keys() ^ independent)
    assert {"geometry[name=turek_hron].flag", "time[scheme=steady].steady_at", "boundaries.NAME.type",
            "boundaries.NAME.micro_rotation.value", "observables.lines.NAME.from", "reference.COLUMN.value",
            "solid.mesh_motion.remesh.quality", "geometry[name=file].cells.solid"} <= set(keys)
    study = _table_keys(page.split("\n## Study files\n", 1)[1])
    assert study == list(Study.model_fields) == [row.key for row in study_fields()]


@pytest.mark.parametrize("key, type_, default, bounds, allowed", [
    ("fluid.rho", "float", "required", "> 0", ""),
    ("micropolar.mu_r", "float", "0.0", ">= 0", ""),
    ("fluid.body_force", "list[float]", "[0.0, 0.0]", "2 to 3 entries", ""),
    ("fluid.viscous_form", "str", "laplacian", "", "`laplacian`, `symmetric`"),
    ("micropolar.body_couple", "float or list[float]", "0.0", "list[float]: 3 entries", ""),
    ("micropolar", "section", "all defaults", "", ""),
    ("solid.mesh_motion.poisson_ratio", "float", "0.0", "> -1, < 0.5", ""),
    ("solid.mesh_motion.stiffness_exponent", "float", "null", ">= 0, <= 4", ""),
    ("time[scheme=generalized_alpha].rho_infinity", "float", "0.5", ">= 0, <= 1", ""),
    ("time[scheme=steady].scheme", "str", "required", "", "`steady`"),
    ("time[scheme=steady].newton_continuation", "list[float]", "[0.25, 0.5, 1.0]", "each > 0, <= 1", ""),
    ("time[scheme=steady].newton_rtol", "float", "1e-10", "> 0, < 1", ""),
    ("geometry[name=turek_hron].level", "int or str", "0", "", "str: `seed`"),
    ("boundaries.NAME.value", "list[EXPR] or EXPR", "null", "", ""),
    ("observables.points", "{NAME: list[float]}", "{}", "each value: 2 to 3 entries", ""),
    ("output.every", "int", "10", ">= 1, <= 1,000,000,000", ""),
    ("solver.petsc_options", "{OPTION: str or int or float or bool}", "{}",
     "keys: matches `^[a-z][a-z0-9_]*$`, at most 200 characters", ""),
    ("reference", "{COLUMN: section}", "null", "", ""),
])
def test_rendered_types_defaults_and_bounds(key, type_, default, bounds, allowed):
    row = {row.key: row for row in scene_fields()}[key]
    assert (row.type, row.default, row.bounds, row.allowed) == (type_, default, bounds, allowed)


def test_owners_and_union_members():
    rows = {row.key: row for row in scene_fields()}
    assert (rows["geometry[name=channel].length"].model, rows["geometry[name=channel].length"].member) == (
        "Channel", "geometry: {name: channel}")
    assert rows["time[scheme=ale_bdf2].dt"].member == "time: {scheme: ale_bdf2}"
    assert (rows["solid.mesh_motion.method"].model, rows["solid.mesh_motion.method"].member) == (
        "MeshMotionSettings", "")


def test_markdown_structure():
    page = scene_reference_markdown()
    assert page.startswith("# Scene reference\n")
    levels = [len(m) for m in re.findall(r"^(#+) ", re.sub(r"```.*?```", "", page, flags=re.S), flags=re.M)]
    assert levels[0] == 1 and levels.count(1) == 1
    assert all(b <= a + 1 for a, b in zip(levels, levels[1:])), levels
    assert "### `geometry: {name: turek_hron}`" in page and "### `time: {scheme: steady}`" in page
    for line in page.splitlines():
        if line.startswith("| "):  # five cells: the pipes inside a cell are escaped
            assert len(re.findall(r"(?<!\\)\|", line)) == 6, line
    assert "\\|K\\|^−χ" in page  # a pipe of the meaning, escaped
    assert study_reference_markdown().startswith("## Study files\n") and page.endswith(study_reference_markdown())


def test_markdown_tables_parse():
    """The tables as a CommonMark/GFM parser (markdown-it, MyST's) reads them: five cells a row, the keys."""
    markdown_it = pytest.importorskip("markdown_it")
    tokens = markdown_it.MarkdownIt("commonmark").enable("table").parse(scene_reference_markdown())
    rows, cells = [], None
    for token in tokens:
        if token.type == "tr_open":
            cells = []
        elif token.type == "inline" and cells is not None:
            cells.append(token)
        elif token.type == "tr_close":
            rows.append(cells)
            cells = None
    assert all(len(r) == 5 for r in rows)
    first = [r[0].children[0].content for r in rows if r[0].children and r[0].children[0].type == "code_inline"]
    assert set(first) == scene_keys() | set(Study.model_fields)
