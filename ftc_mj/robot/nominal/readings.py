"""M(x1) at the readings, as the nominal model's implementations give it
(:meth:`~ftc_mj.robot.nominal.batch.NominalBatch.mass_at_readings`): the plant's own M(q) (:class:`PlantMass`),
M-only points of the nominal batch itself, evaluated in its call (:class:`MassPoints`), or a mass-only batch of
their own (:class:`MassBatch`)."""

from __future__ import annotations

import mujoco
import numpy as np

from ftc_mj.robot.nominal.batch import NominalBatch, PlantMassSource, at_rest
from ftc_mj.robot.nominal.matrices import DenseMass


class PlantMass:
    """M(x1) is the plant's M(q): the readings are the true positions and the models are the same. The
    factorisation is copied out of the plant each period (the methods never see a view of the plant's state)."""

    from_plant = True

    def __init__(self, plant: PlantMassSource):
        self._plant = plant
        self.M = plant.mass_matrices()  # the plant's dense copy, refreshed by each mass_matrices() call
        self.factor, self.diagonal_inverse = plant.factor.copy(), plant.diagonal_inverse.copy()

    def prepare(self, q_meas: np.ndarray, stopped: np.ndarray | None) -> None:
        """Nothing: the readings are the plant's state."""

    def evaluate(self) -> None:
        self._plant.mass_matrices()
        self.factor[...] = self._plant.factor
        self.diagonal_inverse[...] = self._plant.diagonal_inverse


class MassPoints:
    """M(x1) as M-only points of a nominal batch (views of its arrays), evaluated by the batch's own
    :meth:`~NominalBatch.evaluate`: one call a period for Psi and M."""

    from_plant = False

    def __init__(self, qpos: np.ndarray, qvel: np.ndarray, applied: np.ndarray, sparse_M: np.ndarray,
                 factor: np.ndarray, diagonal_inverse: np.ndarray, model: mujoco.MjModel):
        self.qpos, self.qvel, self.applied = qpos, qvel, applied
        self.factor, self.diagonal_inverse = factor, diagonal_inverse
        self._sparse_M = sparse_M
        self._dense = DenseMass(model, len(qpos))
        self.M = self._dense.out

    def prepare(self, q_meas: np.ndarray, stopped: np.ndarray | None) -> None:
        self.qpos[...] = q_meas
        if stopped is not None:  # they may hold NaN or inf
            at_rest(self, stopped)

    def evaluate(self) -> None:
        """The dense M from the batch's last evaluation (which evaluated the points)."""
        self._dense.update(self._sparse_M)


class MassBatch:
    """M(x1) evaluated by a mass-only nominal batch of its own, one point per row, after the Psi batch."""

    from_plant = False

    def __init__(self, batch: NominalBatch):
        self._batch = batch
        self.M, self.factor, self.diagonal_inverse = batch.mass_matrices(), batch.factor, batch.diagonal_inverse

    def prepare(self, q_meas: np.ndarray, stopped: np.ndarray | None) -> None:
        batch = self._batch
        batch.qpos[...] = q_meas
        if stopped is not None:  # they may hold NaN or inf
            at_rest(batch, stopped)

    def evaluate(self) -> None:
        self._batch.evaluate()
        self._batch.mass_matrices()
