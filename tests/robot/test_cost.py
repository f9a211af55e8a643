"""What a robot file may cost (ftc_mj.robot.cost): each bound refused with its name before MuJoCo parses the
file, and the files a model reads (its includes and meshes), which no output of a run may replace."""

from __future__ import annotations

from pathlib import Path

import pytest

from ftc_mj.config.errors import InputError
from ftc_mj.robot import cost
from ftc_mj.robot.model import model_files

ROOT = Path(__file__).resolve().parents[2]


def _error(call, *args) -> str:
    with pytest.raises(InputError) as raised:
        call(*args)
    return str(raised.value)


def test_an_mjcf_within_its_bounds_reads_its_includes_and_meshes(tmp_path):
    (tmp_path / "meshes").mkdir()
    (tmp_path / "meshes" / "part.stl").write_bytes(b"solid x\nendsolid x\n")
    (tmp_path / "assets.xml").write_text('<mujoco><asset><mesh file="part.stl"/></asset></mujoco>')
    (tmp_path / "robot.xml").write_text('<mujoco><compiler meshdir="meshes"/><include file="assets.xml"/>'
                                        '<worldbody><replicate count="10"><body><geom size="0.1"/></body>'
                                        '</replicate></worldbody></mujoco>')
    found = cost.mjcf_files(tmp_path / "robot.xml", "s.yaml", "robot.model")
    assert found == [(tmp_path / name).resolve() for name in ("robot.xml", "assets.xml", "meshes/part.stl")]


def test_each_bound_is_named(tmp_path, monkeypatch):
    path = tmp_path / "robot.xml"
    path.write_text('<mujoco><worldbody><replicate count="3"><replicate count="4"><body><geom size="0.1"/></body>'
                    '</replicate></replicate></worldbody></mujoco>')
    monkeypatch.setattr(cost, "MAX_BODIES", 11)
    assert _error(cost.mjcf_files, path, "s.yaml", "robot.model") == (
        "s.yaml: robot.model: robot.xml has more than 11 bodies, replicated ones counted (MAX_BODIES)")
    monkeypatch.setattr(cost, "MAX_BODIES", 12)
    assert cost.mjcf_files(path, "s.yaml", "robot.model") == [path.resolve()]
    monkeypatch.setattr(cost, "MAX_ELEMENTS", 20)  # 1 worldbody + 3 + 12 bodies + 12 geoms
    assert "(MAX_ELEMENTS)" in _error(cost.mjcf_files, path, "s.yaml", "robot.model")
    monkeypatch.setattr(cost, "MAX_MODEL_BYTES", 10)
    assert "(MAX_MODEL_BYTES)" in _error(cost.mjcf_files, path, "s.yaml", "robot.model")


def test_a_mesh_larger_than_the_bound_and_an_include_loop(tmp_path, monkeypatch):
    (tmp_path / "big.stl").write_bytes(b"x" * 100)
    (tmp_path / "robot.xml").write_text('<mujoco><asset><mesh file="big.stl"/></asset></mujoco>')
    monkeypatch.setattr(cost, "MAX_MESH_BYTES", 99)
    assert _error(cost.mjcf_files, tmp_path / "robot.xml", "s.yaml", "robot.model") == (
        f"s.yaml: robot.model: '{tmp_path / 'big.stl'}' is 0 MiB, more than the 0 MiB a mesh file may have "
        "(MAX_MESH_BYTES)")
    (tmp_path / "a.xml").write_text('<mujoco><include file="b.xml"/></mujoco>')
    (tmp_path / "b.xml").write_text('<mujoco><include file="a.xml"/></mujoco>')
    assert "(MAX_INCLUDES)" in _error(cost.mjcf_files, tmp_path / "a.xml", "s.yaml", "robot.model")


def test_a_urdf_reads_its_meshes(tmp_path):
    found = model_files(ROOT / "tests" / "data" / "urdf" / "arm.urdf", "s.yaml")
    assert found[0] == (ROOT / "tests" / "data" / "urdf" / "arm.urdf").resolve()
    assert any(path.suffix == ".obj" for path in found[1:])
