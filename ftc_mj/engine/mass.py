"""Where M(x1) at every row's measured position comes from, decided once per run (:func:`mass_at_readings`):
the nominal model's implementation gives it
(:meth:`~ftc_mj.robot.nominal.batch.NominalBatch.mass_at_readings`), told whether the plant's own M(q) is M at
the readings; and the plant's M at the sample instant for the terms in acceleration space (:func:`true_mass`).
"""

from __future__ import annotations

import numpy as np

from ftc_mj.engine.plant import Plant
from ftc_mj.robot.nominal import MassAtReadings, NominalBatch


def mass_at_readings(plant: Plant, nominal: NominalBatch, nominal_scale: np.ndarray, plant_scale: np.ndarray,
                     sensor_effects: bool) -> MassAtReadings:
    """M(x1) of every row, from the run's nominal batch (made with the rows' ``mass_points``). The plant's M(q)
    is M at the readings where the nominal model is the plant's (no mass scale on either, ``nominal_scale`` and
    ``plant_scale`` per row) and the encoders read the state exactly (no sensor effects, no sensor cutoff)."""
    same_model = bool(np.all(nominal_scale == 1.0) and np.all(plant_scale == 1.0))
    exact = same_model and not sensor_effects and plant.reads_state_exactly
    return nominal.mass_at_readings(plant if exact else None)


def true_mass(mass: MassAtReadings, plant: Plant) -> np.ndarray:
    """The plant's M(q) at the sample instant, after ``mass`` evaluated this period's M: ``mass.M`` itself where
    it is the plant's (the plant has not moved since), else the plant's refreshed dense copy."""
    return mass.M if mass.from_plant else plant.mass_matrices()
