"""Where M(x1) at the readings comes from (ftc_mj.engine.mass): decided once, from what the nominal model and
the plant each say of themselves."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest

import ftc_mj.robot.nominal as nominal_module
from ftc_mj.engine.mass import MassAtReadings, NominalMass, PlantMass, SharedMass, mass_at_readings
from ftc_mj.engine.plant import MuJoCoPlant
from ftc_mj.robot.nominal import nominal_batch

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
           sensor_effects: bool = False, shared: bool = False) -> MassAtReadings:
    """The M source of a run on ``plant`` (two rows) with these mass scales per row; ``shared``: the nominal
    batch is built with the readings' points, as the loop builds it."""
    psi = nominal_batch(plant_model(), nominal_scale, nthread=1, mass_points=nominal_scale if shared else None)
    return mass_at_readings(plant, psi, plant_model(), nominal_scale, plant_scale, sensor_effects, 1)


def evaluate(mass: MassAtReadings, readings: np.ndarray, stopped: np.ndarray | None, psi=None) -> None:
    """One period's M at the readings, as the loop runs it (``psi``: the nominal batch of a shared source)."""
    mass.prepare(readings, stopped)
    if psi is not None:
        psi.evaluate()
    mass.evaluate()


@pytest.mark.usefixtures("fast_paths")
def test_the_compiled_nominal_model_evaluates_its_own_M(plant):
    assert isinstance(choose(plant), NominalMass)
    assert isinstance(choose(plant, shared=True), SharedMass)


def test_mujoco_evaluating_the_plants_own_model_at_exact_readings_takes_the_plants_M(plant, monkeypatch):
    """Where MuJoCo evaluates the nominal model (here forced: the compiled one declines), M at the readings is
    the plant's M(q) itself, unless a mass scale or a sensor effect makes the two differ."""
    monkeypatch.setattr(nominal_module.RigidTree, "from_model", classmethod(lambda cls, model: None))
    mass = choose(plant)
    assert isinstance(mass, PlantMass)
    evaluate(mass, plant.qpos, None)
    assert mass.M is plant.mass_matrices() and mass.true_mass() is mass.M
    assert np.array_equal(mass.factor, plant.factor) and not np.shares_memory(mass.factor, plant.factor)
    assert isinstance(choose(plant, nominal_scale=np.array([1.0, 1.2])), NominalMass)
    assert isinstance(choose(plant, plant_scale=np.array([0.9, 1.0])), NominalMass)
    assert isinstance(choose(plant, sensor_effects=True), NominalMass)
    assert isinstance(choose(plant, shared=True), PlantMass)  # MuJoCo's batch has no points of the readings


@pytest.mark.usefixtures("fast_paths")
@pytest.mark.parametrize("shared", [False, True], ids=["batch-apart", "shared"])
def test_evaluated_M_is_the_plants_at_the_true_positions_and_at_rest_for_stopped_rows(plant, shared):
    """The nominal model's M at the readings, row by row (equal to the plant's to rounding: the compiled
    model), and a stopped row's point at rest (q = 0) whatever its readings hold; the same bits whether the
    points are a batch apart or the nominal batch's own."""
    psi = nominal_batch(plant_model(), ONES, nthread=1, mass_points=ONES if shared else None)
    mass = mass_at_readings(plant, psi, plant_model(), ONES, ONES, False, 1)
    readings = plant.qpos.copy()
    readings[1] = np.nan
    evaluate(mass, readings, np.array([False, True]), psi)
    np.testing.assert_allclose(mass.M[0], plant.mass_matrices()[0], rtol=1e-12, atol=1e-12)
    rest = nominal_batch(plant_model(), np.ones(1), nthread=1, mass_only=True)
    rest.evaluate()
    np.testing.assert_array_equal(mass.M[1], rest.mass_matrices()[0])
    assert mass.true_mass() is plant.mass_matrices()
    apart = choose(plant)
    evaluate(apart, np.nan_to_num(readings), None)
    if shared:  # row 0 as a batch of its own computes it
        np.testing.assert_array_equal(mass.M[0], apart.M[0])
        np.testing.assert_array_equal(mass.factor[0], apart.factor[0])
