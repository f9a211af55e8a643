"""The simulated robots (ftc_mj.engine.plant.MuJoCoPlant) through the Plant protocol the loop uses, and their
edges: a period against MuJoCo's own mj_step (the first substep's acceleration, every substep, the sensors
current after), the divergence limits exactly at and just past them per row, MuJoCo's bad-state warnings and
errors stopping only their rows, the mass scales, the exact-reading flag, the poses, and the sensor columns
copied from consecutive or scattered addresses."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest
from mujoco.batch import SimulationError

from ftc_mj.engine.plant import MuJoCoPlant, _columns

PUMA = Path(__file__).resolve().parents[2] / "models" / "puma560.xml"
Q0 = np.array([[0.1, -0.2, 0.3], [0.0, 0.5, -0.5]])
QD0 = np.array([[0.2, 0.0, -0.1], [0.0, 0.0, 0.0]])


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


def _puma() -> mujoco.MjModel:
    return mujoco.MjModel.from_xml_path(str(PUMA))


def _driven(plant: MuJoCoPlant) -> None:
    plant.ctrl[:] = [[1.0, 2.0, 3.0], [-1.0, 0.0, 2.0]]
    plant.applied[:] = [[0.5, 0.0, 0.0], [0.0, 0.0, -0.5]]


@pytest.mark.parametrize("substeps", [1, 3])
def test_a_period_is_mujocos_substeps_with_the_first_acceleration(substeps):
    """Bit for bit MuJoCo's mj_step, ``substeps`` times under the held inputs: the acceleration of the first
    at the sampled state, the state after the last, and the encoders and tachometers read at that state."""
    model = _puma()
    plant = MuJoCoPlant(model, 2, substeps=substeps, nthread=1)
    assert plant.running == 2 and plant.batch.nthread == 1 and plant.batch.persistent is True
    plant.reset(Q0, QD0)
    _driven(plant)
    acceleration = np.zeros((2, 3))
    assert plant.step(acceleration) is None
    positions, velocities = np.zeros((2, 3)), np.zeros((2, 3))
    plant.read_positions(positions)
    plant.read_velocities(velocities)
    for row in range(2):
        data = mujoco.MjData(model)
        data.qpos[:], data.qvel[:] = Q0[row], QD0[row]
        data.ctrl[:], data.qfrc_applied[:] = plant.ctrl[row], plant.applied[row]
        mujoco.mj_forward(model, data)
        np.testing.assert_array_equal(acceleration[row], data.qacc)
        for _ in range(substeps):
            mujoco.mj_step(model, data)
        np.testing.assert_array_equal(plant.qpos[row], data.qpos)
        np.testing.assert_array_equal(plant.qvel[row], data.qvel)
        np.testing.assert_array_equal(positions[row], data.qpos)  # jointpos sensors at the new state
        np.testing.assert_array_equal(velocities[row], data.qvel)


def test_a_plant_steps_every_row_before_its_first_reset():
    """A new plant stands at the model's initial state: its first period is that of a reset to it."""
    model = _puma()
    fresh, reset = MuJoCoPlant(model, 2, substeps=2, nthread=1), MuJoCoPlant(model, 2, substeps=2, nthread=1)
    reset.reset(np.tile(model.qpos0, (2, 1)), np.zeros((2, 3)))
    first, again = np.zeros((2, 3)), np.zeros((2, 3))
    for plant, out in ((fresh, first), (reset, again)):
        _driven(plant)
        plant.step(out)
    np.testing.assert_array_equal(first, again)
    np.testing.assert_array_equal(fresh.qpos, reset.qpos)


def test_the_limits_are_inclusive_and_stop_only_their_rows():
    """|q| <= 1 and |qd| <= 5 is within, the limits themselves too; a row past one stops alone, the others
    run on, and stopped rows stay stopped when another one stops."""
    plant = MuJoCoPlant(_puma(), 2, substeps=1, nthread=1, max_position=1.0, max_velocity=5.0)
    plant.reset(np.array([[1.0, -1.0, 0.5], [0.0, 0.2, 0.0]]), np.array([[5.0, -5.0, 0.0], [0.0, 0.0, 0.0]]))
    assert plant.check() is None
    plant.qpos[1, 1] = 1.5  # row 1's position past the limit, its velocity within; row 0 at both limits
    np.testing.assert_array_equal(plant.check(), [False, True])
    assert plant.running == 1
    plant.qvel[0, 2] = -5.5  # now row 0's velocity, its positions within
    np.testing.assert_array_equal(plant.check(), [True, False])
    assert plant.running == 0 and not plant.alive.any()


@pytest.mark.usefixtures("fast_paths")
def test_a_stopped_rows_state_past_the_limits_keeps_the_check_on_its_compiled_pass(monkeypatch):
    """Once a row stopped past a limit, the running rows within it are checked by the compiled pass alone (the
    row-by-row comparison is not reached), and a running row past a limit still stops."""
    plant = MuJoCoPlant(_puma(), 3, substeps=1, nthread=1, max_position=1.0, max_velocity=5.0)
    plant.reset(np.zeros((3, 3)), np.zeros((3, 3)))
    plant.qpos[0, 0] = np.nan  # row 0 stops, its state stays as it stopped
    np.testing.assert_array_equal(plant.check(), [True, False, False])
    compared = []
    real_abs = np.abs
    monkeypatch.setattr(np, "abs", lambda *args, **kwargs: compared.append(1) or real_abs(*args, **kwargs))
    assert plant.check() is None and plant.check() is None
    assert not compared
    plant.qvel[2, 1] = 5.5
    np.testing.assert_array_equal(plant.check(), [False, False, True])
    assert compared and plant.running == 1


def test_a_bad_state_warning_stops_its_row_and_a_stopped_row_stays_put():
    """A velocity MuJoCo calls huge (it warns and resets that simulation): that row stops, the other runs on;
    the stopped row is not stepped again."""
    plant = MuJoCoPlant(_puma(), 2, substeps=2, nthread=1)
    plant.reset(Q0, np.array([[0.0, 0.0, 0.0], [0.0, 1e11, 0.0]]))
    _driven(plant)
    acceleration = np.zeros((2, 3))
    np.testing.assert_array_equal(plant.step(acceleration), [False, True])
    assert plant.running == 1
    stopped, running = plant.qpos[1].copy(), plant.qpos[0].copy()
    assert plant.step(acceleration) is None
    np.testing.assert_array_equal(plant.qpos[1], stopped)
    assert not np.array_equal(plant.qpos[0], running)


def test_mujoco_errors_stop_the_rows_they_name_in_either_substep(monkeypatch):
    """The first substep fails row 0, the others fail row 1 (a stand-in for MuJoCo's per-simulation errors):
    both stop; beside a bad-state warning of row 2 the errors are kept too."""
    plant = MuJoCoPlant(_puma(), 3, substeps=2, nthread=1)
    plant.reset(np.zeros((3, 3)), np.zeros((3, 3)))
    calls = []

    def step(ids=None, nstep=1, stage=0):
        calls.append(nstep)
        raise SimulationError(np.array([0 if len(calls) == 1 else 1]), "stand-in")

    monkeypatch.setattr(plant.batch, "step", step)
    np.testing.assert_array_equal(plant.step(np.zeros((3, 3))), [True, True, False])
    assert calls == [1, 1] and plant.running == 1
    plant.reset(np.zeros((3, 3)), np.zeros((3, 3)))
    calls.clear()
    plant.batch.warning[2, int(mujoco.mjtWarning.mjWARN_BADQACC), 1] = 1
    np.testing.assert_array_equal(plant.step(np.zeros((3, 3))), [True, True, True])


def test_mass_scales_scale_each_rows_mass_matrix():
    """Scales 1 and 2, and 2 and 2: the scaled rows' M(q) is twice the model's (powers of two: exactly)."""
    model = _puma()
    plain = MuJoCoPlant(model, 1, substeps=1, nthread=1)
    plain.reset(Q0[:1], QD0[:1])
    mass = plain.mass_matrices()[0].copy()
    for scale in ([1.0, 2.0], [2.0, 2.0]):
        plant = MuJoCoPlant(model, 2, substeps=1, nthread=1, mass_scale=np.array(scale))
        plant.reset(np.tile(Q0[0], (2, 1)), np.tile(QD0[0], (2, 1)))
        for row, factor in enumerate(scale):
            np.testing.assert_array_equal(plant.mass_matrices()[row], factor * mass)


def _one_joint(position_cutoff: float, velocity_cutoff: float) -> mujoco.MjModel:
    return mujoco.MjModel.from_xml_string(f"""
<mujoco><worldbody><body><joint name="j" axis="0 1 0"/>
  <geom type="capsule" size="0.05" fromto="0 0 0 0.5 0 0" mass="1"/></body></worldbody>
  <sensor><jointpos joint="j" cutoff="{position_cutoff}"/><jointvel joint="j" cutoff="{velocity_cutoff}"/></sensor>
</mujoco>""")


def test_the_encoders_read_exactly_without_a_cutoff_on_them():
    """Only the position sensors' cutoff counts (a jointvel cutoff does not clip the encoders); one joint, one
    sensor of each kind."""
    assert MuJoCoPlant(_puma(), 1, substeps=1, nthread=1).reads_state_exactly is True
    assert MuJoCoPlant(_one_joint(0.0, 2.0), 1, substeps=1, nthread=1).reads_state_exactly is True
    assert MuJoCoPlant(_one_joint(0.5, 0.0), 1, substeps=1, nthread=1).reads_state_exactly is False


def test_the_poses_are_the_forward_kinematics_of_each_row():
    model = _puma()
    plant = MuJoCoPlant(model, 2, substeps=1, nthread=1)
    plant.reset(Q0, QD0)
    xpos, xquat = plant.poses()
    for row in range(2):
        data = mujoco.MjData(model)
        data.qpos[:] = Q0[row]
        mujoco.mj_kinematics(model, data)
        np.testing.assert_array_equal(xpos[row], data.xpos)
        np.testing.assert_array_equal(xquat[row], data.xquat)


@pytest.mark.parametrize("addresses", [[2, 3, 4], [0], [5, 1, 2], []])
def test_sensor_columns_from_any_addresses(addresses):
    """Consecutive addresses (at an offset, or one), scattered ones, none: the columns themselves, in order."""
    values = np.arange(12.0).reshape(2, 6) * [[1.0], [-1.0]]
    out = np.full((2, len(addresses)), np.nan)
    _columns(values, np.array(addresses, dtype=int))(out)
    np.testing.assert_array_equal(out, values[:, addresses])


@pytest.mark.parametrize("persistent_rows", [0, 32])
def test_both_kinds_of_batch_give_the_same_period_and_current_poses(persistent_rows, monkeypatch):
    """A plant beyond PERSISTENT_ROWS (one MjData per thread) steps every row as a persistent one does, bit for
    bit, and its poses are current from the first period (bound on demand, filled at once)."""
    import ftc_mj.engine.plant as plant_module

    model = mujoco.MjModel.from_xml_path(str(PUMA))
    monkeypatch.setattr(plant_module, "PERSISTENT_ROWS", persistent_rows)
    plant = MuJoCoPlant(model, 2, substeps=3, nthread=1)
    assert plant.batch.persistent is (persistent_rows >= 2)
    plant.reset(Q0, QD0)
    xpos, xquat = plant.poses()
    data = mujoco.MjData(model)
    for row in range(2):
        data.qpos[:], data.qvel[:] = Q0[row], QD0[row]
        mujoco.mj_kinematics(model, data)
        np.testing.assert_array_equal(xpos[row], data.xpos)
        np.testing.assert_array_equal(xquat[row], data.xquat)
    plant.ctrl[:] = [[1.0, -2.0, 0.5], [0.0, 3.0, -1.0]]
    acceleration = np.zeros((2, 3))
    plant.step(acceleration)
    for row in range(2):
        data = mujoco.MjData(model)
        data.qpos[:], data.qvel[:], data.ctrl[:] = Q0[row], QD0[row], plant.ctrl[row]
        mujoco.mj_step(model, data)
        np.testing.assert_array_equal(acceleration[row], data.qacc)
        for _ in range(2):
            mujoco.mj_step(model, data)
        np.testing.assert_array_equal(plant.qpos[row], data.qpos)
        np.testing.assert_array_equal(plant.qvel[row], data.qvel)


@pytest.mark.parametrize("mass_scale", [1.0, 2.0])
def test_one_row_on_its_own_mjdata_steps_as_a_batch_of_one(mass_scale):
    """A single row on one MjData (OneRowPlant) gives a persistent batch of one's bits, period after period,
    under changing inputs: the first substep's acceleration, the state, the readings, M(q), its factor, the
    bias forces and the poses; its mass scale scales a copy of the model, not the model."""
    import ftc_mj.engine.plant as plant_module

    model = _puma()
    masses = model.body_mass.copy()
    scale = np.array([mass_scale])
    one = plant_module.plant_for(model, 1, substeps=3, nthread=1, mass_scale=scale)
    batch = MuJoCoPlant(model, 1, substeps=3, nthread=1, mass_scale=scale)
    assert isinstance(one, plant_module.OneRowPlant) and batch.batch.persistent is True
    np.testing.assert_array_equal(model.body_mass, masses)
    poses = []
    for plant in (one, batch):
        plant.reset(Q0[:1], QD0[:1])
        poses.append(plant.poses())
    for period in range(25):
        outputs = []
        for plant in (one, batch):
            plant.ctrl[:] = [[np.sin(period), -2.0, 0.5 * period]]
            plant.applied[:] = [[0.0, np.cos(period), 0.1]]
            acceleration, readings = np.zeros((1, 3)), np.zeros((1, 6))
            assert plant.step(acceleration) is None
            plant.read_positions(readings[:, :3])
            plant.read_velocities(readings[:, 3:])
            outputs.append([acceleration, plant.qpos.copy(), plant.qvel.copy(), readings, plant.mass_matrices().copy(),
                            plant.factor.copy(), plant.diagonal_inverse.copy(), plant.bias.copy()])
        for first, second in zip(*outputs):
            np.testing.assert_array_equal(first, second)
        for first, second in zip(*poses):
            np.testing.assert_array_equal(first, second)


def test_one_row_stops_on_a_bad_state_warning_and_on_a_mujoco_error(monkeypatch):
    """A velocity MuJoCo calls huge stops the single row (MuJoCo warned and reset it); after a reset it runs
    again, and a MuJoCo error in any substep stops it too."""
    import ftc_mj.engine.plant as plant_module

    plant = plant_module.OneRowPlant(_puma(), substeps=2)
    plant.reset(Q0[:1], np.array([[0.0, 1e11, 0.0]]))
    np.testing.assert_array_equal(plant.step(np.zeros((1, 3))), [True])
    assert plant.running == 0 and not plant.alive[0]
    plant.reset(Q0[:1], QD0[:1])
    assert plant.running == 1 and plant.step(np.zeros((1, 3))) is None

    def failing(model, data, nstep=1):
        raise mujoco.FatalError("stand-in")

    monkeypatch.setattr(plant_module.mujoco, "mj_step", failing)
    np.testing.assert_array_equal(plant.step(np.zeros((1, 3))), [True])
    assert plant.running == 0


def test_a_batch_steps_several_rows_and_a_model_on_rk4():
    """plant_for: one MjData for a single row; a batch for more rows, and for a single row of a model on RK4
    (MuJoCo's split step integrates with Euler or an implicit integrator only)."""
    import ftc_mj.engine.plant as plant_module

    model = _puma()
    assert type(plant_module.plant_for(model, 2, substeps=1, nthread=1)) is MuJoCoPlant
    model.opt.integrator = mujoco.mjtIntegrator.mjINT_RK4
    assert type(plant_module.plant_for(model, 1, substeps=1, nthread=1)) is MuJoCoPlant
    with pytest.raises(ValueError, match=r"^mj_step2 does not integrate with RK4: step this model as a batch$"):
        plant_module.OneRowPlant(model, substeps=1)


@pytest.mark.parametrize("rows", [1, 2])
def test_plant_for_passes_the_limits_and_the_mass_scale(rows):
    """Either kind of plant gets the divergence limits and the mass scale: |q| <= 1 and |qd| <= 5 within, the
    limits themselves too, just past either one stopped; M(q) twice the model's at a mass scale of 2."""
    import ftc_mj.engine.plant as plant_module

    model = _puma()
    plain = MuJoCoPlant(model, 1, substeps=1, nthread=1)
    plain.reset(Q0[:1], QD0[:1])
    for quantity in ("qpos", "qvel"):
        plant = plant_module.plant_for(model, rows, substeps=1, nthread=1, mass_scale=np.full(rows, 2.0),
                                       max_position=1.0, max_velocity=5.0)
        plant.reset(np.tile(Q0[0], (rows, 1)), np.tile(QD0[0], (rows, 1)))
        np.testing.assert_array_equal(plant.mass_matrices()[0], 2.0 * plain.mass_matrices()[0])
        plant.qpos[:, 0], plant.qvel[:, 0] = 1.0, -5.0
        assert plant.check() is None
        getattr(plant, quantity)[0, 1] = {"qpos": 1.0 + 1e-9, "qvel": 5.0 + 1e-9}[quantity]
        np.testing.assert_array_equal(plant.check(), [True] + [False] * (rows - 1))


@pytest.mark.parametrize("warning", ["mjWARN_BADQPOS", "mjWARN_BADQVEL", "mjWARN_BADQACC"])
def test_one_row_stops_on_each_of_mujocos_reset_warnings(warning):
    """Each of the three warnings after which MuJoCo resets a simulation stops the single row."""
    import ftc_mj.engine.plant as plant_module

    plant = plant_module.OneRowPlant(_puma(), substeps=1)
    plant.reset(Q0[:1], QD0[:1])
    assert plant.step(np.zeros((1, 3))) is None
    plant.data.warning[int(getattr(mujoco.mjtWarning, warning))].number = 1
    np.testing.assert_array_equal(plant.step(np.zeros((1, 3))), [True])
