"""package:// names (ftc_mj.robot.packages): the folders above the file, ROS_PACKAGE_PATH, AMENT_PREFIX_PATH and
the ROS packages that Python packages install (a prefix with ROS 2's package index inside site-packages, as
the cmeel wheels of example-robot-data have)."""

from __future__ import annotations

import site
from pathlib import Path

import pytest

from ftc_mj.robot import packages
from ftc_mj.robot.packages import package_roots, resolve_package_uri, split_package_uri


def make_prefix(prefix: Path, package: str) -> Path:
    """An install prefix holding ROS package ``package`` with one mesh file; returns the file."""
    (prefix / "share" / "ament_index" / "resource_index" / "packages").mkdir(parents=True)
    (prefix / "share" / "ament_index" / "resource_index" / "packages" / package).write_text("")
    mesh = prefix / "share" / package / "meshes" / "part.stl"
    mesh.parent.mkdir(parents=True)
    mesh.write_text("solid x\nendsolid x\n")
    return mesh


@pytest.fixture()
def clean_environment(monkeypatch):
    for variable in ("ROS_PACKAGE_PATH", "AMENT_PREFIX_PATH"):
        monkeypatch.delenv(variable, raising=False)
    packages._python_prefixes.cache_clear()
    yield monkeypatch
    packages._python_prefixes.cache_clear()


def test_split():
    assert split_package_uri("package://arm/meshes/a.dae") == ("arm", "meshes/a.dae")
    assert split_package_uri("package://arm%20x/a") == ("arm x", "a")
    assert split_package_uri("package://arm") is None
    # an empty host, as some exporters write (TALOS's full URDF): the same file
    assert split_package_uri("package:///arm/meshes/a.dae") == ("arm", "meshes/a.dae")
    assert split_package_uri("package:///arm") is None
    assert split_package_uri("meshes/a.dae") is None


def test_ament_prefix_path(tmp_path, clean_environment):
    mesh = make_prefix(tmp_path / "install", "my_arm")
    assert resolve_package_uri("package://my_arm/meshes/part.stl") is None
    clean_environment.setenv("AMENT_PREFIX_PATH", str(tmp_path / "install"))
    assert resolve_package_uri("package://my_arm/meshes/part.stl") == mesh.resolve()
    assert resolve_package_uri("package://my_arm/meshes/other.stl") is None


def test_prefix_installed_by_a_python_package(tmp_path, clean_environment):
    site_packages = tmp_path / "site-packages"
    mesh = make_prefix(site_packages / "cmeel.prefix", "my_arm")
    clean_environment.setattr(site, "getsitepackages", lambda: [str(site_packages)])
    packages._python_prefixes.cache_clear()
    assert resolve_package_uri("package://my_arm/meshes/part.stl") == mesh.resolve()
    # only prefixes that list the package are searched
    assert site_packages / "cmeel.prefix" / "share" / "other" not in package_roots("other")


def test_lookup_order_folder_above_first(tmp_path, clean_environment):
    above = tmp_path / "work" / "my_arm" / "meshes" / "part.stl"
    above.parent.mkdir(parents=True)
    above.write_text("solid x\nendsolid x\n")
    make_prefix(tmp_path / "install", "my_arm")
    clean_environment.setenv("AMENT_PREFIX_PATH", str(tmp_path / "install"))
    near = tmp_path / "work" / "my_arm" / "urdf"
    assert resolve_package_uri("package://my_arm/meshes/part.stl", near) == above.resolve()


def test_example_robot_data_when_installed():
    """example-robot-data ships its robots as the ROS package ``example-robot-data`` in a cmeel prefix."""
    found = resolve_package_uri("package://example-robot-data/robots/ur_description/urdf/ur5_robot.urdf")
    if found is None:
        pytest.skip("example-robot-data is not installed")
    assert found.is_file() and found.name == "ur5_robot.urdf"


def test_a_missing_example_robot_data_robot_says_how_to_install_it(tmp_path):
    """Whether or not the robots extra is installed, a file it does not have is not found, and the message
    gives the command that installs the extra."""
    from ftc_mj import load_scenario
    from ftc_mj.config.errors import InputError

    scenario = Path(__file__).resolve().parents[2] / "scenarios" / "two_link_do.yaml"
    with pytest.raises(InputError) as error:
        load_scenario(scenario, overrides=["robot.model=package://example-robot-data/robots/none/none.urdf"])
    assert 'pip install -e ".[robots]"' in str(error.value) and "robot.model" in str(error.value)
