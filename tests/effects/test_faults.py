"""Actuator faults (ftc_mj.effects.faults): each kind delivers what it specifies, profiles blend, faults compose in
order; compiled from scenario files with field-path errors; in the closed loop they act through
qfrc_applied only (the command and the recorded tau stay the controller's), and the plant's acceleration
is that of the delivered torque."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from fault_scenarios import assert_input_error, load, puma_model, run, scenario_data, write
from nominal_oracle import NominalModel
from pydantic import TypeAdapter

from ftc_mj.effects.faults import ActuatorFault, ActuatorFaults, ActuatorFaultSpec, compile_actuator_fault
from ftc_mj.effects.profiles import Profile
from ftc_mj.config.errors import InputError
from ftc_mj.scenario.loading import load_scenario

N, NJ, DT = 1000, 3, 1e-3
T = np.arange(N) * DT
ONSET = 0.5
K0 = int(round(ONSET / DT))
# A command that changes every sample on every joint (and crosses zero), so holding and scaling show.
COMMAND = np.stack([10 * np.sin(7 * T + j) + 3 * j for j in range(NJ)], axis=1)


def make(kind: str, joints=(1,), profile: Profile | None = None, parameter=None) -> ActuatorFault:
    mask = np.zeros(NJ, dtype=bool)
    mask[list(joints)] = True
    return ActuatorFault(name=kind, kind=kind, joints=mask, profile=profile or Profile("abrupt", onset=ONSET),
                         parameter=parameter)


def table(values_on_joints: dict[int, np.ndarray | float]) -> np.ndarray:
    out = np.zeros((N, NJ))
    for joint, value in values_on_joints.items():
        out[:, joint] = value
    return out


def delivered(*faults: ActuatorFault, command: np.ndarray = COMMAND) -> tuple[np.ndarray, np.ndarray, ActuatorFaults]:
    """Delivered torque and fault torque for every sample of the grid."""
    applied = ActuatorFaults(list(faults), T, NJ)
    out, torque = np.empty((N, NJ)), np.empty((N, NJ))
    for k in range(N):
        applied.apply(k, command[k])
        out[k], torque[k] = applied.delivered, applied.torque
    return out, torque, applied


def assert_untouched(out: np.ndarray, faulty_joint: int) -> None:
    """Before the onset everything, and on the other joints always, the command passes unchanged."""
    np.testing.assert_array_equal(out[:K0], COMMAND[:K0])
    others = [j for j in range(NJ) if j != faulty_joint]
    np.testing.assert_array_equal(out[:, others], COMMAND[:, others])


# ------------------------------------------------------------------------------------------ each kind


def test_loss_of_effectiveness_half_halves_the_torque() -> None:
    out, torque, applied = delivered(make("loss_of_effectiveness", parameter=table({1: 0.5})))
    assert_untouched(out, 1)
    np.testing.assert_array_equal(out[K0:, 1], 0.5 * COMMAND[K0:, 1])
    np.testing.assert_array_equal(torque, out - COMMAND)
    np.testing.assert_array_equal(applied.active, T >= ONSET)


def test_loss_of_effectiveness_with_alpha_of_time_and_incipient_profile() -> None:
    alpha = 0.2 + 0.6 * T  # alpha(t) = 0.2 + 0.6 t
    rate = np.full(NJ, 4.0)
    out, _, _ = delivered(make("loss_of_effectiveness", parameter=table({1: alpha}),
                               profile=Profile("incipient", onset=ONSET, rate=rate)))
    w = 1 - np.exp(-4.0 * (T[K0:] - ONSET))
    np.testing.assert_allclose(out[K0:, 1], (1 - w * alpha[K0:]) * COMMAND[K0:, 1], rtol=1e-14, atol=1e-14)
    assert out[K0, 1] == COMMAND[K0, 1]  # w(Tf) = 0: the incipient fault starts from nothing


def test_bias_adds_the_offset() -> None:
    out, torque, _ = delivered(make("bias", parameter=table({1: -4.5})))
    assert_untouched(out, 1)
    np.testing.assert_allclose(out[K0:, 1], COMMAND[K0:, 1] - 4.5, rtol=0, atol=1e-14)
    np.testing.assert_allclose(torque[K0:, 1], -4.5, rtol=0, atol=1e-14)


def test_lock_holds_the_command_from_onset() -> None:
    out, _, _ = delivered(make("lock"))
    assert_untouched(out, 1)
    np.testing.assert_array_equal(out[K0:, 1], COMMAND[K0, 1])
    assert np.ptp(COMMAND[K0:, 1]) > 10  # the command did move


def test_lock_ends_and_refreezes_when_intermittent() -> None:
    out, _, _ = delivered(make("lock", profile=Profile("abrupt", onset=ONSET, end=0.7)))
    k_end = int(round(0.7 / DT))
    np.testing.assert_array_equal(out[K0:k_end, 1], COMMAND[K0, 1])
    np.testing.assert_array_equal(out[k_end:, 1], COMMAND[k_end:, 1])
    # On for 0.1 s of every 0.2 s: held at the value of each period's first sample, free in between.
    out, _, _ = delivered(make("lock", profile=Profile("intermittent", onset=ONSET, period=0.2, duty=0.5)))
    for start in (500, 700, 900):
        np.testing.assert_array_equal(out[start:start + 100, 1], COMMAND[start, 1])
        np.testing.assert_array_equal(out[start + 100:start + 200, 1], COMMAND[start + 100:start + 200, 1])


def test_float_delivers_nothing() -> None:
    out, torque, _ = delivered(make("float", joints=(0, 2)))
    np.testing.assert_array_equal(out[:K0], COMMAND[:K0])
    np.testing.assert_array_equal(out[K0:, [0, 2]], 0.0)
    np.testing.assert_array_equal(out[:, 1], COMMAND[:, 1])
    np.testing.assert_array_equal(torque[K0:, [0, 2]], -COMMAND[K0:, [0, 2]])


def _limited(fault: ActuatorFault, limits: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
    applied = ActuatorFaults([fault], T, NJ, limits)
    out, torque = np.empty((N, NJ)), np.empty((N, NJ))
    for k in range(N):
        applied.apply(k, COMMAND[k])
        out[k], torque[k] = applied.delivered, applied.torque
    return out, torque


@pytest.mark.parametrize("kind, parameter", [("float", None), ("bias", 20.0 * np.ones((N, NJ))),
                                             ("loss_of_effectiveness", 0.5 * np.ones((N, NJ))), ("lock", None)])
def test_behind_a_torque_limit_the_fault_acts_on_what_the_motor_gives(kind, parameter) -> None:
    """A motor limited to 5 N m on joint 2 (commanded up to 13): the fault acts on clip(u) and what it delivers
    stays within the limit (a bias too); MuJoCo adds clip(u), so the plant receives clip(u) + torque = delivered.
    Without the limits (None: the composition before, ``faults_after_torque_limit: false``) a float's torque is
    -u, so that the plant, clipping u itself, would receive clip(u) - u."""
    limits = np.array([np.inf, 5.0, np.inf])
    out, torque = _limited(make(kind, parameter=parameter), limits)
    clipped = np.clip(COMMAND, -limits, limits)
    np.testing.assert_allclose(clipped + torque, out, atol=1e-12)
    assert (np.abs(out[:, 1]) <= 5.0).all() and np.abs(COMMAND[:, 1]).max() > 10
    np.testing.assert_array_equal(out[:K0], clipped[:K0])  # before the onset: what the motor gives
    np.testing.assert_array_equal(out[:, [0, 2]], COMMAND[:, [0, 2]])  # unlimited joints as before
    if kind == "float":
        np.testing.assert_array_equal(out[K0:, 1], 0.0)
        _, unlimited = _limited(make(kind), None)
        np.testing.assert_array_equal(unlimited[K0:, 1], -COMMAND[K0:, 1])


def test_saturation_clips_and_ramps_in() -> None:
    limit = np.array([np.inf, 4.0, np.inf])
    out, _, _ = delivered(make("saturation", parameter=limit))
    assert_untouched(out, 1)
    np.testing.assert_array_equal(out[K0:, 1], np.clip(COMMAND[K0:, 1], -4.0, 4.0))
    assert np.abs(COMMAND[K0:, 1]).max() > 10  # it did clip
    # A ramp blends the healthy and the saturated actuator over ramp_time.
    out, _, _ = delivered(make("saturation", parameter=limit, profile=Profile("ramp", onset=ONSET, ramp_time=0.2)))
    w = np.minimum(1.0, (T[K0:] - ONSET) / 0.2)
    u = COMMAND[K0:, 1]
    np.testing.assert_allclose(out[K0:, 1], u + w * (np.clip(u, -4, 4) - u), rtol=1e-14, atol=1e-13)


def test_overlapping_faults_apply_in_order() -> None:
    loe = make("loss_of_effectiveness", parameter=table({1: 0.5}))
    bias = make("bias", parameter=table({1: 2.0}), profile=Profile("abrupt", onset=0.7))
    k_bias = 700
    out, _, _ = delivered(loe, bias)
    np.testing.assert_allclose(out[k_bias:, 1], 0.5 * COMMAND[k_bias:, 1] + 2.0, rtol=1e-15, atol=1e-14)
    np.testing.assert_allclose(out[K0:k_bias, 1], 0.5 * COMMAND[K0:k_bias, 1], rtol=1e-15)
    out, _, _ = delivered(bias, loe)
    np.testing.assert_allclose(out[k_bias:, 1], 0.5 * (COMMAND[k_bias:, 1] + 2.0), rtol=1e-15, atol=1e-14)


def test_intermittent_bias_is_on_for_the_duty_fraction() -> None:
    out, _, applied = delivered(make("bias", parameter=table({1: 1.0}),
                                     profile=Profile("intermittent", onset=ONSET, period=0.1, duty=0.3, end=0.9)))
    on = (T >= ONSET) & (T < 0.9) & (np.round((T - ONSET) / DT).astype(int) % 100 < 30)
    np.testing.assert_array_equal(applied.active, on)
    np.testing.assert_allclose(out[:, 1] - COMMAND[:, 1], np.where(on, 1.0, 0.0), atol=1e-14)


def test_active_is_on_while_any_fault_is() -> None:
    """Two faults on at different times: the run counts a fault as on whenever either is (the union, not the
    last fault's own times)."""
    first = make("bias", parameter=table({1: 1.0}), profile=Profile("abrupt", onset=0.2, end=0.4))
    second = make("lock", joints=(2,), profile=Profile("abrupt", onset=0.7))
    _, _, applied = delivered(first, second)
    np.testing.assert_array_equal(applied.active, ((T >= 0.2) & (T < 0.4)) | (T >= 0.7))


def test_lock_leaves_the_other_joints_alone_whatever_their_command() -> None:
    """A non-finite command on a healthy joint at the lock instant stays in that sample: the lock holds only
    its own joints' torques, so the healthy joint's later torques are its commands."""
    command = COMMAND.copy()
    command[K0, 0], command[K0, 2] = np.nan, np.inf
    with np.errstate(invalid="ignore"):  # that sample's fault torque, inf - inf, is NaN
        out, _, _ = delivered(make("lock"), command=command)
    np.testing.assert_array_equal(out[K0 + 1:, [0, 2]], command[K0 + 1:, [0, 2]])
    np.testing.assert_array_equal(out[K0:, 1], command[K0, 1])


def test_an_unknown_kind_is_named() -> None:
    with pytest.raises(ValueError, match="unknown actuator fault kind 'stuck'"):
        ActuatorFaults([make("stuck")], T, NJ)


# ------------------------------------------------------------------------------------------ scenario files


def faults_data(*faults: dict) -> dict:
    """The LoE scenario with these actuator faults and no diagnosis."""
    data = scenario_data()
    data["actuator_faults"] = list(faults)
    data.pop("diagnosis")
    return data


def test_compiled_from_a_scenario(tmp_path: Path) -> None:
    scenario = load(tmp_path, faults_data(
        {"kind": "loss_of_effectiveness", "joints": ["joint3", 1], "alpha": ["0.1", "0.2 + 0.05*t"],
         "profile": {"shape": "ramp", "onset": 3.0, "ramp_time": 0.5}},
        {"kind": "saturation", "joints": [2], "limit": 30.0, "profile": {"onset": 5.0, "end": 6.0}},
        {"kind": "bias", "offset": "sin(t)"},
    ))
    loe, saturation, bias = scenario.actuator_faults
    np.testing.assert_array_equal(loe.joints, [True, False, True])
    t = scenario.times
    np.testing.assert_allclose(loe.parameter[:, 2], 0.1)  # the first listed joint, joint3, takes the first value
    np.testing.assert_allclose(loe.parameter[:, 0], 0.2 + 0.05 * t, rtol=1e-14)
    np.testing.assert_array_equal(loe.parameter[:, 1], 0.0)
    assert (loe.profile.shape, loe.profile.onset, loe.profile.ramp_time) == ("ramp", 3.0, 0.5)
    np.testing.assert_array_equal(saturation.parameter, [np.inf, 30.0, np.inf])
    assert saturation.profile.end == 6.0
    np.testing.assert_array_equal(bias.joints, [True, True, True])  # joints absent: all
    np.testing.assert_allclose(bias.parameter, np.sin(t)[:, None] * np.ones(3), rtol=1e-14)
    assert bias.profile.onset == 0.0 and bias.profile.shape == "abrupt"
    # Actuator faults count as faults for the windows and the detection metrics.
    assert scenario.fault_onsets == [0.0, 3.0, 5.0]
    np.testing.assert_array_equal(scenario.joint_fault_onsets, [0.0, 0.0, 0.0])


def test_scenario_joint_onsets_from_actuator_faults(tmp_path: Path) -> None:
    scenario = load(tmp_path, scenario_data("puma_bias"))
    assert scenario.fault_onsets == [8.0]
    np.testing.assert_array_equal(scenario.joint_fault_onsets, [np.nan, np.nan, 8.0])


INVALID = [
    ({"kind": "stuck"}, "actuator_faults.0", "kind must be one of"),
    ({"joints": [1]}, "actuator_faults.0", "kind must be one of"),
    ({"kind": "lock", "alpha": 0.5}, "actuator_faults.0.alpha", "unknown key"),
    ({"kind": "loss_of_effectiveness"}, "actuator_faults.0.alpha", "required field is missing"),
    ({"kind": "loss_of_effectiveness", "alpha": 1.5}, "actuator_faults.0.alpha", "within [0, 1]"),
    ({"kind": "loss_of_effectiveness", "alpha": "t/5"}, "actuator_faults.0.alpha", "outside at t = 5.001"),
    ({"kind": "loss_of_effectiveness", "alpha": "q1"}, "actuator_faults.0.alpha", "unknown name 'q1'"),
    ({"kind": "loss_of_effectiveness", "joints": [1, 2], "alpha": [0.1]}, "actuator_faults.0.alpha",
     "has 1 values for 2 joints"),
    ({"kind": "loss_of_effectiveness", "joints": [1, 2], "alpha": [0.1, "open('x')"]}, "actuator_faults.0.alpha.1",
     "call of 'open'"),
    ({"kind": "bias", "offset": "1/(t - t)"}, "actuator_faults.0.offset", ""),
    ({"kind": "bias", "offset": True}, "actuator_faults.0.offset", ""),
    ({"kind": "float", "joints": [4]}, "actuator_faults.0.joints.0", "joint 4 does not exist"),
    ({"kind": "float", "joints": [0]}, "actuator_faults.0.joints.0", "greater than or equal to 1"),
    ({"kind": "float", "joints": ["elbow"]}, "actuator_faults.0.joints.0", "unknown joint 'elbow'"),
    ({"kind": "float", "joints": [2, "joint2"]}, "actuator_faults.0.joints.1", "listed twice"),
    ({"kind": "float", "joints": []}, "actuator_faults.0.joints", "at least 1"),
    ({"kind": "saturation", "limit": -1.0}, "actuator_faults.0.limit", "greater than 0"),
    ({"kind": "saturation"}, "actuator_faults.0.limit", "required field is missing"),
    ({"kind": "float", "profile": {"onset": 5.0, "end": 4.0}}, "actuator_faults.0.profile", "must be after the onset"),
    ({"kind": "float", "profile": {"shape": "incipient"}}, "actuator_faults.0.profile.rate", "required field"),
    ({"kind": "float", "profile": {"shape": "ramp", "ramp_time": 1.0, "rate": 2.0}},
     "actuator_faults.0.profile.rate", "unknown key"),
    ({"kind": "float", "profile": {"shape": "sudden"}}, "actuator_faults.0.profile", "shape must be one of"),
    ({"kind": "float", "profile": {"shape": "intermittent", "period": 1.0, "duty": 1.5}},
     "actuator_faults.0.profile.duty", "less than or equal to 1"),
    ({"kind": "float", "profile": {"shape": "incipient", "rate": [1.0, 2.0]}}, "actuator_faults.0.profile.rate",
     "has 2 values"),
]


@pytest.mark.parametrize(("fault", "field", "fragment"), INVALID, ids=[f"{i}" for i in range(len(INVALID))])
def test_invalid_fault(tmp_path: Path, fault: dict, field: str, fragment: str) -> None:
    assert_input_error(tmp_path, faults_data(fault), field, fragment)


def test_term_profiles(tmp_path: Path) -> None:
    """Additive fault terms take the same profiles; onset/rate stay the dissertation's shorthand."""
    data = scenario_data("puma_intermittent")
    scenario = load(tmp_path, data)
    fault = scenario.terms[2]
    assert fault.time_profile.shape == "intermittent" and fault.onset == 8.0
    assert fault.profile(8.1) == 1.0 and fault.profile(8.5) is None and fault.profile(9.0) == 1.0
    data["terms"][2]["onset"] = 8.0
    path = write(tmp_path, data)
    with pytest.raises(InputError) as info:
        load_scenario(path)
    assert info.value.field == "terms.2.profile" and "not both" in info.value.problem


# ------------------------------------------------------------------------------------------ closed loop


def test_closed_loop_fault_acts_through_qfrc_applied_only(tmp_path: Path) -> None:
    """LoE 0.5 on joint 2 at 0.1 s, perfect sensors, no other terms: the recorded command is the controller's,
    the plant accelerates as with the delivered torque, and the true LUaF is exactly the fault's
    acceleration M^-1 (delivered - commanded)."""
    data = faults_data({"kind": "loss_of_effectiveness", "joints": [2], "alpha": 0.5, "profile": {"onset": 0.1}})
    data.update(duration=0.3, terms=[], sensors={})
    scenario, result = run(tmp_path, data)
    k0 = 100
    assert result.status == "ok"
    np.testing.assert_array_equal(result.tau_delivered[:k0], result.tau[:k0])
    np.testing.assert_array_equal(result.tau_delivered[k0:, [0, 2]], result.tau[k0:, [0, 2]])
    np.testing.assert_array_equal(result.tau_delivered[k0:, 1], 0.5 * result.tau[k0:, 1])
    np.testing.assert_array_equal(result.fault_torque, result.tau_delivered - result.tau)
    np.testing.assert_array_equal(result.fault_active, result.t >= 0.1)
    nominal = NominalModel(scenario.model)
    scale = np.abs(result.qdd_true).max()
    for k in range(0, len(result.t), 7):
        q, qd, qdd = result.q_true[k], result.qd_true[k], result.qdd_true[k]
        # The plant's acceleration is that of the delivered torque ...
        np.testing.assert_allclose(nominal.lumped(q, qd, qdd, result.tau_delivered[k]), 0.0, atol=1e-9 * scale)
        # ... and the fault's acceleration is M^-1 of the fault torque, all of the true LUaF here.
        mass = nominal.mass_matrix(q)
        np.testing.assert_allclose(mass @ result.fault_acceleration[k], result.fault_torque[k], atol=1e-9 * scale)
        np.testing.assert_allclose(result.luaf_true[k], result.fault_acceleration[k], atol=1e-9 * scale)
    assert np.abs(result.fault_acceleration[k0:, 1]).max() > 1.0


@pytest.mark.slow  # a closed-loop run of seconds
def test_closed_loop_acceleration_fault_term_force(tmp_path: Path) -> None:
    """An additive acceleration-space fault: its generalized force is M(q) times it, its acceleration itself."""
    data = scenario_data("puma_intermittent")
    data.update(duration=8.5, sensors={})
    data.pop("diagnosis")
    _, result = run(tmp_path, data)
    on = result.fault_active
    assert on.any()
    np.testing.assert_allclose(result.fault_acceleration[on], result.fault[on], rtol=1e-9, atol=1e-9)
    np.testing.assert_array_equal(result.fault_torque[~on], 0.0)
    np.testing.assert_array_equal(result.tau_delivered, result.tau)


# ------------------------------------------------------------------------------------------ compiling


def compiled(fault: dict, field: str = "actuator_faults.0") -> ActuatorFault:
    """``fault`` validated and compiled for the PUMA on the grid T, as from the file ``f.yaml``."""
    spec = TypeAdapter(ActuatorFaultSpec).validate_python(fault)
    return compile_actuator_fault(spec, "f.yaml", field, puma_model(), T)


def test_default_name_is_the_kind_and_the_index() -> None:
    assert compiled({"kind": "bias", "offset": 1.0}, "actuator_faults.2").name == "bias2"
    assert compiled({"kind": "lock"}, "variants.slow.actuator_faults.4").name == "lock4"
    assert compiled({"kind": "lock", "name": "held elbow"}).name == "held elbow"


def test_parameter_per_kind() -> None:
    """alpha = 1 (the whole command lost) is within [0, 1]; lock and float carry no parameter."""
    full = compiled({"kind": "loss_of_effectiveness", "joints": [2], "alpha": 1.0})
    np.testing.assert_array_equal(full.parameter, table({1: 1.0}))
    assert compiled({"kind": "lock"}).parameter is None
    assert compiled({"kind": "float"}).parameter is None


@pytest.mark.parametrize(("fault", "field", "problem"), [
    # sqrt(0.25 - t) is NaN from the first sample after 0.25 s on; the message names that time.
    ({"kind": "bias", "joints": [1, 3], "offset": ["0", "sqrt(0.25 - t)"]}, "actuator_faults.0.offset",
     f"is not a finite number at t = {T[T > 0.25][0]:g}"),
    ({"kind": "saturation", "joints": [1, 2], "limit": [5.0]}, "actuator_faults.0.limit", "has 1 values for 2 joints"),
], ids=["offset not finite", "limit count"])
def test_compile_errors_name_file_field_and_problem(fault: dict, field: str, problem: str) -> None:
    with pytest.raises(InputError) as info:
        compiled(fault)
    assert (info.value.file, info.value.field, info.value.problem) == ("f.yaml", field, problem)
