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

from collections.abc import Callable
from dataclasses import dataclass
from functools import partial

import numpy as np

from ftc_mj import fast
from ftc_mj.engine.plant import Plant
from ftc_mj.fast import truths as compiled
from ftc_mj.fast.kernels import bound
from ftc_mj.robot.nominal import SparseSolver, solve_sparse


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
    #: The solve of a sample k (:meth:`record`): :func:`record` on the run's buffers, or its accelerator bound
    #: to them (:func:`ftc_mj.fast.truths.record`), called with k and the fault flag.
    _solve: Callable[[int, bool], None]

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
        if fast.enabled():
            solve = bound(compiled.record, *arguments, free=(0, False))
        else:
            solve = partial(record, *arguments)
        return cls(force, None if unit else row_scale, bias, solve)

    def record(self, k: int, fault: bool) -> None:
        """At sample k's instant: M(q)^-1 (tau / c - C qd - G) of the plant for the command into the LUaF
        series' sample k (until :meth:`finish`); with ``fault``, the fault's acceleration M(q)^-1 of the fault
        torque's sample k into its own. After the period's fault torque is written and before the plant steps."""
        self._solve(k, fault)

    @staticmethod
    def finish(qdd_true: np.ndarray, luaf_true: np.ndarray) -> None:
        """After the run: ``luaf_true`` = qdd - (Psi + M^-1 tau) at every sample, from the solutions
        :meth:`record` left in it."""
        np.subtract(qdd_true, luaf_true, out=luaf_true)


def record(factor: np.ndarray, diagonal_inverse: np.ndarray, tau: np.ndarray, bias: np.ndarray,
           scale: np.ndarray, scaled: bool, force: np.ndarray, luaf_true: np.ndarray, fault_torque: np.ndarray,
           fault_acceleration: np.ndarray, rows: np.ndarray, starts: np.ndarray, addresses: np.ndarray,
           columns: np.ndarray, k: int, fault: bool) -> None:
    """The definition of :meth:`Truths.record` at sample k: force = tau / c - bias (tau - bias where c = 1),
    then M(q)^-1 of it into ``luaf_true[k]`` and, with ``fault``, of the fault torque's sample k into
    ``fault_acceleration[k]``, by MuJoCo's sparse solve (:func:`~ftc_mj.robot.nominal.solve_sparse`)."""
    if scaled:
        np.divide(tau, scale, out=force)
        force -= bias
    else:
        np.subtract(tau, bias, out=force)
    structure = (rows, starts, addresses, columns)
    solve_sparse(factor, diagonal_inverse, force, luaf_true[k], *structure)
    if fault:
        solve_sparse(factor, diagonal_inverse, fault_torque[k], fault_acceleration[k], *structure)
