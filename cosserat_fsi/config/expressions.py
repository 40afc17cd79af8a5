"""Expressions of the ``boundaries:`` section: strings in x, y, z, t parsed by a whitelisted grammar.

``parse(text)`` turns e.g. ``"1.5*y*(0.41-y)/0.042025 * (1 - cos(pi*min(t, 2)/2))/2"`` into an
:class:`Expression`: a tree of numbers, the symbols x, y, z, t, pi, the operators + - * / ** (unary + -),
parentheses and the functions sin cos tan asin acos atan atan2(y, x) sinh cosh tanh exp log sqrt abs min max,
and ``where(cond, a, b)`` (a where cond holds, else b) with cond one comparison ``<  <=  >  >=  ==  !=`` of two
expressions, e.g. ``where(t < 1, t, 1)``; a comparison is allowed only there. Python's ``ast`` only *parses*
the text (``ast.parse(mode="eval")``, no compile, no eval); the tree is then walked with an explicit whitelist
of node types and names: anything else (an attribute, a subscript, a call of another name, a lambda, a string,
a keyword argument, a boolean operator, ...) is refused with one line, and nothing of the text is ever executed.
Numbers are IEEE doubles and every operation has IEEE semantics: ``1/0`` is inf, ``atan(1/0)`` is π/2,
``2.0**5000`` is inf and ``min(0, 2.0**5000)`` 0, ``sqrt(-1)`` and ``log(-1)`` are nan, and ``where`` computes both
branches and keeps the one its condition picks (``where(t > 1000, log(0), 0)`` is 0 before t = 1000). A literal
that is no double (``1e400``, an integer of 400 digits) is refused at parse. The boundary code refuses values
that are not finite where they are used (``finite_at``, problem/data.py).

One evaluation: ``evaluate(x, t)``, numpy with every floating-point error ignored, gives the values of every
condition (velocity, pressure, traction, ω), interpolated into a Function (problem/data.py); the checks use the
same evaluation. Light module: no dolfinx/ufl import at import time.
"""

from __future__ import annotations

import ast
import math
from dataclasses import dataclass
from typing import Any

COORDINATES = ("x", "y", "z")
SYMBOLS = (*COORDINATES, "t", "pi")
FUNCTIONS = {"sin": 1, "cos": 1, "tan": 1, "asin": 1, "acos": 1, "atan": 1, "atan2": 2, "sinh": 1, "cosh": 1,
             "tanh": 1, "exp": 1, "log": 1, "sqrt": 1, "abs": 1, "min": 2, "max": 2, "where": 3}
COMPARISONS = {"Lt": "<", "LtE": "<=", "Gt": ">", "GtE": ">=", "Eq": "==", "NotEq": "!="}
MAX_LENGTH = 2000
MAX_DEPTH = 60


class ExpressionError(ValueError):
    """An expression outside the grammar (the message is one line, without the key)."""


@dataclass(frozen=True)
class Expression:
    """A parsed expression: ``text`` and its tree (nested tuples: ("num", v), ("sym", name),
    ("neg", a), ("add"|"sub"|"mul"|"div"|"pow", a, b), ("call", name, args), ("cmp", op, a, b))."""

    text: str
    tree: tuple

    @property
    def symbols(self) -> set[str]:
        """The symbols it uses (x, y, z, t, pi)."""
        found: set[str] = set()

        def walk(node):
            if node[0] == "sym":
                found.add(node[1])
            elif node[0] in ("call", "cmp"):
                for a in node[2:] if node[0] == "cmp" else node[2]:
                    walk(a)
            elif node[0] != "num":
                for a in node[1:]:
                    walk(a)

        walk(self.tree)
        return found

    @property
    def time_dependent(self) -> bool:
        return "t" in self.symbols

    def evaluate(self, x, t: float):
        """numpy values at points ``x`` (shape (3, n)) and time ``t`` (an array of shape (n,))."""
        import numpy as np

        n = x.shape[1]
        env = {"x": x[0], "y": x[1], "z": x[2], "t": np.float64(t), "pi": np.float64(math.pi)}  # numpy scalars: IEEE
        funcs = {"sin": np.sin, "cos": np.cos, "tan": np.tan, "asin": np.arcsin, "acos": np.arccos,
                 "atan": np.arctan, "atan2": np.arctan2, "sinh": np.sinh, "cosh": np.cosh, "tanh": np.tanh,
                 "exp": np.exp, "log": np.log, "sqrt": np.sqrt, "abs": np.abs, "min": np.minimum,
                 "max": np.maximum, "where": np.where, "cmp": _NUMPY_COMPARE, "num": np.float64}
        with np.errstate(all="ignore"):  # IEEE: inf and nan, never an exception (finite_at checks)
            value = _build(self.tree, env, funcs)
        return np.broadcast_to(np.asarray(value, dtype=float), (n,)).copy()

    def finite_at(self, x, t: float) -> bool:
        """True if the values at points ``x`` (shape (3, n)) and time ``t`` are all finite."""
        import numpy as np

        return bool(np.all(np.isfinite(self.evaluate(x, t))))


def _compare(op):
    import operator

    return {"<": operator.lt, "<=": operator.le, ">": operator.gt, ">=": operator.ge, "==": operator.eq,
            "!=": operator.ne}[op]


_NUMPY_COMPARE = {op: _compare(op) for op in COMPARISONS.values()}
_BINARY = {ast.Add: "add", ast.Sub: "sub", ast.Mult: "mul", ast.Div: "div", ast.Pow: "pow"}


def parse(text: Any) -> Expression:
    """A number or a string in the grammar (see the module docstring) -> Expression; ExpressionError if not."""
    if isinstance(text, bool):
        raise ExpressionError(f"must be a number or an expression string (got {text!r})")
    if isinstance(text, (int, float)):
        value = _double(text)
        if value is None:
            raise ExpressionError(f"must be a finite number (got {_short(text)})")
        return Expression(repr(value), ("num", value))
    if not isinstance(text, str):
        raise ExpressionError(f"must be a number or an expression string (got {type(text).__name__})")
    if len(text) > MAX_LENGTH:
        raise ExpressionError(f"expression longer than {MAX_LENGTH} characters")
    if not text.strip():
        raise ExpressionError("empty expression")
    try:
        node = ast.parse(text.strip(), mode="eval")  # parsing only: the tree is walked below, never compiled
    except SyntaxError as exc:
        where = f" at column {exc.offset}" if exc.offset else ""
        raise ExpressionError(f"syntax error in {text!r}{where}") from None
    except (ValueError, RecursionError, MemoryError):
        raise ExpressionError(f"cannot parse {text[:60]!r}") from None
    return Expression(text, _walk(node.body, text, 0))


_BIGGEST = 1.7976931348623157e308


def _double(number) -> float | None:
    """The finite double of a literal (an int of any size or a float), or None if it has none."""
    try:
        value = float(number)
    except OverflowError:  # an int beyond the doubles (float(10**400))
        return None
    return value if math.isfinite(value) else None


def _short(text) -> str:
    """``text`` for a one-line message (at most 60 characters of it)."""
    if isinstance(text, int):
        return f"an integer of about {int(abs(text).bit_length() * 0.30103) + 1} digits"
    text = repr(text) if isinstance(text, str) else str(text)
    return text if len(text) <= 60 else text[:57] + "..."


def _walk(node: ast.AST, text: str, depth: int) -> tuple:
    if depth > MAX_DEPTH:
        raise ExpressionError(f"expression nested deeper than {MAX_DEPTH} levels")
    if isinstance(node, ast.Constant) and type(node.value) in (int, float):
        value = _double(node.value)
        if value is None:
            raise ExpressionError(f"number out of range (beyond ±{_BIGGEST:.4g}) in {_short(text)}")
        return ("num", value)
    if isinstance(node, ast.Name):
        if node.id in SYMBOLS:
            return ("sym", node.id)
        if node.id in FUNCTIONS:
            raise ExpressionError(f"{node.id} is a function: call it, e.g. {node.id}(x)")
        raise ExpressionError(f"unknown symbol {node.id!r} in {text!r} (allowed: {', '.join(SYMBOLS)} and "
                              f"the functions {', '.join(FUNCTIONS)})")
    if isinstance(node, ast.UnaryOp) and isinstance(node.op, (ast.USub, ast.UAdd)):
        inner = _walk(node.operand, text, depth + 1)
        return ("neg", inner) if isinstance(node.op, ast.USub) else inner
    if isinstance(node, ast.BinOp) and type(node.op) in _BINARY:
        return (_BINARY[type(node.op)], _walk(node.left, text, depth + 1), _walk(node.right, text, depth + 1))
    if isinstance(node, ast.Call):
        if not isinstance(node.func, ast.Name):
            raise ExpressionError(f"only the functions {', '.join(FUNCTIONS)} may be called, by name, in {text!r}")
        name = node.func.id
        if name not in FUNCTIONS:
            raise ExpressionError(f"unknown function {name!r} in {text!r} (allowed: {', '.join(FUNCTIONS)})")
        if node.keywords or len(node.args) != FUNCTIONS[name]:
            raise ExpressionError(f"{name} takes {FUNCTIONS[name]} argument(s) in {text!r}")
        if name == "where":
            return ("call", name, (_condition(node.args[0], text, depth + 1),
                                   *(_walk(a, text, depth + 1) for a in node.args[1:])))
        return ("call", name, tuple(_walk(a, text, depth + 1) for a in node.args))
    what = {ast.Attribute: "an attribute", ast.Subscript: "a subscript", ast.Lambda: "a lambda",
            ast.Compare: "a comparison outside where(cond, a, b)", ast.BoolOp: "a boolean operator",
            ast.IfExp: "a conditional",
            ast.Constant: "a constant that is not a number"}.get(type(node), f"a {type(node).__name__}")
    raise ExpressionError(f"{what} is not allowed in {text!r} (numbers, x, y, z, t, pi, + - * / **, "
                          "parentheses and the functions " + ", ".join(FUNCTIONS) + ")")


def _condition(node: ast.AST, text: str, depth: int) -> tuple:
    """The first argument of where: one comparison of two expressions."""
    if not isinstance(node, ast.Compare):
        raise ExpressionError(f"where(cond, a, b) needs a comparison (< <= > >= == !=) as cond in {text!r}")
    if len(node.ops) != 1 or type(node.ops[0]).__name__ not in COMPARISONS:
        raise ExpressionError(f"where's cond is one comparison (< <= > >= == !=; nest where for more) in {text!r}")
    op = COMPARISONS[type(node.ops[0]).__name__]
    return ("cmp", op, _walk(node.left, text, depth + 1), _walk(node.comparators[0], text, depth + 1))


def _build(node: tuple, env: dict, funcs: dict):
    kind = node[0]
    if kind == "num":
        return funcs["num"](node[1])
    if kind == "cmp":
        return funcs["cmp"][node[1]](_build(node[2], env, funcs), _build(node[3], env, funcs))
    if kind == "sym":
        return env[node[1]]
    if kind == "neg":
        return -_build(node[1], env, funcs)
    if kind == "call":
        return funcs[node[1]](*(_build(a, env, funcs) for a in node[2]))
    a, b = _build(node[1], env, funcs), _build(node[2], env, funcs)
    if kind == "add":
        return a + b
    if kind == "sub":
        return a - b
    if kind == "mul":
        return a * b
    if kind == "div":
        return a / b
    return a**b
