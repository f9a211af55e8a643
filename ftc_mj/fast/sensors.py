"""The sensor effects of one sample, compiled: the accelerator of :func:`ftc_mj.effects.sensors.measure`, in one
pass over the rows with NumPy's operations per element (the same bits)."""

from __future__ import annotations

import numba
import numpy as np

from ftc_mj.fast.kernels import WITHOUT_RUNTIME


@numba.njit(cache=True, nogil=True, **WITHOUT_RUNTIME)
def measure(source: np.ndarray, offsets: np.ndarray, offset: bool, quantise: bool, inverse_step: np.ndarray,
            step: np.ndarray, quantised: np.ndarray, stuck: np.ndarray, last: np.ndarray, out: np.ndarray) -> None:
    """:func:`ftc_mj.effects.sensors.measure`, row by row (row r is member r % members)."""
    members = offsets.shape[0]
    for r in range(out.shape[0]):
        member = r % members
        for j in range(out.shape[1]):
            value = source[r, j] + offsets[member, j] if offset else source[r, j]
            if quantise and quantised[j]:
                value = np.rint(value * inverse_step[j]) * step[j]
            if stuck[j]:
                value = last[r, j]
            out[r, j] = value
            last[r, j] = value
