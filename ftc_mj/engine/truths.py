"""The truths that need the plant's M(q)^-1 at each sample instant, solved each period with the plant's own
factorisation: the true LUaF, qdd - (Psi + M^-1 tau) of the nominal model at the true state, and the fault's
acceleration, M^-1 of the fault force.

At the sample instant (before the plant steps) :meth:`Truths.record` solves M_plant^-1 of the right-hand side
into the LUaF series' sample and, where a fault is on, the fault's acceleration, in one compiled call; after
the run :meth:`Truths.finish` subtracts each sample's solution from the true acceleration (known only once the
plant has stepped). The nominal model is the plant's with its masses, inertias and armature scaled by c =
nominal scale / plant scale, so its M and C qd + G are c times the plant's: Psi + M^-1 tau = M_plant^-1
(tau / c - C qd - G) (for c = 1 the plant's numbers themselves; otherwise equal up to rounding).

Solved per period rather than after the run, nothing of M(q) is kept per sample (a run's largest buffers
before: the factorisation of every sample and row).
"""

from __future__ import annotations

import os

os.environ.setdefault("NUMBA_DISABLE_INTEL_SVML", "1")  # before Numba is imported: ftc_mj.robot.rigid says why

from collections.abc import Callable  # noqa: E402
from dataclasses import dataclass  # noqa: E402

import numba  # noqa: E402
import numpy as np  # noqa: E402

from ftc_mj.config.kernels import WITHOUT_RUNTIME, direct  # noqa: E402
from ftc_mj.engine.plant import Plant  # noqa: E402
from ftc_mj.robot.nominal import SparseSolver  # noqa: E402
from ftc_mj.robot.rigid import solve_factored  # noqa: E402


@dataclass
class Truths:
    """The buffers and the per-period solve of the truths of a run's rows."""

    #: tau / c - C qd - G of the plant at the last sample, ``(rows, n)``.
    force: np.ndarray
    #: c per row, ``(rows, 1)``, or None where c = 1 for every row.
    scale: np.ndarray | None
    #: C qd + G of the right-hand side: the plant's ``bias`` itself, or a buffer its caller fills each period
    #: (C qd + G + F / c, with the nominal model's joint friction F, :mod:`ftc_mj.robot.friction`).
    bias: np.ndarray
    #: The solve of a sample k (:meth:`record`), past Numba's dispatcher, and its arguments after k and the
    #: fault flag.
    _solve: Callable[..., None]
    _arguments: tuple

    @classmethod
    def allocate(cls, solver: SparseSolver, plant: Plant, scale: np.ndarray, tau: np.ndarray,
                 luaf_true: np.ndarray, fault_torque: np.ndarray, fault_acceleration: np.ndarray,
                 bias: np.ndarray | None = None) -> Truths:
        """For ``plant``'s rows; ``scale``: c of each row, ``(rows,)``; ``tau``: the loop's command buffer; the
        series ``(steps, rows, n)`` the solves go to (the LUaF's, until :meth:`finish`; the fault's
        acceleration) and the one the fault torque is read from. ``bias``: a ``(rows, n)`` buffer the caller fills
        with C qd + G plus the nominal friction before each :meth:`record`; None: the plant's C qd + G."""
        force = np.zeros(plant.qpos.shape)
        unit = bool(np.all(scale == 1.0))
        row_scale = np.ascontiguousarray(scale, dtype=float)[:, None]  # not read where every c is 1
        bias = plant.bias if bias is None else bias
        arguments = (plant.factor, plant.diagonal_inverse, tau, bias, row_scale, not unit, force, luaf_true,
                     fault_torque, fault_acceleration, *solver.structure)
        return cls(force, None if unit else row_scale, bias, direct(_record, 0, False, *arguments), arguments)

    def record(self, k: int, fault: bool) -> None:
        """At sample k's instant: M(q)^-1 (tau / c - C qd - G) of the plant for the command into the LUaF
        series' sample k (until :meth:`finish`); with ``fault``, the fault's acceleration M(q)^-1 of the fault
        torque's sample k into its own. After the period's fault torque is written and before the plant steps."""
        self._solve(k, fault, *self._arguments)

    @staticmethod
    def finish(qdd_true: np.ndarray, luaf_true: np.ndarray) -> None:
        """After the run: ``luaf_true`` = qdd - (Psi + M^-1 tau) at every sample, from the solutions
        :meth:`record` left in it."""
        np.subtract(qdd_true, luaf_true, out=luaf_true)


@numba.njit(cache=True, nogil=True, fastmath=False, error_model="numpy", **WITHOUT_RUNTIME)
def _record(k, fault, factor, diagonal_inverse, tau, bias, scale, scaled, force, luaf_true,  # noqa: ANN001, ANN202
            fault_torque, fault_acceleration, rows, starts, addresses, columns):
    """:meth:`Truths.record` of sample k: force = tau / c - bias (tau - bias where c = 1: no division), each an
    IEEE operation as NumPy's; then MuJoCo's sparse solves (:func:`~ftc_mj.robot.rigid.solve_factored`)."""
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
