"""Batch-safe building blocks of the methods' laws: powers, exp, and numbers as array operands.

The engine runs ``members`` copies of a method at once, and member k of a batch must give the bits it gives
alone (the rule and its reasons: ``docs/explanation/batching.md``). NumPy's element-wise kernels (pow, exp,
log, tanh, ...; SIMD, with masked loads for the tails) compute each element from that element alone, at any
position and in any layout; what can differ between a member alone and in a batch is *which* kernel NumPy
picks, and that is decided by the operands' types and strides:

* ``power``'s loop, when it sees the exponent with stride 0, replaces pow by exact operations for the
  exponents -1, 0, 0.5, 1, 2 (1/x, 1, sqrt, x, x*x), which differ from pow in the last bit for some values.
  A Python number is always seen with stride 0; an exponent array broadcast from fewer elements
  (one per member, ``(members, 1)``; one per joint; ``(1, 1)``) is seen so in some shapes and not in others:
  with one exponent per member, a member alone takes sqrt and the same member among five takes pow.
* the C library (``math.exp``, ``math.pow``, NumPy scalars such as ``x[0, 1] ** p``) and NumPy's array
  kernels differ in the last bit for some values of pow, exp, tanh, expm1, log1p;
* a one-element array raised in place is seen with stride 0 by ``power``'s loop, as a number is.

These functions take each case one way whatever the shapes, and avoid NumPy's conversion of a Python number
on every call (a per-step cost) by keeping the number as a cached 0-d array, which NumPy treats exactly as the
number.
"""

from __future__ import annotations

import numpy as np

#: Python numbers already made 0-d arrays (exponents, the period), by value.
_SCALARS: dict[float, np.ndarray] = {}
#: The result shape of x ** p for array shapes that differ, by (x's shape, p's shape).
_RESULT_SHAPES: dict[tuple[tuple[int, ...], tuple[int, ...]], tuple[int, ...]] = {}

ArrayOrNumber = np.ndarray | float


def scalar(value: float) -> np.ndarray:
    """``value`` as a read-only 0-d float64 array, the same one for the same value.

    NumPy treats a 0-d array as the number it holds (same kernels, same bits: a product ``scalar(dt) * x`` is
    ``dt * x`` bit for bit, and ``power(x, 0.5)`` still takes the exact sqrt), but does not convert it on every
    operation as it converts a Python float. It is still a number for Python: ``float()``, ``math``,
    comparisons and formatting work on it.
    """
    try:
        return _SCALARS[value]
    except KeyError:
        found = np.array(float(value))
        found.setflags(write=False)
        if value != value or value == 0:  # NaN is no key, and -0.0 would find 0.0: made afresh each time
            return found
        return _SCALARS.setdefault(value, found)
    except TypeError:  # unhashable: a 0-d array
        return scalar(float(value))


def _operand(x: ArrayOrNumber, exponent: ArrayOrNumber) -> np.ndarray:
    """``exponent`` as :func:`power` hands it to NumPy: a number as its 0-d array, an array of exponents with
    the result's full shape."""
    if not isinstance(exponent, np.ndarray) or not exponent.ndim:
        return scalar(exponent)
    x_shape = np.shape(x)
    if exponent.shape != x_shape:
        key = (x_shape, exponent.shape)
        shape = _RESULT_SHAPES.get(key)
        if shape is None:
            shape = _RESULT_SHAPES[key] = np.broadcast_shapes(x_shape, exponent.shape)
        if exponent.shape != shape:
            return np.ascontiguousarray(np.broadcast_to(exponent, shape))
    return exponent


def power(x: ArrayOrNumber, exponent: ArrayOrNumber, out: np.ndarray | None = None) -> np.ndarray:
    r""":math:`x^p` element-wise, with the exponent p a Python number (the same for every element) or an array.

    A number is one exponent for every element: -1, 0, 0.5, 1, 2 are computed exactly (``1/x``, ``1``,
    ``sqrt(x)``, ``x``, ``x*x``), every other value by pow, in every shape (it is NumPy's own ``x ** p``,
    without converting ``p`` on every call). An array is one exponent per element, always by pow (so an
    exponent of 0.5 in an array is pow's :math:`x^{0.5}`, not sqrt: the gains a plugin receives are such
    arrays). An array with fewer elements than the
    result (a column, a row) is first expanded to the result's shape, so that NumPy never sees it with stride
    0 in some shapes and not in others; pass exponents of the result's shape (the engine's gains are
    ``(members, n)``, as the states are) to avoid that copy. In place (``out`` is ``x``) with an array exponent
    the result is computed apart and copied: NumPy's in-place loop over one element sees the exponent with
    stride 0.
    """
    if type(exponent) is np.ndarray and type(x) is np.ndarray and x.ndim and exponent.shape == x.shape:
        # The engine's gains: one exponent per element, pow for each (the cheapest test first).
        if out is x:
            out[...] = np.power(x, exponent)
            return out
        return np.power(x, exponent, out)
    operand = _SCALARS.get(exponent) if isinstance(exponent, float) else None  # a number, without a call
    if operand is None:
        operand = _operand(x, exponent)
        if operand.ndim and out is x:
            out[...] = np.power(x, operand)
            return out
    return np.power(x, operand, out)


def signed_power(x: ArrayOrNumber, exponent: ArrayOrNumber, out: np.ndarray | None = None) -> np.ndarray:
    r""":math:`|x|^p \operatorname{sign}(x)`, the building block of every sliding-mode term in the dissertation
    (e.g. the TOSMO's :math:`k_1 |\tilde x_1|^{2/3} \operatorname{sign}(\tilde x_1)`, eq. (5.6));
    :math:`\operatorname{sign}(0) = 0` (:math:`|0|^p = 0` for :math:`p > 0`).

    The exponent p as for :func:`power` (a number: exact for 0.5 and the other special exponents; an array:
    pow per element). The result is written into ``out`` if given (it must not be ``x``, whose signs it
    needs), else into a new array. With a number no temporary is made beyond the result (:math:`|x|` is raised
    in place); with an array exponent :math:`|x|` is one temporary, since NumPy's in-place loop over a single
    element sees the exponent with stride 0 (and would take sqrt for 0.5 where a batch takes pow).
    """
    if out is x:
        raise ValueError("signed_power: out must not be x (the signs of x are read after |x|^p is written)")
    if type(exponent) is np.ndarray and type(x) is np.ndarray and x.ndim and exponent.shape == x.shape:
        # The engine's gains: |x| apart (see above), pow per element into the result (the cheapest test first).
        result = np.power(np.abs(x), exponent, out)
        return np.copysign(result, x, result)
    operand = _SCALARS.get(exponent) if isinstance(exponent, float) else None  # a number, without a call
    if operand is None:
        operand = _operand(x, exponent)
    if operand.ndim or not isinstance(x, np.ndarray) or not x.ndim:
        # An array exponent, or a number x: |x| apart, the power into the result.
        result = np.power(np.abs(x), operand, out)
        return np.copysign(result, x, result) if isinstance(result, np.ndarray) else np.copysign(result, x)
    magnitude = np.abs(x, out)
    np.power(magnitude, operand, magnitude)
    return np.copysign(magnitude, x, magnitude)


def exp(x: ArrayOrNumber, out: np.ndarray | None = None) -> np.ndarray:
    r""":math:`e^x` element-wise, by NumPy's array kernel: each element's bits depend on that element alone (in a batch
    or alone, at any position, contiguous or strided).

    Never ``math.exp`` on a member's value instead: the C library's exp differs from NumPy's in the last bit
    for some values, so a constant computed per member in Python would not equal the one a batch computes as
    an array.
    """
    return np.exp(x, out=out)
