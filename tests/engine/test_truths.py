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
    steps, rng = 5, np.random.default_rng(3)
    tau, qdd, fault = (rng.normal(0.0, size, (steps, 2, 3)) for size in (20.0, 5.0, 10.0))
    luaf, fault_acceleration = np.zeros((steps, 2, 3)), np.zeros((steps, 2, 3))
    command = np.zeros((2, 3))
    truths = Truths.allocate(SparseSolver(model), plant, scale, command, luaf, fault, fault_acceleration)
    assert (truths.scale is None) == bool(np.all(scale == 1.0))
    masses, biases = np.zeros((steps, 2, 3, 3)), np.zeros((steps, 2, 3))
    for k in range(steps):
        plant.reset(rng.uniform(-1.0, 1.0, (2, 3)), rng.uniform(-2.0, 2.0, (2, 3)))
        command[...] = tau[k]
        truths.record(k, fault=k != 2)  # no fault at sample 2: its acceleration is not solved
        masses[k], biases[k] = plant.mass_matrices(), plant.bias
    truths.finish(qdd, luaf)
    for k in range(steps):
        for row in range(2):
            expected = qdd[k, row] - np.linalg.solve(masses[k, row], tau[k, row] / scale[row] - biases[k, row])
            np.testing.assert_allclose(luaf[k, row], expected, rtol=1e-9, atol=1e-9)
            expected = np.zeros(3) if k == 2 else np.linalg.solve(masses[k, row], fault[k, row])
            np.testing.assert_allclose(fault_acceleration[k, row], expected, rtol=1e-9, atol=1e-12)


def test_unit_scale_is_the_plants_numbers_bit_for_bit():
    """For c = 1 the force is tau - bias exactly (no division), so the truths keep the plant's bits."""
    model = mujoco.MjModel.from_xml_path(str(PUMA))
    plant = MuJoCoPlant(model, 2, substeps=1, nthread=1)
    plant.reset(np.array([[0.1, -0.2, 0.3], [0.4, 0.5, -0.5]]), np.array([[1.0, 0.0, -1.0], [0.5, 0.5, 0.5]]))
    tau, series = np.array([[1.0, 2.0, 3.0], [-1.0, 0.5, 0.25]]), np.zeros((1, 2, 3))
    truths = Truths.allocate(SparseSolver(model), plant, np.ones(2), tau, series, np.zeros((1, 2, 3)),
                             np.zeros((1, 2, 3)))
    truths.record(0, False)
    np.testing.assert_array_equal(truths.force, tau - plant.bias)


def test_the_force_is_numpys_division_and_subtraction_bit_for_bit():
    """With c != 1 the compiled force is NumPy's tau / c - bias, two roundings, bit for bit; the LUaF's sample is
    SparseSolver.solve of it."""
    model = mujoco.MjModel.from_xml_path(str(PUMA))
    plant = MuJoCoPlant(model, 3, substeps=1, nthread=1)
    rng = np.random.default_rng(11)
    plant.reset(rng.uniform(-1.0, 1.0, (3, 3)), rng.uniform(-2.0, 2.0, (3, 3)))
    scale = np.array([0.7, 1.0, 1.3])
    tau, luaf = rng.normal(0.0, 20.0, (3, 3)), np.zeros((2, 3, 3))
    truths = Truths.allocate(SparseSolver(model), plant, scale, tau, luaf, np.zeros((2, 3, 3)), np.zeros((2, 3, 3)))
    truths.record(1, False)
    expected = np.divide(tau, scale[:, None])
    expected -= plant.bias
    np.testing.assert_array_equal(truths.force, expected)
    solved = SparseSolver(model).solve(plant.factor, plant.diagonal_inverse, expected, np.zeros((3, 3)))
    np.testing.assert_array_equal(luaf[1], solved)
    assert not luaf[0].any()
