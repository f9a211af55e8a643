"""A small, safe expression language for scenario files.

Grammar: numbers, ``+ - * / **``, unary minus/plus, parentheses, the functions
``sin cos tan exp log sqrt abs sign tanh`` (one argument each), the constants ``pi`` and ``e``, and the
variables a field allows (``t``, ``q1..qn``, ``qd1..qn``).

The text is parsed with :func:`ast.parse` (which only parses) and the tree is walked against a whitelist
into a SymPy expression; nothing from the file is ever evaluated as Python. SymPy gives exact derivatives
(reference velocity and acceleration) and compiles each expression once into a plain numeric function.
"""

from __future__ import annotations

import ast
import math
import re
from collections.abc import Callable, Mapping, Sequence

import numpy as np
import sympy as sp

MAX_SOURCE_LENGTH = 2000
MAX_DEPTH = 60

FUNCTIONS: dict[str, Callable[[sp.Expr], sp.Expr]] = {
    "sin": sp.sin,
    "cos": sp.cos,
    "tan": sp.tan,
    "exp": sp.exp,
    "log": sp.log,
    "sqrt": sp.sqrt,
    "abs": sp.Abs,
    "sign": sp.sign,
    "tanh": sp.tanh,
}
CONSTANTS: dict[str, sp.Expr] = {"pi": sp.pi, "e": sp.E}

_BINARY = {
    ast.Add: lambda a, b: a + b,
    ast.Sub: lambda a, b: a - b,
    ast.Mult: lambda a, b: a * b,
    ast.Div: lambda a, b: a / b,
    ast.Pow: lambda a, b: a**b,
}
_NODE_NAMES = {
    ast.Attribute: "attribute access",
    ast.Call: "function call",
    ast.Subscript: "indexing",
    ast.Lambda: "lambda",
    ast.Compare: "comparison",
    ast.BoolOp: "boolean operator",
    ast.IfExp: "conditional",
    ast.List: "list",
    ast.Tuple: "tuple",
    ast.Dict: "dict",
    ast.Set: "set",
    ast.ListComp: "comprehension",
    ast.GeneratorExp: "comprehension",
    ast.NamedExpr: "assignment",
    ast.JoinedStr: "string",
}


class ExpressionError(ValueError):
    """The text is not a valid expression of the language; the message says why (no location)."""


def symbol(name: str) -> sp.Symbol:
    """The SymPy symbol used for a variable (all variables are real)."""
    return sp.Symbol(name, real=True)


def parse(source: str | int | float, variables: Sequence[str]) -> sp.Expr:
    """Parse ``source`` into a SymPy expression over ``variables``.

    Raises:
        ExpressionError: on anything outside the language.
    """
    if isinstance(source, bool) or not isinstance(source, (str, int, float)):
        raise ExpressionError(f"expected a number or an expression string, got {type(source).__name__}")
    if not isinstance(source, str):
        if not math.isfinite(source):
            raise ExpressionError(f"number {source!r} is not finite")
        return sp.Float(source)
    if len(source) > MAX_SOURCE_LENGTH:
        raise ExpressionError(f"expression longer than {MAX_SOURCE_LENGTH} characters")
    if not source.strip():
        raise ExpressionError("empty expression")
    try:
        tree = ast.parse(source.strip(), mode="eval")
    except SyntaxError as exc:
        raise ExpressionError(f"syntax error in {source!r}: {exc.msg}") from None
    allowed = {name: symbol(name) for name in variables}
    expr = _convert(tree.body, allowed, depth=0)
    if any(number.is_finite and not math.isfinite(float(number)) for number in expr.atoms(sp.Float)):
        raise ExpressionError(f"a number in {source!r} is outside the double-precision range")
    if expr.has(sp.zoo, sp.oo, -sp.oo, sp.nan, sp.I):
        raise ExpressionError(f"{source!r} is infinite, undefined or complex")
    return expr


def _number_power(base: float, exponent: float) -> sp.Expr:
    """A constant power, computed in doubles: SymPy would try huge exact powers (9**9**9**9 never returns)."""
    try:
        value = base**exponent
    except OverflowError:
        raise ExpressionError(f"{base!r}**{exponent!r} is outside the double-precision range") from None
    except ZeroDivisionError:
        raise ExpressionError(f"{base!r}**{exponent!r} divides by zero") from None
    if isinstance(value, complex):
        raise ExpressionError(f"{base!r}**{exponent!r} is not a real number")
    if not math.isfinite(value):
        raise ExpressionError(f"{base!r}**{exponent!r} is outside the double-precision range")
    return sp.Float(value)


def _convert(node: ast.AST, allowed: dict[str, sp.Symbol], depth: int) -> sp.Expr:
    if depth > MAX_DEPTH:
        raise ExpressionError("expression nested too deeply")
    depth += 1
    if isinstance(node, ast.Constant):
        value = node.value
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ExpressionError(f"constant {value!r} is not a real number")
        if not math.isfinite(value):
            raise ExpressionError(f"number {ast.unparse(node)!r} is outside the double-precision range")
        # Floats keep SymPy from building huge exact integers (e.g. 9**9**9).
        return sp.Float(value)
    if isinstance(node, ast.Name):
        if node.id in allowed:
            return allowed[node.id]
        if node.id in CONSTANTS:
            return CONSTANTS[node.id]
        if node.id in FUNCTIONS:
            raise ExpressionError(f"function {node.id!r} used without an argument")
        names = ", ".join(sorted(allowed)) or "none"
        raise ExpressionError(f"unknown name {node.id!r} (variables allowed here: {names})")
    if isinstance(node, ast.BinOp) and type(node.op) in _BINARY:
        left = _convert(node.left, allowed, depth)
        right = _convert(node.right, allowed, depth)
        if isinstance(node.op, ast.Pow) and left.is_Number and right.is_Number:
            return _number_power(float(left), float(right))
        try:
            return _BINARY[type(node.op)](left, right)
        except (ZeroDivisionError, OverflowError, ValueError, TypeError) as exc:
            raise ExpressionError(f"cannot compute {ast.unparse(node)!r}: {exc}") from None
    if isinstance(node, ast.UnaryOp) and isinstance(node.op, (ast.USub, ast.UAdd)):
        operand = _convert(node.operand, allowed, depth)
        return -operand if isinstance(node.op, ast.USub) else operand
    if isinstance(node, ast.Call):
        func = node.func
        if not isinstance(func, ast.Name) or func.id not in FUNCTIONS:
            what = ast.unparse(func)
            raise ExpressionError(f"call of {what!r} is not allowed (functions: {', '.join(FUNCTIONS)})")
        if node.keywords or len(node.args) != 1 or isinstance(node.args[0], ast.Starred):
            raise ExpressionError(f"{func.id}() takes exactly one argument")
        return FUNCTIONS[func.id](_convert(node.args[0], allowed, depth))
    what = _NODE_NAMES.get(type(node), type(node).__name__)
    raise ExpressionError(f"{what} is not allowed in an expression")


def _without_impulses(expr: sp.Expr) -> sp.Expr:
    """Derivatives of sign/abs produce DiracDelta terms; numerically they are zero almost everywhere."""
    return expr.replace(lambda e: isinstance(e, sp.DiracDelta), lambda e: sp.Integer(0))


class TimeFunctions:
    """Several expressions of ``t`` (and of named parameters) with their exact first and second time
    derivatives, compiled once.

    Evaluated on a whole time grid at once (the reference is known in advance): ``(len(times), k)`` arrays, or,
    with one row of parameter values per member, ``(len(times), members, k)``.
    """

    def __init__(self, exprs: Sequence[sp.Expr], parameters: Sequence[str] = ()):
        t = symbol("t")
        self.exprs = list(exprs)
        self.parameters = list(parameters)
        self.first = [_without_impulses(sp.diff(e, t)) for e in self.exprs]
        self.second = [_without_impulses(sp.diff(e, t)) for e in self.first]
        arguments = [t] + [symbol(name) for name in self.parameters]
        self._funcs = [sp.lambdify(arguments, group, modules="numpy") for group in (self.exprs, self.first, self.second)]

    def evaluate(self, times: np.ndarray, parameters: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Values, first and second derivatives on ``times``: three ``(len(times), k)`` arrays; with
        ``parameters`` ``(members, p)``, three ``(len(times), members, k)`` arrays."""
        times = np.asarray(times, dtype=float)
        if parameters is None:
            grid, columns = times, ()
        else:
            parameters = np.asarray(parameters, dtype=float)
            grid = times[:, None] * np.ones(len(parameters))  # (N, members)
            columns = tuple(parameters.T)  # each (members,), broadcast against the grid
        out = []
        for func in self._funcs:
            values = [np.broadcast_to(np.asarray(v, dtype=float), grid.shape) for v in func(grid, *columns)]
            out.append(np.stack(values, axis=-1) if values else np.zeros(grid.shape + (0,)))
        return out[0], out[1], out[2]


class StateFunction:
    """A vector of expressions of ``(t, q1..qn, qd1..qn, parameters...)`` compiled once by SymPy into NumPy code
    (common subexpressions shared), evaluated for every row of a batch at once (a row: one variant of one
    member) on whole columns.

    This is the definition; :mod:`ftc_mj.fast.programs` runs the same code as one compiled program, or row by
    row on Python floats for a few rows, with the same bits.
    """

    def __init__(self, exprs: Sequence[sp.Expr], n_joints: int, parameters: Sequence[str] = ()):
        self.exprs = list(exprs)
        self.n_joints = n_joints
        self.parameters = list(parameters)
        #: The SymPy symbols of the arguments, in order: t, q1..qn, qd1..qn, the parameters.
        self.symbols = [symbol(v) for v in state_variables(n_joints) + self.parameters]
        self.columns = sp.lambdify(self.symbols, self.exprs, modules="numpy", cse=True)

    def __call__(self, t: float | np.ndarray, q: Sequence, qd: Sequence, parameters: Sequence = ()) -> list:
        """Values at ``t`` and the state ``q``, ``qd`` (one number or ``(rows,)`` array per joint, e.g. the
        columns ``qpos.T``) and the parameters: one per expression (a plain number where constant)."""
        return self.columns(t, *q, *qd, *parameters)

    def evaluation(self, q: np.ndarray, qd: np.ndarray, parameters: np.ndarray,
                   out: np.ndarray) -> Callable[[float], None]:
        """:meth:`evaluate` of these buffers (the same objects every call, read and written in place) as a
        function of time alone."""
        return lambda t: self.evaluate(t, q, qd, parameters, out)

    def evaluate(self, t: float, q: np.ndarray, qd: np.ndarray, parameters: np.ndarray, out: np.ndarray) -> None:
        """Every row at once into ``out`` ``(rows, expressions)``, from ``q``, ``qd`` ``(rows, n)`` and
        ``parameters`` ``(rows, p)``."""
        for column, values in enumerate(self.columns(t, *q.T, *qd.T, *parameters.T)):
            out[:, column] = values


def is_free_name(name: str) -> bool:
    """Whether ``name`` may name a user's variable (a scenario parameter): an identifier that is not a
    function, a constant, ``t``, or a joint variable (``q<k>``, ``qd<k>``)."""
    return (
        re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", name) is not None
        and name not in FUNCTIONS
        and name not in CONSTANTS
        and name != "t"
        and re.fullmatch(r"qd?[0-9]+", name) is None
    )


def state_variables(n_joints: int) -> list[str]:
    """Variable names of a state-dependent field: ``t, q1..qn, qd1..qn``."""
    return ["t"] + [f"q{i + 1}" for i in range(n_joints)] + [f"qd{i + 1}" for i in range(n_joints)]


def first_nonfinite(expr: sp.Expr, times: np.ndarray, values: Mapping[str, float] | None = None,
                    where: np.ndarray | None = None) -> float | None:
    """The first time of the grid ``times`` (among those where ``where`` is true) at which ``expr`` is NaN or
    infinite, the named ``values`` (a scenario's parameters) put in; None when it is finite on all of them.

    A check made once when a scenario loads, on a throwaway function (the compiled ones are not involved):
    ``log(t - 5)`` on a run from 0 s is refused there rather than running to a NaN reference. Only an
    expression of ``t`` and the parameters has values on the grid; one of the state (``q1``, ``qd1``, ...)
    has values only along a trajectory, which is not known before the run, so it cannot be checked here.

    Raises:
        ValueError: ``expr`` has a variable other than ``t`` and the names of ``values``.
    """
    t = symbol("t")
    known = {symbol(name): float(value) for name, value in (values or {}).items()}
    others = expr.free_symbols - {t} - set(known)
    if others:
        raise ValueError(f"depends on {', '.join(sorted(str(s) for s in others))}: not a function of time alone")
    function = sp.lambdify([t], expr.subs(known), modules="numpy")
    times = np.asarray(times, dtype=float)
    with np.errstate(all="ignore"):
        result = np.broadcast_to(np.asarray(function(times), dtype=complex if expr.has(sp.I) else float), times.shape)
    bad = ~np.isfinite(result)
    if where is not None:
        bad &= where
    found = np.flatnonzero(bad)
    return float(times[found[0]]) if found.size else None
