"""Visual mesh files that are missing (ftc_mj.robot.visuals, through ftc_mj.robot.model and ftc_mj.robot.urdf).

* A Menagerie-form MJCF copied without its ``assets/`` folder (built here from models/ur5e.xml: one visual
  mesh geom per body, ``meshdir="assets"``) loads with the mesh geoms dropped, one warning line naming the
  resolved folder, and the same dynamics as the model without those geoms; ``robot.strict_meshes`` refuses it
  naming the resolved path; a body without an explicit inertial, or a mesh used for contacts, is refused.
* An MJCF in the testbed's form (used as it is) with a missing visual mesh: the same dynamics as the file
  without it.
* A URDF with a missing mesh: dropped with one warning line, the same dynamics as with the mesh present;
  strict: refused naming the path looked for.
"""

from __future__ import annotations

import logging
import re
import shutil
from pathlib import Path

import mujoco
import numpy as np
import pytest
import yaml

from ftc_mj.config.errors import InputError
from ftc_mj.robot import urdf
from ftc_mj.scenario.loading import load_scenario

ROOT = Path(__file__).resolve().parents[2]
UR5E_XML = ROOT / "models" / "ur5e.xml"
UR5E_YAML = ROOT / "scenarios" / "robots" / "ur5e_fault.yaml"
PUMA_XML = ROOT / "models" / "puma560.xml"
DATA = ROOT / "tests" / "data" / "urdf"


def menagerie_form(folder: Path, *, drop_inertial: str | None = None, collision_mesh: bool = False) -> Path:
    """models/ur5e.xml as Menagerie ships its arms: ``meshdir="assets"`` and a visual mesh geom per body,
    written in ``folder`` without the ``assets/`` folder."""
    text = UR5E_XML.read_text(encoding="utf-8")
    text = text.replace('<compiler angle="radian" autolimits="true"/>',
                        '<compiler angle="radian" meshdir="assets" autolimits="true"/>')
    bodies = re.findall(r'<body name="(\w+)"', text)
    assets = "".join(f'\n    <mesh name="{b}_0" file="{b}_0.obj"/>' for b in bodies)
    text = text.replace("<asset>", f"<asset>{assets}", 1)
    for body in bodies:
        pattern = re.compile(rf'(<body name="{body}"[^>]*>\s*<inertial[^>]*/>)')
        geom = f'<geom mesh="{body}_0" class="visual" type="mesh"/>'
        if collision_mesh and body == "wrist_3_link":
            geom = f'<geom mesh="{body}_0" type="mesh"/>'  # collides (the default contype and conaffinity)
        if body == drop_inertial:  # drawn only, but with the default density: its mass counts
            geom = f'<geom mesh="{body}_0" type="mesh" contype="0" conaffinity="0" group="2"/>'
        text = pattern.sub(rf'\1\n      {geom}', text, count=1)
    if drop_inertial is not None:
        text = re.sub(rf'(<body name="{drop_inertial}"[^>]*>)\s*<inertial[^>]*/>', r'\1', text, count=1)
    path = folder / "ur5e_menagerie.xml"
    path.write_text(text, encoding="utf-8")
    assert text.count('type="mesh"') == len(bodies) == 7 and not (folder / "assets").exists()
    return path


def scenario_on(folder: Path, model: Path, **robot) -> Path:
    data = yaml.safe_load(UR5E_YAML.read_text(encoding="utf-8"))
    data["base"] = str(UR5E_YAML.parent / data["base"])  # the copy names the same base
    data["robot"]["model"] = model.name
    data["robot"].update(robot)
    data["duration"] = 0.2
    path = folder / "scenario.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False), encoding="utf-8")
    return path


def dynamics(model: mujoco.MjModel, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """M(q) and the bias forces at q (qd = 0.3): everything the loop's dynamics read from the model."""
    data = mujoco.MjData(model)
    data.qpos[:], data.qvel[:] = q, 0.3
    mujoco.mj_forward(model, data)
    M = np.zeros((model.nv, model.nv))
    mujoco.mj_fullM(model, data, M)
    return M, data.qfrc_bias.copy()


def test_menagerie_form_without_assets_loads_with_one_warning(tmp_path, caplog):
    model_path = menagerie_form(tmp_path)
    with caplog.at_level(logging.WARNING, logger="ftc_mj.robot"):
        scenario = load_scenario(scenario_on(tmp_path, model_path))
    lines = [r.getMessage() for r in caplog.records if r.name == "ftc_mj.robot"]
    assert len(lines) == 1 and "\n" not in lines[0]
    assert "7 visual mesh file(s) missing" in lines[0] and "7 geom(s) dropped" in lines[0]
    assert f"{(tmp_path / 'assets').resolve()}/{{base_0.obj, " in lines[0]  # the resolved folder
    assert not any(scenario.model.geom_type == mujoco.mjtGeom.mjGEOM_MESH)
    # the same dynamics as the shipped model (the primitives it draws with change nothing either)
    shipped = load_scenario(UR5E_YAML, overrides=["duration=0.2"]).model
    np.testing.assert_array_equal(scenario.model.body_mass, shipped.body_mass)
    np.testing.assert_array_equal(scenario.model.body_inertia, shipped.body_inertia)
    q = np.array([0.1, -1.2, 1.3, -1.4, -1.5, 0.2])
    for ours, theirs in zip(dynamics(scenario.model, q), dynamics(shipped, q)):
        np.testing.assert_array_equal(ours, theirs)


def test_strict_meshes_refuses_naming_the_resolved_path(tmp_path):
    model_path = menagerie_form(tmp_path)
    with pytest.raises(InputError) as info:
        load_scenario(scenario_on(tmp_path, model_path, strict_meshes=True))
    assert info.value.field == "robot.model"
    assert f"looked for {(tmp_path / 'assets' / 'base_0.obj').resolve()}" in str(info.value)
    assert "strict_meshes" in str(info.value)


def test_a_mesh_that_gives_mass_is_refused(tmp_path):
    model_path = menagerie_form(tmp_path, drop_inertial="forearm_link")
    with pytest.raises(InputError) as info:
        load_scenario(scenario_on(tmp_path, model_path))
    message = str(info.value)
    assert f"looked for {(tmp_path / 'assets' / 'forearm_link_0.obj').resolve()}" in message
    assert "body 'forearm_link'" in message and "mass" in message


def test_a_collision_mesh_is_refused_only_when_contacts_are_kept(tmp_path):
    model_path = menagerie_form(tmp_path, collision_mesh=True)
    load_scenario(scenario_on(tmp_path, model_path))  # contacts off (the testbed's convention): dropped
    with pytest.raises(InputError) as info:
        load_scenario(scenario_on(tmp_path, model_path, contacts="keep"))
    assert "takes part in contacts" in str(info.value)
    assert str((tmp_path / "assets" / "wrist_3_link_0.obj").resolve()) in str(info.value)


def test_testbed_form_mjcf_with_a_missing_visual_mesh_keeps_its_dynamics(tmp_path, caplog):
    text = PUMA_XML.read_text(encoding="utf-8")
    body = '<body name="link1" childclass="link1" pos="0 0 0.67183">'  # a body with an explicit inertial
    assert body in text
    text = text.replace(body, body + '\n<geom type="mesh" mesh="logo" contype="0" conaffinity="0"/>', 1)
    text = text.replace("</mujoco>", '<asset><mesh name="logo" file="meshes/logo.stl"/></asset>\n</mujoco>')
    (tmp_path / "puma.xml").write_text(text, encoding="utf-8")
    data = yaml.safe_load((ROOT / "scenarios" / "puma_fault.yaml").read_text(encoding="utf-8"))
    data["robot"]["model"] = "puma.xml"
    data.pop("figures")
    (tmp_path / "puma.yaml").write_text(yaml.safe_dump(data, sort_keys=False), encoding="utf-8")
    with caplog.at_level(logging.WARNING, logger="ftc_mj.robot"):
        ours = load_scenario(tmp_path / "puma.yaml").model
    assert [r.getMessage().count(str((tmp_path / "meshes" / "logo.stl").resolve())) for r in caplog.records] == [1]
    shipped = mujoco.MjModel.from_xml_path(str(PUMA_XML))
    assert ours.ngeom == shipped.ngeom
    q = np.array([-0.5, 0.3, 0.2])
    for a, b in zip(dynamics(ours, q), dynamics(shipped, q)):
        np.testing.assert_array_equal(a, b)


def test_urdf_with_a_missing_mesh_drops_its_visual(tmp_path, caplog):
    shutil.copytree(DATA / "meshes", tmp_path / "meshes")
    text = (DATA / "arm.urdf").read_text(encoding="utf-8")
    assert 'filename="meshes/bracket.obj"' in text
    (tmp_path / "full.urdf").write_text(text, encoding="utf-8")
    (tmp_path / "gone.urdf").write_text(text.replace("meshes/bracket.obj", "meshes/gone.obj"), encoding="utf-8")
    full = urdf.load_model(tmp_path / "full.urdf", source="s.yaml")
    with caplog.at_level(logging.WARNING, logger="ftc_mj.robot"):
        gone = urdf.load_model(tmp_path / "gone.urdf", source="s.yaml")
    lines = [r.getMessage() for r in caplog.records]
    assert len(lines) == 1 and "\n" not in lines[0]
    assert lines[0].startswith("warning: s.yaml: robot.model: gone.urdf: 1 visual mesh file(s) missing")
    assert f"looked for {(tmp_path / 'meshes' / 'gone.obj').resolve()}" in lines[0]
    assert gone.ngeom == full.ngeom - 2  # the bracket draws two links
    q = np.full(full.nv, 0.3)
    for a, b in zip(dynamics(gone, q), dynamics(full, q)):
        np.testing.assert_array_equal(a, b)
    with pytest.raises(InputError) as info:
        urdf.load_model(tmp_path / "gone.urdf", source="s.yaml", strict_meshes=True)
    assert info.value.field.endswith(": mesh")
    assert f"looked for {(tmp_path / 'meshes' / 'gone.obj').resolve()}" in str(info.value)


def test_urdf_mesh_of_a_package_not_installed_is_dropped(tmp_path, caplog):
    shutil.copytree(DATA / "meshes", tmp_path / "meshes")
    text = (DATA / "arm.urdf").read_text(encoding="utf-8")
    (tmp_path / "arm.urdf").write_text(text.replace("meshes/bracket.obj", "package://no_such_pkg/m.obj"),
                                       encoding="utf-8")
    with caplog.at_level(logging.WARNING, logger="ftc_mj.robot"):
        urdf.load_model(tmp_path / "arm.urdf", source="s.yaml")
    assert "package://no_such_pkg/m.obj (no ROS package of that name here)" in caplog.records[0].getMessage()
