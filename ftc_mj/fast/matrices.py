"""Row-by-row products and gathers of the nominal model's matrices, compiled: accelerators of
:func:`ftc_mj.robot.nominal.matvec` (``numpy.einsum("rij,rj->ri")``) and of ``numpy.take`` into
:class:`~ftc_mj.robot.nominal.DenseMass`.

Each call costs a quarter of NumPy's on a single run's few rows. :func:`matvec_in_pairs` sums the products of
a row as einsum's loop sums fewer than eight (two running sums), which gives einsum's bits on the CPUs where
einsum takes that loop, and agrees with it to rounding (a few ulps of the row's largest product) anywhere
(``tests/fast/test_matrices.py``). Every row is summed by the same code whatever the number of rows, so a
member of a batch gets its single run's bits.
"""

from __future__ import annotations

import numba
import numpy as np

from ftc_mj.fast.kernels import WITHOUT_RUNTIME


@numba.njit(cache=True, nogil=True, **WITHOUT_RUNTIME)
def matvec_in_pairs(matrices: np.ndarray, vectors: np.ndarray, out: np.ndarray) -> None:
    """``out[r, i] = sum_j matrices[r, i, j] vectors[r, j]``, summed as einsum's loop sums fewer than eight
    products: even and odd products in two running sums, an odd count's last product into the even one, then
    even + odd."""
    n = matrices.shape[2]
    for r in range(matrices.shape[0]):
        for i in range(matrices.shape[1]):
            even = 0.0
            odd = 0.0
            j = 0
            while j + 1 < n:
                even += matrices[r, i, j] * vectors[r, j]
                odd += matrices[r, i, j + 1] * vectors[r, j + 1]
                j += 2
            if j < n:
                even += matrices[r, i, j] * vectors[r, j]
            out[r, i] = even + odd


@numba.njit(cache=True, nogil=True, **WITHOUT_RUNTIME)
def gather(values: np.ndarray, index: np.ndarray, out: np.ndarray) -> None:
    """``out[r, e] = values[r, index[e]]``: ``values.take(index, axis=1, out=out)`` in one compiled pass."""
    for r in range(out.shape[0]):
        for e in range(out.shape[1]):
            out[r, e] = values[r, index[e]]
