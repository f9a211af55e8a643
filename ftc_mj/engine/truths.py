"""The truths that need the plant's M(q)^-1 at each sample instant, solved each period with the plant's own
factorisation: the true LUaF, qdd - (Psi + M^-1 tau) of the nominal model at the true state, and the fault's
acceleration, M^-1 of the fault force.

At the sample instant (before the plant steps) :meth:`Truths.record` solves M_plant^-1 of the right-hand side
into the LUaF series' sample, and :meth:`Truths.fault` the fault's acceleration where a fault is on; after
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

import numpy as np

from ftc_mj.engine.plant import Plant
from ftc_mj.robot.nominal import SparseSolver


@dataclass
class Truths:
    """The buffers and solves of the per-period truths of a run's rows."""

    #: tau / c - C qd - G of the plant at the last sample, ``(rows, n)``.
    force: np.ndarray
    #: c per row, ``(rows, 1)``, or None where c = 1 for every row.
    scale: np.ndarray | None
    #: M(q)^-1 ``force`` of the plant into a sample of a series (:meth:`SparseSolver.into`).
    solve_force: Callable[[np.ndarray], None]
    #: M(q)^-1 of one sample of a series into another (:meth:`SparseSolver.between`).
    solve_sample: Callable[[np.ndarray, np.ndarray], None]

    @classmethod
    def allocate(cls, solver: SparseSolver, plant: Plant, scale: np.ndarray) -> Truths:
        """For ``plant``'s rows; ``scale``: c of each row, ``(rows,)``."""
        force = np.zeros(plant.qpos.shape)
        return cls(force, None if np.all(scale == 1.0) else scale[:, None],
                   solver.into(plant.factor, plant.diagonal_inverse, force, np.zeros_like(force)),
                   solver.between(plant.factor, plant.diagonal_inverse, force))

    def record(self, plant: Plant, tau: np.ndarray, out: np.ndarray) -> None:
        """At the sample instant: M(q)^-1 (tau / c - C qd - G) of the plant for the command ``tau`` into
        ``out`` (the LUaF series' sample, until :meth:`finish`)."""
        if self.scale is None:
            force = np.subtract(tau, plant.bias, out=self.force)
        else:
            force = np.divide(tau, self.scale, out=self.force)
            force -= plant.bias
        self.solve_force(out)

    def fault(self, fault_torque: np.ndarray, out: np.ndarray) -> None:
        """At the sample instant: the fault's acceleration M(q)^-1 ``fault_torque`` into ``out``, two samples of
        series (C-ordered ``(rows, n)`` float arrays: the solve is called past Numba's dispatcher)."""
        self.solve_sample(fault_torque, out)

    @staticmethod
    def finish(qdd_true: np.ndarray, luaf_true: np.ndarray) -> None:
        """After the run: ``luaf_true`` = qdd - (Psi + M^-1 tau) at every sample, from the solutions
        :meth:`record` left in it."""
        np.subtract(qdd_true, luaf_true, out=luaf_true)
