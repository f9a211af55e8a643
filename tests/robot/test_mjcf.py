"""MJCF robots as they come, rebuilt as testbed robots (ftc_mj.robot.mjcf, ftc_mj.robot.editing).

* Menagerie form (models/ur5e.xml, models/panda.xml: servos, damping, armature, a tendon-coupled gripper, no
  sensors) through ``robot.menagerie`` on a local checkout (``MENAGERIE_ROOT``, no network): motors and
  sensors added, fingers locked with their tendon and equality, file unchanged on disk, a short run through
  the command line.
* Locking is exact: bodies where the full model puts them, M(q) the free block of the full model's.
* The model's damping acts on the plant and not on the nominal model: the plant's acceleration is the
  nominal Psi plus -M^-1 D qd.
* Bad options give the one-line error naming the field.
"""

from __future__ import annotations

import hashlib
import shutil
from pathlib import Path

import mujoco
import numpy as np
import pytest
import yaml

from ftc_mj.robot import mjcf
from ftc_mj.robot.nominal import nominal_batch
from ftc_mj.run import main
from ftc_mj.config.errors import InputError
from ftc_mj.scenario.loading import load_scenario

ROOT = Path(__file__).resolve().parents[2]
MODELS = ROOT / "models"
UR5E_YAML = ROOT / "scenarios" / "robots" / "ur5e_fault.yaml"
PANDA_YAML = ROOT / "scenarios" / "robots" / "panda_fault.yaml"
FINGERS = {"finger_joint1": 0.04, "finger_joint2": 0.04}


@pytest.fixture()
def menagerie(tmp_path, monkeypatch) -> Path:
    """A Menagerie checkout holding the two arms, laid out as the real one (robot folder / entry XML)."""
    root = tmp_path / "menagerie"
    for robot, file in (("universal_robots_ur5e", "ur5e.xml"), ("franka_emika_panda", "panda.xml")):
        (root / robot).mkdir(parents=True)
        shutil.copy(MODELS / file, root / robot / file)
    monkeypatch.setenv("MENAGERIE_ROOT", str(root))
    return root


def rebuilt(file: str, **options) -> mujoco.MjModel:
    options = {"joints": None, "lock": {}, "torque_limits": None, "contacts": "off", **options}
    return mjcf.rebuild(mujoco.MjSpec.from_file(str(MODELS / file)), name=file, source="s.yaml", **options)


def test_panda_rebuilt_in_the_testbed_form():
    model = rebuilt("panda.xml", lock=FINGERS, torque_limits="model")
    assert [model.joint(i).name for i in range(model.njnt)] == [f"joint{k}" for k in range(1, 8)]
    assert [model.actuator(i).name for i in range(model.nu)] == [f"motor{k}" for k in range(1, 8)]
    assert all(model.actuator_biastype[i] == 0 and model.actuator_gainprm[i, 0] == 1 for i in range(model.nu))
    assert [model.sensor(i).name for i in range(model.nsensor)] == (
        [f"joint{k}_pos" for k in range(1, 8)] + [f"joint{k}_vel" for k in range(1, 8)])
    np.testing.assert_array_equal(model.actuator_ctrlrange[:, 1], [87, 87, 87, 87, 12, 12, 12])
    assert model.ntendon == 0 and model.neq == 0 and model.nkey == 0  # the gripper's coupling went with it
    np.testing.assert_array_equal(model.dof_damping, 1.0)  # kept: part of the true plant
    np.testing.assert_array_equal(model.dof_armature, 0.1)
    assert model.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_CONTACT
    assert model.opt.integrator == mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    kept = rebuilt("panda.xml", lock=FINGERS, contacts="keep")
    assert not kept.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_CONTACT and np.any(kept.geom_contype)
    assert not np.any(kept.actuator_ctrllimited)  # no torque_limits: ideal torque sources


@pytest.mark.parametrize("lock", [{"joint3": 0.3, "joint5": -0.4, "joint7": 0.5, **FINGERS},
                                  {"joint1": -1.0, "finger_joint1": 0.01, "finger_joint2": 0.03}])
def test_locking_is_exact(lock):
    full = mujoco.MjModel.from_xml_path(str(MODELS / "panda.xml"))
    model = rebuilt("panda.xml", lock=lock)
    names = [full.joint(j).name for j in range(full.njnt)]
    free = [model.joint(j).name for j in range(model.njnt)]
    rng = np.random.default_rng(3)
    for _ in range(5):
        q = rng.uniform(-0.5, 0.5, model.nq) + np.where(np.array(free) == "joint4", -1.5, 0.0)
        values = {**lock, **dict(zip(free, q))}
        d_full, d = mujoco.MjData(full), mujoco.MjData(model)
        d_full.qpos[:] = [values[name] for name in names]
        d.qpos[:] = q
        mujoco.mj_forward(full, d_full)
        mujoco.mj_forward(model, d)
        np.testing.assert_allclose(d.xpos, d_full.xpos, atol=1e-14)
        M_full, M = np.zeros((full.nv, full.nv)), np.zeros((model.nv, model.nv))
        mujoco.mj_fullM(full, d_full, M_full)
        mujoco.mj_fullM(model, d, M)
        index = [names.index(name) for name in free]
        np.testing.assert_allclose(M, M_full[np.ix_(index, index)], atol=1e-13)


def test_menagerie_name_runs_unchanged_on_disk(menagerie, tmp_path, monkeypatch, capfd):
    """robot: {menagerie: franka_emika_panda}, read from MENAGERIE_ROOT by mujoco-menagerie (no download)."""
    digest = hashlib.sha256((menagerie / "franka_emika_panda" / "panda.xml").read_bytes()).hexdigest()
    data = yaml.safe_load(PANDA_YAML.read_text(encoding="utf-8"))
    data["robot"] = {"menagerie": "franka_emika_panda", "lock": {"finger_joint1": 0.04, "finger_joint2": 0.04},
                     "torque_limits": "model"}
    data["duration"] = 0.3
    data["actuator_faults"][0]["profile"]["onset"] = 0.2
    data.pop("diagnosis")
    data.pop("base")  # the calibrated thresholds, of the diagnosis left out
    scenario = tmp_path / "menagerie_panda.yaml"
    scenario.write_text(yaml.safe_dump(data, sort_keys=False), encoding="utf-8")
    monkeypatch.chdir(tmp_path)
    assert main([str(scenario), "--json", "out.json", "--no-record", "--quiet"]) == 0, capfd.readouterr().err
    assert hashlib.sha256((menagerie / "franka_emika_panda" / "panda.xml").read_bytes()).hexdigest() == digest
    assert sorted(p.name for p in (menagerie / "franka_emika_panda").iterdir()) == ["panda.xml"]


def test_damping_acts_on_the_plant_not_the_nominal_model():
    """At any state the plant's acceleration (no command) is the nominal Psi plus -M^-1 D qd: the model's
    damping is an uncertainty the observers estimate, not part of the controller's model."""
    scenario = load_scenario(UR5E_YAML)
    model = scenario.model
    assert np.all(model.dof_damping > 0)
    nominal = nominal_batch(model, np.ones(4), nthread=1)
    rng = np.random.default_rng(5)
    q, qd = rng.uniform(-1.5, 1.5, (4, model.nv)), rng.uniform(-1.0, 1.0, (4, model.nv))
    nominal.qpos[:], nominal.qvel[:], nominal.applied[:] = q, qd, 0.0
    nominal.evaluate()
    data = mujoco.MjData(model)
    for row in range(4):
        data.qpos[:], data.qvel[:], data.ctrl[:] = q[row], qd[row], 0.0
        mujoco.mj_forward(model, data)
        damped = np.zeros((1, model.nv))
        mujoco.mj_solveM(model, data, damped, (-model.dof_damping * qd[row]).reshape(1, -1))
        np.testing.assert_allclose(data.qacc, nominal.qacc[row] + damped[0], rtol=1e-9, atol=1e-9)
        assert np.abs(damped).max() > 5.0  # rad/s^2: a large part of the LUaF


def scenario_with_robot(tmp_path: Path, robot: dict, source: Path = UR5E_YAML) -> Path:
    data = yaml.safe_load(source.read_text(encoding="utf-8"))
    data["robot"] = robot
    if "base" in data:  # the copy names the same base
        data["base"] = str(source.parent / data["base"])
    path = tmp_path / "s.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False), encoding="utf-8")
    return path


UR5E = str(MODELS / "ur5e.xml")
UR5E_JOINTS = ["shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint", "wrist_2_joint",
               "wrist_3_joint"]


@pytest.mark.parametrize("robot, field, problem", [
    ({"model": UR5E}, "robot.model", "give robot.joints"),  # Menagerie form, used as is: refused
    ({"model": UR5E, "joints": UR5E_JOINTS[::-1]}, "robot.joints", "model's joint order"),
    ({"model": UR5E, "joints": ["knee"] + UR5E_JOINTS[1:]}, "robot.joints.0", "no joint 'knee'"),
    ({"model": UR5E, "joints": UR5E_JOINTS[:5], "lock": {"wrist_3_joint": 7.0}}, "robot.lock.wrist_3_joint",
     "outside the range"),
    ({"model": UR5E, "joints": UR5E_JOINTS, "torque_limits": [1.0, 2.0]}, "robot.torque_limits", "has 2 values"),
    ({"model": UR5E, "joints": UR5E_JOINTS, "armature": 0.1}, "robot.armature", "URDF models only"),
    ({"model": UR5E, "joints": UR5E_JOINTS, "contacts": "sometimes"}, "robot.contacts", ""),
    ({"menagerie": "universal_robots_ur5f"}, "robot.menagerie", "Did you mean 'universal_robots_ur5e'"),
    ({"menagerie": "universal_robots_ur5e", "menagerie_entry": "arm"}, "robot.menagerie_entry", "no entry point"),
    ({"menagerie": "universal_robots_ur5e", "model": UR5E}, "robot.menagerie", "not both"),
    ({"sensors": ["position"]}, "robot.model", "required field is missing"),
])
def test_bad_robot_options(menagerie, tmp_path, robot, field, problem):
    with pytest.raises(InputError) as info:
        load_scenario(scenario_with_robot(tmp_path, robot))
    assert info.value.field == field and problem in info.value.problem, info.value


def test_floating_and_ball_joints_are_refused(tmp_path):
    for joint, problem in (('<freejoint name="base"/>', "free joint (a floating base)"),
                           ('<joint name="base" type="ball"/>', "ball joint")):
        (tmp_path / "x.xml").write_text(f"""<mujoco><worldbody><body name="b">{joint}<geom size="0.1"/>
            <body name="c"><joint name="j"/><geom size="0.1"/></body></body></worldbody></mujoco>""")
        with pytest.raises(InputError) as info:
            mjcf.rebuild(mujoco.MjSpec.from_file(str(tmp_path / "x.xml")), joints=["j"], lock={}, torque_limits=None,
                         contacts="off", name="x.xml", source="s.yaml")
        assert problem in info.value.problem
