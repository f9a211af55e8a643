"""Members and batching: the declared batchable fields (parsed, refused), each override validated against its
section and applied to its member only, the compiled scenario's configs reused (nothing compiled again), and
the stacked values equal to those of the scenario re-validated whole with the member's overrides."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

from ftc_mj.config.errors import InputError
from ftc_mj.engine.batching import (FIELD_KINDS, NOT_BATCHABLE, MemberField, batchable, member_field, stack,
                                    stack_select, stack_states)
from ftc_mj.engine.members import Members, members_from_overrides, replicates, single
from ftc_mj.methods.controllers.nftsmc import NFTSMCConfig
from ftc_mj.scenario.loading import load_scenario

ROOT = Path(__file__).resolve().parents[2]
NFTSMC = {"beta1": 15.0, "beta2": 10.0, "beta3": 10.0, "beta4": 5.0, "gamma1": 0.5, "bound": 0.5, "mu": 0.5}


def scenario_dict() -> dict[str, Any]:
    return {
        "name": "members_test",
        "robot": {"model": str(ROOT / "models" / "puma560.xml")},
        "seed": 3,
        "duration": 0.05,
        "initial": {"q": [-0.5, -0.4, -0.3]},
        "observer_initial": {"q_hat": [0.1, 0.2, 0.3], "qd_hat": [0.5, 0.5, 0.5]},
        "parameters": {"fault_scale": 1.0, "fault_rate": 20.0},
        "reference": ["0", "0", "0"],
        "terms": [{"kind": "fault", "space": "acceleration", "sign": 1, "onset": 0.01, "rate": "fault_rate",
                   "value": ["fault_scale*sin(q1)", "0", "0"]}],
        "variants": {
            "hs": {"observer": {"type": "hs_tosmo", "gains": {"D": 22.0, "gamma": 5.0}},
                   "controller": {"type": "nftsmc", "gains": {**NFTSMC, "bound": [0.5, 0.6, 0.7]}},
                   "monitors": {"eso": {"type": "eso", "gains": {"bandwidth": 60.0}}}},
            "own": {"observer": {"type": "eso", "gains": {"bandwidth": 40.0}},
                    "controller": {"type": "smc", "gains": {"c": 10.0, "bound": 5.0, "mu": 0.5}},
                    "observer_initial": {"qd_hat": [0.0, 0.1, 0.2]}},
        },
        "metrics": {"window_start": 0.01, "estimation_window_start": 0.01},
    }


@pytest.fixture(scope="module")
def path(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("members") / "members.yaml"
    path.write_text(yaml.safe_dump(scenario_dict(), sort_keys=False), encoding="utf-8")
    return path


@pytest.fixture(scope="module")
def scenario(path):
    return load_scenario(path)


# ------------------------------------------------------------------------------------------- the declared fields


@pytest.mark.parametrize("path, expected", [
    ("seed", MemberField("seed", "seed", "seed")),
    ("initial.q", MemberField("initial.q", "initial", "q")),
    ("initial.qd.2", MemberField("initial.qd.2", "initial", "qd", element=2)),
    ("observer_initial.q_hat", MemberField("observer_initial.q_hat", "observer_initial", "q_hat")),
    ("observer_initial.qd_hat.1", MemberField("observer_initial.qd_hat.1", "observer_initial", "qd_hat", 1)),
    ("variants.own.observer_initial.qd_hat",
     MemberField("variants.own.observer_initial.qd_hat", "observer_initial", "qd_hat", variant="own")),
    ("parameters.fault_scale", MemberField("parameters.fault_scale", "parameter", "fault_scale")),
    ("nominal.mass_scale", MemberField("nominal.mass_scale", "mass_scale", "nominal")),
    ("plant.mass_scale", MemberField("plant.mass_scale", "mass_scale", "plant")),
    ("variants.hs.observer.gains.gamma",
     MemberField("variants.hs.observer.gains.gamma", "gain", "gamma", variant="hs", role="observer", key="gamma")),
    ("variants.hs.controller.gains.bound.1",
     MemberField("variants.hs.controller.gains.bound.1", "gain", "bound", variant="hs", role="controller",
                 key="bound.1")),
    ("variants.hs.monitors.eso.gains.bandwidth",
     MemberField("variants.hs.monitors.eso.gains.bandwidth", "gain", "bandwidth", variant="hs", role="monitor",
                 monitor="eso", key="bandwidth")),
])
def test_every_declared_field_parses(path, expected):
    assert member_field(path, "f.yaml") == expected


def test_the_parse_cases_cover_every_declared_kind():
    parsed = {batchable(path).kind for path in ("seed", "initial.q", "observer_initial.q_hat",
                                                "parameters.a", "plant.mass_scale", "variants.v.observer.gains.k")}
    assert parsed == {info.kind for info in FIELD_KINDS}


def test_sections_name_what_an_override_is_validated_with():
    assert member_field("variants.hs.monitors.eso.gains.bandwidth", "f").section == "variants.hs.monitors.eso"
    assert member_field("variants.own.observer_initial.q_hat.0", "f").section == "variants.own.observer_initial"
    assert member_field("initial.qd.1", "f").section == "initial"


@pytest.mark.parametrize("path", [
    "duration", "initial", "initial.q.x", "initial.q.0.1", "observer_initial.bogus", "observer_initial",
    "parameters", "parameters.1x", "nominal", "plant.other", "variants.hs.observer.type", "variants.hs.observer.gains",
    "variants.hs.controller_velocity", "variants.hs.monitors.eso.type", "terms.0.onset", "seed.0", "",
    "variants..observer.gains.k",
])
def test_a_path_outside_the_list_is_refused_in_one_line(path):
    assert batchable(path) is None
    with pytest.raises(InputError) as error:
        member_field(path, "f.yaml")
    assert str(error.value) == (f"f.yaml: {path}: {NOT_BATCHABLE}" if path else f"f.yaml: {NOT_BATCHABLE}")


# ------------------------------------------------------------------------------------ overrides and their member


def test_each_kind_applied_to_its_member_only(scenario):
    overrides = [
        {}, {"seed": 40}, {"initial.q": [0.1, 0.2, 0.3], "initial.qd.1": 2.0}, {"parameters.fault_scale": 0.25},
        {"nominal.mass_scale": 1.2, "plant.mass_scale": 0.8}, {"observer_initial.qd_hat.2": 9.0},
        {"variants.own.observer_initial.qd_hat": [1.0, 2.0, 3.0]}, {"variants.hs.observer.gains.gamma": 3.0},
        {"variants.hs.controller.gains.bound.1": 0.9}, {"variants.hs.monitors.eso.gains.bandwidth": 90.0},
    ]
    members = members_from_overrides(scenario, overrides)
    base = single(scenario)
    expected = {name: np.repeat(getattr(base, name), len(overrides), axis=0)
                for name in ("q0", "qd0", "parameters", "nominal_mass_scale", "plant_mass_scale")}
    expected["seeds"] = scenario.spec.seed + np.arange(len(overrides))
    expected["seeds"][1] = 40
    expected["q0"][2] = [0.1, 0.2, 0.3]
    expected["qd0"][2, 1] = 2.0
    expected["parameters"][3, 0] = 0.25
    expected["nominal_mass_scale"][4], expected["plant_mass_scale"][4] = 1.2, 0.8
    for name, values in expected.items():
        np.testing.assert_array_equal(getattr(members, name), values, err_msg=name)

    hs, own = members.variants
    qd_hat = np.repeat(base.variants[0].qd_hat0, len(overrides), axis=0)
    qd_hat[5, 2] = 9.0  # the scenario's estimate: hs uses it, own has its own
    np.testing.assert_array_equal(hs.qd_hat0, qd_hat)
    own_qd_hat = np.repeat(base.variants[1].qd_hat0, len(overrides), axis=0)
    own_qd_hat[6] = [1.0, 2.0, 3.0]
    np.testing.assert_array_equal(own.qd_hat0, own_qd_hat)
    gamma = np.full((len(overrides), 3), 5.0)
    gamma[7] = 3.0
    np.testing.assert_array_equal(hs.observer.gamma, gamma)
    bound = np.repeat([[0.5, 0.6, 0.7]], len(overrides), axis=0)
    bound[8, 1] = 0.9
    np.testing.assert_array_equal(hs.controller.bound, bound)
    bandwidth = np.full((len(overrides), 3), 60.0)
    bandwidth[9] = 90.0
    np.testing.assert_array_equal(hs.monitors[0].bandwidth, bandwidth)
    assert members.overrides == overrides


@pytest.mark.parametrize("member", [
    {"seed": 11, "variants.hs.controller.gains.mu": [1.0, 2.0, 3.0], "parameters.fault_rate": 3.0},
    {"variants.hs.observer.gains.D": 30.0, "variants.hs.observer.gains.gamma": 0, "initial.q.0": 1},
    {"variants.own.observer_initial.q_hat": [0.3, 0.2, 0.1], "observer_initial.qd_hat": [1.0, 1.0, 1.0],
     "observer_initial.q_hat.1": -1.0, "plant.mass_scale": 1.1},
    {"initial.qd": [0.0, 5.0, 0.0], "initial.qd.2": 1.5, "variants.own.controller.gains.c": 7,
     "variants.hs.monitors.eso.gains.bandwidth": [50.0, 60.0, 70.0], "nominal.mass_scale": 0.9},
    {"variants.hs.observer_initial.qd_hat": [2.0, 2.0, 2.0]},  # hs's own: its q_hat is no longer the scenario's
])
def test_a_member_equals_the_scenario_revalidated_with_its_overrides(path, scenario, member):
    """Bit for bit, every value, against the scenario loaded, validated and compiled whole with the same
    values (a variant's own observer_initial, once given, replaces the scenario's wholesale)."""
    members = members_from_overrides(scenario, [member, member])  # not {} first: q_hat0 None beside a given one
    alone = single(load_scenario(path, assignments={"seed": scenario.spec.seed + 1, **member}))
    picked = members.select(slice(1, 2))
    for name in ("seeds", "q0", "qd0", "parameters", "nominal_mass_scale", "plant_mass_scale"):
        a, b = getattr(picked, name), getattr(alone, name)
        assert a.dtype == b.dtype and a.tobytes() == b.tobytes(), name
    for ours, theirs in zip(picked.variants, alone.variants):
        for config, other in [(ours.observer, theirs.observer), (ours.controller, theirs.controller),
                              *zip(ours.monitors, theirs.monitors)]:
            assert dict(config).keys() == dict(other).keys()
            for name, value in config:
                if isinstance(value, np.ndarray):
                    assert value.tobytes() == getattr(other, name).tobytes(), name
                else:
                    assert value == getattr(other, name), name
        for name in ("q_hat0", "qd_hat0"):
            a, b = getattr(ours, name), getattr(theirs, name)
            assert (a is None and b is None) or a.tobytes() == b.tobytes(), name


def test_members_reuse_the_compiled_configs(scenario, monkeypatch):
    """Nothing is compiled again: only an overridden method's gains are validated, once per member."""
    calls = []
    validate = NFTSMCConfig.model_validate.__func__

    def counted(cls, *args, **kwargs):
        calls.append(cls)
        return validate(cls, *args, **kwargs)

    monkeypatch.setattr(NFTSMCConfig, "model_validate", classmethod(counted))
    members_from_overrides(scenario, [{"seed": 1}, {"parameters.fault_scale": 2.0}] * 5)
    replicates(scenario, 3)
    assert calls == []
    members_from_overrides(scenario, [{"variants.hs.controller.gains.mu": 1.0 + k,
                                       "variants.hs.controller.gains.beta1": 2.0} for k in range(4)])
    assert calls == [NFTSMCConfig] * 4


def test_a_gain_is_validated_with_the_methods_other_gains(scenario):
    members = members_from_overrides(scenario, [{"variants.hs.observer.gains.D": None,
                                                 "variants.hs.observer.gains.k1": 1.0,
                                                 "variants.hs.observer.gains.k2": 2.0,
                                                 "variants.hs.observer.gains.k3": 3.0}])
    assert members.variants[0].observer.D is None
    np.testing.assert_array_equal(members.variants[0].observer.k2, [[2.0, 2.0, 2.0]])
    with pytest.raises(InputError, match="variants.hs.observer.gains: member 0: give either D or k1, k2, k3"):
        members_from_overrides(scenario, [{"variants.hs.observer.gains.k1": 1.0, "variants.hs.observer.gains.k2": 2.0,
                                           "variants.hs.observer.gains.k3": 3.0}])


@pytest.mark.parametrize("override, field, problem", [
    ({"variants.hs.observer.gains.gamma": -1.0}, "variants.hs.observer.gains.gamma",
     "member 1: Input should be greater than or equal to 0"),
    ({"variants.hs.controller.gains.mu": [1.0, 2.0]}, "variants.hs.controller.gains.mu",
     "member 1: has 2 values, the robot has 3 joints"),
    ({"variants.hs.observer.gains.bogus": 1.0}, "variants.hs.observer.gains.bogus", "member 1: unknown key"),
    ({"variants.hs.controller.gains.compensation": "none"}, "variants.hs.controller.gains.compensation",
     "member 1: cannot differ between the members of a batch: it selects the law's form"),
    ({"variants.other.observer.gains.D": 1.0}, "variants.other.observer.gains.D",
     "member 1: no variant 'other' (known: hs, own)"),
    ({"variants.hs.monitors.sosmo.gains.L": 1.0}, "variants.hs.monitors.sosmo.gains.L",
     "member 1: variant hs has no monitor 'sosmo'"),
    ({"duration": 1.0}, "duration", f"member 1: {NOT_BATCHABLE}"),
    ({"parameters.other": 1.0}, "parameters.other", "member 1: set the scenario's parameters, do not add any"),
    ({"parameters.fault_rate": -2.0}, "parameters.fault_rate",
     "member 1: is the rate of terms.0: it must be positive, not -2"),
    ({"parameters.fault_scale": float("inf")}, "parameters.fault_scale", "member 1: Input should be a finite number"),
    ({"seed": -1}, "seed", "member 1: Input should be greater than or equal to 0"),
    ({"seed": 1.5}, "seed", "member 1: Input should be a valid integer, got a number with a fractional part"),
    ({"plant.mass_scale": 0.0}, "plant.mass_scale", "member 1: Input should be greater than 0"),
    ({"initial.q": [1.0, 2.0]}, "initial.q", "member 1: has 2 values, the robot has 3 joints"),
    ({"initial.q.1": float("nan")}, "initial.q.1", "member 1: Input should be a finite number"),
    ({"initial.q.3": 1.0}, "initial.q.3", "member 1: initial.q has 3 values: it has no element 3 to set"),
    ({"variants.own.observer_initial.q_hat.0": 1.0}, "variants.own.observer_initial.q_hat.0",
     "member 1: variants.own.observer_initial.q_hat has no values: it has no element 0 to set"),
    ({"observer_initial.qd_hat": [1.0]}, "observer_initial.qd_hat", "member 1: has 1 values, the robot has 3 joints"),
])
def test_a_bad_override_names_its_member_and_field(path, scenario, override, field, problem):
    with pytest.raises(InputError) as error:
        members_from_overrides(scenario, [{}, override])
    assert (error.value.file, error.value.field, error.value.problem) == (str(path), field, problem)
    assert "\n" not in str(error.value)


def test_an_estimate_for_some_members_only_is_refused(scenario):
    no_estimate = load_scenario(scenario.path, overrides=["observer_initial.q_hat=null"])
    with pytest.raises(InputError, match="variants.hs.observer_initial.q_hat: members: given for some members"):
        members_from_overrides(no_estimate, [{}, {"observer_initial.q_hat": [0.0, 0.0, 0.0]}])


def test_a_variant_left_out_takes_overrides_unused(path):
    one = load_scenario(path, variants=["own"])
    members = members_from_overrides(one, [{"variants.hs.controller.gains.mu": 9.0}, {}])
    assert len(members.variants) == 1 and members.count == 2


# ---------------------------------------------------------------------------------------------------- stacking


def test_stack_makes_member_by_joint_arrays_and_select_takes_members():
    configs = [NFTSMCConfig.model_validate({**NFTSMC, "mu": mu}, context={"n_joints": 3}) for mu in (0.5, 1.0)]
    stacked = stack(configs, 3)
    assert stacked.mu.shape == (2, 3) and stacked.beta1.shape == (2, 3) and stacked.compensation == "injection"
    np.testing.assert_array_equal(stacked.mu, [[0.5] * 3, [1.0] * 3])
    assert stacked.mu.flags.c_contiguous
    picked = stack_select(stacked, np.array([1]))
    np.testing.assert_array_equal(picked.mu, [[1.0] * 3])
    other = NFTSMCConfig.model_validate({**NFTSMC, "compensation": "none"}, context={"n_joints": 3})
    with pytest.raises(ValueError, match="compensation: differs between members"):
        stack([configs[0], other], 3)


def test_stack_states():
    assert stack_states([None, None]) is None
    np.testing.assert_array_equal(stack_states([np.zeros(2), np.ones(2)]), [[0, 0], [1, 1]])
    with pytest.raises(ValueError, match="some members and not for others"):
        stack_states([None, np.ones(2)])


def test_replicates_and_single(scenario):
    three = replicates(scenario, 3)
    assert isinstance(three, Members) and three.count == 3 and three.overrides == []
    np.testing.assert_array_equal(three.seeds, scenario.spec.seed + np.arange(3))
    np.testing.assert_array_equal(three.q0, np.repeat(scenario.q0[None], 3, axis=0))
    assert single(scenario).count == 1
