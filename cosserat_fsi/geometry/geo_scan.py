"""The .geo contract: a scene's gmsh script builds a model and nothing else (docs/reliability.md, "Scene files").

gmsh's .geo language can run programs (``System``, ``SystemCall``, ``NonBlockingSystemCall``, ``OnelabRun``),
write or remove files (``Printf(...) > "file"``, ``Save``, ``Print "file"``, ``CreateDir``, ``DeleteFile``,
``RenameFile``, plugins), read files outside the scene (``Include``, ``Merge``, ``ShapeFromFile``), end or
stall the program (``Exit``, ``Abort``, ``Sleep``) and point gmsh at programs (``Solver.*`` options).
:func:`scan_geo` refuses every such command, naming the file and line, unless the scene says
``geometry.trusted: true``; ``Include``/``Merge``/``ShapeFromFile`` of a literal file name inside the .geo's
folder are allowed (and included .geo files are scanned too). Comments (``//``, ``/* */``) and the inside of
strings are skipped, so a word in them is not a command.

:func:`file_dimension` reads the dimension a file declares without meshing it: 3 when a ``Physical Volume``
(in the .geo or a file it ``Include``s) or a dimension-3 entry of a ``.msh``'s ``$PhysicalNames`` (the file
itself or one a .geo ``Merge``s) names cells, else 2.
"""

from __future__ import annotations

import os
import re
from pathlib import Path

from ..errors import InputError
from ..files import read_regular

ALWAYS = ("System", "SystemCall", "NonBlockingSystemCall", "OnelabRun", "SendToServer", "Exit", "Abort", "Sleep",
          "CreateDir", "DeleteFile", "RenameFile", "Save", "Plugin", "MergeWithBoundingBox")
"""Commands refused wherever they appear (outside comments and strings)."""
READS = ("Include", "Merge", "ShapeFromFile")
"""Commands that read a file: a literal name inside the .geo's folder is allowed."""
MAX_INCLUDES = 100
_STRINGS = (r'"[^"]*(?:"|\Z)', r'"(?:\\.|[^"\\])*(?:"|\Z)')  # gmsh 4.8: no escapes; later ones: \"
_TOKENS = [re.compile(r'//[^\n]*|/\*.*?(?:\*/|\Z)|' + string + r'|[A-Za-z_][A-Za-z_0-9]*|\S', re.S)
           for string in _STRINGS]


def _tokens(text: str, token: re.Pattern):
    """(kind, value, line) of the script: ``id``, ``str`` (its content), ``sym``; comments dropped."""
    line = 1
    pos = 0
    for m in token.finditer(text):
        line += text.count("\n", pos, m.start())
        pos = m.start()
        tok = m.group()
        if tok.startswith("//") or tok.startswith("/*"):
            continue
        if tok.startswith('"'):
            yield "str", tok[1:-1] if len(tok) > 1 and tok.endswith('"') else tok[1:], line
        elif tok[0].isalpha() or tok[0] == "_":
            yield "id", tok, line
        else:
            yield "sym", tok, line


def _redirected(toks, start: int) -> bool:
    """A ``>`` or ``>>`` outside parentheses before the statement's ``;`` (``Printf(...) > "file"``)."""
    depth = 0
    for _, value, _ in toks[start:]:
        if value == ";":
            return False
        depth += (value in "([{") - (value in ")]}")
        if value == ">" and depth == 0:
            return True
    return False


def _refuse(path: Path, line: int, command: str, why: str = "") -> InputError:
    return InputError(f"{path}:{line}: gmsh command {command}{why} is not allowed in a scene "
                      "(geometry.trusted: true allows it)")


def scan_geo(path: str | os.PathLike, _root: Path | None = None, _seen: set | None = None) -> None:
    """InputError ``<file>:<line>: gmsh command X is not allowed in a scene ...`` for the first command of
    the .geo ``path`` (or of a file it includes) that reaches outside the model (see the module docstring)."""
    path = Path(path)
    root = _root or path.resolve().parent
    seen = _seen if _seen is not None else set()
    seen.add(path.resolve())
    if len(seen) > MAX_INCLUDES:
        raise InputError(f"{path}: includes more than {MAX_INCLUDES} files")
    data = read_regular(path, "gmsh .geo file", max_bytes=16 << 20)
    text = data.decode("utf-8", "replace")
    for token in _TOKENS:  # read as either gmsh reads strings (with or without \" escapes)
        _scan(path, list(_tokens(text, token)), root, seen)


def _scan(path: Path, toks: list, root: Path, seen: set) -> None:
    for i, (kind, value, line) in enumerate(toks):
        if kind != "id":
            continue
        prev = toks[i - 1][1] if i else ""
        nxt = toks[i + 1] if i + 1 < len(toks) else ("sym", "", line)
        if prev == ".":  # an option or a field name (Mesh.Algorithm, View.Name): not a command
            continue
        if value == "Solver" and nxt[1] == ".":
            raise _refuse(path, line, "Solver.*", " (it names programs to run)")
        if value in ALWAYS:
            raise _refuse(path, line, value)
        if value in ("Printf", "Print"):
            if value == "Print" and nxt[1] == ".":  # Print.* options
                continue
            if value == "Print" or _redirected(toks, i + 1):
                raise _refuse(path, line, value, " to a file" if value == "Printf" else "")
        if value in READS:
            j = i + 1
            while j < len(toks) and toks[j][1] in ("(", "[", "OCC", "Built"):  # ShapeFromFile("x"); Merge "x"
                j += 1
            after = toks[j + 1][1] if j + 1 < len(toks) else ";"
            if j >= len(toks) or toks[j][0] != "str" or after not in (";", ")", "]"):
                raise _refuse(path, line, value, " of a computed file name")
            target = (path.parent / toks[j][1]).resolve()
            if root not in target.parents:
                raise _refuse(path, line, value, f" of a file outside {root}")
            if value == "Include" and target not in seen:
                scan_geo(target, root, seen)


def file_dimension(path: str | os.PathLike, _seen: set | None = None, _merged: bool = False) -> int:
    """3 if the .geo or .msh ``path`` (or a file it Includes or Merges) has a physical volume, else 2."""
    path = Path(path)
    seen = _seen if _seen is not None else set()
    suffix = path.suffix.lower()
    if (path.resolve() in seen or len(seen) > MAX_INCLUDES or not path.is_file()
            or (_merged and suffix not in (".geo", ".msh"))):  # a merged CAD file names no groups
        return 2
    seen.add(path.resolve())
    if suffix == ".msh":
        return 3 if any(dim == 3 for dim, _, _ in msh_physical_names(path)) else 2
    text = read_regular(path, "gmsh .geo file", max_bytes=16 << 20).decode("utf-8", "replace")
    for token in _TOKENS:
        toks = list(_tokens(text, token))
        for i, (kind, value, _) in enumerate(toks[:-1]):
            if kind == "id" and value == "Physical" and toks[i + 1][1] == "Volume":
                return 3
            if kind == "id" and value in ("Include", "Merge") and toks[i + 1][0] == "str":
                if file_dimension(path.parent / toks[i + 1][1], seen, value == "Merge") == 3:
                    return 3
    return 2


def msh_physical_names(path: str | os.PathLike) -> list[tuple[int, int, str]]:
    """(dimension, tag, name) of each entry of a .msh's ``$PhysicalNames`` (read from its first MB)."""
    head = read_regular(Path(path), "gmsh .msh file", max_bytes=1 << 20)
    if b"$PhysicalNames" not in head:
        return []
    block = head.split(b"$PhysicalNames", 1)[1].split(b"$EndPhysicalNames", 1)[0].decode("utf-8", "replace")
    out = []
    for line in block.strip().splitlines()[1:]:
        parts = line.split(None, 2)
        if len(parts) == 3 and parts[0].isdigit() and parts[1].isdigit():
            out.append((int(parts[0]), int(parts[1]), parts[2].strip().strip('"')))
    return out
