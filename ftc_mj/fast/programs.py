"""Expressions of the state run by one compiled interpreter: the fast form of a
:class:`~ftc_mj.config.expressions.StateFunction` (the definition) for any number of rows, and the choice
between the fast forms (:func:`evaluation`).

SymPy's lambdified code of a vector of expressions (common subexpressions first, then the list of values) is
read back with :mod:`ast` and turned into a postfix program: a stack machine's instructions in the order in
which Python evaluates that code (a binary operation's left operand, its right one, then the operation), so
each row's numbers come out of the same IEEE operations, one by one, as NumPy's on whole columns. One kernel,
compiled once and cached, runs every program row by row: no code is generated per scenario, and a period's
terms cost one call instead of one NumPy call per operation.

Only operations whose bits compiled code shares with NumPy are taken: ``+ - * /``, negation, ``sin``,
``cos`` (NumPy's float64 sine and cosine are the C library's, as compiled code's; tested), ``sqrt``
(correctly rounded in both), ``abs``, ``sign``, and an array's power by the exponents of NumPy's fast paths
(``x ** 2`` is ``x * x``, ``x ** -1`` is ``1 / x``, ``x ** 0.5`` is ``sqrt(x)``). Code with anything else
(another power, ``exp``, ``tanh``, ...: NumPy's SIMD versions round differently) gives no program, and the
function keeps its NumPy forms. An operation of time and literals alone is one of Python numbers in NumPy's
code too: literals are folded as Python computes them, and a power of them is refused. Division by zero and
NaN follow NumPy (``error_model="numpy"``: inf or NaN, never an exception).
"""

from __future__ import annotations

import ast
import inspect
import math
import operator
import weakref
from collections.abc import Callable
from dataclasses import dataclass

import numba
import numpy as np

from ftc_mj import fast
from ftc_mj.config.expressions import StateFunction
from ftc_mj.fast.crossovers import SCALAR_ROWS
from ftc_mj.fast.kernels import WITHOUT_RUNTIME, bound, cache_folder, cache_is_cold
from ftc_mj.fast.rows import evaluate_rows, row_function

# Opcodes. A load pushes one number; an operation pops its operands and pushes its result; a store pops one.
LOAD_CONSTANT, LOAD_TIME, LOAD_POSITION, LOAD_VELOCITY, LOAD_PARAMETER, LOAD_TEMPORARY = range(6)
STORE_TEMPORARY, STORE_OUTPUT = 6, 7
ADD, SUBTRACT, MULTIPLY, DIVIDE, NEGATE = 8, 9, 10, 11, 12
SIN, COS, SQRT, ABS, SIGN, SQUARE, RECIPROCAL, ONE = 13, 14, 15, 16, 17, 18, 19, 20

_BINARY = {ast.Add: ADD, ast.Sub: SUBTRACT, ast.Mult: MULTIPLY, ast.Div: DIVIDE}
_FUNCTIONS = {"sin": SIN, "cos": COS, "sqrt": SQRT, "abs": ABS, "absolute": ABS, "sign": SIGN}
_CONSTANTS = {"pi": math.pi, "e": math.e}
#: NumPy's ``array ** exponent`` fast paths (numpy's ``fast_scalar_power``): exponent -> the exact operation it
#: is (None: the value itself); tested against NumPy bit for bit.
_FAST_POWERS = {2.0: SQUARE, 0.5: SQRT, 1.0: None, 0.0: ONE, -1.0: RECIPROCAL}
#: The deepest stack a program may need (a bound on what a scenario's expression can cost here).
MAX_STACK = 128


class Unsupported(Exception):
    """The code uses something the interpreter does not run bit for bit as NumPy does."""


@dataclass(frozen=True)
class Program:
    """A postfix program over ``(t, q1..qn, qd1..qn, parameters...)``: ``code`` ``(instructions, 2)`` (opcode,
    argument), its constants, the temporaries (common subexpressions) and the stack it needs."""

    code: np.ndarray
    constants: np.ndarray
    temporaries: int
    stack: int
    outputs: int

    @classmethod
    def from_source(cls, source: str, n_joints: int, parameters: int) -> Program | None:
        """The program of SymPy's lambdified ``source`` (arguments ``t, q1..qn, qd1..qn, parameters``), or None
        where it uses anything :mod:`this module <ftc_mj.fast.programs>` does not run."""
        try:
            return _Compiler(source, n_joints, parameters).program()
        except (Unsupported, SyntaxError, RecursionError):
            return None

    def evaluate(self, t: float, q: np.ndarray, qd: np.ndarray, parameters: np.ndarray, out: np.ndarray) -> None:
        """Every row of ``q``, ``qd`` ``(rows, n)`` and ``parameters`` ``(rows, p)`` into ``out``
        ``(rows, outputs)``."""
        _run(self.code, self.constants, *self.buffers(len(out)), q, qd, parameters, out, float(t))

    def buffers(self, rows: int) -> tuple[np.ndarray, np.ndarray]:
        """The interpreter's working buffers for ``rows`` rows: the stack ``(stack, rows)`` and the temporaries
        ``(temporaries, rows)`` (at least one slot)."""
        return np.empty((self.stack, rows)), np.empty((max(self.temporaries, 1), rows))

    def evaluation(self, q: np.ndarray, qd: np.ndarray, parameters: np.ndarray,
                   out: np.ndarray) -> Callable[[float], None]:
        """:meth:`evaluate` of these buffers (the same objects every call) as a function of time alone, the
        kernel bound to them past Numba's dispatcher (:func:`~ftc_mj.fast.kernels.bound`)."""
        return bound(_run, self.code, self.constants, *self.buffers(len(out)), q, qd, parameters, out, free=(0.0,))


class _Compiler:
    """Walks the lambdified function's body: assignments of temporaries, then ``return [values]``."""

    def __init__(self, source: str, n_joints: int, parameters: int):
        tree = ast.parse(source)
        functions = [node for node in tree.body if isinstance(node, ast.FunctionDef)]
        if len(functions) != 1:
            raise Unsupported("not one function")
        self.function = functions[0]
        names = [argument.arg for argument in self.function.args.args]
        if len(names) != 1 + 2 * n_joints + parameters:
            raise Unsupported("unexpected arguments")
        self.arguments = {name: (LOAD_TIME, 0) if i == 0 else
                          (LOAD_POSITION, i - 1) if i <= n_joints else
                          (LOAD_VELOCITY, i - 1 - n_joints) if i <= 2 * n_joints else
                          (LOAD_PARAMETER, i - 1 - 2 * n_joints) for i, name in enumerate(names)}
        self.temporaries: dict[str, int] = {}
        self.row_temporaries: dict[str, bool] = {}
        self.code: list[tuple[int, int]] = []
        self.constants: list[float] = []
        self.depth = self.deepest = 0

    def program(self) -> Program:
        *assignments, last = self.function.body
        for statement in assignments:
            if not (isinstance(statement, ast.Assign) and len(statement.targets) == 1
                    and isinstance(statement.targets[0], ast.Name)):
                raise Unsupported("a statement other than an assignment")
            row = self.expression(statement.value)
            name = statement.targets[0].id
            self.temporaries[name] = self.temporaries.get(name, len(self.temporaries))
            self.row_temporaries[name] = row
            self.emit(STORE_TEMPORARY, self.temporaries[name], -1)
        if not (isinstance(last, ast.Return) and isinstance(last.value, (ast.List, ast.Tuple))):
            raise Unsupported("no list returned")
        for index, value in enumerate(last.value.elts):
            self.expression(value)
            self.emit(STORE_OUTPUT, index, -1)
        return Program(np.array(self.code, dtype=np.int64).reshape(-1, 2), np.array(self.constants, dtype=float),
                       len(self.temporaries), max(self.deepest, 1), len(last.value.elts))

    def emit(self, opcode: int, argument: int, change: int) -> None:
        self.code.append((opcode, argument))
        self.depth += change
        self.deepest = max(self.deepest, self.depth)
        if self.deepest > MAX_STACK:
            raise Unsupported("too deep")

    def constant(self, value: float) -> None:
        self.constants.append(float(value))
        self.emit(LOAD_CONSTANT, len(self.constants) - 1, 1)

    def expression(self, node: ast.expr) -> bool:
        """Code that pushes ``node``'s value, its operands in Python's order of evaluation; whether the value
        depends on the row (in NumPy's code, an array rather than a Python number)."""
        folded = _constant_value(node)
        if folded is not None:
            # Python computes an operation of two numbers as Python numbers before any array is involved (SymPy
            # prints 1/2 as "(1/2)"); an int meeting a float operand is converted exactly as float() does.
            self.constant(folded)
            return False
        if isinstance(node, ast.Name) and node.id in self.arguments:
            opcode, argument = self.arguments[node.id]
            self.emit(opcode, argument, 1)
            return opcode != LOAD_TIME
        if isinstance(node, ast.Name) and node.id in self.temporaries:
            self.emit(LOAD_TEMPORARY, self.temporaries[node.id], 1)
            return self.row_temporaries[node.id]
        if _name(node) in _CONSTANTS:
            self.constant(_CONSTANTS[_name(node)])
            return False
        if isinstance(node, ast.BinOp) and isinstance(node.op, ast.Pow):
            # An array's power by one of NumPy's fast paths' exponents is an exact operation (SymPy prints x / y
            # as x * y**(-1.0)); any other power is NumPy's pow, and a Python number's is the C library's.
            exponent = _constant_value(node.right)
            if exponent not in _FAST_POWERS or not self.expression(node.left):
                raise Unsupported("a power other than an array's by 2, 1/2, 1, 0 or -1")
            if _FAST_POWERS[exponent] is not None:
                self.emit(_FAST_POWERS[exponent], 0, 0)
            return True
        if isinstance(node, ast.BinOp) and type(node.op) in _BINARY:
            left = self.expression(node.left)
            right = self.expression(node.right)
            self.emit(_BINARY[type(node.op)], 0, -1)
            return left or right
        if isinstance(node, ast.UnaryOp) and isinstance(node.op, (ast.USub, ast.UAdd)):
            row = self.expression(node.operand)
            if isinstance(node.op, ast.USub):
                self.emit(NEGATE, 0, 0)
            return row
        if (isinstance(node, ast.Call) and _name(node.func) in _FUNCTIONS and len(node.args) == 1
                and not node.keywords):
            row = self.expression(node.args[0])
            self.emit(_FUNCTIONS[_name(node.func)], 0, 0)
            return row
        raise Unsupported(ast.dump(node)[:80])


def _name(node: ast.expr) -> str | None:
    """``sin`` for ``sin`` and ``numpy.sin``; None for anything else."""
    if isinstance(node, ast.Name):
        return node.id
    if isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name) and node.value.id in ("numpy", "math"):
        return node.attr
    return None


#: Python's own arithmetic, for the operations of literals alone.
_FOLDED = {ast.Add: operator.add, ast.Sub: operator.sub, ast.Mult: operator.mul, ast.Div: operator.truediv,
           ast.Pow: operator.pow}


def _constant_value(node: ast.expr) -> float | None:
    """The value Python gives an expression of number literals alone (as a float), or None for any other
    node. Powers are folded only of small operands, so that no literal can make this costly."""
    def value(node: ast.expr) -> int | float | None:
        if isinstance(node, ast.Constant) and type(node.value) in (int, float):
            return node.value
        if isinstance(node, ast.UnaryOp) and isinstance(node.op, (ast.USub, ast.UAdd)):
            operand = value(node.operand)
            return None if operand is None else (-operand if isinstance(node.op, ast.USub) else operand)
        if isinstance(node, ast.BinOp) and type(node.op) in _FOLDED:
            left, right = value(node.left), value(node.right)
            if left is None or right is None:
                return None
            if isinstance(node.op, ast.Pow) and not (abs(left) <= 2**64 and abs(right) <= 64):
                raise Unsupported("a power of large literals")
            try:
                return _FOLDED[type(node.op)](left, right)
            except (ArithmeticError, ValueError) as error:  # Python would raise at run time too
                raise Unsupported(str(error)) from error
        return None

    folded = value(node)
    if folded is None:
        return None
    if not isinstance(folded, (int, float)) or (isinstance(folded, int) and abs(folded) > 2**1000):
        raise Unsupported("not a real number")  # e.g. (-8)**(1/3) is complex in Python
    return float(folded)


@numba.njit(cache=True, nogil=True, error_model="numpy", **WITHOUT_RUNTIME)
def _run(code: np.ndarray, constants: np.ndarray, stack: np.ndarray, saved: np.ndarray, q: np.ndarray,
         qd: np.ndarray, parameters: np.ndarray, out: np.ndarray, t: float) -> None:
    """The stack machine (opcodes at the top of the module), each instruction over all rows at once: a stack
    slot holds a value per row; ``stack`` and ``saved`` (the temporaries) are the caller's buffers
    (:meth:`Program.buffers`), so the kernel allocates nothing."""
    rows = out.shape[0]
    top = 0  # the number of slots in use
    for i in range(code.shape[0]):
        opcode, argument = code[i, 0], code[i, 1]
        if opcode <= LOAD_TEMPORARY:
            slot = stack[top]
            if opcode == LOAD_CONSTANT:
                slot[:] = constants[argument]
            elif opcode == LOAD_TIME:
                slot[:] = t
            elif opcode == LOAD_POSITION:
                for r in range(rows):
                    slot[r] = q[r, argument]
            elif opcode == LOAD_VELOCITY:
                for r in range(rows):
                    slot[r] = qd[r, argument]
            elif opcode == LOAD_PARAMETER:
                for r in range(rows):
                    slot[r] = parameters[r, argument]
            else:
                for r in range(rows):
                    slot[r] = saved[argument, r]
            top += 1
        elif opcode == STORE_TEMPORARY:
            top -= 1
            for r in range(rows):
                saved[argument, r] = stack[top, r]
        elif opcode == STORE_OUTPUT:
            top -= 1
            for r in range(rows):
                out[r, argument] = stack[top, r]
        elif opcode <= DIVIDE:
            top -= 1
            left, right = stack[top - 1], stack[top]
            if opcode == ADD:
                for r in range(rows):
                    left[r] = left[r] + right[r]
            elif opcode == SUBTRACT:
                for r in range(rows):
                    left[r] = left[r] - right[r]
            elif opcode == MULTIPLY:
                for r in range(rows):
                    left[r] = left[r] * right[r]
            else:
                for r in range(rows):
                    left[r] = left[r] / right[r]
        else:
            x = stack[top - 1]
            if opcode == NEGATE:
                for r in range(rows):
                    x[r] = -x[r]
            elif opcode == SIN:
                for r in range(rows):
                    x[r] = math.sin(x[r])
            elif opcode == COS:
                for r in range(rows):
                    x[r] = math.cos(x[r])
            elif opcode == SQRT:
                for r in range(rows):
                    x[r] = math.sqrt(x[r])
            elif opcode == ABS:
                for r in range(rows):
                    x[r] = abs(x[r])
            elif opcode == SQUARE:
                for r in range(rows):
                    x[r] = x[r] * x[r]
            elif opcode == RECIPROCAL:
                for r in range(rows):
                    x[r] = 1.0 / x[r]
            elif opcode == ONE:
                x[:] = 1.0
            else:  # SIGN as NumPy's: +0 for either zero, NaN stays the same NaN
                for r in range(rows):
                    if x[r] == 0.0:
                        x[r] = 0.0
                    elif x[r] == x[r]:
                        x[r] = math.copysign(1.0, x[r])


#: The interpreter every program runs on (compiled at its first call in a process, or loaded from Numba's cache).
INTERPRETER = _run


def program_of(function: StateFunction) -> Program | None:
    """The compiled program of ``function``'s NumPy code (made once per function), or None where that code
    uses an operation this interpreter does not run as NumPy does."""
    try:
        return _PROGRAMS[function]
    except KeyError:
        pass
    try:
        source = inspect.getsource(function.columns)  # lambdify keeps the code it generated in linecache
    except (OSError, TypeError):
        program = None
    else:
        program = Program.from_source(source, function.n_joints, len(function.parameters))
    _PROGRAMS[function] = program
    return program


#: :func:`program_of` of each function alive.
_PROGRAMS: weakref.WeakKeyDictionary[StateFunction, Program | None] = weakref.WeakKeyDictionary()
_ROWS: weakref.WeakKeyDictionary[StateFunction, Callable[..., list]] = weakref.WeakKeyDictionary()


def evaluation(function: StateFunction, q: np.ndarray, qd: np.ndarray, parameters: np.ndarray,
               out: np.ndarray) -> Callable[[float], None]:
    """:meth:`StateFunction.evaluation <ftc_mj.config.expressions.StateFunction.evaluation>` of these buffers
    (the same objects every call) in its cheapest form with the same bits: the compiled program where there is
    one, else row by row on Python floats up to :data:`~ftc_mj.fast.crossovers.SCALAR_ROWS` rows
    (:mod:`ftc_mj.fast.rows`), else the definition. With the fast paths off, the definition."""
    if not fast.enabled():
        return function.evaluation(q, qd, parameters, out)
    program = program_of(function)
    if program is not None:
        _announce()
        return program.evaluation(q, qd, parameters, out)
    if len(out) > SCALAR_ROWS:
        return function.evaluation(q, qd, parameters, out)
    row = _ROWS.get(function)
    if row is None:
        row = _ROWS[function] = row_function(function)
    return lambda t: evaluate_rows(function, row, t, q, qd, parameters, out)


def _announce() -> None:
    """One line on stderr, once per process, when the interpreter will compile (the first run on a machine, or
    after an update)."""
    fast.announce_compilation("the plant terms' interpreter", cache_is_cold(INTERPRETER, __file__),
                              cache_folder(INTERPRETER))
