"""The fast forms of a state function (ftc_mj.fast.programs, ftc_mj.fast.rows) against its definition (the
lambdified NumPy code on whole columns): the compiled program and the row-by-row form on floats give its bits
(tolerance: none), at states that include zeros of both signs, NaN, infinities and huge numbers; a program is
refused (the definition runs) wherever an operation would round otherwise."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from ftc_mj import load_scenario
from ftc_mj import fast
from ftc_mj.config.expressions import ExpressionError, StateFunction, parse, state_variables
from ftc_mj.fast.crossovers import SCALAR_ROWS
from ftc_mj.fast.programs import MAX_STACK, Program, evaluation, program_of
from ftc_mj.fast.rows import row_function

ROOT = Path(__file__).resolve().parents[2]
N = 3
PARAMETERS = ["fault_scale", "zeta"]
NAMES = state_variables(N) + PARAMETERS
SPECIAL = np.array([0.0, -0.0, np.nan, np.inf, -np.inf, 1e300, -1e-300, 5e-324, 1e16, -3.5])


def numpy_forms(function: StateFunction, t: float, q: np.ndarray, qd: np.ndarray, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The lambdified code on whole columns, and row by row on floats where Python does not raise."""
    rows, outputs = len(q), len(function.exprs)
    columns = np.empty((rows, outputs))
    for column, values in enumerate(function.columns(t, *q.T, *qd.T, *p.T)):
        columns[:, column] = values
    by_row = columns.copy()
    row_form = row_function(function)
    for row in range(rows):
        try:
            by_row[row] = row_form(float(t), *q[row].tolist(), *qd[row].tolist(), *p[row].tolist())
        except (ArithmeticError, ValueError):  # Python raises where NumPy gives inf or NaN: the columns' answer
            pass
    return columns, by_row


def states(rng: np.random.Generator, rows: int, special: bool, n: int = N, parameters: int = 2
           ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    q, qd, p = rng.normal(0, 3, (rows, n)), rng.normal(0, 10, (rows, n)), rng.normal(0, 2, (rows, parameters))
    if special:
        for values in (q, qd, p):
            mask = rng.random(values.shape) < 0.3
            values[mask] = rng.choice(SPECIAL, mask.sum())
    return q, qd, p


def same_bits(a: np.ndarray, b: np.ndarray) -> bool:
    """Every element the same 64 bits (NaN's included, and the sign of a zero)."""
    return a.shape == b.shape and np.array_equal(np.ascontiguousarray(a).view(np.int64),
                                                 np.ascontiguousarray(b).view(np.int64))


def assert_program_matches(function: StateFunction, rng: np.random.Generator, rows_list=(1, 7, SCALAR_ROWS + 5),
                           n: int = N, parameters: int = 2) -> None:
    program = program_of(function)
    assert program is not None
    with np.errstate(all="ignore"):
        for rows in rows_list:
            for special in (False, True):
                q, qd, p = states(rng, rows, special, n, parameters)
                t = float(rng.choice([0.0, 3.7, np.inf]) if special else rng.uniform(0, 30))
                got = np.full((rows, len(function.exprs)), 7.0)
                program.evaluate(t, q, qd, p, got)
                columns, by_row = numpy_forms(function, t, q, qd, p)
                assert same_bits(got, columns), (function.exprs, rows, special)
                # The loop's form: the same buffers as a function of time, past Numba's dispatcher.
                again = np.full_like(got, 7.0)
                evaluation(function, q, qd, p, again)(t)
                assert same_bits(again, got), (function.exprs, rows, special)
                # Row by row on floats, NaN is Python's (its sign bit may differ from NumPy's): equal values.
                assert np.array_equal(got, by_row, equal_nan=True), (function.exprs, rows, special)
                finite = ~np.isnan(got)
                assert np.array_equal(np.signbit(got[finite]), np.signbit(by_row[finite]))


@pytest.mark.parametrize("path", ["scenarios/puma_fault.yaml", "scenarios/two_link_do.yaml",
                                  "scenarios/robots/panda_fault.yaml"])
def test_shipped_terms_run_as_a_program_with_numpys_bits(path: str) -> None:
    file = ROOT / path
    if not file.exists():
        pytest.skip(f"{path} is not shipped")
    scenario = load_scenario(file, duration=0.01)
    function = scenario.terms_function
    parameters = list(scenario.spec.parameters)
    assert_program_matches(StateFunction(function.exprs, scenario.n_joints, parameters), np.random.default_rng(1),
                           n=scenario.n_joints, parameters=len(parameters))


def random_expression(rng: np.random.Generator, depth: int) -> str:
    """An expression of the operations a program runs: + - * /, negation, sin, cos, sqrt, abs, sign."""
    if depth == 0 or rng.random() < 0.25:
        choice = rng.integers(3)
        if choice == 0:
            return str(rng.choice(NAMES))
        if choice == 1:
            return repr(float(np.round(rng.normal(0, 5), 3)))
        return str(rng.choice(["2", "1/3", "pi", "e", "7"]))
    kind = rng.integers(4)
    if kind == 0:
        op = rng.choice(["+", "-", "*", "/"])
        return f"({random_expression(rng, depth - 1)} {op} {random_expression(rng, depth - 1)})"
    if kind == 1:
        return f"-({random_expression(rng, depth - 1)})"
    function = rng.choice(["sin", "cos", "sqrt", "abs", "sign"])
    return f"{function}({random_expression(rng, depth - 1)})"


def test_random_expressions_run_as_programs_with_numpys_bits() -> None:
    rng = np.random.default_rng(7)
    refused = 0
    for _ in range(40):
        exprs = []
        while len(exprs) < 4:
            try:
                exprs.append(parse(random_expression(rng, 4), NAMES))
            except ExpressionError:  # e.g. sqrt of a negative literal: refused when the file loads
                continue
        function = StateFunction(exprs, N, PARAMETERS)
        if program_of(function) is None:  # a power of time alone (t**(-1.0) for 1/t): Python's pow, not NumPy's
            refused += 1
            continue
        assert_program_matches(function, rng, rows_list=(1, SCALAR_ROWS + 2))
    assert refused <= 4


def test_shared_subexpressions_and_folded_literals() -> None:
    """SymPy's common subexpressions become temporaries; 1/3 and 2**3 are Python's numbers, folded."""
    exprs = [parse(s, NAMES) for s in ["sin(q1*q2) + q1/3", "2*sin(q1*q2) - (2**3)*qd1", "q1/2", "0", "pi*zeta"]]
    function = StateFunction(exprs, N, PARAMETERS)
    assert program_of(function) is not None and program_of(function).temporaries >= 1
    assert_program_matches(function, np.random.default_rng(3))


@pytest.mark.parametrize("text", ["q1**3", "t**2", "exp(qd1)", "tanh(q2)", "tan(q3)", "log(1 + q1**2)", "sqrt(q1)**3"])
def test_operations_that_round_otherwise_keep_the_numpy_forms(text: str) -> None:
    """Powers and SIMD transcendental functions are NumPy's to compute: no program, the same values as ever."""
    function = StateFunction([parse(text, NAMES), parse("sin(q1)", NAMES)], N, PARAMETERS)
    assert program_of(function) is None
    rng = np.random.default_rng(0)
    q, qd, p = states(rng, 3, False)
    got = np.empty((3, 2))
    evaluation(function, q, qd, p, got)(1.0)  # row by row: 3 rows
    columns, _ = numpy_forms(function, 1.0, q, qd, p)
    np.testing.assert_array_equal(got, columns)


def test_a_program_deeper_than_the_bound_is_refused() -> None:
    """Each nested right operand takes a slot of the stack: beyond MAX_STACK the code is not compiled."""
    def source(levels: int) -> str:
        expression = "q1"
        for _ in range(levels):
            expression = f"(qd1 - {expression})"
        return f"def f(t, q1, q2, q3, qd1, qd2, qd3):\n    return [{expression}]\n"

    assert Program.from_source(source(MAX_STACK - 2), N, 0) is not None
    assert Program.from_source(source(MAX_STACK + 1), N, 0) is None


def test_division_by_zero_and_domain_errors_follow_numpy() -> None:
    exprs = [parse(s, NAMES) for s in ["1/q1", "q1/qd1", "sqrt(q2)", "sign(q3)", "abs(qd2)"]]
    function = StateFunction(exprs, N, PARAMETERS)
    q = np.array([[0.0, -4.0, -0.0], [-0.0, 9.0, np.nan]])
    qd = np.array([[0.0, -0.0, 1.0], [2.0, 0.0, 1.0]])
    got = np.empty((2, 5))
    with np.errstate(all="ignore"):
        program_of(function).evaluate(0.0, q, qd, np.zeros((2, 2)), got)
        columns, _ = numpy_forms(function, 0.0, q, qd, np.zeros((2, 2)))
    assert same_bits(got, columns)
    assert got[0, 0] == np.inf and got[1, 0] == -np.inf and np.isnan(got[0, 1]) and np.isnan(got[0, 2])


def test_without_the_generated_source_the_numpy_forms_run(monkeypatch: pytest.MonkeyPatch) -> None:
    """Where the lambdified code's source cannot be read back, no program: the NumPy forms, the same values."""
    import inspect

    def unavailable(_: object) -> str:
        raise OSError("could not get source code")

    monkeypatch.setattr(inspect, "getsource", unavailable)
    function = StateFunction([parse("sin(q1) + qd2", NAMES)], N, PARAMETERS)
    assert program_of(function) is None
    got = np.empty((2, 1))
    q, qd, p = states(np.random.default_rng(0), 2, False)
    function.evaluate(0.5, q, qd, p, got)
    np.testing.assert_array_equal(got[:, 0], np.sin(q[:, 0]) + qd[:, 1])
    again = np.empty((2, 1))
    evaluation(function, q, qd, p, again)(0.5)
    np.testing.assert_array_equal(again, got)


def test_with_the_fast_paths_off_the_definition_runs(monkeypatch: pytest.MonkeyPatch) -> None:
    """The switch: no program and no row form, the lambdified NumPy code on whole columns."""
    function = StateFunction([parse("sin(q1) + qd2", NAMES)], N, PARAMETERS)
    monkeypatch.setattr(fast, "_enabled", False)
    q, qd, p = states(np.random.default_rng(0), 2, False)
    calls = []
    monkeypatch.setattr(StateFunction, "evaluate", lambda self, *arguments: calls.append(arguments))
    evaluation(function, q, qd, p, np.empty((2, 1)))(0.5)
    assert len(calls) == 1
