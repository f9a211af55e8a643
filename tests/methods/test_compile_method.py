"""ftc_mj.methods.registry.compile_method and Plugins, called directly: the exact one-line messages
(``FILE: FIELD: PROBLEM``) of an unknown name, a plugin that cannot be imported, and missing gains (one, two,
three), the gains sized for the robot's joints, and the names of a registry without importing anything."""

from __future__ import annotations

from importlib.metadata import EntryPoint

import numpy as np
import pytest

from ftc_mj.config.errors import InputError
from ftc_mj.methods.gains import GainConfig, PositiveFloat, PositiveJoints
from ftc_mj.methods.registry import MethodSpec, Plugins, compile_method


class ThreeGains(GainConfig):
    alpha: PositiveFloat
    beta: PositiveJoints
    gamma: PositiveFloat
    delta: PositiveFloat = 1.0


class Law:
    Config = ThreeGains


class Other:
    Config = ThreeGains


KNOWN = {"law": Law, "other": Other}


def message(method: MethodSpec, known=KNOWN, n: int = 3) -> str:
    with pytest.raises(InputError) as info:
        compile_method("s.yaml", "variants.a.controller", method, known, "controller", n)
    return str(info.value)


def test_an_unknown_name_lists_the_known_ones():
    assert message(MethodSpec(type="lwa")) == (
        "s.yaml: variants.a.controller.type: unknown controller 'lwa' (known: law, other)")


def test_a_plugin_that_cannot_be_imported_names_its_entry_point():
    broken = Plugins({}, {"broken": EntryPoint(name="broken", value="ftc_mj_no_such_module:X",
                                                 group="ftc_mj.controllers")})
    assert message(MethodSpec(type="broken"), broken).startswith(
        "s.yaml: variants.a.controller.type: plugin 'broken' (ftc_mj_no_such_module:X) cannot be imported: ")


@pytest.mark.parametrize(("gains", "expected"), [
    ({"alpha": 1.0, "beta": 2.0}, "gamma: required field is missing (controller 'law' has no default for it)"),
    ({"alpha": 1.0}, "beta: required field is missing (controller 'law' has no default for it; it also needs "
                     "gamma)"),
    ({}, "alpha: required field is missing (controller 'law' has no default for it; it also needs beta, gamma)"),
])
def test_missing_gains_are_named_in_one_line(gains, expected):
    assert message(MethodSpec(type="law", gains=gains)) == f"s.yaml: variants.a.controller.gains.{expected}"


def test_a_bad_gain_names_the_file_and_the_field():
    assert message(MethodSpec(type="law", gains={"alpha": -1.0, "beta": 2.0, "gamma": 3.0})).startswith(
        "s.yaml: variants.a.controller.gains.alpha: ")


def test_the_gains_have_one_value_per_joint_of_the_robot():
    plugin, config = compile_method("s.yaml", "c", MethodSpec(type="other", gains={"alpha": 1.0, "beta": 2.0,
                                                                                   "gamma": 3.0}),
                                    KNOWN, "controller", 4)
    assert plugin is Other and isinstance(config, ThreeGains)
    np.testing.assert_array_equal(config.beta, [2.0, 2.0, 2.0, 2.0])
    assert config.alpha == 1.0 and config.delta == 1.0
    # A list must match the robot's joints.
    assert message(MethodSpec(type="law", gains={"alpha": 1.0, "beta": [2.0, 3.0], "gamma": 3.0}), n=3) == (
        "s.yaml: variants.a.controller.gains.beta: has 2 values, the robot has 3 joints")


def test_without_a_robot_a_list_gain_is_taken_as_given():
    """Validated without the ``n_joints`` context (a plugin's own unit test): a list is one value per joint,
    a number one value."""
    config = ThreeGains.model_validate({"alpha": 1.0, "beta": [2.0, 3.0, 4.0], "gamma": 1.0})
    np.testing.assert_array_equal(config.beta, [2.0, 3.0, 4.0])
    np.testing.assert_array_equal(ThreeGains.model_validate({"alpha": 1.0, "beta": 2.0, "gamma": 1.0}).beta, [2.0])


def test_the_registry_lists_built_ins_then_declared_names_without_importing():
    declared = {name: EntryPoint(name=name, value=f"ftc_mj_no_such_module:{name}", group="ftc_mj.observers")
                for name in ("third", "law")}
    plugins = Plugins({"law": Law, "other": Other}, declared)
    assert list(plugins) == ["law", "other", "third"] and len(plugins) == 3
    assert "third" in plugins and "fourth" not in plugins
    assert plugins["law"] is Law  # the built-in, not the declared entry of the same name
