"""The log played back as the plant (ftc_mj.engine.plant.LogPlant): period k reads sample k, not k - 1 or
k + 1; the last sample stays; no truth (NaN state and acceleration, no M(q)); the poses are the forward
kinematics at the logged positions."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest

from ftc_mj.engine.plant import LogPlant
from ftc_mj.logs.trajectory import Log

TWO_LINK = Path(__file__).resolve().parents[2] / "models" / "two_link.xml"


def _log(steps: int = 4, velocity: bool = True) -> Log:
    """Sample k: positions 0.1 k and -0.2 k, velocities 10 k + joint, torques 100 k + joint (each sample its own)."""
    k = np.arange(steps, dtype=float)[:, None]
    joint = np.arange(2, dtype=float)[None, :]
    return Log(Path("log.csv"), k[:, 0] * 0.01, np.column_stack([0.1 * k[:, 0], -0.2 * k[:, 0]]),
               10.0 * k + joint if velocity else None, 100.0 * k + joint, 0.01, 0.0, (0.01, 0.01, 0.01))


@pytest.mark.parametrize("rows", [1, 3])
def test_each_period_reads_its_own_sample_and_the_last_one_stays(rows):
    model = mujoco.MjModel.from_xml_path(str(TWO_LINK))
    log = _log()
    plant = LogPlant(model, log, rows)
    position, velocity, acceleration = np.zeros((rows, 2)), np.zeros((rows, 2)), np.zeros((rows, 2))
    assert plant.alive.dtype == bool and plant.running == rows
    plant.step(acceleration)  # a step before the reset: from sample 0 to 1; the reset goes back to sample 0
    plant.read_positions(position)
    np.testing.assert_array_equal(position, np.broadcast_to(log.position[1], (rows, 2)))
    plant.reset(np.zeros((rows, 2)), np.zeros((rows, 2)))
    for k in [0, 1, 2, 3, 3, 3]:  # three periods past the end: the last sample is held
        plant.read_positions(position)
        plant.read_velocities(velocity)
        np.testing.assert_array_equal(position, np.broadcast_to(log.position[k], (rows, 2)))
        np.testing.assert_array_equal(velocity, np.broadcast_to(log.velocity[k], (rows, 2)))
        np.testing.assert_array_equal(plant.torque, np.broadcast_to(log.torque[k], (rows, 2)))
        data = mujoco.MjData(model)
        data.qpos[:] = log.position[k]
        mujoco.mj_kinematics(model, data)
        xpos, xquat = plant.poses()
        np.testing.assert_allclose(xpos, np.broadcast_to(data.xpos, xpos.shape), atol=1e-15)
        np.testing.assert_allclose(xquat, np.broadcast_to(data.xquat, xquat.shape), atol=1e-15)
        acceleration[:] = 0.0
        assert plant.step(acceleration) is None
        assert np.isnan(acceleration).all()
        assert plant.check() is None and plant.running == rows and plant.alive.all()


def test_no_truth_and_no_velocity_left_untouched():
    """Without logged velocities the readings are not written; no true state, bias or M(q)."""
    model = mujoco.MjModel.from_xml_path(str(TWO_LINK))
    plant = LogPlant(model, _log(velocity=False), 2)
    plant.reset(np.zeros((2, 2)), np.zeros((2, 2)))
    velocity = np.full((2, 2), 7.0)
    plant.read_velocities(velocity)
    np.testing.assert_array_equal(velocity, 0.0)
    assert not plant.has_truth and not plant.reads_state_exactly
    assert np.isnan(plant.qpos).all() and np.isnan(plant.qvel).all() and np.isnan(plant.bias).all()
    assert plant.factor.shape == plant.diagonal_inverse.shape == (2, 0)  # no factorisation to solve with
    with pytest.raises(TypeError, match=r"^a log holds no true M\(q\)$"):
        plant.mass_matrices()
