"""The scenario expression language of ftc_mj.config.expressions: grammar, rejections, exact derivatives and the
compiled per-step state functions.

Tests named ``test_regression_*`` pin bugs found while writing this file (fixed in commit b37582f).
"""

from __future__ import annotations

import math
import multiprocessing
import queue

import numpy as np
import pytest
import sympy as sp
from hypothesis import assume, example, given, settings
from hypothesis import strategies as st

from ftc_mj.config.expressions import (
    FUNCTIONS,
    MAX_DEPTH,
    MAX_SOURCE_LENGTH,
    ExpressionError,
    StateFunction,
    TimeFunctions,
    parse,
    state_variables,
    symbol,
)

T = symbol("t")
STATE3 = state_variables(3)
GRID = np.linspace(0.0, 20.0, 2001)


def value(source, variables=("t",), **subs) -> float:
    """Numeric value of a parsed expression with the given variable values."""
    expr = parse(source, list(variables))
    return float(expr.subs({symbol(k): v for k, v in subs.items()}).evalf())


# ---------------------------------------------------------------------------------------------- grammar


@pytest.mark.parametrize(
    ("source", "expected"),
    [
        ("3", 3.0),
        ("2.5", 2.5),
        ("1e-3", 1e-3),
        (".5", 0.5),
        ("1_000", 1000.0),
        ("1 + 2", 3.0),
        ("7 - 10", -3.0),
        ("2 * 3.5", 7.0),
        ("7 / 2", 3.5),
        ("2 ** 10", 1024.0),
        ("-4", -4.0),
        ("+4", 4.0),
        ("--4", 4.0),
        ("-2 ** 2", -4.0),  # Python precedence: unary minus binds looser than **
        ("(-2) ** 2", 4.0),
        ("2 * (3 + 4)", 14.0),
        ("2 * 3 + 4", 10.0),
        ("((((1))))", 1.0),
        ("2 ** 3 ** 2", 512.0),  # right associative
        ("10 - 4 - 3", 3.0),  # left associative
        ("pi", math.pi),
        ("e", math.e),
        ("2*pi - e", 2 * math.pi - math.e),
        ("sin(pi/6)", 0.5),
        ("cos(pi/3)", 0.5),
        ("tan(pi/4)", 1.0),
        ("exp(1)", math.e),
        ("log(e**2)", 2.0),
        ("sqrt(16)", 4.0),
        ("abs(-2.5)", 2.5),
        ("sign(-3)", -1.0),
        ("sign(2)", 1.0),
        ("sign(0)", 0.0),
        ("tanh(0.5)", math.tanh(0.5)),
        ("  1 + 1  ", 2.0),  # surrounding whitespace is fine
    ],
)
def test_constant_expressions(source, expected):
    assert value(source) == pytest.approx(expected, rel=1e-14, abs=1e-15)


@pytest.mark.parametrize("number", [0, 3, -7, 2.5, -1e-300, 1.7e308])
def test_numbers_are_accepted_as_numbers(number):
    expr = parse(number, ["t"])
    assert expr.is_Number
    assert float(expr) == number


NUMPY_FUNCTIONS = {"sin": np.sin, "cos": np.cos, "tan": np.tan, "exp": np.exp, "log": np.log, "sqrt": np.sqrt,
                   "abs": np.abs, "sign": np.sign, "tanh": np.tanh}


@pytest.mark.parametrize("name", sorted(FUNCTIONS))
@pytest.mark.parametrize("x", [0.37, 2.9])
def test_every_function_is_available_and_matches_numpy(name, x):
    assert value(f"{name}(t)", t=x) == pytest.approx(NUMPY_FUNCTIONS[name](x), rel=1e-14)
    if name in ("abs", "sign", "sin", "tan", "tanh", "cos"):
        assert value(f"{name}(-t)", t=x) == pytest.approx(NUMPY_FUNCTIONS[name](-x), rel=1e-14)


def test_function_set_is_exactly_the_documented_one():
    assert set(FUNCTIONS) == set(NUMPY_FUNCTIONS) == {"sin", "cos", "tan", "exp", "log", "sqrt", "abs", "sign", "tanh"}


def test_variables_become_real_symbols():
    expr = parse("q1 * qd2 + t - q3", STATE3)
    assert expr.free_symbols == {symbol("q1"), symbol("qd2"), symbol("t"), symbol("q3")}
    assert all(s.is_real for s in expr.free_symbols)
    assert expr.subs({symbol("q1"): 2, symbol("qd2"): 3, symbol("t"): 1, symbol("q3"): 4}) == 3


def test_state_variables_names():
    assert state_variables(3) == ["t", "q1", "q2", "q3", "qd1", "qd2", "qd3"]
    assert state_variables(1) == ["t", "q1", "qd1"]


def test_abs_of_real_variable_is_kept_and_differentiates_to_sign():
    expr = parse("abs(t)", ["t"])
    assert sp.diff(expr, T) == sp.sign(T)


# -------------------------------------------------------------------------------------------- rejection


@pytest.mark.parametrize(
    ("source", "variables", "fragment"),
    [
        ("x", ["t"], "unknown name 'x'"),
        ("q1", ["t"], "unknown name 'q1'"),  # a state variable in a time-only field
        ("q4", STATE3, "unknown name 'q4'"),
        ("T", ["t"], "unknown name 'T'"),  # names are case-sensitive
        ("Pi", ["t"], "unknown name"),
        ("__builtins__", ["t"], "unknown name"),
        ("sin", ["t"], "without an argument"),
        ("t + cos", ["t"], "without an argument"),
    ],
)
def test_unknown_names_are_rejected(source, variables, fragment):
    with pytest.raises(ExpressionError, match=fragment):
        parse(source, variables)


@pytest.mark.parametrize(
    ("source", "fragment"),
    [
        # attribute access
        ("q1.real", "attribute"),
        ("().__class__", "attribute"),
        ("().__class__.__bases__[0].__subclasses__()", "not allowed"),
        ("t.__class__", "attribute"),
        ("pi.evalf", "attribute"),
        # calls of anything but the whitelist
        ("__import__('os')", "call of '__import__'"),
        ("__import__('os').system('touch pwned')", "not allowed"),
        ("open('x')", "call of 'open'"),
        ("eval('1')", "call of 'eval'"),
        ("exec('1')", "call of 'exec'"),
        ("getattr(t, 'real')", "call of 'getattr'"),
        ("sin.__call__(1)", "not allowed"),
        ("(lambda: 1)()", "not allowed"),
        ("t(1)", "call of 't'"),
        # calls of whitelisted functions with the wrong arguments
        ("sin(x=1)", "exactly one argument"),
        ("sin(t, t)", "exactly one argument"),
        ("sin()", "exactly one argument"),
        ("sin(*t)", "exactly one argument"),
        ("sin(**t)", "exactly one argument"),
        # other node kinds
        ("lambda: 1", "lambda"),
        ("[x for x in t]", "comprehension"),
        ("(x for x in t)", "comprehension"),
        ("{x for x in t}", "not allowed"),
        ("{x: 1 for x in t}", "not allowed"),
        ("t[0]", "indexing"),
        ("[1][0]", "not allowed"),
        ("'abc'", "not a real number"),
        ("b'abc'", "not a real number"),
        ("f'{t}'", "string"),
        ("t < 1", "comparison"),
        ("t == 1", "comparison"),
        ("1 if t else 2", "conditional"),
        ("(y := 1)", "assignment"),
        ("True", "not a real number"),
        ("False", "not a real number"),
        ("None", "not a real number"),
        ("t and 1", "boolean"),
        ("not t", "not allowed"),
        ("~1", "not allowed"),
        ("t % 2", "not allowed"),
        ("t // 2", "not allowed"),
        ("t @ t", "not allowed"),
        ("t << 1", "not allowed"),
        ("t & 1", "not allowed"),
        ("1j", "not a real number"),
        ("...", "not a real number"),
        ("[1, 2]", "list"),
        ("(1, 2)", "tuple"),
        ("{1: 2}", "dict"),
        ("{1}", "set"),
        ("await t", "not allowed"),
        # not an expression at all
        ("import os", "syntax error"),
        ("x = 1", "syntax error"),
        ("1 +", "syntax error"),
        ("sin(t", "syntax error"),
        ("", "empty"),
        ("   ", "empty"),
    ],
)
def test_outside_the_language_is_rejected(source, fragment):
    with pytest.raises(ExpressionError, match=fragment.replace("(", r"\(").replace(")", r"\)")):
        parse(source, ["t"])


def test_rejected_import_has_no_side_effect(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(ExpressionError):
        parse("__import__('os').system('touch pwned')", ["t"])
    with pytest.raises(ExpressionError):
        parse("open('created', 'w')", ["t"])
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("source", [True, False, None, [1], {"a": 1}, b"1", 1j])
def test_non_text_non_number_sources_are_rejected(source):
    with pytest.raises(ExpressionError, match="expected a number or an expression string"):
        parse(source, ["t"])


@pytest.mark.parametrize("source", [float("inf"), float("-inf"), float("nan")])
def test_non_finite_numbers_are_rejected(source):
    with pytest.raises(ExpressionError, match="not finite"):
        parse(source, ["t"])


@pytest.mark.parametrize(
    "source", ["9**9**9", "1e999", "-1e999", "1e308 * 10", "2**2000", "exp(1000)", "e**710", "0 * 1e999",
               "t + 1e400", "10.0**400"]
)
def test_numbers_outside_double_range_are_rejected(source):
    with pytest.raises(ExpressionError, match="outside the double-precision range"):
        parse(source, ["t"])


def test_largest_double_range_numbers_are_accepted():
    assert float(parse("1.7e308", ["t"])) == 1.7e308
    assert float(parse("2**1000", ["t"])) == 2.0**1000
    assert float(parse("5e-324", ["t"])) == 5e-324


def test_too_long_text_is_rejected_and_the_limit_is_inclusive():
    at_limit = "t" + " " * (MAX_SOURCE_LENGTH - 1)
    assert len(at_limit) == MAX_SOURCE_LENGTH
    assert parse(at_limit, ["t"]) == T
    with pytest.raises(ExpressionError, match="longer than"):
        parse(at_limit + " ", ["t"])
    with pytest.raises(ExpressionError, match="longer than"):
        parse("+".join(["t"] * 2000), ["t"])


@pytest.mark.parametrize(
    "source",
    [
        "-" * (MAX_DEPTH + 5) + "t",
        "sin(" * (MAX_DEPTH + 5) + "t" + ")" * (MAX_DEPTH + 5),
        "+".join(["t"] * (MAX_DEPTH + 5)),
        "2**" * (MAX_DEPTH + 5) + "t",
        "-" * 1999 + "1",  # as deep as the length limit allows
    ],
)
def test_deep_nesting_is_rejected(source):
    with pytest.raises(ExpressionError, match="nested too deeply"):
        parse(source, ["t"])


def test_moderate_nesting_is_accepted():
    source = "sin(" * (MAX_DEPTH // 2) + "t" + ")" * (MAX_DEPTH // 2)
    expr = parse(source, ["t"])
    assert float(expr.subs(T, 0.3)) == pytest.approx(_nested_sin(0.3, MAX_DEPTH // 2), rel=1e-14)


def _nested_sin(x: float, n: int) -> float:
    for _ in range(n):
        x = math.sin(x)
    return x


def test_too_many_parentheses_is_an_expression_error():
    with pytest.raises(ExpressionError):
        parse("(" * 300 + "t" + ")" * 300, ["t"])


_TOKENS = ["t", "q1", "0", "1", "2.5", "+", "-", "*", "/", "(", ")", "sin", "abs", "sign", "sqrt", "log", "x",
           ".", "[", "]", ",", "'a'", "__class__", "lambda", ":", " if ", " else ", "=", " ", "pi", "e", "1e999",
           "True", "=="]


@settings(max_examples=300, deadline=None)
@given(st.lists(st.sampled_from(_TOKENS), max_size=14).map("".join))
@example("1/0")
@example("sqrt(-1)")
@example("log(0)")
@example("t/(1 - 1)")
def test_any_token_soup_parses_or_raises_expression_error(source):
    """Nothing but ExpressionError ever escapes. (``**`` is left out so that a regression of the power-tower
    hang cannot stall the suite; test_regression_power_tower_is_rejected_quickly covers it.)"""
    assume("**" not in source)
    try:
        expr = parse(source, ["t", "q1"])
    except ExpressionError:
        return
    assert isinstance(expr, sp.Expr)
    assert expr.free_symbols <= {symbol("t"), symbol("q1")}


@settings(max_examples=200, deadline=None)
@given(st.floats(allow_nan=False, allow_infinity=False))
def test_number_text_round_trips_exactly(x):
    assert float(parse(repr(x), ["t"])) == x
    assert float(parse(x, ["t"])) == x


# ------------------------------------------------------------------------------------ regressions


def test_regression_division_by_zero_raises_expression_error():
    """Was a bug: parse("1/0") raised a bare ZeroDivisionError from SymPy (not an ExpressionError), so a
    scenario with ``reference: [1/0, ...]`` ended in a traceback instead of a one-line error."""
    with pytest.raises(ExpressionError):
        parse("t + 1/(2 - 2)", ["t"])
    with pytest.raises(ExpressionError):
        parse("1/0", ["t"])


@pytest.mark.parametrize("source", ["log(0)", "0**-1", "sqrt(-1)", "log(-1)", "(-8)**(1/3)", "t + sqrt(-4)"])
def test_regression_infinite_or_complex_constants_are_rejected(source):
    """Was a bug: these parsed to zoo (complex infinity) or to complex numbers, which the real-numbers-only
    language must reject; later they crashed the run (KeyError 'ComplexInfinity' in lambdify, TypeError
    'complex' -> float)."""
    with pytest.raises(ExpressionError):
        parse(source, ["t"])


def _parse_in_child(source: str, results) -> None:
    try:
        parse(source, ["t"])
        results.put("accepted")
    except ExpressionError:
        results.put("ExpressionError")
    except BaseException as exc:  # noqa: BLE001 - reported to the parent
        results.put(type(exc).__name__)


def test_regression_power_tower_is_rejected_quickly():
    """Was a bug: "9**9**9**9" (ten characters) made parse spin forever inside SymPy/mpmath (9.0**387420489.0
    is already outside the double range but was only checked after the whole tree was built). Run in a
    forked child so that a hang fails the test instead of stalling the suite."""
    context = multiprocessing.get_context("fork")
    results = context.Queue()
    child = context.Process(target=_parse_in_child, args=("9**9**9**9", results))
    child.start()
    child.join(timeout=2.0)
    hung = child.is_alive()
    if hung:
        child.kill()
        child.join()
    assert not hung, "parse('9**9**9**9') did not return within 2 s"
    try:
        outcome = results.get(timeout=1.0)
    except queue.Empty:  # pragma: no cover
        outcome = "no result"
    assert outcome == "ExpressionError"


# ------------------------------------------------------------------------------------------ TimeFunctions


def _exprs(*sources):
    return [parse(s, ["t"]) for s in sources]


HAND_DERIVED = [
    (
        "1.05*cos(pi*t/6) - 1",
        lambda t: 1.05 * np.cos(np.pi * t / 6) - 1,
        lambda t: -1.05 * np.pi / 6 * np.sin(np.pi * t / 6),
        lambda t: -1.05 * (np.pi / 6) ** 2 * np.cos(np.pi * t / 6),
    ),
    ("t**3", lambda t: t**3, lambda t: 3 * t**2, lambda t: 6 * t),
    (
        "exp(-t)*sin(2*t)",
        lambda t: np.exp(-t) * np.sin(2 * t),
        lambda t: np.exp(-t) * (2 * np.cos(2 * t) - np.sin(2 * t)),
        lambda t: np.exp(-t) * (-4 * np.cos(2 * t) - 3 * np.sin(2 * t)),
    ),
    (
        "sin(pi*t/5 + pi/2) - 1",
        lambda t: np.cos(np.pi * t / 5) - 1,
        lambda t: -np.pi / 5 * np.sin(np.pi * t / 5),
        lambda t: -((np.pi / 5) ** 2) * np.cos(np.pi * t / 5),
    ),
    (
        "tanh(t - 3)",
        lambda t: np.tanh(t - 3),
        lambda t: 1 - np.tanh(t - 3) ** 2,
        lambda t: -2 * np.tanh(t - 3) * (1 - np.tanh(t - 3) ** 2),
    ),
    (
        "sqrt(t + 1)",
        lambda t: np.sqrt(t + 1),
        lambda t: 0.5 / np.sqrt(t + 1),
        lambda t: -0.25 * (t + 1) ** -1.5,
    ),
    ("log(t + 2)", lambda t: np.log(t + 2), lambda t: 1 / (t + 2), lambda t: -1 / (t + 2) ** 2),
    ("e**(t/10)", lambda t: np.exp(t / 10), lambda t: np.exp(t / 10) / 10, lambda t: np.exp(t / 10) / 100),
    (
        "tan(t/20)",
        lambda t: np.tan(t / 20),
        lambda t: 1 / (20 * np.cos(t / 20) ** 2),
        lambda t: np.tan(t / 20) / (200 * np.cos(t / 20) ** 2),
    ),
    ("-t**2/2 + 3*t", lambda t: -(t**2) / 2 + 3 * t, lambda t: -t + 3, lambda t: -np.ones_like(t)),
]


@pytest.mark.parametrize(("source", "f", "df", "ddf"), HAND_DERIVED, ids=[h[0] for h in HAND_DERIVED])
def test_time_function_derivatives_are_exact(source, f, df, ddf):
    values, first, second = TimeFunctions(_exprs(source)).evaluate(GRID)
    assert values.shape == first.shape == second.shape == (GRID.size, 1)
    np.testing.assert_allclose(values[:, 0], f(GRID), rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(first[:, 0], df(GRID), rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(second[:, 0], ddf(GRID), rtol=1e-12, atol=1e-12)


def test_time_functions_evaluate_several_columns_at_once():
    functions = TimeFunctions(_exprs("t**3", "1.05*cos(pi*t/6) - 1", "exp(-t)*sin(2*t)"))
    values, first, second = functions.evaluate(GRID)
    assert values.shape == (GRID.size, 3)
    np.testing.assert_allclose(values[:, 0], GRID**3, rtol=1e-12)
    np.testing.assert_allclose(first[:, 1], -1.05 * np.pi / 6 * np.sin(np.pi * GRID / 6), rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(second[:, 2], np.exp(-GRID) * (-4 * np.cos(2 * GRID) - 3 * np.sin(2 * GRID)),
                               rtol=1e-12, atol=1e-12)


def test_constants_are_broadcast_to_the_grid():
    functions = TimeFunctions([parse(0, ["t"]), parse("pi", ["t"]), parse(-2.5, ["t"]), parse("e**2", ["t"])])
    values, first, second = functions.evaluate(GRID)
    assert values.shape == first.shape == second.shape == (GRID.size, 4)
    for column, expected in enumerate([0.0, math.pi, -2.5, math.e**2]):
        np.testing.assert_allclose(values[:, column], expected, rtol=1e-15)
    assert np.all(first == 0.0)
    assert np.all(second == 0.0)
    assert values.dtype == first.dtype == second.dtype == np.float64


def test_time_functions_with_no_expressions():
    values, first, second = TimeFunctions([]).evaluate(GRID)
    assert values.shape == first.shape == second.shape == (GRID.size, 0)


def test_impulses_of_sign_and_abs_are_dropped():
    functions = TimeFunctions(_exprs("abs(t - 1)", "sign(t - 2)"))
    grid = np.array([0.0, 0.5, 1.0, 1.5, 2.0, 3.0])
    values, first, second = functions.evaluate(grid)
    np.testing.assert_array_equal(values[:, 0], np.abs(grid - 1))
    np.testing.assert_array_equal(first[:, 0], np.sign(grid - 1))  # sign(0) = 0 at the kink
    np.testing.assert_array_equal(second[:, 0], 0.0)
    np.testing.assert_array_equal(values[:, 1], np.sign(grid - 2))
    np.testing.assert_array_equal(first[:, 1], 0.0)
    np.testing.assert_array_equal(second[:, 1], 0.0)
    assert not any(e.has(sp.DiracDelta) for e in functions.first + functions.second)


def test_time_function_derivatives_are_symbolic():
    functions = TimeFunctions(_exprs("t**3"))
    assert not any(e.has(sp.Derivative) for e in functions.first + functions.second)
    assert float(functions.first[0].subs(T, 2)) == 12.0
    assert float(functions.second[0].subs(T, 2)) == 12.0


_coefficients = st.lists(
    st.one_of(st.integers(-1000, 1000).map(float),
              st.floats(-100, 100, allow_nan=False, allow_infinity=False, allow_subnormal=False)),
    min_size=1, max_size=7,
)


@pytest.mark.slow  # a closed-loop run of seconds
@settings(max_examples=60, deadline=None)
@given(_coefficients)
def test_polynomial_derivatives_match_numpy_polyder(coefficients):
    """coefficients are highest power first, as numpy.polyval takes them."""
    degree = len(coefficients) - 1
    source = " + ".join(f"{c!r}*t**{degree - i}" for i, c in enumerate(coefficients))
    grid = np.linspace(-2.0, 2.0, 41)
    values, first, second = TimeFunctions(_exprs(source)).evaluate(grid)
    scale = sum(abs(c) for c in coefficients) * 2.0**degree * (degree + 1) ** 2 + 1.0
    np.testing.assert_allclose(values[:, 0], np.polyval(coefficients, grid), rtol=1e-12, atol=1e-13 * scale)
    np.testing.assert_allclose(first[:, 0], np.polyval(np.polyder(coefficients), grid), rtol=1e-12,
                               atol=1e-13 * scale)
    np.testing.assert_allclose(second[:, 0], np.polyval(np.polyder(coefficients, 2), grid), rtol=1e-12,
                               atol=1e-13 * scale)


# ------------------------------------------------------------------------------------------ StateFunction


STATE_EXPRS = [
    "10*sin(q1*q2) + 3.7*cos(qd1*q2) + 5.2*cos(qd1*qd2)",
    "sign(q1)*abs(qd2) + tanh(q3) - t*exp(-qd3**2)",
    "sqrt(q1**2 + 1) * log(qd1**2 + 2) + tan(q2/4) / (1 + q3**2)",
    "pi*e - q1**3 + 1.1*qd1 + 1.2*sin(3*q1)",
    "-3.01*qd3 + 1.3*sin(q3)",
    "0",
]


def _numpy_state(t, q, qd):
    q1, q2, q3 = q
    qd1, qd2, qd3 = qd
    return [
        10 * np.sin(q1 * q2) + 3.7 * np.cos(qd1 * q2) + 5.2 * np.cos(qd1 * qd2),
        np.sign(q1) * np.abs(qd2) + np.tanh(q3) - t * np.exp(-(qd3**2)),
        np.sqrt(q1**2 + 1) * np.log(qd1**2 + 2) + np.tan(q2 / 4) / (1 + q3**2),
        np.pi * np.e - q1**3 + 1.1 * qd1 + 1.2 * np.sin(3 * q1),
        -3.01 * qd3 + 1.3 * np.sin(q3),
        0.0,
    ]


def test_state_function_matches_numpy_at_random_states():
    function = StateFunction([parse(s, STATE3) for s in STATE_EXPRS], 3)
    rng = np.random.default_rng(12345)
    for _ in range(200):
        t = rng.uniform(0, 30)
        q = rng.uniform(-3, 3, size=3)
        qd = rng.uniform(-10, 10, size=3)
        got = function(t, q.tolist(), qd.tolist())
        assert len(got) == len(STATE_EXPRS)
        np.testing.assert_allclose(got, _numpy_state(t, q, qd), rtol=1e-12, atol=1e-12)


def test_state_function_accepts_numpy_arrays_and_returns_floats():
    function = StateFunction([parse("q1 + 2*qd1 + t", ["t", "q1", "qd1"])], 1)
    out = function(0.5, np.array([1.0]), np.array([2.0]))
    assert out == [5.5]
    assert all(isinstance(v, float) for v in out)


def test_state_function_sign_of_zero_is_zero():
    function = StateFunction([parse(s, STATE3) for s in ["sign(q1)", "sign(qd2)", "sign(q3 - 1)"]], 3)
    assert function(0.0, [0.0, 5.0, 1.0], [3.0, 0.0, -1.0]) == [0.0, 0.0, 0.0]
    assert function(0.0, [-2.0, 5.0, 3.0], [3.0, 7.0, -1.0]) == [-1.0, 1.0, 1.0]
    assert function(0.0, [1e-300, 0.0, -5.0], [0.0, -1e-300, 0.0]) == [1.0, -1.0, -1.0]


def test_state_function_abs():
    function = StateFunction([parse(s, STATE3) for s in ["abs(q1)", "abs(qd1 - q2)", "abs(t)"]], 3)
    assert function(-4.0, [-2.5, 1.0, 0.0], [0.0, 0.0, 0.0]) == [2.5, 1.0, 4.0]
    assert function(0.0, [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]) == [0.0, 0.0, 0.0]


def test_state_function_constants():
    function = StateFunction([parse(0, STATE3), parse("pi", STATE3), parse(-1.5, STATE3)], 3)
    assert function(1.0, [1, 2, 3], [4, 5, 6]) == pytest.approx([0.0, math.pi, -1.5], rel=1e-15)


def test_state_function_arguments_are_in_documented_order():
    """t, q1..qn, qd1..qn: each variable picks out exactly its own argument."""
    names = state_variables(2)
    function = StateFunction([parse(name, names) for name in names], 2)
    assert function(1.0, [2.0, 3.0], [4.0, 5.0]) == [1.0, 2.0, 3.0, 4.0, 5.0]
