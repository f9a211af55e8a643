"""A state function evaluated row by row on Python floats: for a few rows much cheaper than NumPy's calls on
tiny columns (:data:`~ftc_mj.fast.crossovers.SCALAR_ROWS`), with the same bits as the definition
(:class:`~ftc_mj.config.expressions.StateFunction`'s NumPy code on whole columns).

The same SymPy code, with every power written ``_pow(base, exponent)`` and ``numpy`` replaced by
:data:`_SCALAR_NUMPY`: math's sin and cos (NumPy's float64 sine and cosine are the C library's; tested), exactly
rounded operations on Python floats, and NumPy's own ufuncs on one element for the rest (exp, log, tanh, tan,
whose C-library versions differ from NumPy's in the last bit). Where Python raises (a division by zero) the
row is evaluated by the definition, whose answer is inf or NaN.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
import sympy as sp
from sympy.printing.numpy import NumPyPrinter
from sympy.printing.precedence import precedence

from ftc_mj.config.expressions import StateFunction


def row_function(function: StateFunction) -> Callable[..., list]:
    """``function``'s expressions as code on Python floats: ``row(t, *q, *qd, *parameters)`` is one row's values."""
    return sp.lambdify(function.symbols, function.exprs, modules=[{"numpy": _SCALAR_NUMPY, "_pow": _pow}],
                       printer=_ScalarPrinter, cse=True)


def evaluate_rows(function: StateFunction, row: Callable[..., list], t: float, q: np.ndarray, qd: np.ndarray,
                  parameters: np.ndarray, out: np.ndarray) -> None:
    """Every row of ``q``, ``qd``, ``parameters`` into ``out`` by ``row`` (:func:`row_function`), one by one."""
    t = float(t)
    for index, (q_row, qd_row, p_row) in enumerate(zip(q.tolist(), qd.tolist(), parameters.tolist())):
        try:
            out[index] = row(t, *q_row, *qd_row, *p_row)
        except (ArithmeticError, ValueError):  # Python raises where NumPy gives inf or NaN: its answer
            values = function(t, q[index:index + 1].T, qd[index:index + 1].T, parameters[index:index + 1].T)
            out[index] = [np.ravel(value)[0] for value in values]


class _ScalarPrinter(NumPyPrinter):
    """NumPy's code for an expression with every power written ``_pow(base, exponent)``, so that the same code
    evaluates one row on Python floats with the functions of :data:`_SCALAR_NUMPY`."""

    def _hprint_Pow(self, expr, rational=False, sqrt="numpy.sqrt"):
        text = super()._hprint_Pow(expr, rational=rational, sqrt=sqrt)
        if "**" not in text:  # sqrt(x), 1/sqrt(x), 1/x: already calls or divisions
            return text
        precedence_ = precedence(expr)
        return f"_pow({self.parenthesize(expr.base, precedence_)}, {self.parenthesize(expr.exp, precedence_)})"


def _one_element(ufunc: Callable[..., np.ndarray]) -> Callable[..., float]:
    """``ufunc`` on a one-element array: exactly what it gives that element inside any array (NumPy's SIMD
    loops compute each element alike), where Python's math may differ in the last bit (exp, log, tanh, tan)."""
    buffers = [np.zeros(1), np.zeros(1)]

    def call(*arguments: float) -> float:
        for buffer, argument in zip(buffers, arguments):
            buffer[0] = argument
        return float(ufunc(*buffers[:len(arguments)])[0])

    return call


def _sqrt(x: float) -> float:
    return math.sqrt(x) if x >= 0.0 else math.nan  # correctly rounded, as NumPy's; NaN where NumPy gives NaN


def _sign(x: float) -> float:
    if x == 0.0:
        return 0.0  # NumPy's sign of either zero is +0
    return math.copysign(1.0, x) if x == x else x  # NaN stays NaN


class _ScalarNumPy:
    """The ``numpy`` of the row-by-row code: math's sin and cos (bit-identical to NumPy's, checked by the
    tests), exactly rounded operations as Python floats, NumPy's own ufuncs on one element for the rest."""

    sin, cos = math.sin, math.cos
    sqrt, sign = staticmethod(_sqrt), staticmethod(_sign)
    pi, e = math.pi, math.e

    def __getattr__(self, name: str) -> Callable[..., float]:
        function = _one_element(getattr(np, name))
        setattr(self, name, function)
        return function


_SCALAR_NUMPY = _ScalarNumPy()
_POW_BASE = np.zeros(1)


def _pow(base: float, exponent: float) -> float:
    """``base ** exponent`` as an array with a scalar exponent computes it, fast paths included (x * x for 2,
    sqrt for 0.5, ...): NumPy's power, not the C library's."""
    _POW_BASE[0] = base
    return float((_POW_BASE ** exponent)[0])


