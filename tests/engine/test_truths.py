"""The truths solved at each sample instant (ftc_mj.engine.truths.Truths): qdd - M^-1 (tau / c - C qd - G) and
M^-1 of the fault torque, against dense NumPy solves of the plant's own M(q)."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest

from ftc_mj.engine.plant import MuJoCoPlant
from ftc_mj.engine.truths import Truths
from ftc_mj.robot.nominal import SparseSolver

PUMA = Path(__file__).resolve().parents[2] / "models" / "puma560.xml"


@pytest.mark.parametrize("scale", [np.array([1.0, 1.0]), np.array([1.0, 0.8]), np.array([1.25, 0.8])])
def test_truths_are_the_dense_solves_of_the_plant(scale):
    """luaf = qdd - M^-1 (tau / c - bias) at every sample (each row its own c: a c of 1 on one row and not on
    the other must not be taken for 1 everywhere); the fault's acceleration M^-1 f at each sample solved."""
    model = mujoco.MjModel.from_xml_path(str(PUMA))
    plant = MuJoCoPlant(model, 2, substeps=1, nthread=1)
    truths = Truths.allocate(SparseSolver(model), plant, scale)
    assert (truths.scale is None) == bool(np.all(scale == 1.0))
    steps, rng = 5, np.random.default_rng(3)
    tau, qdd, fault = (rng.normal(0.0, size, (steps, 2, 3)) for size in (20.0, 5.0, 10.0))
    luaf, fault_acceleration = np.zeros((steps, 2, 3)), np.zeros((steps, 2, 3))
    masses, biases = np.zeros((steps, 2, 3, 3)), np.zeros((steps, 2, 3))
    for k in range(steps):
        plant.reset(rng.uniform(-1.0, 1.0, (2, 3)), rng.uniform(-2.0, 2.0, (2, 3)))
        truths.record(plant, tau[k], luaf[k])
        truths.fault(fault[k], fault_acceleration[k])
        masses[k], biases[k] = plant.mass_matrices(), plant.bias
    truths.finish(qdd, luaf)
    for k in range(steps):
        for row in range(2):
            expected = qdd[k, row] - np.linalg.solve(masses[k, row], tau[k, row] / scale[row] - biases[k, row])
            np.testing.assert_allclose(luaf[k, row], expected, rtol=1e-9, atol=1e-9)
            np.testing.assert_allclose(fault_acceleration[k, row], np.linalg.solve(masses[k, row], fault[k, row]),
                                       rtol=1e-9, atol=1e-12)


def test_unit_scale_is_the_plants_numbers_bit_for_bit():
    """For c = 1 the force is tau - bias exactly (no division), so the truths keep the plant's bits."""
    model = mujoco.MjModel.from_xml_path(str(PUMA))
    plant = MuJoCoPlant(model, 2, substeps=1, nthread=1)
    plant.reset(np.array([[0.1, -0.2, 0.3], [0.4, 0.5, -0.5]]), np.array([[1.0, 0.0, -1.0], [0.5, 0.5, 0.5]]))
    truths = Truths.allocate(SparseSolver(model), plant, np.ones(2))
    tau, out = np.array([[1.0, 2.0, 3.0], [-1.0, 0.5, 0.25]]), np.zeros((2, 3))
    truths.record(plant, tau, out)
    np.testing.assert_array_equal(truths.force, tau - plant.bias)
