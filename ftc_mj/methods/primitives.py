"""Batch-safe building blocks of the methods' laws: powers, exp, and numbers as array operands.

The engine runs ``members`` copies of a method at once, and member k of a batch must give the bits it gives
alone (the rule and its reasons: ``docs/architecture/batching.md``). NumPy's element-wise kernels (pow, exp,
log, tanh, ...; SIMD, with masked loads for the tails) compute each element from that element alone, at any
position and in any layout; what can differ between a member alone and in a batch is *which* kernel NumPy
picks, and that is decided by the operands' types and strides:

* ``power``'s loop, when it sees the exponent with stride 0, replaces pow by exact operations for the
  exponents -1, 0, 0.5, 1, 2 (1/x, 1, sqrt, x, x*x), which differ from pow in the last bit of about one value
  in twenty. A Python number is always seen with stride 0; an exponent array broadcast from fewer elements
  (one per member, ``(members, 1)``; one per joint; ``(1, 1)``) is seen so in some shapes and not in others:
  with one exponent per member, a member alone takes sqrt and the same member among five takes pow.
* the C library (``math.exp``, ``math.pow``, NumPy scalars such as ``x[0, 1] ** p``) and NumPy's array
  kernels differ in the last bit of about one value in twenty for pow, exp, tanh, expm1, log1p.

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
    key = float(value)
    found = _SCALARS.get(key)
    if found is None:
        found = np.array(key)
        found.setflags(write=False)
        _SCALARS[key] = found
    return found


def power(x: ArrayOrNumber, p: ArrayOrNumber, out: np.ndarray | None = None) -> np.ndarray:
    """x^p element-wise, with ``p`` a Python number (the same for every element) or an array of exponents.

    A number is one exponent for every element: -1, 0, 0.5, 1, 2 are computed exactly (1/x, 1, sqrt(x), x,
    x*x), every other value by pow, in every shape (it is NumPy's own ``x ** p``, without converting ``p`` on
    every call). An array is one exponent per element, always by pow (so an exponent of 0.5 in an array is
    pow's x^0.5, not sqrt: the gains a plugin receives are such arrays). An array with fewer elements than the
    result (a column, a row) is first expanded to the result's shape, so that NumPy never sees it with stride
    0 in some shapes and not in others; pass exponents of the result's shape (the engine's gains are
    ``(members, n)``, as the states are) to avoid that copy.
    """
    if isinstance(p, np.ndarray) and p.ndim:
        x_shape = np.shape(x)
        if p.shape != x_shape:
            key = (x_shape, p.shape)
            shape = _RESULT_SHAPES.get(key)
            if shape is None:
                shape = _RESULT_SHAPES[key] = np.broadcast_shapes(x_shape, p.shape)
            if p.shape != shape:
                p = np.ascontiguousarray(np.broadcast_to(p, shape))
        return np.power(x, p, out=out)
    return np.power(x, scalar(p), out=out)


def signed_power(x: np.ndarray, p: ArrayOrNumber, out: np.ndarray | None = None) -> np.ndarray:
    """|x|^p sign(x), the building block of every sliding-mode term in the dissertation; sign(0) = 0 (|0|^p = 0
    for p > 0).

    ``p`` as for :func:`power` (a number: exact for 0.5 and the other special exponents; an array: pow per
    element). The result is written into ``out`` if given (it must not be ``x``, whose signs it needs), else
    into one new array: no temporary beyond the result.
    """
    if out is x:
        raise ValueError("signed_power: out must not be x (the signs of x are read after |x|^p is written)")
    if isinstance(p, np.ndarray) and p.ndim and p.shape != np.shape(x):  # the result has another shape than x
        return np.copysign(power(np.abs(x), p), x, out=out)
    magnitude = np.abs(x, out=out)
    power(magnitude, p, out=magnitude)
    return np.copysign(magnitude, x, out=magnitude)


def exp(x: ArrayOrNumber, out: np.ndarray | None = None) -> np.ndarray:
    """e^x element-wise, by NumPy's array kernel: each element's bits depend on that element alone (in a batch
    or alone, at any position, contiguous or strided).

    Never ``math.exp`` on a member's value instead: the C library's exp differs from NumPy's in the last bit of
    about one value in twenty, so a constant computed per member in Python would not equal the one a batch
    computes as an array.
    """
    return np.exp(x, out=out)
