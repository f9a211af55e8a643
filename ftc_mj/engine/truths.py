"""The truths that need the plant's M(q)^-1 at each sample instant, solved after the run over every sample at
once: the true LUaF, qdd - (Psi + M^-1 tau) of the nominal model at the true state, and the fault's
acceleration, M^-1 of the fault force.

Each period keeps the plant's factorisation of M(q) and the right-hand side (:meth:`Truths.record`). The
nominal model is the plant's with its masses, inertias and armature scaled by c = nominal scale / plant scale,
so its M and C qd + G are c times the plant's: Psi + M^-1 tau = M_plant^-1 (tau / c - C qd - G) (for c = 1 the
plant's numbers themselves; otherwise equal up to rounding).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ftc_mj.engine.plant import Plant
from ftc_mj.robot.nominal import SparseSolver

#: Samples whose truths are solved together after the run (bounds the temporary arrays).
TRUTH_CHUNK = 2048


@dataclass
class Truths:
    """What each sample keeps for the truths, ``(steps, rows, ...)``."""

    #: The plant's factorisation of M(q) (``qLD``, ``qLDiagInv``).
    factor: np.ndarray
    diagonal_inverse: np.ndarray
    #: tau / c - C qd - G of the plant.
    force: np.ndarray
    #: c per row, ``(rows, 1)``, or None where c = 1 for every row.
    scale: np.ndarray | None

    @classmethod
    def allocate(cls, steps: int, plant: Plant, scale: np.ndarray) -> Truths:
        """Buffers for ``steps`` samples of ``plant``'s rows; ``scale``: c of each row, ``(rows,)``."""
        rows, n = plant.qpos.shape
        return cls(np.zeros((steps, rows) + plant.factor.shape[1:]), np.zeros((steps, rows, n)),
                   np.zeros((steps, rows, n)), None if np.all(scale == 1.0) else scale[:, None])

    def record(self, k: int, plant: Plant, tau: np.ndarray) -> None:
        """Sample k: the plant's M(q) and tau / c - C qd - G for the command ``tau``."""
        self.factor[k] = plant.factor
        self.diagonal_inverse[k] = plant.diagonal_inverse
        if self.scale is None:
            np.subtract(tau, plant.bias, out=self.force[k])
        else:
            force = np.divide(tau, self.scale, out=self.force[k])
            force -= plant.bias

    def solve(self, solver: SparseSolver, qdd_true: np.ndarray, fault_torque: np.ndarray, fault_on: list[bool],
              luaf_true: np.ndarray, fault_acceleration: np.ndarray) -> None:
        """``luaf_true`` = qdd - (Psi + M^-1 tau) at every sample, and ``fault_acceleration`` = M^-1 fault
        torque at the samples where a fault is on (left as they are elsewhere: zero). The same operations as
        ``mj_solveM`` per sample (:class:`~ftc_mj.robot.nominal.SparseSolver`), in chunks of samples."""
        steps = len(self.force)
        for start in range(0, steps, TRUTH_CHUNK):
            samples = slice(start, min(start + TRUTH_CHUNK, steps))
            acceleration = self._solve(solver, samples, self.force[samples])
            np.subtract(qdd_true[samples], acceleration, out=luaf_true[samples])
        fault_samples = np.flatnonzero(fault_on)
        for start in range(0, len(fault_samples), TRUTH_CHUNK):
            samples = fault_samples[start:start + TRUTH_CHUNK]
            fault_acceleration[samples] = self._solve(solver, samples, fault_torque[samples])

    def _solve(self, solver: SparseSolver, samples: slice | np.ndarray, vector: np.ndarray) -> np.ndarray:
        """M^-1 vector for the ``(samples, rows, n)`` vectors, every (sample, row) at once."""
        factor, diagonal_inverse = self.factor[samples], self.diagonal_inverse[samples]
        rows = factor.shape[0] * factor.shape[1]
        return solver.solve(factor.reshape(rows, -1), diagonal_inverse.reshape(rows, -1), vector.reshape(rows, -1),
                            np.empty((rows, vector.shape[-1]))).reshape(vector.shape)
