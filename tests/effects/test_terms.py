"""Plant terms (ftc_mj.effects.terms): a fault term s f(t, q, qd) omega(t - Tf) with the incipient profile
omega(t - Tf) = 1 - exp(-zeta (t - Tf)) of (5.1) and (5.38) enters the plant as the closed form says, whether its
rate ``zeta`` is a number or names a scenario parameter (each member's own, worked out in the loop rather than
tabulated): both forms give the same series, for both signs s, for values f of both signs, before, at and after
the onset, in torque and in acceleration space (the latter through the true M(q)), one row or many."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml

from ftc_mj import fast
from ftc_mj.config.errors import InputError
from ftc_mj.fast.crossovers import PAIRED_COLUMNS, SCALAR_ROWS
from ftc_mj.effects.terms import PlantTerms, TermSpec, active_term_sets, compile_terms
from ftc_mj.engine.runner import simulate_variant
from ftc_mj.scenario.loading import load_scenario

ROOT = Path(__file__).resolve().parents[2]
NJ = 3
DT = 1e-3
TIMES = np.arange(1200) * DT
ONSET = 0.4
K0 = int(round(ONSET / DT))
PARAMETERS = ["fault_scale", "zeta"]
# f crosses zero on joints 1 and 2 as the states below swing (joint 1 through q1, joint 2 through qd2), so the
# term is checked with f > 0 and f < 0; joint 3 is healthy (f = 0).
VALUE = ["fault_scale*(3*sin(q1) + 0.5*cos(qd1*q2))", "fault_scale*(2*qd2 - 1.5*sin(q1*q2))", "0"]


def phi(q: np.ndarray, qd: np.ndarray, scale: np.ndarray) -> np.ndarray:
    """VALUE in NumPy, ``(samples, rows, NJ)`` from states ``(samples, rows, NJ)`` and ``scale`` ``(rows,)``."""
    return np.stack([scale * (3 * np.sin(q[..., 0]) + 0.5 * np.cos(qd[..., 0] * q[..., 1])),
                     scale * (2 * qd[..., 1] - 1.5 * np.sin(q[..., 0] * q[..., 1])),
                     np.zeros(q.shape[:-1])], axis=-1)


def states(rows: int) -> tuple[np.ndarray, np.ndarray]:
    """A trajectory per row, ``(len(TIMES), rows, NJ)``: q and qd swing through zero with row-dependent
    phases, so that f takes both signs on every faulty joint, in time and across rows."""
    phase = np.linspace(0.0, 2 * np.pi, rows, endpoint=False)[None, :, None] + np.arange(NJ)[None, None, :]
    t = TIMES[:, None, None]
    return 1.3 * np.sin(9 * t + phase), 2.1 * np.cos(7 * t + 2 * phase)


def masses(rows: int) -> np.ndarray:
    """Symmetric positive definite M(q) per sample and row, ``(len(TIMES), rows, NJ, NJ)``, changing in time."""
    rng = np.random.default_rng(5)
    a = rng.normal(size=(rows, NJ, NJ))
    base = a @ np.swapaxes(a, 1, 2) + NJ * np.eye(NJ)
    return base[None] * (1.0 + 0.3 * np.sin(3 * TIMES))[:, None, None, None]


def omega(zeta: np.ndarray) -> np.ndarray:
    """The incipient profile 1 - exp(-zeta (t - Tf)) for t >= Tf, 0 before, ``(len(TIMES), rows, 1)``."""
    elapsed = (TIMES - ONSET)[:, None, None]
    return np.where(elapsed >= 0, 1.0 - np.exp(-np.asarray(zeta)[None, :, None] * elapsed), 0.0)


def sweep(rate: float | str, sign: int, space: str, scale: np.ndarray, zeta: np.ndarray,
          extra: list[TermSpec] = ()) -> dict[str, np.ndarray]:
    """The fault term s VALUE, onset ONSET and the given ``rate``, after the ``extra`` terms, through
    :func:`apply_terms`."""
    spec = TermSpec(kind="fault", space=space, sign=sign, value=VALUE, onset=ONSET, rate=rate, name="fault")
    series, plant = apply_terms([*extra, spec], scale, zeta)
    np.testing.assert_array_equal(plant.fault_on, TIMES >= ONSET)
    return series


def apply_terms(specs: list[TermSpec], scale: np.ndarray, zeta: np.ndarray) -> tuple[dict[str, np.ndarray], PlantTerms]:
    """Every sample of the grid through PlantTerms.apply, for rows with the given ``fault_scale`` and ``zeta``
    parameters: the applied force and the fault sums, ``(len(TIMES), rows, NJ)`` each, and the terms."""
    rows = len(zeta)
    terms = compile_terms(specs, "test.yaml", NJ, PARAMETERS)
    plant = PlantTerms(terms, TIMES, rows, NJ, np.column_stack([scale, zeta]), PARAMETERS)
    q, qd = states(rows)
    mass = masses(rows)
    series = {name: np.empty((len(TIMES), rows, NJ)) for name in ("applied", "fault", "fault_force")}
    out = np.empty((rows, NJ))
    for k, t in enumerate(TIMES.tolist()):
        plant.apply(k, t, q[k], qd[k], mass[k] if plant.maps_acceleration(k) else None, out)
        series["applied"][k], series["fault"][k], series["fault_force"][k] = out, plant.fault, plant.fault_force
    return series, plant


def closed_form(sign: int, space: str, scale: np.ndarray, zeta: np.ndarray) -> dict[str, np.ndarray]:
    """s f omega(t - Tf), and its generalized force (M(q) times it in acceleration space)."""
    q, qd = states(len(zeta))
    fault = sign * phi(q, qd, scale) * omega(zeta)
    force = np.einsum("krij,krj->kri", masses(len(zeta)), fault) if space == "acceleration" else fault
    return {"applied": force, "fault": fault, "fault_force": force}


def test_a_parameter_rate_compiles_to_an_abrupt_profile_and_its_parameter() -> None:
    """The loop multiplies the abrupt profile by each member's 1 - exp(-zeta (t - Tf)); a numeric rate is
    tabulated in the profile itself."""
    spec = dict(kind="fault", space="acceleration", sign=1, value=VALUE, onset=ONSET)
    by_name, by_number = compile_terms([TermSpec(**spec, rate="zeta"), TermSpec(**spec, rate=2.0)], "test.yaml", NJ,
                                       PARAMETERS)
    assert by_name.rate_parameter == "zeta" and by_name.time_profile.shape == "abrupt"
    assert by_number.rate_parameter is None and by_number.time_profile.shape == "incipient"
    np.testing.assert_array_equal(by_number.rate, [2.0, 2.0, 2.0])
    np.testing.assert_array_equal(by_name.joints, [True, True, False])


@pytest.mark.slow  # a closed-loop run of seconds
@pytest.mark.parametrize("space", ["acceleration", "torque"])
@pytest.mark.parametrize("sign", [1, -1])
@pytest.mark.parametrize("zeta", [0.5, 2.0, 40.0])
def test_parameter_rate_equals_numeric_rate_and_the_closed_form(space: str, sign: int, zeta: float) -> None:
    """The same term with ``rate: zeta`` (zeta a parameter) and with the number itself: the same series bit for bit, and
    both s f (1 - exp(-zeta (t - Tf))) from the onset on, zero before."""
    rows = 4
    scale, rates = np.array([1.0, 0.5, -2.0, 1.0]), np.full(rows, zeta)
    by_name = sweep("zeta", sign, space, scale, rates)
    by_number = sweep(zeta, sign, space, scale, rates)
    expected = closed_form(sign, space, scale, rates)
    fault = expected["fault"][K0 + 1:, :, :2]
    assert (fault > 0).any() and (fault < 0).any()  # f of both signs on the faulty joints, after the onset
    for name, series in by_name.items():
        np.testing.assert_array_equal(series, by_number[name],
                                   err_msg=f"{name}: rate as a parameter differs from the same rate as a number")
        np.testing.assert_allclose(series, expected[name], rtol=1e-12, atol=1e-12,
                                   err_msg=f"{name}: not s f (1 - exp(-zeta (t - Tf)))")
        np.testing.assert_array_equal(series[:K0], 0.0, err_msg=f"{name}: on before the onset")
        np.testing.assert_array_equal(series[K0], 0.0, err_msg=f"{name}: omega(0) = 0 at the onset")
    # The term always has the sign of s f (the profile is in [0, 1)): a sign error in the profile flips it.
    sign_of = np.sign(by_name["fault"][K0 + 1:, :, :2])
    np.testing.assert_array_equal(sign_of, np.sign(sign * phi(*states(rows), scale)[K0 + 1:, :, :2]),
                                  err_msg="the fault term does not have the sign of s f")


@pytest.mark.slow  # a closed-loop run of seconds
@pytest.mark.parametrize("rows", [3, SCALAR_ROWS + 3])
@pytest.mark.parametrize("sign", [1, -1])
def test_each_member_follows_its_own_rate(rows: int, sign: int) -> None:
    """Rows (members) with different rates: each row is the closed form with its own rate and equals the row
    of a run with that rate as a number; on both sides of the row count where expressions go columnwise."""
    rng = np.random.default_rng(rows)
    zeta = rng.uniform(0.3, 30.0, rows)
    scale = rng.choice([-1.5, -0.5, 0.7, 2.0], rows)
    by_name = sweep("zeta", sign, "acceleration", scale, zeta)
    expected = closed_form(sign, "acceleration", scale, zeta)
    for name, series in by_name.items():
        np.testing.assert_allclose(series, expected[name], rtol=1e-12, atol=1e-12, err_msg=name)
    for row in (0, rows - 1):
        alone = sweep(float(zeta[row]), sign, "acceleration", scale, zeta)
        np.testing.assert_array_equal(by_name["fault"][:, row], alone["fault"][:, row])


def test_other_terms_add_and_stay_out_of_the_fault_sums() -> None:
    """A torque-space friction term beside the parameter-rate fault: the applied force is friction plus the
    fault's M(q) image; the fault sums hold the fault alone."""
    friction = TermSpec(kind="friction", space="torque", sign=-1, value=["1.9*sin(qd1)", "2.03*sin(qd2)", "0.5"])
    scale, zeta = np.array([1.0, -1.0]), np.array([2.0, 5.0])
    series = sweep("zeta", 1, "acceleration", scale, zeta, extra=[friction])
    expected = closed_form(1, "acceleration", scale, zeta)
    _, qd = states(2)
    torque = -np.stack([1.9 * np.sin(qd[..., 0]), 2.03 * np.sin(qd[..., 1]), np.full(qd.shape[:-1], 0.5)], axis=-1)
    np.testing.assert_allclose(series["applied"], torque + expected["applied"], rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(series["fault"], expected["fault"], rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(series["fault_force"], expected["fault_force"], rtol=1e-12, atol=1e-12)


def test_acceleration_friction_stays_out_of_the_fault_force() -> None:
    """An acceleration-space friction term beside the acceleration-space fault: the applied force is M(q) times
    both, the fault's generalized force M(q) times the fault alone (not the image of the whole acceleration
    sum, which is the fault's only when the fault terms are all the acceleration terms)."""
    friction = TermSpec(kind="friction", space="acceleration", sign=-1, value=["0.8*qd1", "0.6*sin(qd2)", "0.4"])
    scale, zeta = np.array([1.0, -1.0]), np.array([2.0, 5.0])
    series = sweep("zeta", 1, "acceleration", scale, zeta, extra=[friction])
    expected = closed_form(1, "acceleration", scale, zeta)
    _, qd = states(2)
    acceleration = -np.stack([0.8 * qd[..., 0], 0.6 * np.sin(qd[..., 1]), np.full(qd.shape[:-1], 0.4)], axis=-1)
    applied = np.einsum("krij,krj->kri", masses(2), acceleration) + expected["applied"]
    np.testing.assert_allclose(series["applied"], applied, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(series["fault_force"], expected["fault_force"], rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(series["fault"], expected["fault"], rtol=1e-12, atol=1e-12)


def test_torque_and_acceleration_faults_add_in_the_fault_force() -> None:
    """A torque-space fault from the start beside the acceleration-space one: the fault force is the torque
    fault plus M(q) times the acceleration fault; the fault signal is their sum, each in its own space."""
    torque_fault = TermSpec(kind="fault", space="torque", sign=1, value=["2.5", "-1.5*sin(q1)", "0"])
    scale, zeta = np.array([1.0, 0.5]), np.array([3.0, 1.0])
    series, plant = apply_terms([torque_fault, TermSpec(kind="fault", space="acceleration", sign=-1, value=VALUE,
                                                        onset=ONSET, rate="zeta")], scale, zeta)
    assert plant.fault_on.all()
    expected = closed_form(-1, "acceleration", scale, zeta)
    q, _ = states(2)
    torque = np.stack([np.full(q.shape[:-1], 2.5), -1.5 * np.sin(q[..., 0]), np.zeros(q.shape[:-1])], axis=-1)
    np.testing.assert_allclose(series["fault_force"], torque + expected["fault_force"], rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(series["fault"], torque + expected["fault"], rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(series["applied"], torque + expected["applied"], rtol=1e-12, atol=1e-12)


def test_only_periods_with_acceleration_terms_need_the_mass() -> None:
    """The loop computes the true M(q) only where :meth:`PlantTerms.maps_acceleration` says so: from an
    acceleration-space fault's onset on, never with torque-space terms alone (``apply_terms`` passes None
    elsewhere, so a period that used M anyway would fail)."""
    rows = 2
    torque_fault = TermSpec(kind="fault", space="torque", sign=1, value=VALUE, onset=ONSET)
    acceleration_fault = TermSpec(kind="fault", space="acceleration", sign=1, value=VALUE, onset=ONSET)
    for specs, expected in (([torque_fault], np.zeros(len(TIMES), dtype=bool)),
                            ([torque_fault, acceleration_fault], TIMES >= ONSET)):
        terms = PlantTerms(compile_terms(specs, "test.yaml", NJ, PARAMETERS), TIMES, rows, NJ,
                           np.ones((rows, 2)), PARAMETERS)
        np.testing.assert_array_equal([terms.maps_acceleration(k) for k in range(len(TIMES))], expected)


def test_an_onset_without_a_rate_is_a_step() -> None:
    """``onset`` alone: an abrupt profile, s f from the onset on, zero before."""
    step = TermSpec(kind="fault", space="torque", sign=-1, value=VALUE, onset=ONSET)
    (term,) = compile_terms([step], "test.yaml", NJ, PARAMETERS)
    assert term.time_profile.shape == "abrupt" and term.rate is None and term.onset == ONSET
    assert term.profile(ONSET - DT) is None and term.profile(ONSET) == 1.0
    scale = np.array([1.0, -2.0])
    series, _ = apply_terms([step], scale, np.ones(2))
    expected = -phi(*states(2), scale) * (TIMES >= ONSET)[:, None, None]
    np.testing.assert_allclose(series["fault"], expected, rtol=1e-12, atol=1e-12)


def test_a_profile_section_and_the_always_on_term() -> None:
    """A term's ``profile:`` takes the profile's own rate, one per joint; a term with neither profile nor onset
    is on at full weight from the start."""
    incipient = TermSpec(kind="disturbance", space="torque", sign=1, value=["1", "1", "1"],
                         profile={"shape": "incipient", "onset": 0.2, "rate": 4.0})
    always = TermSpec(kind="friction", space="torque", sign=-1, value=["qd1", "0", "0"])
    first, second = compile_terms([incipient, always], "test.yaml", NJ, PARAMETERS)
    np.testing.assert_array_equal(first.rate, [4.0, 4.0, 4.0])
    np.testing.assert_allclose(first.profile(0.45), np.full(3, 1 - np.exp(-1.0)), rtol=1e-15)
    assert second.time_profile is None and second.profile(0.0) == 1.0 and second.profile(1e3) == 1.0


def test_names_and_the_term_function() -> None:
    """Unnamed terms are called by their kind and index; a term's own function evaluates its expressions with
    the scenario's parameters."""
    specs = [TermSpec(kind="friction", space="torque", sign=-1, value=["qd1", "0", "0"]),
             TermSpec(kind="fault", space="torque", sign=1, value=VALUE, name="Phi")]
    friction, fault = compile_terms(specs, "test.yaml", NJ, PARAMETERS)
    assert (friction.name, fault.name) == ("friction0", "Phi")
    assert fault.parameters == tuple(PARAMETERS)
    q, qd = states(2)
    scale = np.array([0.5, -1.0])
    out = np.empty((2, NJ))
    fault.function.evaluate(0.3, q[5], qd[5], np.column_stack([scale, [1.0, 1.0]]), out)
    np.testing.assert_allclose(out, phi(q[5:6], qd[5:6], scale)[0], rtol=1e-14, atol=1e-14)


TERM_ERRORS = [
    ({"value": ["1", "2"]}, "terms.0.value", "has 2 values, the robot has 3 joints"),
    ({"value": ["1", "open('x')", "0"]}, "terms.0.value.1", None),
    ({"onset": 0.1, "profile": {"shape": "abrupt"}}, "terms.0.profile",
     "give either a profile or onset and rate, not both"),
    ({"profile": {"shape": "incipient", "rate": [1.0, 2.0]}}, "terms.0.profile.rate",
     "has 2 values, the robot has 3 joints"),
    ({"rate": 2.0}, "terms.0.rate", "an evolution rate needs an onset"),
    ({"onset": 0.1, "rate": "speed"}, "terms.0.rate", "'speed' is not one of the scenario's parameters"),
    ({"onset": 0.1, "rate": [1.0, 2.0]}, "terms.0.rate", "has 2 values, the robot has 3 joints"),
]


@pytest.mark.parametrize(("change", "field", "problem"), TERM_ERRORS,
                         ids=[f"{field} {i}" for i, (_, field, _) in enumerate(TERM_ERRORS)])
def test_compile_errors_name_file_field_and_problem(change: dict, field: str, problem: str | None) -> None:
    """Each problem of a term names the file, the exact field and (where this module writes it) the problem."""
    spec = TermSpec(**{"kind": "fault", "space": "torque", "sign": 1, "value": ["1", "0", "0"], **change})
    with pytest.raises(InputError) as info:
        compile_terms([spec], "test.yaml", NJ, PARAMETERS)
    assert (info.value.file, info.value.field) == ("test.yaml", field)
    assert problem is None or info.value.problem == problem, info.value.problem


def test_closed_loop_parameter_rate_equals_the_numeric_rate(tmp_path: Path) -> None:
    """scenarios/puma_fault.yaml (``rate: zeta``, zeta = 2) with its fault moved to 0.2 s, against the same file
    with ``rate: 2.0``: the same run bit for bit, and the recorded fault is (5.38)'s Phi times
    1 - exp(-2 (t - 0.2)) on the true state, with the sign +1 of (5.1)."""
    data = yaml.safe_load((ROOT / "scenarios" / "puma_fault.yaml").read_text(encoding="utf-8"))
    data["robot"]["model"] = str(ROOT / "models" / "puma560.xml")
    data.update(duration=0.8, figures=[])
    data.pop("output", None)
    data.pop("diagnosis", None)
    data["variants"] = {"proposed": data["variants"]["proposed"]}
    data["metrics"].update(window_start=0.1, estimation_window_start=0.1)
    fault = data["terms"][2]
    assert fault["rate"] == "zeta" and data["parameters"]["zeta"] == 2.0
    fault["onset"] = 0.2
    results = []
    for rate in ("zeta", 2.0):
        fault["rate"] = rate
        path = tmp_path / f"rate_{rate}.yaml"
        path.write_text(yaml.safe_dump(data, sort_keys=False), encoding="utf-8")
        scenario = load_scenario(path)
        results.append(simulate_variant(scenario, scenario.variants[0]))
    by_name, by_number = results
    assert by_name.status == by_number.status == "ok"
    for name in ("fault", "fault_acceleration", "fault_torque", "tau", "q_true", "luaf_true"):
        np.testing.assert_array_equal(getattr(by_name, name), getattr(by_number, name), err_msg=name)
    t, q, qd = by_name.t, by_name.q_true, by_name.qd_true
    phi_538 = np.stack([10 * np.sin(q[:, 0] * q[:, 1]) + 3.7 * np.cos(qd[:, 0] * q[:, 1])
                        + 5.2 * np.cos(qd[:, 0] * qd[:, 1]),
                        15 * np.sin(q[:, 0] * q[:, 1]) + 3.6 * np.cos(qd[:, 0] * q[:, 1])
                        + 2.7 * np.cos(qd[:, 0] * qd[:, 1]), np.zeros(len(t))], axis=1)
    weight = np.where(t >= 0.2, 1.0 - np.exp(-2.0 * (t - 0.2)), 0.0)[:, None]
    np.testing.assert_allclose(by_name.fault, phi_538 * weight, rtol=1e-12, atol=1e-12,
                               err_msg="the fault is not +Phi (1 - exp(-zeta (t - Tf)))")
    assert by_name.fault[-1, 0] > 1.0  # well into the fault: Phi_1 is about 9 here


@pytest.mark.parametrize("sign", [1, -1])
def test_the_tabulated_weights_are_each_periods_numpy_sequence_bit_for_bit(sign: int) -> None:
    """The rate parameters' weights, tabulated a block of samples at a time, against NumPy's sequence on
    one period's ``(rows, 1)`` column, sample by sample: ``rate * -(t - onset)``, exp, ``1 - e`` (or
    ``e - 1``), over more samples than one block and 7 rows of rates from slow to fast. The samples are
    taken out of order too, as a run that restarts its blocks would."""
    from ftc_mj.effects import terms as module

    rows = 7
    times = np.arange(2 * module.WEIGHT_BLOCK + 37) * 1e-3 + ONSET - 0.05
    rates = np.geomspace(0.1, 60.0, rows)
    spec = TermSpec(kind="fault", space="torque", sign=sign, value=VALUE, onset=ONSET, rate="zeta")
    plant = PlantTerms(compile_terms([spec], "test.yaml", NJ, PARAMETERS), times, rows, NJ,
                       np.column_stack([np.ones(rows), rates]), PARAMETERS)
    column = rates[:, None].copy()
    for k in [*range(len(times)), 3 * module.WEIGHT_BLOCK // 2, 5]:
        t = float(times[k])
        if t < ONSET:
            continue
        expected = np.multiply(column, -(t - ONSET))
        np.exp(expected, out=expected)
        expected = 1.0 - expected if sign > 0 else expected - 1.0
        block = k - plant._block_start
        if not 0 <= block < plant._weights.shape[1]:
            plant._tabulate_weights(k)
            block = 0
        np.testing.assert_array_equal(plant._weights[0, block], expected[:, 0])


def test_the_terms_are_evaluated_on_the_buffers_given_bound_once_per_pair() -> None:
    """The loop passes the plant's live state buffers every period: the terms' evaluation is bound to them once,
    reads them as they are now, and is bound again when another buffer comes (either of the two)."""
    friction = TermSpec(kind="friction", space="torque", sign=1, value=["qd1", "2*q2 + qd3", "q1*qd2"])
    terms = PlantTerms(compile_terms([friction], "test.yaml", NJ, PARAMETERS), TIMES, 2, NJ, np.ones((2, 2)),
                       PARAMETERS)
    rng = np.random.default_rng(9)
    q, qd, out = rng.normal(size=(2, NJ)), rng.normal(size=(2, NJ)), np.empty((2, NJ))

    def expected(q: np.ndarray, qd: np.ndarray) -> np.ndarray:
        return np.stack([qd[:, 0], 2 * q[:, 1] + qd[:, 2], q[:, 0] * qd[:, 1]], axis=1)

    terms.apply(0, 0.0, q, qd, None, out)
    np.testing.assert_array_equal(out, expected(q, qd))
    binding = terms._state[2]
    q[...], qd[...] = rng.normal(size=(2, NJ)), rng.normal(size=(2, NJ))  # in place, as the plant steps
    terms.apply(1, DT, q, qd, None, out)
    np.testing.assert_array_equal(out, expected(q, qd))
    assert terms._state[2] is binding
    for q_next, qd_next in ((q, rng.normal(size=(2, NJ))), (rng.normal(size=(2, NJ)), qd)):
        terms.apply(2, 2 * DT, q_next, qd_next, None, out)
        np.testing.assert_array_equal(out, expected(q_next, qd_next))
        assert terms._state[2] is not binding
        binding = terms._state[2]
        q, qd = q_next, qd_next


@pytest.mark.slow  # a closed-loop run of seconds
def test_the_mapped_terms_are_the_same_on_a_live_mass_buffer_and_on_new_ones() -> None:
    """The loop passes one live M(q) buffer every period (the products then run past the dispatcher), or a new
    one; both give the bits of a new view each period, also after the buffer changes, for the acceleration sum
    and the fault's (an acceleration friction beside the fault: the two sums differ)."""
    friction = TermSpec(kind="friction", space="acceleration", sign=-1, value=["0.5*qd1", "sin(q2)", "qd3"])
    specs = [friction, TermSpec(kind="fault", space="acceleration", sign=1, value=VALUE, onset=ONSET, rate="zeta")]
    scale, zeta = np.array([1.0, 0.5, 2.0]), np.array([3.0, 1.0, 2.0])
    expected, _ = apply_terms(specs, scale, zeta)  # a new view of the masses each period
    rows = len(zeta)
    plant = PlantTerms(compile_terms(specs, "test.yaml", NJ, PARAMETERS), TIMES, rows, NJ,
                       np.column_stack([scale, zeta]), PARAMETERS)
    q, qd = states(rows)
    mass, live, other = masses(rows), np.empty((rows, NJ, NJ)), np.empty((2 * rows, NJ, NJ))[::2]
    out = np.empty((rows, NJ))
    for k, t in enumerate(TIMES.tolist()):
        buffer = live if k < len(TIMES) // 2 else other  # one buffer, then another of another layout
        buffer[...] = mass[k]
        plant.apply(k, t, q[k], qd[k], buffer, out)
        np.testing.assert_array_equal(out, expected["applied"][k])
        np.testing.assert_array_equal(plant.fault_force, expected["fault_force"][k])
    if NJ <= PAIRED_COLUMNS and fast.enabled():  # the compiled product, bound to the live buffers
        assert plant._map_acceleration.vectors is plant.acceleration and plant._map_acceleration.matrices is other
        assert plant._map_fault_acceleration.vectors is plant._fault_acceleration


@pytest.mark.parametrize("shape", [(3, 400), (1, 1), (5, 2), (0, 7), (2, 0)])
def test_the_active_term_sets_are_numpys_unique_rows_of_every_sample(shape: tuple[int, int]) -> None:
    """The sets and each sample's set as ``np.unique(on.T, axis=0, return_inverse=True)`` gives them: stretches of
    one set, a set that comes back after another, a term that flips every sample, no terms, no samples."""
    generator = np.random.default_rng(7)
    on = np.zeros(shape, dtype=bool)
    if on.size:
        on[:, shape[1] // 3:] = True
        on[0, 2 * shape[1] // 3:] = False  # back to an earlier set
        on[-1, ::2] = generator.random(on[-1, ::2].shape) < 0.5
    expected_sets, expected_plans = np.unique(on.T, axis=0, return_inverse=True)
    sets, plans = active_term_sets(on)
    np.testing.assert_array_equal(sets, expected_sets)
    np.testing.assert_array_equal(plans, expected_plans.reshape(-1))
    assert plans.shape == (shape[1],)


@pytest.mark.parametrize(("samples", "onset_sample", "rows"), [(300, 50, 2), (100, 10, 3), (600, 0, 300)])
def test_a_rated_fault_reads_its_own_samples_weights_on_any_grid(samples: int, onset_sample: int, rows: int) -> None:
    """The incipient weights are tabulated a block of periods at a time from the first faulted period on: on a
    grid shorter than a block, one between one and two blocks long, an onset a few periods in, and more rows
    than a block has periods, every sample's fault is s (1 - exp(-zeta (t - Tf))) of its own time."""
    times = np.arange(samples) * DT
    onset = float(times[onset_sample])
    spec = TermSpec(kind="fault", space="torque", sign=-1, value=["1", "2", "0"], onset=onset, rate="zeta",
                    name="fault")
    zeta = np.linspace(2.0, 9.0, rows)
    plant = PlantTerms(compile_terms([spec], "test.yaml", NJ, PARAMETERS), times, rows, NJ,
                       np.column_stack([np.ones(rows), zeta]), PARAMETERS)
    q, qd, out = np.zeros((rows, NJ)), np.zeros((rows, NJ)), np.empty((rows, NJ))
    for k, t in enumerate(times.tolist()):
        plant.apply(k, t, q, qd, None, out)
        elapsed = t - onset
        weight = 1.0 - np.exp(-zeta * elapsed) if elapsed >= 0 else np.zeros(rows)
        np.testing.assert_allclose(plant.fault, -weight[:, None] * np.array([1.0, 2.0, 0.0]), rtol=1e-12, atol=0,
                                   err_msg=f"sample {k}")
