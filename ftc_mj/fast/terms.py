"""The plant terms' sums of one period, compiled: the accelerator of :func:`ftc_mj.effects.terms.sum_terms`, in
one pass with one product and one sum per element as the definition's NumPy calls (the same bits)."""

from __future__ import annotations

import numba
import numpy as np

from ftc_mj.fast.kernels import WITHOUT_RUNTIME


@numba.njit(cache=True, nogil=True, **WITHOUT_RUNTIME)
def sum_terms(values: np.ndarray, terms: np.ndarray, slots: np.ndarray, targets: np.ndarray, factors: np.ndarray,
              weights: np.ndarray, sums: np.ndarray, k: int, block: int) -> None:
    """:func:`ftc_mj.effects.terms.sum_terms`, element by element."""
    sums[:] = 0.0
    rows, n = sums.shape[1], sums.shape[2]
    for step in range(len(terms)):
        term, slot = terms[step], slots[step]
        for r in range(rows):
            for j in range(n):
                factor = weights[slot, block, r] if slot >= 0 else factors[term, k, j]
                value = values[r, term * n + j] * factor
                for target in range(sums.shape[0]):
                    if targets[step, target]:
                        sums[target, r, j] += value
