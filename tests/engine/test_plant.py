"""The simulated robots (ftc_mj.engine.plant.MuJoCoPlant) through the Plant protocol the loop uses."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np

from ftc_mj.engine.plant import MuJoCoPlant

PUMA = Path(__file__).resolve().parents[2] / "models" / "puma560.xml"


def test_reset_starts_every_row_again_at_its_initial_state():
    """After a run in which a row diverged, reset puts every row back at its initial state, running, with its
    readings current, and the next period repeats the first one bit for bit."""
    model = mujoco.MjModel.from_xml_path(str(PUMA))
    q0, qd0 = np.array([[0.1, -0.2, 0.3], [0.0, 0.5, -0.5]]), np.zeros((2, 3))
    plant = MuJoCoPlant(model, 2, substeps=2, nthread=1, max_velocity=50.0)
    plant.reset(q0, qd0)
    readings, first = np.zeros((2, 3)), np.zeros((2, 3))
    plant.read_positions(readings)
    np.testing.assert_array_equal(readings, q0)
    plant.step(first)
    plant.ctrl[1] = 1e6  # row 1 leaves the plausible range
    for _ in range(20):
        plant.step(np.zeros((2, 3)))
        plant.check()
    assert plant.running == 1 and not plant.alive[1]
    plant.ctrl[:] = 0.0
    plant.reset(q0, qd0)
    assert plant.running == 2 and plant.alive.all()
    plant.read_positions(readings)
    np.testing.assert_array_equal(readings, q0)
    again = np.zeros((2, 3))
    assert plant.step(again) is None
    np.testing.assert_array_equal(again, first)
