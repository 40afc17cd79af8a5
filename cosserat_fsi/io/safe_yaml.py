"""The project's YAML reader for scene, study and reference files: safe, bounded, one-line errors.

A ``yaml.SafeLoader`` (no tags, no code) that also reads ``1e-3`` as a float (YAML 1.1 wants
``1.0e-3``), rejects duplicate and unhashable keys, accepts merge keys (``<<: *anchor``), and bounds what
a hostile or broken file can cost: nesting depth, node count (aliases counted as often as they are
used, so "billion laughs" files are refused before they are expanded), integer length, file size.
Every failure is a ``yaml.YAMLError`` (or, from :func:`read_yaml_file`, an ``InputError`` naming the file).

Light module: PyYAML only.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import yaml

from cosserat_fsi.errors import InputError

MAX_BYTES = 1 << 20
"""Largest YAML file read (1 MiB; a scene is about 1 KiB)."""
MAX_DEPTH = 32
"""Deepest nesting of mappings/sequences."""
MAX_NODES = 100_000
"""Most nodes after alias expansion."""
MAX_INT_DIGITS = 64
"""Longest integer literal (Python refuses above 4300 digits with a ValueError)."""


class YamlLimitError(yaml.YAMLError):
    """A limit of the reader was exceeded (depth, size, integer length, key type)."""

    def __init__(self, problem: str, mark=None):
        super().__init__(problem)
        self.problem, self.problem_mark = problem, mark

    def __str__(self):
        return self.problem


class YamlLoader(yaml.SafeLoader):
    """SafeLoader with float ``1e-3``, duplicate/unhashable key checks, merge keys and size limits."""

    def __init__(self, stream):
        super().__init__(stream)
        self._depth = 0

    # ---- composition: depth and expanded size
    def compose_node(self, parent, index):
        """Compose one node, refusing nesting deeper than MAX_DEPTH."""
        self._depth += 1
        try:
            if self._depth > MAX_DEPTH:
                raise YamlLimitError(f"nested deeper than {MAX_DEPTH} levels", self.peek_event().start_mark)
            return super().compose_node(parent, index)
        finally:
            self._depth -= 1

    def get_single_node(self):
        """The document's node, refused when its alias-expanded size exceeds MAX_NODES."""
        node = super().get_single_node()
        if node is not None:
            _check_size(node)
        return node

    # ---- construction: keys and integers
    def construct_mapping(self, node, deep=False):
        """Build a mapping, failing on a key that appears twice or cannot be a key (a list, a mapping)."""
        if not isinstance(node, yaml.MappingNode):
            return super().construct_mapping(node, deep)
        seen = set()
        for key_node, _ in node.value:
            if key_node.tag == "tag:yaml.org,2002:merge":
                continue
            if not isinstance(key_node, yaml.ScalarNode):
                raise YamlLimitError("a key must be a plain value, not a list or a mapping", key_node.start_mark)
            key = self.construct_object(key_node, deep=True)
            if key in seen:
                raise yaml.constructor.ConstructorError(
                    None, None, f"duplicate key {key!r}", key_node.start_mark)
            seen.add(key)
        for key_node, value_node in node.value:  # merge keys take a mapping or a list of mappings
            if key_node.tag == "tag:yaml.org,2002:merge":
                items = value_node.value if isinstance(value_node, yaml.SequenceNode) else [value_node]
                if not all(isinstance(item, yaml.MappingNode) for item in items):
                    raise YamlLimitError("'<<' needs a mapping or a list of mappings", key_node.start_mark)
        return super().construct_mapping(node, deep)

    def construct_yaml_int(self, node):
        """An integer, refused above MAX_INT_DIGITS digits."""
        text = str(node.value).replace("_", "")
        if len(text.lstrip("+-")) > MAX_INT_DIGITS:
            raise YamlLimitError(f"integer with more than {MAX_INT_DIGITS} digits", node.start_mark)
        return super().construct_yaml_int(node)


YamlLoader.add_constructor("tag:yaml.org,2002:int", YamlLoader.construct_yaml_int)
YamlLoader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(r"""^(?:[-+]?(?:[0-9][0-9_]*)\.[0-9_]*(?:[eE][-+]?[0-9]+)?
                   |[-+]?(?:[0-9][0-9_]*)(?:[eE][-+]?[0-9]+)
                   |\.[0-9_]+(?:[eE][-+]?[0-9]+)?
                   |[-+]?\.(?:inf|Inf|INF)
                   |\.(?:nan|NaN|NAN))$""", re.X),
    list("-+0123456789."),
)


def _check_size(root) -> None:
    """Refuse a node graph whose alias-expanded size exceeds MAX_NODES (each shared node counted once per
    use, computed once per node)."""
    sizes: dict[int, int] = {}
    path: set[int] = set()  # nodes being sized: met again below themselves = an alias to an ancestor
    stack = [(root, False)]
    while stack:
        node, done = stack.pop()
        if id(node) in sizes:
            continue
        children = ([c for pair in node.value for c in pair] if isinstance(node, yaml.MappingNode)
                    else node.value if isinstance(node, yaml.SequenceNode) else [])
        if done:
            path.discard(id(node))
            sizes[id(node)] = 1 + sum(sizes[id(c)] for c in children)
            if sizes[id(node)] > MAX_NODES:
                raise YamlLimitError(f"more than {MAX_NODES} values (after expanding aliases)", node.start_mark)
        else:
            if id(node) in path:
                raise YamlLimitError("an alias refers to a value that contains it (recursive)", node.start_mark)
            path.add(id(node))
            stack.append((node, True))
            stack.extend((c, False) for c in children if id(c) not in sizes)


def yaml_load(text: str) -> Any:
    """Parse YAML text safely (no tags, no code, bounded), with ``1e-3`` read as a float."""
    if len(text) > MAX_BYTES:
        raise YamlLimitError(f"more than {MAX_BYTES} characters")
    try:
        return yaml.load(text, Loader=YamlLoader)  # noqa: S506 (YamlLoader is a SafeLoader)
    except RecursionError:  # belt and braces: the depth limit should have stopped it
        raise YamlLimitError(f"nested deeper than {MAX_DEPTH} levels") from None


def read_text_file(path: str | Path, what: str = "file", max_bytes: int = MAX_BYTES) -> str:
    """UTF-8 text of a small file; InputError naming it if missing, a folder, too large, binary or not UTF-8."""
    from ..files import read_regular

    path = Path(path)
    data = read_regular(path, what, max_bytes=max_bytes)  # a FIFO would block, a device not end: refused
    if len(data) > max_bytes:
        raise InputError(f"{path}: larger than {max_bytes // 1024} KiB (not a {what}?)")
    if b"\0" in data:
        raise InputError(f"{path}: binary data (not a {what})")
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise InputError(f"{path}: not UTF-8 text (byte 0x{data[exc.start]:02x} at offset {exc.start})") from None


def describe_yaml_error(exc: yaml.YAMLError) -> str:
    """``line N: could not parse YAML (<problem>)`` for a YAMLError."""
    mark = getattr(exc, "problem_mark", None)
    line = f"line {mark.line + 1}: " if mark else ""
    problem = getattr(exc, "problem", None) or str(exc).splitlines()[0]
    return f"{line}could not parse YAML ({problem})"


def read_yaml_file(path: str | Path, what: str = "YAML file") -> Any:
    """Parsed content of a YAML file; InputError ``<path>: <problem>`` on any failure."""
    text = read_text_file(path, what)
    try:
        return yaml_load(text)
    except yaml.YAMLError as exc:
        raise InputError(f"{path}: {describe_yaml_error(exc)}") from None
