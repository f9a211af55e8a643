"""The truths' per-period solve, compiled: the accelerator of :meth:`ftc_mj.engine.truths.Truths.record`'s
NumPy definition (:func:`ftc_mj.engine.truths.record`), with its operations in its order: the same bits."""

from __future__ import annotations

import numba

from ftc_mj.fast.kernels import WITHOUT_RUNTIME
from ftc_mj.fast.rigid import solve_factored


@numba.njit(cache=True, nogil=True, fastmath=False, error_model="numpy", **WITHOUT_RUNTIME)
def record(factor, diagonal_inverse, tau, bias, scale, scaled, force, luaf_true,  # noqa: ANN001, ANN201
           fault_torque, fault_acceleration, rows, starts, addresses, columns, k, fault):
    """Sample k: force = tau / c - bias (tau - bias where c = 1: no division), each an IEEE operation as
    NumPy's; then MuJoCo's sparse solves (:func:`~ftc_mj.fast.rigid.solve_factored`) into ``luaf_true[k]`` and,
    with ``fault``, of the fault torque's sample k into ``fault_acceleration[k]``."""
    for r in range(force.shape[0]):
        for j in range(force.shape[1]):
            if scaled:
                force[r, j] = tau[r, j] / scale[r, 0] - bias[r, j]
            else:
                force[r, j] = tau[r, j] - bias[r, j]
    solve_factored(factor, diagonal_inverse, force, luaf_true[k], rows, starts, addresses, columns)
    if fault:
        solve_factored(factor, diagonal_inverse, fault_torque[k], fault_acceleration[k], rows, starts, addresses,
                       columns)
