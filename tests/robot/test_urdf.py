"""URDF robots (ftc_mj.robot.urdf) and scenarios on them.

* ``models/puma560.urdf`` with its wrist locked reproduces ``models/puma560.xml``: M(q), G(q), C(q, qd) qd at
  100 random states (1e-9), the body poses, and the metrics of ``puma_fault`` against ``puma_fault_urdf``.
* Locking is exact: the locked model's dynamics are the free block of the unlocked model's at the lock angle.
* The test arm (tests/data/urdf: primitives, an OBJ mesh, a locked wrist, an effort limit) runs its scenario
  end to end through ``python -m ftc_mj.run``; the recording draws the URDF's mesh where the URDF puts it.
* Torque limits clamp the torque the plant receives; the recorded tau is the commanded one.
* Broken input (malformed XML, a moving link without inertial, an unknown joint to lock, a missing mesh, ...)
  exits 2 with one line naming the file and the element, and writes nothing.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np
import pytest
import yaml
from rerun.chunk import RrdReader
from nominal_oracle import NominalModel
from test_models import dynamics  # M(q), G(q), C(q, qd) qd on fresh MjData, as the MJCF models are checked

from ftc_mj.analysis.metrics import compute_metrics
from ftc_mj.engine.runner import simulate_variant
from ftc_mj.robot.urdf import load_model, read_urdf, resolve_mesh
from ftc_mj.run import main
from ftc_mj.config.errors import InputError
from ftc_mj.scenario.loading import load_scenario

ROOT = Path(__file__).resolve().parents[2]
MODELS = ROOT / "models"
PUMA_YAML = ROOT / "scenarios" / "puma_fault.yaml"
PUMA_URDF_YAML = ROOT / "scenarios" / "puma_fault_urdf.yaml"
DATA = ROOT / "tests" / "data" / "urdf"
ARM_URDF = DATA / "arm.urdf"
ARM_YAML = DATA / "arm.yaml"
PUMA_LOCK = {"joint4": 0.0, "joint5": 0.0, "joint6": 0.0}
PUMA_ARMATURE = [0.784029, 2.324805, 0.576866]


# ------------------------------------------------------------------------------------ PUMA560 from URDF


@pytest.fixture(scope="module")
def puma_pair() -> tuple[mujoco.MjModel, mujoco.MjModel]:
    mjcf = mujoco.MjModel.from_xml_path(str(MODELS / "puma560.xml"))
    from_urdf = load_model(MODELS / "puma560.urdf", lock=PUMA_LOCK, armature=PUMA_ARMATURE, source="test")
    return mjcf, from_urdf


def test_puma_urdf_structure(puma_pair):
    mjcf, m = puma_pair
    assert m.nq == m.nv == m.nu == m.njnt == 3 and m.nsensor == 6
    assert [m.joint(i).name for i in range(3)] == ["joint1", "joint2", "joint3"]
    assert [m.actuator(i).name for i in range(3)] == ["motor1", "motor2", "motor3"]
    assert [m.sensor(i).name for i in range(m.nsensor)] == (
        ["joint1_pos", "joint2_pos", "joint3_pos", "joint1_vel", "joint2_vel", "joint3_vel"])
    for i in range(3):
        assert m.actuator_trnid[i, 0] == i and m.actuator_gear[i, 0] == 1.0
        assert not m.actuator_ctrllimited[i] and not m.jnt_actfrclimited[i]  # no efforts in the URDF
    assert m.opt.integrator == mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    assert m.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_CONTACT
    assert np.all(m.geom_contype == 0) and np.all(m.geom_conaffinity == 0)
    assert not np.any(m.jnt_limited)  # joints 1-3 are continuous, as the MJCF's hinges have no range
    np.testing.assert_array_equal(m.dof_armature, mjcf.dof_armature)
    # Same bodies in the same order (plus the massless tool flange), the welded wrist kept.
    names = [m.body(i).name for i in range(m.nbody)]
    assert names == [mjcf.body(i).name for i in range(mjcf.nbody)] + ["flange"]
    np.testing.assert_allclose(m.body_mass[: mjcf.nbody], mjcf.body_mass, rtol=0, atol=1e-15)
    assert m.body("link3").subtreemass[0] == pytest.approx(6.05)
    assert m.ngeom > 10  # the URDF's visuals are kept


def test_puma_urdf_reproduces_mjcf_dynamics(puma_pair):
    """M(q), G(q) and C(q, qd) qd agree with models/puma560.xml at 100 random states, to 1e-9."""
    mjcf, m = puma_pair
    rng = np.random.default_rng(5)
    worst = np.zeros(3)
    for _ in range(100):
        q, qd = rng.uniform(-np.pi, np.pi, 3), rng.uniform(-3.0, 3.0, 3)
        for k, (a, b) in enumerate(zip(dynamics(m, q, qd), dynamics(mjcf, q, qd), strict=True)):
            worst[k] = max(worst[k], np.abs(a - b).max())
    assert np.all(worst < 1e-9), f"max |difference| of M, G, C qd: {worst}"


def test_puma_urdf_reproduces_mjcf_poses(puma_pair):
    mjcf, m = puma_pair
    rng = np.random.default_rng(6)
    dm, dx = mujoco.MjData(m), mujoco.MjData(mjcf)
    for _ in range(20):
        dm.qpos[:] = dx.qpos[:] = rng.uniform(-np.pi, np.pi, 3)
        mujoco.mj_kinematics(m, dm)
        mujoco.mj_kinematics(mjcf, dx)
        n = mjcf.nbody
        np.testing.assert_allclose(dm.xpos[:n], dx.xpos, rtol=0, atol=1e-12)
        np.testing.assert_allclose(dm.xipos[:n], dx.xipos, rtol=0, atol=1e-12)
        # the flange frame is the MJCF's flange site
        np.testing.assert_allclose(dm.xpos[m.body("flange").id], dx.site_xpos[mjcf.site("flange").id], atol=1e-12)


def test_puma_urdf_scenario_locks_and_loads_the_wrist_as_the_model_tests_do():
    """puma_fault_urdf.yaml inherits puma_fault.yaml (base:) and sets the robot the model tests above check."""
    robot = load_scenario(PUMA_URDF_YAML, duration=0.1).spec.robot
    assert (robot.lock, robot.armature) == (PUMA_LOCK, PUMA_ARMATURE)


@pytest.mark.slow  # a closed-loop run of seconds
def test_puma_fault_same_metrics_on_both_models():
    """2 s of puma_fault on the MJCF and on the URDF: the same metrics.

    Not bit for bit: the two models differ by rounding (rpy versus quaternion frames, a full versus a diagonal
    inertia; M, G and C qd by < 1e-13), and the sliding-mode observers' sign() turns such differences into a
    different switching pattern. A change of one unit in the last place of a mass in the MJCF itself moves the
    metrics as much (measured: 0.4% on rms_error_converged over 30 s). Over 2 s the largest relative
    difference measured is 1.4e-5.
    """
    metrics = []
    for path in (PUMA_YAML, PUMA_URDF_YAML):
        scenario = load_scenario(path, duration=2.0)
        metrics.append({v.name: compute_metrics(simulate_variant(scenario, v), scenario.spec.metrics,
                                                scenario.fault_onsets) for v in scenario.variants})
    assert list(metrics[0]) == list(metrics[1]) == ["proposed", "nftsmc_tosmo", "nftsmc_sosmo", "nftsmc"]
    for variant, values in metrics[0].items():
        for name, value in values.items():
            np.testing.assert_allclose(metrics[1][variant][name], value, rtol=1e-4, atol=0,
                                       err_msg=f"{variant}: {name}")


# ------------------------------------------------------------------------------------------------ locking


@pytest.mark.parametrize("kind, value", [("revolute", 0.3), ("revolute", -1.2), ("prismatic", 0.04)])
def test_locking_is_exact(tmp_path, kind, value):
    """The locked model's dynamics and poses are those of the unlocked model with the joint at the value."""
    path = tmp_path / "arm.urdf"
    shutil.copytree(DATA / "meshes", tmp_path / "meshes")
    path.write_text(ARM_URDF.read_text(encoding="utf-8").replace('name="wrist" type="revolute"',
                                                                 f'name="wrist" type="{kind}"'), encoding="utf-8")
    locked = load_model(path, lock={"wrist": value}, source="test")
    free = load_model(path, source="test")
    assert [free.joint(i).name for i in range(free.njnt)] == ["shoulder", "elbow", "wrist"]
    assert [locked.joint(i).name for i in range(locked.njnt)] == ["shoulder", "elbow"]
    rng = np.random.default_rng(7)
    for _ in range(30):
        q, qd = rng.uniform(-2.0, 2.0, 2), rng.uniform(-3.0, 3.0, 2)
        M, G, C = dynamics(free, np.append(q, value), np.append(qd, 0.0))
        Ml, Gl, Cl = dynamics(locked, q, qd)
        np.testing.assert_allclose(Ml, M[:2, :2], rtol=0, atol=1e-12)
        np.testing.assert_allclose(Gl, G[:2], rtol=0, atol=1e-12)
        np.testing.assert_allclose(Cl, C[:2], rtol=0, atol=1e-12)
        dl, df = mujoco.MjData(locked), mujoco.MjData(free)
        dl.qpos[:], df.qpos[:] = q, np.append(q, value)
        mujoco.mj_kinematics(locked, dl)
        mujoco.mj_kinematics(free, df)
        np.testing.assert_allclose(dl.xpos, df.xpos, rtol=0, atol=1e-12)
        np.testing.assert_allclose(dl.xmat, df.xmat, rtol=0, atol=1e-12)


def test_kinematic_order_is_depth_first_in_file_order(tmp_path):
    link = '<link name="{0}"><inertial><mass value="1"/><inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/>' \
           '</inertial></link>'
    joint = '<joint name="{0}" type="continuous"><parent link="{1}"/><child link="{2}"/></joint>'
    path = tmp_path / "tree.urdf"
    path.write_text('<robot name="tree"><link name="base"/>' + joint.format("b", "base", "B")
                    + joint.format("a", "base", "A") + joint.format("a2", "A", "A2")
                    + "".join(link.format(n) for n in ("A2", "B", "A")) + "</robot>", encoding="utf-8")
    assert read_urdf(path).movable == ("b", "a", "a2")
    m = load_model(path, source="test")
    assert [m.joint(i).name for i in range(m.njnt)] == ["b", "a", "a2"]
    assert [m.actuator(i).name for i in range(m.nu)] == ["motor1", "motor2", "motor3"]
    assert [m.sensor(i).name for i in range(m.nsensor)] == ["b_pos", "a_pos", "a2_pos", "b_vel", "a_vel", "a2_vel"]


# --------------------------------------------------------------------------------- meshes and geometry


def test_test_arm_model():
    m = load_model(ARM_URDF, lock={"wrist": 0.3}, source="test")
    assert [m.joint(i).name for i in range(m.njnt)] == ["shoulder", "elbow"]
    # The shoulder's effort becomes its torque limit; the continuous elbow has none.
    assert list(m.actuator_ctrllimited) == [1, 0]
    np.testing.assert_array_equal(m.actuator_ctrlrange[0], [-40.0, 40.0])
    assert m.jnt_limited[0] and np.array_equal(m.jnt_range[0], [-2.5, 2.5])  # position limits kept
    geoms = {m.geom(i).name for i in range(m.ngeom)}
    assert geoms == {"base_block", "upper_tube", "fore_bracket", "hand_knuckle", "hand_finger"}  # no collision
    assert m.nmesh == 2
    np.testing.assert_allclose(m.body("tip").mass, 0.0)  # no inertial: massless, whatever its geometry


def test_collision_geometry_drawn_when_a_link_has_no_visual(tmp_path):
    shutil.copytree(DATA / "meshes", tmp_path / "meshes")
    text = ARM_URDF.read_text(encoding="utf-8")
    start, end = text.index('<visual name="upper_tube">'), text.index("<collision>")
    (tmp_path / "arm.urdf").write_text(text[:start] + text[end:], encoding="utf-8")
    m = load_model(tmp_path / "arm.urdf", source="test")
    body = m.body("upper").id
    sizes = [m.geom_size[g] for g in range(m.ngeom) if m.geom_bodyid[g] == body]
    assert len(sizes) == 1 and sizes[0][0] == pytest.approx(0.035)  # the collision cylinder's radius


def test_package_uri_resolution(tmp_path, monkeypatch):
    package = tmp_path / "my_arm"
    (package / "meshes").mkdir(parents=True)
    (package / "urdf").mkdir()
    shutil.copy(DATA / "meshes" / "bracket.obj", package / "meshes")
    base = package / "urdf"
    target = (package / "meshes" / "bracket.obj").resolve()
    assert resolve_mesh("package://my_arm/meshes/bracket.obj", base) == target  # the package above the URDF
    assert resolve_mesh("../meshes/bracket.obj", base) == target
    assert resolve_mesh(f"file://{target}", base) == target
    assert resolve_mesh("package://other/meshes/bracket.obj", base) is None
    monkeypatch.setenv("ROS_PACKAGE_PATH", str(tmp_path))
    assert resolve_mesh("package://my_arm/meshes/bracket.obj", tmp_path / "elsewhere") == target
    # and a whole model through package://
    text = ARM_URDF.read_text(encoding="utf-8").replace("meshes/bracket.obj", "package://my_arm/meshes/bracket.obj")
    (base / "arm.urdf").write_text(text, encoding="utf-8")
    assert load_model(base / "arm.urdf", source="test").nmesh == 2


# ------------------------------------------------------------------------------------------ torque limits


def test_torque_limits_clamp_the_applied_torque_not_the_recorded_one():
    """With |tau| <= 0.5 N m the controller asks for more; the plant gets the clamped torque (MuJoCo clamps
    ctrl to ctrlrange), the recording keeps the command, and the difference shows in the true LUaF."""
    limit = 0.5
    scenario = load_scenario(ARM_YAML, duration=0.3, variants=["proposed"],
                             overrides=["terms=[]", f"robot.torque_limits={limit}"])
    np.testing.assert_array_equal(scenario.model.actuator_ctrlrange, [[-limit, limit]] * 2)  # replaces effort 40
    result = simulate_variant(scenario, scenario.variants[0])
    assert result.status == "ok"
    assert np.abs(result.tau).max() > 2 * limit  # commanded, as recorded
    nominal = NominalModel(scenario.model)
    for k in range(0, len(result.t), 10):  # no plant terms: the true LUaF is only the saturation
        M = nominal.mass_matrix(result.q_true[k])
        expected = np.linalg.solve(M, np.clip(result.tau[k], -limit, limit) - result.tau[k])
        np.testing.assert_allclose(result.luaf_true[k], expected, rtol=1e-9, atol=1e-9)
    # and on one MjData: ctrl stays as written, the joint torque is clamped
    data = mujoco.MjData(scenario.model)
    data.ctrl[:] = [3.0, -0.2]
    mujoco.mj_forward(scenario.model, data)
    np.testing.assert_array_equal(data.ctrl, [3.0, -0.2])
    np.testing.assert_array_equal(data.qfrc_actuator, [limit, -0.2])


# ------------------------------------------------------------------------------------ the command line


@dataclass
class Case:
    urdf: Callable[[str], str] = lambda text: text  # edits the URDF text
    scenario: Callable[[dict], dict] = lambda data: data  # edits the scenario data
    model: str | None = None  # robot.model instead of the URDF
    element: str = ""  # expected in the error line
    file: str = "arm.urdf"  # the file the error line names
    problem: str = ""  # expected in the error line


def replace(old: str, new: str) -> Callable[[str], str]:
    def edit(text: str) -> str:
        assert old in text, old
        return text.replace(old, new)

    return edit


def robot(**fields) -> Callable[[dict], dict]:
    def edit(data: dict) -> dict:
        data["robot"].update(fields)
        return data

    return edit


FORE_INERTIAL = """<inertial>
      <origin xyz="0.12 0 0"/>
      <mass value="1.0"/>
      <inertia ixx="0.0005" ixy="0" ixz="0" iyy="0.005" iyz="0" izz="0.005"/>
    </inertial>"""

#: Broken input run through ``python -m ftc_mj.run`` as a subprocess (about 2 s of start-up each).
BROKEN = {
    "malformed_xml": Case(urdf=replace("</robot>", ""), element="line ", problem="malformed XML"),
    "missing_mesh_strict": Case(urdf=replace('filename="meshes/bracket.obj"/>', 'filename="meshes/gone.obj"/>'),
                                scenario=robot(strict_meshes=True), element="link 'fore': visual 1: mesh",
                                problem="'meshes/gone.obj' not found: looked for "),
}

#: More broken input, in-process through ftc_mj.run.main: the same code path without the start-up; capfd
#: also sees what C code (MuJoCo) would print.
BROKEN_IN_PROCESS = {
    "moving_link_without_inertial": Case(urdf=replace(FORE_INERTIAL, ""), element="link 'fore'",
                                         problem="has no <inertial>"),
    "unknown_joint_to_lock": Case(scenario=robot(lock={"wrist": 0.3, "knee": 0.0}), file="arm.yaml",
                                  element="robot.lock.knee", problem="arm.urdf has no joint 'knee'"),
    "lock_a_fixed_joint": Case(scenario=robot(lock={"tool": 0.0}), file="arm.yaml", element="robot.lock.tool",
                               problem="is fixed"),
    "lock_outside_limits": Case(scenario=robot(lock={"wrist": 2.0}), file="arm.yaml", element="robot.lock.wrist",
                                problem="outside the limits"),
    "lock_everything": Case(scenario=robot(lock={"wrist": 0.0, "shoulder": 0.0, "elbow": 0.0}), file="arm.yaml",
                            element="robot.lock", problem="nothing to control"),
    "torque_limits_wrong_length": Case(scenario=robot(torque_limits=[1.0, 2.0, 3.0]), file="arm.yaml",
                                       element="robot.torque_limits", problem="has 3 values, the robot has 2 free"),
    "torque_limit_negative": Case(scenario=robot(torque_limits=-1.0), file="arm.yaml",
                                  element="robot.torque_limits"),
    "lock_on_mjcf": Case(scenario=robot(lock={"joint3": 0.0}), model=str(MODELS / "puma560.xml"), file="arm.yaml",
                         element="robot.lock", problem="URDF models only"),
    "wrong_joint_count": Case(scenario=robot(lock={}), file="arm.yaml", element="initial.q",
                              problem="the robot has 3 joints"),
    "mesh_format": Case(urdf=replace("meshes/bracket.obj\"/>", "meshes/bracket.dae\"/>"),
                        element="link 'fore': visual 1: mesh", problem="MuJoCo reads .stl, .obj, .msh"),
    "inertia_not_physical": Case(urdf=replace('iyy="0.005" iyz="0" izz="0.005"', 'iyy="0.005" iyz="0" izz="0.05"'),
                                 element="link 'fore': inertial", problem="not physical"),
    "mass_zero_on_moving_link": Case(urdf=replace('<mass value="1.0"/>', '<mass value="0"/>'),
                                     element="link 'fore': inertial", problem="mass must be a number > 0"),
    "not_a_number": Case(urdf=replace('<mass value="2.0"/>', '<mass value="two"/>'), element="link 'upper'",
                         problem="'two' is not a number"),
    "floating_joint": Case(urdf=replace('name="elbow" type="continuous"', 'name="elbow" type="floating"'),
                           element="joint 'elbow'", problem="not supported"),
    "revolute_without_limit": Case(urdf=replace('<limit lower="-1.5" upper="1.5" effort="5" velocity="5"/>', ""),
                                   element="joint 'wrist'", problem="needs a <limit>"),
    "unknown_child_link": Case(urdf=replace('<child link="hand"/>', '<child link="palm"/>'),
                               element="joint 'wrist'", problem="'palm' does not exist"),
    "two_roots": Case(urdf=replace('<link name="tip"/>', '<link name="tip"/><link name="stray"/>'),
                      element="<robot>", problem="2 root links"),
    "entity_declaration": Case(urdf=lambda text: '<!DOCTYPE robot [<!ENTITY a "aaaa">]>\n' + text.split("?>", 1)[1],
                               element="DOCTYPE"),
    "not_a_urdf": Case(urdf=lambda text: "<mujoco/>", element="<mujoco>", problem="must be <robot>"),
}


def prepare(directory: Path, case: Case) -> Path:
    """The test arm and its scenario in ``directory``, edited by ``case``; returns the scenario path."""
    shutil.copytree(DATA / "meshes", directory / "meshes")
    (directory / "meshes" / "bracket.dae").write_text("<COLLADA/>\n", encoding="utf-8")
    (directory / "arm.urdf").write_text(case.urdf(ARM_URDF.read_text(encoding="utf-8")), encoding="utf-8")
    data = case.scenario(yaml.safe_load(ARM_YAML.read_text(encoding="utf-8")))
    if case.model is not None:
        data["robot"]["model"] = case.model
    scenario = directory / "arm.yaml"
    scenario.write_text(yaml.safe_dump(data, sort_keys=False), encoding="utf-8")
    return scenario


def listing(directory: Path) -> list[str]:
    return sorted(str(p.relative_to(directory)) for p in directory.rglob("*"))


OUTPUTS = ["--json", "out.json", "--out", "rec.rrd"]


def run_cli(directory: Path, scenario: Path, *args: str) -> subprocess.CompletedProcess:
    # The package of this source tree, whatever tree is installed: the subprocess tests the code under test.
    path = os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")]))
    env = {**os.environ, "PYTHONDONTWRITEBYTECODE": "1", "PYTHONPATH": path}
    return subprocess.run([sys.executable, "-m", "ftc_mj.run", str(scenario), *args], cwd=directory,
                          capture_output=True, text=True, timeout=180, env=env)


@pytest.fixture(scope="module")
def outcomes(tmp_path_factory) -> dict:
    """Every subprocess at once: name -> (process, files before, files after); "_dirs": name -> directory."""
    cases = {**BROKEN, "good": Case()}
    directories = {name: tmp_path_factory.mktemp(name) for name in cases}

    def one(name: str):
        scenario = prepare(directories[name], cases[name])
        before = listing(directories[name])
        process = run_cli(directories[name], scenario, *OUTPUTS)
        return process, before, listing(directories[name])

    with ThreadPoolExecutor(max_workers=max(2, os.cpu_count() or 2)) as pool:
        futures = {name: pool.submit(one, name) for name in sorted(cases, key=lambda n: n != "good")}
        return {name: future.result() for name, future in futures.items()} | {"_dirs": directories}


def check_broken(case: Case, returncode: int, stdout: str, stderr: str, before: list[str], after: list[str]) -> None:
    assert "Traceback" not in stderr, stderr
    assert returncode == 2, stderr
    lines = stderr.splitlines()
    assert len(lines) == 1, stderr
    assert lines[0].startswith("error: ")
    assert case.file in lines[0] and case.element in lines[0] and case.problem in lines[0], lines[0]
    assert stdout == ""
    assert after == before, "bad input wrote something"


@pytest.mark.slow  # a subprocess
@pytest.mark.parametrize("name", list(BROKEN))
def test_broken_input_exits_2_with_one_line_and_writes_nothing(outcomes, name):
    process, before, after = outcomes[name]
    check_broken(BROKEN[name], process.returncode, process.stdout, process.stderr, before, after)


@pytest.mark.parametrize("name", list(BROKEN_IN_PROCESS))
def test_more_broken_input_in_process(tmp_path, monkeypatch, capfd, name):
    check_broken(BROKEN_IN_PROCESS[name], *run_in_process(tmp_path, BROKEN_IN_PROCESS[name], monkeypatch, capfd))


def run_in_process(directory: Path, case: Case, monkeypatch, capfd) -> tuple[int, str, str, list[str], list[str]]:
    scenario = prepare(directory, case)
    before = listing(directory)
    monkeypatch.chdir(directory)
    capfd.readouterr()
    returncode = main([str(scenario), *OUTPUTS])
    captured = capfd.readouterr()
    return returncode, captured.out, captured.err, before, listing(directory)


def test_broken_urdf_message_form(tmp_path, monkeypatch, capfd):
    _, _, stderr, _, _ = run_in_process(tmp_path, BROKEN_IN_PROCESS["moving_link_without_inertial"], monkeypatch,
                                        capfd)
    assert stderr == f"error: {(tmp_path / 'arm.urdf').resolve()}: link 'fore': moves (it is the child of a " \
                     "movable joint) but has no <inertial>\n"


def test_load_scenario_raises_input_error_naming_the_urdf(tmp_path):
    scenario = prepare(tmp_path, BROKEN["missing_mesh_strict"])
    with pytest.raises(InputError) as info:
        load_scenario(scenario)
    assert info.value.file == str((tmp_path / "arm.urdf").resolve())
    assert info.value.field == "link 'fore': visual 1: mesh"


@pytest.mark.slow  # a subprocess
def test_test_arm_runs_end_to_end(outcomes):
    process, before, after = outcomes["good"]
    assert process.returncode == 0, process.stderr
    assert "Traceback" not in process.stderr
    assert sorted(set(after) - set(before)) == ["out.json", "rec.rrd"]
    document = json.loads((outcomes["_dirs"]["good"] / "out.json").read_text(encoding="utf-8"))
    assert document["scenario"] == "urdf_test_arm"
    for name, variant in document["variants"].items():
        assert variant["status"] == "ok", name
        assert all(len(values) == 2 for values in variant["metrics"].values())
        assert max(variant["metrics"]["max_error_converged"]) < 0.02, name  # it tracks


@pytest.mark.slow  # a subprocess
def test_recording_draws_the_urdf_meshes_and_primitives(outcomes):
    """The 3-D view holds every visual of the URDF; the forearm mesh, placed by its geom transform, is the
    OBJ file's box where the URDF puts it (0.12 m along the forearm link)."""
    chunks = RrdReader(outcomes["_dirs"]["good"] / "rec.rrd").stream().to_chunks()
    static = {}
    for chunk in chunks:
        if chunk.is_static and "/geoms/" in chunk.entity_path:
            batch = chunk.to_record_batch()
            for column in batch.schema.names:
                if ":" in column:
                    static.setdefault(chunk.entity_path, {})[column] = batch.column(column).to_pylist()[0]
    assert set(static) == {"/world/base/geoms/base_block", "/world/upper/geoms/upper_tube",
                           "/world/fore/geoms/fore_bracket", "/world/hand/geoms/hand_knuckle",
                           "/world/hand/geoms/hand_finger"}
    assert "Boxes3D:half_sizes" in static["/world/base/geoms/base_block"]
    assert "Cylinders3D:radii" in static["/world/upper/geoms/upper_tube"]
    bracket = static["/world/fore/geoms/fore_bracket"]
    vertices = np.array(bracket["Mesh3D:vertex_positions"], dtype=float)
    x, y, z, w = np.array(bracket["Transform3D:quaternion"], dtype=float).ravel()
    rotation = np.zeros(9)
    mujoco.mju_quat2Mat(rotation, np.array([w, x, y, z]))
    placed = vertices @ rotation.reshape(3, 3).T + np.array(bracket["Transform3D:translation"], dtype=float).ravel()
    obj_lines = (DATA / "meshes" / "bracket.obj").read_text(encoding="utf-8").splitlines()
    obj = np.array([[float(v) for v in line.split()[1:]] for line in obj_lines if line.startswith("v ")])
    expected = obj + [0.12, 0.0, 0.0]
    assert len(placed) == len(expected)
    for vertex in expected:
        assert np.min(np.linalg.norm(placed - vertex, axis=1)) < 1e-6
    assert len(bracket["Mesh3D:triangle_indices"]) == 12


# ------------------------------------------------------------------------ URDF as ROS packages ship it

MESH_DATA = ROOT / "tests" / "data" / "meshes"
#: Two fingers on the test arm's hand, the second mimicking the first (as the Panda's gripper), and the
#: forearm drawn by a two-colour COLLADA file (as ROS description packages draw their links).
GRIPPER = """
  <joint name="finger_left" type="prismatic">
    <parent link="hand"/><child link="left"/>
    <origin xyz="0.06 0 0"/><axis xyz="0 1 0"/>
    <limit lower="0" upper="0.04" effort="20" velocity="0.2"/>
  </joint>
  <link name="left">
    <inertial><mass value="0.02"/><inertia ixx="1e-6" ixy="0" ixz="0" iyy="1e-6" iyz="0" izz="1e-6"/></inertial>
    <visual><geometry><box size="0.01 0.01 0.02"/></geometry></visual>
  </link>
  <joint name="finger_right" type="prismatic">
    <parent link="hand"/><child link="right"/>
    <origin xyz="0.06 0 0"/><axis xyz="0 -1 0"/>
    <limit lower="0" upper="0.04" effort="20" velocity="0.2"/>
    <mimic joint="finger_left" multiplier="0.5" offset="0.01"/>
  </joint>
  <link name="right">
    <inertial><mass value="0.02"/><inertia ixx="1e-6" ixy="0" ixz="0" iyy="1e-6" iyz="0" izz="1e-6"/></inertial>
    <visual><geometry><box size="0.01 0.01 0.02"/></geometry></visual>
  </link>
</robot>"""


def ros_arm(directory: Path) -> Path:
    """The test arm with the gripper and the COLLADA forearm, its mesh given as package://test_arm/..."""
    package = directory / "test_arm"
    shutil.copytree(DATA / "meshes", package / "meshes")
    shutil.copy(MESH_DATA / "two_colours.dae", package / "meshes" / "forearm.dae")
    text = ARM_URDF.read_text(encoding="utf-8").replace("</robot>", GRIPPER)
    fore = ('<geometry><mesh filename="meshes/bracket.obj"/></geometry>\n      <material name="grey"/>')
    assert fore in text
    text = text.replace(fore, '<geometry><mesh filename="package://test_arm/meshes/forearm.dae"/></geometry>')
    text = text.replace('filename="meshes/bracket.obj"', 'filename="../meshes/bracket.obj"')
    (package / "urdf").mkdir()
    urdf = package / "urdf" / "arm.urdf"
    urdf.write_text(text, encoding="utf-8")
    return urdf


@pytest.fixture()
def mesh_cache(tmp_path, monkeypatch) -> Path:
    monkeypatch.setenv("FTC_MJ_CACHE_DIR", str(tmp_path / "cache"))
    return tmp_path / "cache"


def test_collada_visual_and_locked_mimic_joint(tmp_path, mesh_cache):
    urdf = ros_arm(tmp_path)
    before = sorted(p.name for p in urdf.parent.parent.rglob("*"))
    model = load_model(urdf, lock={"wrist": 0.3, "finger_left": 0.02}, source="test")
    assert [model.joint(i).name for i in range(model.njnt)] == ["shoulder", "elbow"]
    # The mimic finger is locked with its leader at 0.5 * 0.02 + 0.01 = 0.02 m along its axis (0, -1, 0).
    np.testing.assert_allclose(model.body("right").pos, [0.06, -0.02, 0.0], atol=1e-15)
    np.testing.assert_allclose(model.body("left").pos, [0.06, 0.02, 0.0], atol=1e-15)
    # The forearm's COLLADA file: two parts, each with its file's colour (the visual has no material).
    fore = [g for g in range(model.ngeom) if model.geom_bodyid[g] == model.body("fore").id]
    assert len(fore) == 2 and all(model.geom_type[g] == mujoco.mjtGeom.mjGEOM_MESH for g in fore)
    colours = sorted(tuple(np.round(model.geom_rgba[g], 3)) for g in fore)
    assert colours == [(0.102, 0.2, 0.902, 1.0), (0.8, 0.102, 0.102, 1.0)]
    assert sorted(p.name for p in urdf.parent.parent.rglob("*")) == before  # nothing written beside the files
    assert any(mesh_cache.rglob("*.obj"))


def test_mimic_joint_given_its_own_value_must_agree(tmp_path, mesh_cache):
    urdf = ros_arm(tmp_path)
    load_model(urdf, lock={"wrist": 0.3, "finger_left": 0.02, "finger_right": 0.02}, source="test")  # agrees
    with pytest.raises(InputError) as info:
        load_model(urdf, lock={"wrist": 0.3, "finger_left": 0.02, "finger_right": 0.03}, source="s.yaml")
    assert info.value.field == "robot.lock.finger_right" and "disagrees with the mimic" in info.value.problem


@pytest.mark.parametrize("lock", [{"wrist": 0.3}, {"wrist": 0.3, "finger_right": 0.02}])
def test_free_mimic_joint_is_refused(tmp_path, mesh_cache, lock):
    """A mimic joint has no motor of its own: it must follow a locked leader."""
    with pytest.raises(InputError) as info:
        load_model(ros_arm(tmp_path), lock=lock, source="s.yaml")
    assert info.value.field == "robot.lock" and "mimics 'finger_left'" in info.value.problem


def test_fixed_joint_with_a_mimic_constrains_nothing(tmp_path, mesh_cache):
    """A <mimic> on a fixed joint (TALOS's gripper parts) is ignored: not locked, not refused, even when its
    leader is held because robot.joints leaves it out."""
    urdf = ros_arm(tmp_path)
    text = urdf.read_text(encoding="utf-8").replace("</robot>", """
  <joint name="finger_pad" type="fixed">
    <parent link="left"/><child link="pad"/>
    <mimic joint="finger_left" multiplier="-1.0" offset="0.0"/>
  </joint>
  <link name="pad"/>
</robot>""")
    urdf.write_text(text, encoding="utf-8")
    model = load_model(urdf, joints=["shoulder", "elbow"], lock={"finger_left": 0.02}, source="s.yaml")
    assert [model.joint(i).name for i in range(model.njnt)] == ["shoulder", "elbow"]
    assert model.body("pad").pos.tolist() == [0.0, 0.0, 0.0]
    # a fixed joint named in robot.lock is still refused: there is nothing to lock
    with pytest.raises(InputError) as info:
        load_model(urdf, lock={"wrist": 0.3, "finger_left": 0.02, "finger_pad": 0.0}, source="s.yaml")
    assert info.value.field == "robot.lock.finger_pad" and "is fixed" in info.value.problem


def test_three_slash_package_mesh_is_found(tmp_path, mesh_cache, monkeypatch):
    urdf = ros_arm(tmp_path)
    text = urdf.read_text(encoding="utf-8")
    assert "package://test_arm/" in text
    urdf.write_text(text.replace("package://test_arm/", "package:///test_arm/"), encoding="utf-8")
    monkeypatch.setenv("ROS_PACKAGE_PATH", str(tmp_path))
    model = load_model(urdf, lock={"wrist": 0.3, "finger_left": 0.02}, source="s.yaml", strict_meshes=True)
    fore = [g for g in range(model.ngeom) if model.geom_bodyid[g] == model.body("fore").id]
    assert len(fore) == 2 and all(model.geom_type[g] == mujoco.mjtGeom.mjGEOM_MESH for g in fore)


def test_closed_loop_is_still_one_line(tmp_path, mesh_cache):
    urdf = ros_arm(tmp_path)
    text = urdf.read_text(encoding="utf-8").replace("</robot>", """
  <joint name="closing" type="revolute">
    <parent link="right"/><child link="left"/><axis xyz="0 0 1"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/>
  </joint>
</robot>""")
    urdf.write_text(text, encoding="utf-8")
    with pytest.raises(InputError) as info:
        load_model(urdf, lock={"wrist": 0.3, "finger_left": 0.02}, source="s.yaml")
    assert "closed kinematic loops are not supported" in info.value.problem and "\n" not in str(info.value)


def test_controlled_joints_lock_the_others(tmp_path, mesh_cache):
    """robot.joints on a URDF: the joints not named are locked (at their lock value, else 0); names in order."""
    urdf = ros_arm(tmp_path)
    model = load_model(urdf, joints=["elbow", "wrist"], lock={"finger_left": 0.0}, source="test")
    assert [model.joint(i).name for i in range(model.njnt)] == ["elbow", "wrist"]
    for joints, field, problem in [(["wrist", "elbow"], "robot.joints", "kinematic order"),
                                   (["elbow", "knee"], "robot.joints.1", "no movable joint 'knee'"),
                                   (["elbow", "finger_left"], "robot.joints.1", "also in robot.lock")]:
        with pytest.raises(InputError) as info:
            load_model(urdf, joints=joints, lock={"finger_left": 0.0}, source="s.yaml")
        assert info.value.field == field and problem in info.value.problem, (joints, info.value)


def test_ros_arm_records_its_collada_meshes(tmp_path, mesh_cache, monkeypatch, capfd):
    """Through the command line, with package:// resolved from ROS_PACKAGE_PATH: the recording draws both
    COLLADA parts where the URDF puts them, in their colours."""
    urdf = ros_arm(tmp_path / "ros")
    monkeypatch.setenv("ROS_PACKAGE_PATH", str(tmp_path / "ros"))
    data = yaml.safe_load(ARM_YAML.read_text(encoding="utf-8"))
    data["robot"] = {"model": "package://test_arm/urdf/arm.urdf", "lock": {"wrist": 0.3, "finger_left": 0.04}}
    data["duration"] = 0.05
    scenario = tmp_path / "ros.yaml"
    scenario.write_text(yaml.safe_dump(data, sort_keys=False), encoding="utf-8")
    monkeypatch.chdir(tmp_path)
    assert main([str(scenario), "--out", "rec.rrd", "--quiet"]) == 0, capfd.readouterr().err
    static: dict[str, dict] = {}
    for chunk in RrdReader(tmp_path / "rec.rrd").stream().to_chunks():
        if chunk.is_static and chunk.entity_path.startswith("/world/fore/geoms/"):
            batch = chunk.to_record_batch()
            for column in (c for c in batch.schema.names if ":" in c):
                static.setdefault(chunk.entity_path, {})[column] = batch.column(column).to_pylist()[0]
    meshes = {path: fields for path, fields in static.items() if "Mesh3D:vertex_positions" in fields}
    assert len(meshes) == 2
    placed = []
    for mesh in meshes.values():  # MuJoCo centres a mesh; its geom frame puts it back
        x, y, z, w = np.array(mesh["Transform3D:quaternion"], dtype=float).ravel()
        rotation = np.zeros(9)
        mujoco.mju_quat2Mat(rotation, np.array([w, x, y, z]))
        vertices = np.array(mesh["Mesh3D:vertex_positions"], dtype=float)
        placed.append(vertices @ rotation.reshape(3, 3).T + np.array(mesh["Transform3D:translation"], dtype=float).ravel())
    corners = sorted(sorted(map(tuple, np.round(p, 9))) for p in placed)
    # the squares of the file (millimetres) in metres, 0.12 m along the forearm, the second 15 mm up
    expected = [sorted((0.12 + a, b, h) for a in (0.0, 0.1) for b in (0.0, 0.1)) for h in (0.0, 0.015)]
    np.testing.assert_allclose(corners, expected, atol=1e-9)
    assert urdf.is_file()


def _chain(limits: list[tuple[float, float]]) -> str:
    """A URDF chain of revolute joints ``j1``, ``j2``, ... with these limits."""
    inertial = ('<inertial><origin xyz="0.1 0 0"/><mass value="1"/><inertia ixx="0.01" ixy="0" ixz="0" '
                'iyy="0.01" iyz="0" izz="0.01"/></inertial>')
    links = "".join(f'<link name="l{k}">{inertial}</link>' for k in range(len(limits) + 1))
    joints = "".join(f'<joint name="j{k + 1}" type="revolute"><parent link="l{k}"/><child link="l{k + 1}"/>'
                     f'<origin xyz="0.2 0 0"/><axis xyz="0 0 1"/><limit lower="{lower}" upper="{upper}" effort="10" '
                     'velocity="1"/></joint>' for k, (lower, upper) in enumerate(limits))
    return f'<robot name="chain">{links}{joints}</robot>'


def test_a_locked_joint_whose_limits_exclude_0_is_held_at_its_nearest_limit_with_one_warning(tmp_path, caplog):
    """One arm of a humanoid whose other arm's elbow cannot straighten (TALOS: [-2.87, -0.0087]): the joint
    left out of ``robot.joints`` is locked at its limit nearest 0, with one warning line saying so."""
    path = tmp_path / "chain.urdf"
    path.write_text(_chain([(-1.0, 1.0), (-2.87, -0.0087), (0.2, 1.5), (-1.0, 1.0)]))
    with caplog.at_level("WARNING", logger="ftc_mj.robot"):
        held = load_model(path, joints=["j1", "j4"], source="s.yaml")
    warnings = [r.getMessage() for r in caplog.records if "nearest 0" in r.getMessage()]
    assert warnings == ["warning: s.yaml: robot.lock: 2 joint(s) not in robot.joints are locked at their limit "
                        "nearest 0, which is outside their limits: j2 at -0.0087 (limits [-2.87, -0.0087]); j3 at 0.2 "
                        "(limits [0.2, 1.5]) (robot.lock sets another value)"]
    explicit = load_model(path, joints=["j1", "j4"], lock={"j2": -0.0087, "j3": 0.2}, source="s.yaml")
    data, same = mujoco.MjData(held), mujoco.MjData(explicit)
    mujoco.mj_forward(held, data)
    mujoco.mj_forward(explicit, same)
    assert held.nv == 2 and np.allclose(data.xpos, same.xpos, atol=1e-12)
