"""The truths solved after the run (ftc_mj.engine.truths.Truths): qdd - M^-1 (tau / c - C qd - G) and
M^-1 of the fault torque at the faulty samples, against dense NumPy solves of the plant's own M(q)."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest

from ftc_mj.engine import truths as truths_module
from ftc_mj.engine.plant import MuJoCoPlant
from ftc_mj.engine.truths import Truths
from ftc_mj.robot.nominal import SparseSolver

PUMA = Path(__file__).resolve().parents[2] / "models" / "puma560.xml"


def _record(scale: np.ndarray, steps: int = 5):
    """A Puma plant of two rows recorded at ``steps`` different states; the dense M and bias of each sample."""
    model = mujoco.MjModel.from_xml_path(str(PUMA))
    plant = MuJoCoPlant(model, 2, substeps=1, nthread=1)
    truths = Truths.allocate(steps, plant, scale)
    rng = np.random.default_rng(3)
    tau = rng.normal(0.0, 20.0, (steps, 2, 3))
    masses, biases = np.zeros((steps, 2, 3, 3)), np.zeros((steps, 2, 3))
    for k in range(steps):
        plant.reset(rng.uniform(-1.0, 1.0, (2, 3)), rng.uniform(-2.0, 2.0, (2, 3)))
        truths.record(k, plant, tau[k])
        masses[k], biases[k] = plant.mass_matrices(), plant.bias
    return model, truths, tau, masses, biases, rng


@pytest.mark.parametrize("scale", [np.array([1.0, 1.0]), np.array([1.0, 0.8]), np.array([1.25, 0.8])])
@pytest.mark.parametrize("chunk", [truths_module.TRUTH_CHUNK, 2])
def test_truths_are_the_dense_solves_of_the_plant(monkeypatch, scale, chunk):
    """luaf = qdd - M^-1 (tau / c - bias) at every sample (each row its own c: a c of 1 on one row and not
    on the other must not be taken for 1 everywhere); the fault's acceleration M^-1 f only where a fault is on,
    zero elsewhere; chunks of 2 samples (every boundary, a last partial chunk) give the same numbers."""
    monkeypatch.setattr(truths_module, "TRUTH_CHUNK", chunk)
    steps = 5
    model, truths, tau, masses, biases, rng = _record(scale, steps)
    assert (truths.scale is None) == bool(np.all(scale == 1.0))
    qdd = rng.normal(0.0, 5.0, (steps, 2, 3))
    fault = rng.normal(0.0, 10.0, (steps, 2, 3))
    fault_on = [False, True, True, False, True]
    luaf, fault_acceleration = np.zeros((steps, 2, 3)), np.zeros((steps, 2, 3))
    truths.solve(SparseSolver(model), qdd, fault, fault_on, luaf, fault_acceleration)
    for k in range(steps):
        for row in range(2):
            expected = qdd[k, row] - np.linalg.solve(masses[k, row], tau[k, row] / scale[row] - biases[k, row])
            np.testing.assert_allclose(luaf[k, row], expected, rtol=1e-9, atol=1e-9)
            if fault_on[k]:
                np.testing.assert_allclose(fault_acceleration[k, row], np.linalg.solve(masses[k, row], fault[k, row]),
                                           rtol=1e-9, atol=1e-12)
            else:
                np.testing.assert_array_equal(fault_acceleration[k, row], 0.0)


def test_unit_scale_is_the_plants_numbers_bit_for_bit():
    """For c = 1 the force is tau - bias exactly (no division), so the truths keep the plant's bits."""
    _, truths, tau, _, biases, _ = _record(np.array([1.0, 1.0]), steps=3)
    np.testing.assert_array_equal(truths.force, tau - biases)
