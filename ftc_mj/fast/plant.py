"""The plant's per-period bounds check, compiled: the accelerator of
:func:`ftc_mj.engine.plant.within` (one pass, and an early exit, where NumPy makes four temporaries)."""

from __future__ import annotations

import numba
import numpy as np

from ftc_mj.fast.kernels import WITHOUT_RUNTIME


@numba.njit(cache=True, nogil=True, **WITHOUT_RUNTIME)
def within(qpos: np.ndarray, qvel: np.ndarray, alive: np.ndarray, max_position: float, max_velocity: float) -> bool:
    """Whether every |qpos| <= max_position and every |qvel| <= max_velocity (NaN is not) in the rows still
    ``alive``."""
    for r in range(qpos.shape[0]):
        if not alive[r]:
            continue
        for j in range(qpos.shape[1]):
            if not abs(qpos[r, j]) <= max_position:
                return False
        for j in range(qvel.shape[1]):
            if not abs(qvel[r, j]) <= max_velocity:
                return False
    return True
