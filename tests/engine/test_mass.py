"""Where M(x1) at the readings comes from (ftc_mj.engine.mass): the nominal model's implementation gives it
(ftc_mj.robot.nominal's mass_at_readings), told whether the plant's own M(q) is M at the readings."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest

import ftc_mj.robot.nominal as nominal_module
from ftc_mj.engine.mass import mass_at_readings, true_mass
from ftc_mj.engine.plant import MuJoCoPlant
from ftc_mj.robot.nominal import MassAtReadings, MassBatch, MassPoints, PlantMass, nominal_batch

PUMA = Path(__file__).resolve().parents[2] / "models" / "puma560.xml"
ONES = np.ones(2)


@pytest.fixture()
def plant() -> MuJoCoPlant:
    plant = MuJoCoPlant(plant_model(), 2, substeps=1, nthread=1)
    plant.reset(np.array([[0.1, -0.2, 0.3], [0.4, 0.5, -0.5]]), np.zeros((2, 3)))
    return plant


def plant_model() -> mujoco.MjModel:
    return mujoco.MjModel.from_xml_path(str(PUMA))


def choose(plant: MuJoCoPlant, nominal_scale: np.ndarray = ONES, plant_scale: np.ndarray = ONES,
           sensor_effects: bool = False):
    """The nominal batch of a run on ``plant`` (two rows, as the loop builds it: with the rows' mass points)
    with these mass scales per row, and its M source."""
    psi = nominal_batch(plant_model(), nominal_scale, nthread=1, mass_points=nominal_scale)
    return psi, mass_at_readings(plant, psi, nominal_scale, plant_scale, sensor_effects)


def evaluate(mass: MassAtReadings, readings: np.ndarray, stopped: np.ndarray | None, psi) -> None:
    """One period's M at the readings, as the loop runs it."""
    mass.prepare(readings, stopped)
    psi.evaluate()
    mass.evaluate()


def test_the_rigid_body_algorithms_evaluate_their_own_M_in_the_batchs_call(plant):
    """The rigid-body algorithms (compiled or not) round otherwise than MuJoCo: M at the readings is always
    the batch's own M-only points, whatever the plant; a batch made without the rows' points has none."""
    for arguments in ({}, {"nominal_scale": np.array([1.0, 1.2])}, {"sensor_effects": True}):
        assert isinstance(choose(plant, **arguments)[1], MassPoints)
    with pytest.raises(ValueError, match="mass_points"):
        nominal_batch(plant_model(), ONES, nthread=1).mass_at_readings(None)


def test_mujoco_evaluating_the_plants_own_model_at_exact_readings_takes_the_plants_M(plant, monkeypatch):
    """Where MuJoCo evaluates the nominal model (here forced: the rigid-body algorithms decline), M at the
    readings is the plant's M(q) itself, unless a mass scale or a sensor effect makes the two differ: then a
    mass-only MuJoCo batch of the rows."""
    monkeypatch.setattr(nominal_module.RigidTree, "from_model", classmethod(lambda cls, model: None))
    psi, mass = choose(plant)
    assert isinstance(mass, PlantMass) and mass.from_plant
    evaluate(mass, plant.qpos, None, psi)
    assert mass.M is plant.mass_matrices() and true_mass(mass, plant) is mass.M
    assert np.array_equal(mass.factor, plant.factor) and not np.shares_memory(mass.factor, plant.factor)
    for arguments in ({"nominal_scale": np.array([1.0, 1.2])}, {"plant_scale": np.array([0.9, 1.0])},
                      {"sensor_effects": True}):
        psi, mass = choose(plant, **arguments)
        assert isinstance(mass, MassBatch) and not mass.from_plant
        evaluate(mass, plant.qpos, None, psi)
        np.testing.assert_allclose(mass.M[0] * arguments.get("nominal_scale", ONES)[0] ** -1,
                                   plant.mass_matrices()[0], rtol=1e-12)
        assert true_mass(mass, plant) is plant.mass_matrices()


@pytest.mark.parametrize("backend", ["algorithms", "mujoco"])
def test_evaluated_M_is_the_plants_at_the_true_positions_and_at_rest_for_stopped_rows(plant, backend,
                                                                                      monkeypatch):
    """The nominal model's own M at the readings, row by row (equal to the plant's to rounding for the
    rigid-body algorithms, bit for bit for MuJoCo's batch), and a stopped row's point at rest (q = 0)
    whatever its readings hold, its bits those of a batch at rest of its own."""
    if backend == "mujoco":
        monkeypatch.setattr(nominal_module.RigidTree, "from_model", classmethod(lambda cls, model: None))
    psi, mass = choose(plant, sensor_effects=True)  # not the plant's M
    readings = plant.qpos.copy()
    readings[1] = np.nan
    evaluate(mass, readings, np.array([False, True]), psi)
    np.testing.assert_allclose(mass.M[0], plant.mass_matrices()[0], rtol=1e-12, atol=1e-12)
    rest = nominal_batch(plant_model(), np.ones(1), nthread=1, mass_only=True)
    rest.evaluate()
    np.testing.assert_array_equal(mass.M[1], rest.mass_matrices()[0])
    assert true_mass(mass, plant) is plant.mass_matrices()
