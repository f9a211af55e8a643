"""Scenario files (ftc_mj.scenario.definition): the reference scenario compiled, ``--set`` overrides, variant filtering,
Remark 5.3 gains, and invalid files, each rejected with an InputError naming the file and the field path.

Invalid files are written to tmp_path from the reference scenario (scenarios/puma_fault.yaml) with one
mutation each and ``robot.model`` made absolute so that it resolves from tmp_path.

Tests named ``test_regression_*`` pin bugs found while writing this file (fixed in commit b37582f).
"""

from __future__ import annotations

import functools
import json
import math
from pathlib import Path

import numpy as np
import pytest
import yaml

from ftc_mj.config.errors import InputError
from ftc_mj.config.expressions import ExpressionError
from ftc_mj.scenario.loading import load_scenario

ROOT = Path(__file__).resolve().parents[2]
PUMA_YAML = ROOT / "scenarios" / "puma_fault.yaml"
PUMA_MODEL = ROOT / "models" / "puma560.xml"
VARIANTS = ["proposed", "nftsmc_tosmo", "nftsmc_sosmo", "nftsmc"]
DELETE = object()


@pytest.fixture(scope="module")
def puma():
    return load_scenario(PUMA_YAML)


@functools.cache
def _reference_data() -> dict:
    return yaml.safe_load(PUMA_YAML.read_text(encoding="utf-8"))


def base_dict() -> dict:
    """The reference scenario as plain data, with the model path made absolute."""
    # A JSON round trip copies and also unshares the YAML aliases (deepcopy would keep them shared), so a
    # mutation changes exactly one place.
    data = json.loads(json.dumps(_reference_data()))
    data["robot"]["model"] = str(PUMA_MODEL)
    return data


def write(tmp_path: Path, data, name: str = "scenario.yaml") -> Path:
    path = tmp_path / name
    text = data if isinstance(data, str) else yaml.safe_dump(data, sort_keys=False)
    path.write_text(text, encoding="utf-8")
    return path


def mutate(data: dict, dotted: str, value) -> dict:
    """Set (or delete with DELETE) the item at a dotted path; list indices are numbers."""
    parts = dotted.split(".")
    node = data
    for part in parts[:-1]:
        node = node[int(part)] if isinstance(node, list) else node[part]
    key = int(parts[-1]) if isinstance(node, list) else parts[-1]
    if value is DELETE:
        del node[key]
    else:
        node[key] = value
    return data


def load_error(path: Path, **kwargs) -> InputError:
    with pytest.raises(InputError) as info:
        load_scenario(path, **kwargs)
    return info.value


def assert_names(error: InputError, path: Path, field: str) -> None:
    """The one-line message is FILE: FIELD: PROBLEM, with a non-empty problem."""
    message = str(error)
    assert "\n" not in message
    assert error.file == str(path)
    assert error.field == field, message
    assert message.startswith(f"{path}: {field}: ") if field else message.startswith(f"{path}: ")
    assert error.problem.strip()
    assert message.endswith(error.problem)


# ------------------------------------------------------------------------------------- reference scenario


def test_reference_scenario_structure(puma):
    assert puma.name == "puma_fault"
    assert puma.n_joints == 3
    assert [v.name for v in puma.variants] == VARIANTS
    assert puma.fault_onsets == [10.0]
    # (5.38) has no fault on joint 3: its value there is 0, so joint 3 counts as healthy.
    np.testing.assert_array_equal(puma.joint_fault_onsets, [10.0, 10.0, np.nan])
    assert not puma.measures_velocity
    assert puma.model_path == PUMA_MODEL
    assert puma.model.nv == 3
    np.testing.assert_array_equal(puma.q0, [-0.5, -0.5, -0.5])
    np.testing.assert_array_equal(puma.qd0, [0.0, 0.0, 0.0])
    assert puma.output_path == Path("recordings/puma_fault.rrd")


def test_reference_scenario_substeps(puma):
    spec = puma.spec
    assert isinstance(puma.substeps, int) and puma.substeps >= 1
    assert puma.timestep == (spec.timestep if spec.timestep is not None else spec.control_dt)
    assert puma.substeps * puma.timestep == pytest.approx(spec.control_dt, rel=1e-12)
    assert puma.model.opt.timestep == puma.timestep


@pytest.mark.parametrize(
    ("control_dt", "timestep", "substeps"),
    [(0.001, None, 1), (0.001, 0.001, 1), (0.001, 0.00025, 4), (0.002, 0.0005, 4), (0.003, 0.001, 3)],
)
def test_substeps_from_control_dt_and_timestep(tmp_path, control_dt, timestep, substeps):
    data = mutate(base_dict(), "control_dt", control_dt)
    mutate(data, "timestep", DELETE if timestep is None else timestep)
    scenario = load_scenario(write(tmp_path, data))
    assert scenario.substeps == substeps
    assert scenario.timestep == pytest.approx(timestep or control_dt, rel=1e-15)
    assert scenario.model.opt.timestep == scenario.timestep


def test_reference_trajectory(puma):
    times = np.array([0.0, 1.25, 2.5, 5.0, 10.0])
    q, qd, qdd = puma.reference.evaluate(times)
    assert q.shape == qd.shape == qdd.shape == (5, 3)
    np.testing.assert_allclose(q[0], 0.0, atol=1e-15)
    np.testing.assert_allclose(qd[0], 0.0, atol=1e-15)
    w = math.pi / 5  # every joint follows cos(pi t / 5) - 1
    for j in range(3):
        np.testing.assert_allclose(q[:, j], np.cos(w * times) - 1, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(qd[:, j], -w * np.sin(w * times), rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(qdd[:, j], -(w**2) * np.cos(w * times), rtol=1e-12, atol=1e-12)


def test_reference_terms_signs_spaces_and_values(puma):
    summary = [(t.name, t.kind, t.space, t.sign, t.onset) for t in puma.terms]
    assert summary == [
        ("friction", "friction", "torque", -1.0, None),
        ("disturbance", "disturbance", "torque", -1.0, None),
        ("actuator_fault", "fault", "acceleration", 1.0, 10.0),
    ]
    friction, disturbance, fault = puma.terms
    assert friction.rate is None and disturbance.rate is None
    # The fault's size and evolution rate are parameters (a campaign varies them per member).
    assert fault.rate_parameter == "zeta" and puma.spec.parameters == {"fault_scale": 1.0, "zeta": 2.0}
    rng = np.random.default_rng(7)
    for _ in range(50):
        t = rng.uniform(0, 30)
        q1, q2, q3 = q = rng.uniform(-2, 2, 3)
        qd1, qd2, qd3 = qd = rng.uniform(-5, 5, 3)
        np.testing.assert_allclose(friction.function(t, q, qd, [1.0, 2.0]),
                                   [1.9 * np.sin(qd1), 2.03 * np.sin(qd2), 1.76 * np.sin(qd3)], rtol=1e-12)
        np.testing.assert_allclose(
            disturbance.function(t, q, qd, [1.0, 2.0]),
            [1.1 * qd1 + 1.2 * np.sin(3 * q1), 1.65 * qd2 + 2.14 * np.sin(2 * q2), -3.01 * qd3 + 1.3 * np.sin(q3)],
            rtol=1e-12,
        )
        np.testing.assert_allclose(
            fault.function(t, q, qd, [1.0, 2.0]),
            [
                10 * np.sin(q1 * q2) + 3.7 * np.cos(qd1 * q2) + 5.2 * np.cos(qd1 * qd2),
                15 * np.sin(q1 * q2) + 3.6 * np.cos(qd1 * q2) + 2.7 * np.cos(qd1 * qd2),
                0.0,
            ],
            rtol=1e-12, atol=1e-12,
        )


def test_fault_profile():
    puma = load_scenario(PUMA_YAML, overrides=["terms.2.rate=2.0"])
    fault = puma.terms[2]
    for t in (0.0, 5.0, 9.999):
        profile = fault.profile(t)
        assert profile is None or np.all(np.asarray(profile) == 0.0)
    np.testing.assert_array_equal(fault.profile(10.0), [0.0, 0.0, 0.0])
    for t in (10.001, 10.5, 11.0, 13.0, 30.0):
        profile = fault.profile(t)
        assert np.shape(profile) == (3,)
        np.testing.assert_allclose(profile, 1 - math.exp(-2 * (t - 10)), rtol=1e-14)
    # Terms without an onset are always on.
    assert puma.terms[0].profile(0.0) == 1.0
    assert puma.terms[1].profile(25.0) == 1.0


def test_abrupt_fault_profile_and_per_joint_rates(tmp_path):
    abrupt = load_scenario(PUMA_YAML, overrides=["terms.2.rate=null"])
    assert abrupt.terms[2].rate is None
    assert abrupt.terms[2].profile(9.5) is None
    assert abrupt.terms[2].profile(10.0) == 1.0
    assert abrupt.terms[2].profile(20.0) == 1.0
    rates = load_scenario(PUMA_YAML, overrides=["terms.2.rate=[1, 2, 4]"])
    np.testing.assert_allclose(rates.terms[2].profile(10.5), 1 - np.exp(-np.array([1, 2, 4]) * 0.5), rtol=1e-14)


def test_relative_model_path_resolves_from_the_scenario_file(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    scenario = load_scenario(PUMA_YAML)
    assert scenario.model_path == PUMA_MODEL


# -------------------------------------------------------------------------------------- Remark 5.3 gains


def test_remark_5_3_gains_from_D(puma):
    by_name = {v.name: v for v in puma.variants}
    for name in ("proposed", "nftsmc_tosmo", "nftsmc"):
        variant = by_name[name]
        assert variant.observer_config.D == pytest.approx([22.0] * 3)
        k1, k2, k3 = variant.observer_config.gains()
        np.testing.assert_allclose(k1, 2 * 22 ** (1 / 3), rtol=1e-14)
        np.testing.assert_allclose(k2, 2.12 * 22 ** (2 / 3), rtol=1e-14)
        np.testing.assert_allclose(k3, 1.1 * 22, rtol=1e-14)
        observer = variant.observer_type(variant.observer_config, 3, 1e-3)
        np.testing.assert_allclose([observer.k1, observer.k2, observer.k3], [k1, k2, k3], rtol=0)
    assert by_name["proposed"].observer_type.name == "hs_tosmo"
    assert by_name["proposed"].observer_type(by_name["proposed"].observer_config, 3, 1e-3).linear_gain == 5.0
    tosmo = by_name["nftsmc_tosmo"]
    assert tosmo.observer_type.name == "tosmo"
    assert not hasattr(tosmo.observer_type(tosmo.observer_config, 3, 1e-3), "linear_gain")  # (3.11): no Gamma terms
    sosmo = by_name["nftsmc_sosmo"]
    assert sosmo.observer_type.name == "sosmo"
    k1, k2 = sosmo.observer_config.gains()
    np.testing.assert_allclose(k1, 1.5 * math.sqrt(22), rtol=1e-14)
    np.testing.assert_allclose(k2, 1.1 * 22, rtol=1e-14)


def test_remark_5_3_gains_per_joint_D():
    scenario = load_scenario(PUMA_YAML, overrides=["variants.nftsmc_tosmo.observer.gains.D=[8, 27, 64]"])
    k1, k2, k3 = scenario.variants[1].observer_config.gains()
    np.testing.assert_allclose(k1, [4.0, 6.0, 8.0], rtol=1e-14)
    np.testing.assert_allclose(k2, [8.48, 19.08, 33.92], rtol=1e-14)
    np.testing.assert_allclose(k3, [8.8, 29.7, 70.4], rtol=1e-14)


def test_explicit_observer_gains_without_D():
    scenario = load_scenario(
        PUMA_YAML,
        overrides=["variants.nftsmc.observer.gains={k1: 1.0, k2: 2.0, k3: [3.0, 4.0, 5.0]}"],
    )
    k1, k2, k3 = scenario.variants[3].observer_config.gains()
    np.testing.assert_array_equal(k1, [1.0] * 3)
    np.testing.assert_array_equal(k2, [2.0] * 3)
    np.testing.assert_array_equal(k3, [3.0, 4.0, 5.0])


def test_controller_gains_built(puma):
    controller = puma.variants[0].controller_config
    np.testing.assert_array_equal(controller.beta1, [15.0] * 3)
    assert controller.gamma1 == 0.5
    assert controller.gamma2 == pytest.approx(2 / 3, rel=1e-15)
    assert controller.compensation == "injection"
    assert puma.variants[3].controller_config.compensation == "none"
    np.testing.assert_array_equal(puma.variants[3].controller_config.bound, [25.0] * 3)


# ---------------------------------------------------------------------------------------------- overrides


def test_scalar_override():
    scenario = load_scenario(PUMA_YAML, overrides=["duration=2.5", "seed=7", "name=renamed"])
    assert scenario.spec.duration == 2.5
    assert scenario.spec.seed == 7
    assert scenario.name == "renamed"


def test_duration_argument_overrides_the_file():
    assert load_scenario(PUMA_YAML, duration=0.5).spec.duration == 0.5


def test_nested_gain_override_does_not_leak_through_the_yaml_alias():
    # proposed, nftsmc_tosmo and nftsmc_sosmo share one controller mapping (&nftsmc_compensated) in the file.
    scenario = load_scenario(PUMA_YAML, overrides=["variants.proposed.controller.gains.mu=0.7"])
    mu = {v.name: v.controller_config.mu for v in scenario.variants}
    np.testing.assert_array_equal(mu["proposed"], [0.7] * 3)
    np.testing.assert_array_equal(mu["nftsmc_tosmo"], [0.5] * 3)
    np.testing.assert_array_equal(mu["nftsmc_sosmo"], [0.5] * 3)


def test_compensation_override_changes_only_that_variant():
    scenario = load_scenario(PUMA_YAML, overrides=["variants.nftsmc_sosmo.controller.gains.compensation=estimate"])
    compensation = {v.name: v.controller_config.compensation for v in scenario.variants}
    assert compensation == {
        "proposed": "injection", "nftsmc_tosmo": "injection", "nftsmc_sosmo": "estimate", "nftsmc": "none",
    }


def test_list_index_override():
    scenario = load_scenario(PUMA_YAML, overrides=["initial.q.0=0.25", "initial.qd.2=-1"])
    np.testing.assert_array_equal(scenario.q0, [0.25, -0.5, -0.5])
    np.testing.assert_array_equal(scenario.qd0, [0.0, 0.0, -1.0])


def test_list_and_expression_overrides():
    scenario = load_scenario(
        PUMA_YAML,
        overrides=[
            "variants.proposed.controller.gains.beta1=[1, 2, 3]",
            "reference.2=0.3*sin(2*t) - 0.5",
            "observer_initial.q_hat=[0.1, 0.2, 0.3]",
        ],
    )
    np.testing.assert_array_equal(scenario.variants[0].controller_config.beta1, [1.0, 2.0, 3.0])
    np.testing.assert_array_equal(scenario.variants[1].controller_config.beta1, [15.0] * 3)
    q, qd, _ = scenario.reference.evaluate(np.array([0.0, 1.0]))
    np.testing.assert_allclose(q[:, 2], [-0.5, 0.3 * math.sin(2) - 0.5], rtol=1e-14)
    np.testing.assert_allclose(qd[:, 2], [0.6, 0.6 * math.cos(2)], rtol=1e-14)
    for variant in scenario.variants:
        np.testing.assert_array_equal(variant.q_hat0, [0.1, 0.2, 0.3])


def test_overrides_do_not_change_the_file_or_later_loads():
    before = PUMA_YAML.read_bytes()
    load_scenario(PUMA_YAML, overrides=["variants.proposed.controller.gains.mu=0.9", "duration=1"])
    assert PUMA_YAML.read_bytes() == before
    again = load_scenario(PUMA_YAML)
    np.testing.assert_array_equal(again.variants[0].controller_config.mu, [0.5] * 3)
    assert again.spec.duration == yaml.safe_load(before)["duration"]


@pytest.mark.parametrize(
    ("override", "field", "fragment"),
    [
        ("duration=-1", "duration", "greater than 0"),
        ("duration=.nan", "duration", "finite"),
        ("duration=abc", "duration", ""),
        ("initial.q.0=abc", "initial.q.0", ""),
        ("initial.q.3=0", "initial.q.3", "not an index"),
        ("initial.q.x=0", "initial.q.x", "not an index"),
        ("initial.q=[1, 2]", "initial.q", "3 joints"),
        ("variants.proposed.controller.gains.gamma1=1.5", "variants.proposed.controller.gains.gamma1", "less than 1"),
        ("variants.proposed.controller.gains.colour=1", "variants.proposed.controller.gains.colour", "unknown key"),
        ("variants.proposed.observer.type=luenberger", "variants.proposed.observer.type", "unknown observer"),
        ("colour=red", "colour", "unknown key"),
        ("duration.x=1", "duration.x", "not a mapping or list"),
        ("duration=[1", "duration", "not a valid YAML"),
        ("terms.2.value.0=__import__('os')", "terms.2.value.0", "not allowed"),
        ("reference.0=q1", "reference.0", "unknown name 'q1'"),
    ],
)
def test_overrides_are_validated_like_the_file(override, field, fragment):
    error = load_error(PUMA_YAML, overrides=[override])
    assert_names(error, PUMA_YAML, field)
    assert fragment in error.problem


@pytest.mark.parametrize("override", ["duration", "=1", " =1"])
def test_malformed_override_text(override):
    error = load_error(PUMA_YAML, overrides=[override])
    assert error.field.startswith("--set")
    assert "key.path=value" in error.problem


@pytest.mark.parametrize("duration", [0.0, -1.0, float("nan"), float("inf"), 1e-5])
def test_bad_duration_argument(duration):
    error = load_error(PUMA_YAML, duration=duration)
    assert_names(error, PUMA_YAML, "duration")


# -------------------------------------------------------------------------------------- variant filtering


def test_variant_filtering():
    scenario = load_scenario(PUMA_YAML, variants=["nftsmc", "proposed"])
    assert sorted(v.name for v in scenario.variants) == ["nftsmc", "proposed"]
    by_name = {v.name: v for v in scenario.variants}
    assert by_name["nftsmc"].controller_config.compensation == "none"
    assert by_name["proposed"].observer_type.name == "hs_tosmo"
    assert load_scenario(PUMA_YAML, variants=["nftsmc_sosmo"]).variants[0].name == "nftsmc_sosmo"


def test_unknown_variant_is_an_input_error():
    error = load_error(PUMA_YAML, variants=["proposed", "kalman_pid"])
    assert_names(error, PUMA_YAML, "variants")
    assert "kalman_pid" in error.problem


def test_filtering_applies_after_overrides_of_other_variants():
    scenario = load_scenario(PUMA_YAML, overrides=["variants.nftsmc.controller.gains.mu=2"], variants=["nftsmc"])
    np.testing.assert_array_equal(scenario.variants[0].controller_config.mu, [2.0] * 3)


# ------------------------------------------------------------------------------------------ invalid files

INVALID = [
    # unknown keys
    ("colour", "red", "colour", "unknown key"),
    ("robot.colour", "red", "robot.colour", "unknown key"),
    ("variants.proposed.observer.colour", 1, "variants.proposed.observer.colour", "unknown key"),
    ("variants.proposed.controller.gains.beta9", 1.0, "variants.proposed.controller.gains.beta9", "unknown key"),
    ("variants.nftsmc_sosmo.observer.gains.D", 1.0, "variants.nftsmc_sosmo.observer.gains.D", "unknown key"),
    ("terms.0.colour", 1, "terms.0.colour", "unknown key"),
    ("metrics.colour", 1, "metrics.colour", "unknown key"),
    ("initial.qdd", [0, 0, 0], "initial.qdd", "unknown key"),
    # missing required fields
    ("duration", DELETE, "duration", "required field is missing"),
    ("name", DELETE, "name", "required field is missing"),
    ("robot.model", DELETE, "robot.model", "required field is missing"),
    ("initial.q", DELETE, "initial.q", "required field is missing"),
    ("reference", DELETE, "reference", "required field is missing"),
    ("terms.1.sign", DELETE, "terms.1.sign", "required field is missing"),
    ("variants.proposed.controller", DELETE, "variants.proposed.controller", "required field is missing"),
    ("variants.nftsmc.controller.gains.mu", DELETE, "variants.nftsmc.controller.gains.mu", "required field is missing"),
    ("variants.proposed.observer.gains.gamma", DELETE, "variants.proposed.observer.gains.gamma", "required field"),
    # wrong vector lengths
    ("initial.q", [-0.5, -0.5], "initial.q", "has 2 values, the robot has 3 joints"),
    ("initial.qd", [0, 0, 0, 0], "initial.qd", "has 4 values"),
    ("reference", ["0", "0"], "reference", "has 2 values"),
    ("reference", ["0", "0", "0", "0"], "reference", "has 4 values"),
    ("terms.0.value", ["0"], "terms.0.value", "has 1 values"),
    ("terms.2.rate", [1.0, 2.0], "terms.2.rate", "has 2 values"),
    ("variants.proposed.controller.gains.beta1", [1.0, 2.0], "variants.proposed.controller.gains.beta1", "has 2 values"),
    ("variants.nftsmc.observer.gains.D", [1.0, 2.0, 3.0, 4.0], "variants.nftsmc.observer.gains.D", "has 4 values"),
    # durations and steps
    ("duration", 0, "duration", "greater than 0"),
    ("duration", -1.0, "duration", "greater than 0"),
    ("duration", float("nan"), "duration", "finite"),
    ("duration", float("inf"), "duration", "finite"),
    ("duration", "long", "duration", "valid number"),
    ("duration", 0.0001, "duration", "shorter than one control period"),
    ("control_dt", -0.001, "control_dt", "greater than 0"),
    ("control_dt", 0, "control_dt", "greater than 0"),
    ("timestep", 0.0003, "control_dt", "not an integer multiple"),
    ("timestep", 0.002, "control_dt", "not an integer multiple"),
    ("timestep", -0.001, "timestep", "greater than 0"),
    ("initial.q.1", float("nan"), "initial.q.1", "finite"),
    ("seed", "abc", "seed", "integer"),
    ("seed", 1.5, "seed", "integer"),
    # method types
    ("variants.proposed.observer.type", "luenberger", "variants.proposed.observer.type", "unknown observer 'luenberger'"),
    ("variants.nftsmc.controller.type", "lqr", "variants.nftsmc.controller.type", "unknown controller 'lqr'"),
    # gains
    ("variants.nftsmc.observer.gains", {}, "variants.nftsmc.observer.gains", "give D"),
    ("variants.nftsmc.observer.gains", {"D": 22.0, "k1": 3.0}, "variants.nftsmc.observer.gains", "not both"),
    ("variants.nftsmc.observer.gains", {"k1": 1.0, "k2": 2.0}, "variants.nftsmc.observer.gains", "give D"),
    ("variants.nftsmc_sosmo.observer.gains", {"L": 22.0, "k1": 1.0, "filter_time_constant": 0.01},
     "variants.nftsmc_sosmo.observer.gains", "not both"),
    ("variants.nftsmc_sosmo.observer.gains.filter_time_constant", 0,
     "variants.nftsmc_sosmo.observer.gains.filter_time_constant", "greater than 0"),
    ("variants.proposed.observer.gains.gamma", -1.0, "variants.proposed.observer.gains.gamma", "greater than or equal"),
    ("variants.nftsmc.controller.gains.gamma1", 1.0, "variants.nftsmc.controller.gains.gamma1", "less than 1"),
    ("variants.nftsmc.controller.gains.gamma1", 0.0, "variants.nftsmc.controller.gains.gamma1", "greater than 0"),
    ("variants.nftsmc.controller.gains.gamma1", -0.5, "variants.nftsmc.controller.gains.gamma1", "greater than 0"),
    ("variants.nftsmc.controller.gains.gamma2", 1.5, "variants.nftsmc.controller.gains.gamma2", "less than 1"),
    ("variants.nftsmc.controller.gains.compensation", "all",
     "variants.nftsmc.controller.gains.compensation", "'injection'"),
    # plant terms
    ("terms.2.onset", DELETE, "terms.2.rate", "needs an onset"),
    ("terms.2.onset", -1.0, "terms.2.onset", "greater than or equal to 0"),
    ("terms.1.sign", 2, "terms.1.sign", "1 or -1"),
    ("terms.1.sign", 0, "terms.1.sign", "1 or -1"),
    ("terms.1.space", "velocity", "terms.1.space", "'torque' or 'acceleration'"),
    ("terms.0.kind", "noise", "terms.0.kind", "'friction', 'disturbance' or 'fault'"),
    ("terms.0.value", "sin(qd1)", "terms.0.value", "list"),
    # expressions, reported with their index
    ("terms.2.value.1", "q1.real", "terms.2.value.1", "attribute access"),
    ("terms.2.value.1", "().__class__.__bases__", "terms.2.value.1", "attribute access"),
    ("terms.0.value.2", "__import__('os').system('true')", "terms.0.value.2", "not allowed"),
    ("terms.1.value.0", "open('x')", "terms.1.value.0", "call of 'open'"),
    ("terms.1.value.0", "q4", "terms.1.value.0", "unknown name 'q4'"),
    ("reference.0", "q1", "reference.0", "unknown name 'q1'"),
    ("reference.2", "eval('1')", "reference.2", "call of 'eval'"),
    ("reference.1", "9**9**9", "reference.1", "double-precision"),
    ("reference.1", "sin(", "reference.1", "syntax error"),
    # names, sensors, other sections
    ("name", "puma fault", "name", "pattern"),
    ("name", "", "name", "at least 1"),
    ("variants", {}, "variants", "at least 1"),
    ("robot.sensors", ["torque"], "robot.sensors.0", "'position' or 'velocity'"),
    ("robot.model", "/nonexistent/robot.xml", "robot.model", "not found"),
    ("robot.model", "no_such_model.xml", "robot.model", "not found"),
    ("nominal.mass_scale", 0, "nominal.mass_scale", "greater than 0"),
    ("metrics.tracking_tolerance", 0, "metrics.tracking_tolerance", "greater than 0"),
    ("metrics.window_start", -1, "metrics.window_start", "greater than or equal"),
    ("divergence", {"max_position": -5}, "divergence.max_position", "greater than 0"),
    ("divergence", {"max_velocity": 0}, "divergence.max_velocity", "greater than 0"),
]


@pytest.mark.parametrize(("dotted", "value", "field", "fragment"), INVALID,
                         ids=[f"{i:02d}-{case[0]}" for i, case in enumerate(INVALID)])
def test_invalid_file(tmp_path, dotted, value, field, fragment):
    path = write(tmp_path, mutate(base_dict(), dotted, value))
    error = load_error(path)
    assert_names(error, path, field)
    assert fragment in error.problem


def test_variant_name_with_space(tmp_path):
    data = base_dict()
    data["variants"] = {"bad name": data["variants"]["proposed"]}
    path = write(tmp_path, data)
    error = load_error(path)
    assert_names(error, path, "variants")
    assert "'bad name'" in error.problem


def test_per_variant_observer_initial_length(tmp_path):
    data = mutate(base_dict(), "variants.nftsmc.observer_initial", {"q_hat": [0.0, 0.0]})
    path = write(tmp_path, data)
    assert_names(load_error(path), path, "variants.nftsmc.observer_initial.q_hat")


def test_duplicate_top_level_key(tmp_path):
    text = yaml.safe_dump(base_dict(), sort_keys=False)
    text += "duration: 5.0\n"
    path = write(tmp_path, text)
    error = load_error(path)
    line = text.count("\n")  # the duplicate is on the last line
    assert_names(error, path, f"line {line}")
    assert "duplicate key 'duration'" in error.problem


def test_duplicate_nested_key(tmp_path):
    data = base_dict()
    data["metrics"] = {"window_start": 5.0, **{k: v for k, v in data["metrics"].items() if k != "window_start"}}
    text = yaml.safe_dump(data, sort_keys=False)
    marker = "metrics:\n  window_start: 5.0\n"
    assert marker in text
    text = text.replace(marker, marker + "  window_start: 6.0\n")
    path = write(tmp_path, text)
    error = load_error(path)
    line = text[: text.index("  window_start: 6.0")].count("\n") + 1
    assert_names(error, path, f"line {line}")
    assert "duplicate key 'window_start'" in error.problem


@pytest.mark.parametrize(
    ("text", "fragment"),
    [("- name: a\n- name: b\n", "mapping"), ("42\n", "mapping"), ("just text\n", "mapping"), ("", "mapping"),
     ("null\n", "mapping")],
)
def test_file_that_is_not_a_mapping(tmp_path, text, fragment):
    path = write(tmp_path, text)
    error = load_error(path)
    assert_names(error, path, "")
    assert fragment in error.problem


@pytest.mark.parametrize(
    "text",
    ["name: [unclosed\nduration: 1\n", "name: a\n  bad: indent\n", "a: b: c\n", "name: puma\n\tduration: 1\n",
     "name: 'open\n"],
)
def test_invalid_yaml_syntax(tmp_path, text):
    path = write(tmp_path, text)
    error = load_error(path)
    assert error.file == str(path)
    assert error.field.startswith("line ")
    assert "invalid YAML" in error.problem
    assert "\n" not in str(error)


def test_yaml_python_tags_are_not_constructed(tmp_path):
    text = yaml.safe_dump(base_dict(), sort_keys=False) + "description: !!python/object/apply:os.system ['true']\n"
    path = write(tmp_path, text)
    error = load_error(path)
    assert error.field.startswith("line ")
    assert "invalid YAML" in error.problem


def test_missing_file(tmp_path):
    path = tmp_path / "nope.yaml"
    error = load_error(path)
    assert_names(error, path, "")
    assert "cannot read" in error.problem


def test_directory_instead_of_file(tmp_path):
    error = load_error(tmp_path)
    assert_names(error, tmp_path, "")


def test_model_mujoco_cannot_load(tmp_path):
    (tmp_path / "broken.xml").write_text("<mujoco><worldbody><body></mujoco>", encoding="utf-8")
    path = write(tmp_path, mutate(base_dict(), "robot.model", "broken.xml"))
    error = load_error(path)
    assert_names(error, path, "robot.model")
    assert "MuJoCo cannot load 'broken.xml'" in error.problem


def test_model_without_position_sensors(tmp_path):
    (tmp_path / "bare.xml").write_text(
        """<mujoco><worldbody>
        <body><joint name="a" type="hinge"/><geom size="0.1"/>
        <body pos="0 0 1"><joint name="b" type="hinge"/><geom size="0.1"/>
        <body pos="0 0 1"><joint name="c" type="hinge"/><geom size="0.1"/></body></body></body>
        </worldbody><actuator><motor joint="a"/><motor joint="b"/><motor joint="c"/></actuator></mujoco>""",
        encoding="utf-8",
    )
    path = write(tmp_path, mutate(base_dict(), "robot.model", "bare.xml"))
    error = load_error(path)
    assert_names(error, path, "robot.model")
    assert "jointpos sensor" in error.problem


def test_monitor_is_checked_like_an_observer(tmp_path):
    base = base_dict()
    variant = next(iter(base["variants"]))
    for monitors, field, fragment in [
        ({"m": {"type": "nope"}}, f"variants.{variant}.monitors.m.type", "unknown observer 'nope'"),
        ({"m": {"type": "tosmo", "gains": {"D": -1}}}, f"variants.{variant}.monitors.m.gains.D", "greater than 0"),
        ({"m": {"type": "do", "gains": {"k1": 8, "k2": 18, "p1": 10, "p2": 10}}}, f"variants.{variant}.monitors.m.type",
         "velocity"),
        ({"a.b": {"type": "tosmo", "gains": {"D": 9}}}, f"variants.{variant}.monitors", "monitor name 'a.b'"),
    ]:
        path = write(tmp_path, mutate(base_dict(), f"variants.{variant}.monitors", monitors))
        error = load_error(path)
        assert_names(error, path, field)
        assert fragment in error.problem, (monitors, error.problem)


def test_velocity_sensing_needs_tachometers_in_the_model(tmp_path):
    source = (Path(__file__).resolve().parents[2] / "models" / "puma560.xml").read_text(encoding="utf-8")
    without = "\n".join(line for line in source.splitlines() if "<jointvel" not in line)
    (tmp_path / "encoders_only.xml").write_text(without, encoding="utf-8")
    data = mutate(mutate(base_dict(), "robot.model", "encoders_only.xml"), "robot.sensors", ["position", "velocity"])
    path = write(tmp_path, data)
    error = load_error(path)
    assert_names(error, path, "robot.sensors")
    assert "jointvel sensor per joint" in error.problem


def test_expression_errors_do_not_leak_as_expression_error(tmp_path):
    path = write(tmp_path, mutate(base_dict(), "reference.0", "t.real"))
    with pytest.raises(InputError) as info:
        load_scenario(path)
    assert not isinstance(info.value, ExpressionError)


# ------------------------------------------------------------------------------------ regressions


def test_regression_non_utf8_file_is_an_input_error(tmp_path):
    """Was a bug (load_scenario, the ``except (OSError, UnicodeDecodeError)`` branch): ``exc.strerror`` does
    not exist on UnicodeDecodeError, so a Latin-1 file raised AttributeError (a traceback)."""
    path = tmp_path / "latin1.yaml"
    path.write_bytes(yaml.safe_dump(base_dict()).encode("utf-8") + "# caf\xe9\n".encode("latin-1"))
    error = load_error(path)
    assert_names(error, path, "")


def test_regression_yaml_merge_keys_are_accepted(tmp_path):
    """Was a bug (_construct_mapping): the duplicate-key check constructed every key node, including YAML
    merge keys (``<<: *anchor``), which SafeLoader only handles in flatten_mapping, so a valid file was
    rejected with "could not determine a constructor for the tag 'tag:yaml.org,2002:merge'"."""
    # Build the file from data so the merge key sits inside 'variants' whatever the file's layout.
    data = base_dict()
    variants = data.pop("variants")
    data.pop("figures", None)  # they name the file's variants, replaced here
    body = yaml.safe_dump(data, sort_keys=False)
    body += "variants:\n"
    body += "  proposed: &proposed\n" + _indent(yaml.safe_dump(variants["proposed"], sort_keys=False), 4)
    body += "  faster:\n    <<: *proposed\n    observer: {type: tosmo, gains: {D: 30.0}}\n"
    path = write(tmp_path, body)
    scenario = load_scenario(path)
    assert [v.name for v in scenario.variants] == ["proposed", "faster"]
    assert scenario.variants[1].observer_type.name == "tosmo"
    assert scenario.variants[1].controller_type.name == "nftsmc"


def _indent(text: str, spaces: int) -> str:
    return "".join(" " * spaces + line + "\n" for line in text.splitlines())


def test_regression_boolean_expression_value_is_rejected(tmp_path):
    """Was a bug (``ExpressionText = str | float | int``): pydantic coerced a YAML boolean to 1, so
    ``value: [true, ...]`` loaded although expressions.parse explicitly rejects booleans."""
    path = write(tmp_path, mutate(base_dict(), "terms.1.value.0", True))
    error = load_error(path)
    assert error.field == "terms.1.value.0"


UNION_FIELDS = [
    ("variants.nftsmc.controller.gains.beta2", -1.0),
    ("variants.nftsmc.controller.gains.mu", 0.0),
    ("variants.nftsmc.observer.gains.D", 0.0),
    ("terms.2.rate", 0.0),
]


@pytest.mark.parametrize(("field", "value"), UNION_FIELDS)
def test_non_positive_per_joint_values_are_rejected(tmp_path, field, value):
    path = write(tmp_path, mutate(base_dict(), field, value))
    error = load_error(path)
    assert error.field.startswith(field)
    assert str(error).startswith(f"{path}: {field}")
    assert "greater than 0" in error.problem


@pytest.mark.parametrize(("field", "value"), UNION_FIELDS)
def test_regression_union_gain_error_names_the_plain_field(tmp_path, field, value):
    """Was a bug (_input_error): for values typed ``float | list[float]`` (per-joint gains, rate) pydantic's
    union member tag leaked into the field path and the same problem was counted twice:
    "variants.nftsmc.controller.gains.beta2.constrained-float: Input should be greater than 0 (and 1 more
    problem)". That field is not a path the user can write (e.g. with --set)."""
    path = write(tmp_path, mutate(base_dict(), field, value))
    error = load_error(path)
    assert error.field == field
    assert "more problem" not in error.problem


def test_regression_top_level_observer_initial_error_names_its_own_field(tmp_path):
    """Was a bug (_compile): a wrong-length top-level ``observer_initial.qd_hat`` was reported as
    "variants.proposed.observer_initial.qd_hat", a field that does not exist in the file."""
    path = write(tmp_path, mutate(base_dict(), "observer_initial.qd_hat", [0.5, 0.5]))
    error = load_error(path)
    assert error.field == "observer_initial.qd_hat"


# ------------------------------------------------------------------------------ controller velocity


def test_controller_velocity_defaults_to_what_the_robot_measures(tmp_path):
    """Without tachometers the controller uses the estimate; with them the measured velocity; a variant may
    override the scenario's choice."""
    base = base_dict()
    variant = next(iter(base["variants"]))
    assert {v.controller_velocity for v in load_scenario(write(tmp_path, base)).variants} == {"estimated"}
    tach = mutate(base_dict(), "robot.sensors", ["position", "velocity"])
    assert {v.controller_velocity for v in load_scenario(write(tmp_path, tach)).variants} == {"measured"}
    chosen = mutate(tach, "controller_velocity", "estimated")
    assert {v.controller_velocity for v in load_scenario(write(tmp_path, chosen)).variants} == {"estimated"}
    overridden = mutate(chosen, f"variants.{variant}.controller_velocity", "measured")
    loaded = {v.name: v.controller_velocity for v in load_scenario(write(tmp_path, overridden)).variants}
    assert loaded[variant] == "measured"


def test_measured_controller_velocity_needs_tachometers(tmp_path):
    base = base_dict()
    variant = next(iter(base["variants"]))
    for field in ("controller_velocity", f"variants.{variant}.controller_velocity"):
        path = write(tmp_path, mutate(base_dict(), field, "measured"))
        error = load_error(path)
        assert_names(error, path, field)
        assert "velocity sensors" in error.problem
    path = write(tmp_path, mutate(base_dict(), "controller_velocity", "tachometer"))
    assert_names(load_error(path), path, "controller_velocity")
