"""M(x1) at every row's measured position, the M of the period's :class:`~ftc_mj.robot.nominal.StepModel`, and
where it comes from, decided once per run (:func:`mass_at_readings`).

Where the nominal model may take M from a plant of the same model (MuJoCo evaluates it:
:attr:`~ftc_mj.robot.nominal.NominalBatch.mass_from_plant`), the nominal model is the plant's (no mass scale
on either) and the encoders read the state exactly (no sensor effects, no sensor cutoff), M at the measured
position is the plant's own M(q) and its factorisation, bit for bit, at no extra evaluation
(:class:`PlantMass`). Otherwise the nominal model evaluates M at the readings, one point per row, without the
velocity terms: the compiled model in the same call as its Psi points (:class:`SharedMass`: one kernel call
a period, not two), MuJoCo's in a batch of its own (:class:`NominalMass`).

Each period the loop calls :meth:`~MassAtReadings.prepare` with the readings before the nominal model is
evaluated and :meth:`~MassAtReadings.evaluate` after.
"""

from __future__ import annotations

from typing import Protocol

import mujoco
import numpy as np

from ftc_mj.engine.plant import Plant
from ftc_mj.robot.nominal import MassPoints, NominalBatch, at_rest, nominal_batch


class MassAtReadings(Protocol):
    """M(x1) of every row, ``(rows, n, n)``, and its factorisation in MuJoCo's sparse layout: buffers that
    :meth:`evaluate` refreshes once per period."""

    M: np.ndarray
    factor: np.ndarray
    diagonal_inverse: np.ndarray

    def prepare(self, q_meas: np.ndarray, stopped: np.ndarray | None) -> None:
        """Take the readings ``q_meas`` ``(rows, n)``; the ``stopped`` rows (indices or a mask, or None) at rest
        instead. Before the nominal model is evaluated."""

    def evaluate(self) -> None:
        """M at the readings taken: after the nominal model is evaluated."""

    def true_mass(self) -> np.ndarray:
        """The plant's M(q) at the sample instant (for the terms in acceleration space), after :meth:`evaluate`."""


class PlantMass(MassAtReadings):
    """M(x1) is the plant's M(q): the readings are the true positions and the models are the same. The
    factorisation is copied out of the plant each period (the methods never see a view of the plant's state)."""

    def __init__(self, plant: Plant):
        self._plant = plant
        self.M = plant.mass_matrices()  # the plant's dense copy, refreshed by each mass_matrices() call
        self.factor, self.diagonal_inverse = plant.factor.copy(), plant.diagonal_inverse.copy()

    def prepare(self, q_meas: np.ndarray, stopped: np.ndarray | None) -> None:
        """Nothing: the readings are the plant's state."""

    def evaluate(self) -> None:
        self._plant.mass_matrices()
        self.factor[...] = self._plant.factor
        self.diagonal_inverse[...] = self._plant.diagonal_inverse

    def true_mass(self) -> np.ndarray:
        return self.M  # this period's, and the plant has not moved since


class NominalMass(MassAtReadings):
    """M(x1) evaluated by the nominal model at the readings, one point per row."""

    def __init__(self, batch: NominalBatch, plant: Plant):
        self._batch, self._plant = batch, plant
        self.M, self.factor, self.diagonal_inverse = batch.mass_matrices(), batch.factor, batch.diagonal_inverse

    def prepare(self, q_meas: np.ndarray, stopped: np.ndarray | None) -> None:
        batch = self._batch
        batch.qpos[...] = q_meas
        if stopped is not None:  # they may hold NaN or inf
            at_rest(batch, stopped)

    def evaluate(self) -> None:
        self._batch.evaluate()
        self._batch.mass_matrices()

    def true_mass(self) -> np.ndarray:
        return self._plant.mass_matrices()


class SharedMass(NominalMass):
    """M(x1) at the readings as the M-only points of the nominal batch itself (``at_readings``): evaluated in
    the same kernel call as the Psi points."""

    def __init__(self, points: MassPoints, plant: Plant):
        self._batch, self._plant = points, plant
        self.M, self.factor, self.diagonal_inverse = points.mass_matrices(), points.factor, points.diagonal_inverse

    def evaluate(self) -> None:
        self._batch.mass_matrices()  # the points were evaluated with the nominal batch


def mass_at_readings(plant: Plant, nominal: NominalBatch, model: mujoco.MjModel, nominal_scale: np.ndarray,
                     plant_scale: np.ndarray, sensor_effects: bool, nthread: int) -> MassAtReadings:
    """Where M(x1) comes from (the module docstring): the plant's or the nominal model's (a batch of ``model``
    with the rows' ``nominal_scale``). ``nominal``: the run's Psi batch, which answers whether the nominal
    model's M may be the plant's; ``sensor_effects``: whether the encoders' readings are corrupted."""
    if nominal.at_readings is not None:  # the compiled model was built with the readings' points
        return SharedMass(nominal.at_readings, plant)
    same_model = bool(np.all(nominal_scale == 1.0) and np.all(plant_scale == 1.0))
    if nominal.mass_from_plant and same_model and not sensor_effects and plant.reads_state_exactly:
        return PlantMass(plant)
    return NominalMass(nominal_batch(model, nominal_scale, nthread, mass_only=True), plant)
