"""The batched engine: every member of a batch equals its own run alone (B = 1), for every built-in observer and
controller, with per-member gains, seeds, parameters, mass mismatch of the plant and of the nominal model, and a
member that diverges while the others finish. B = 5 members of a 3-joint robot (B != n, so that a mixed-up
member and joint axis shows)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml

from ftc_mj.analysis.metrics import compute_metrics
from ftc_mj.engine import runner
from ftc_mj.engine.loop import quiet_warnings, simulate
from ftc_mj.engine.members import Members, members_from_overrides, replicates
from ftc_mj.engine.runner import run_batch, variant_result
from ftc_mj.config.errors import InputError
from ftc_mj.scenario.loading import load_scenario
from ftc_mj.scenario.definition import Scenario

#: closed-loop batches checked member by member against single runs
pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[2]
PUMA = ROOT / "models" / "puma560.xml"
NFTSMC = {"beta1": 15.0, "beta2": 10.0, "beta3": 10.0, "beta4": 5.0, "gamma1": 0.5, "bound": 0.5, "mu": 0.5}

#: One variant per built-in observer and controller (the DO, the NDOB and the momentum observer read the
#: tachometers; the momentum observer also as a variant's own observer, whose StepModel the controller shares).
VARIANTS = {
    "hs_nftsmc": {"observer": {"type": "hs_tosmo", "gains": {"D": 22.0, "gamma": 5.0}},
                  "controller": {"type": "nftsmc", "gains": NFTSMC},
                  "monitors": {"eso": {"type": "eso", "gains": {"bandwidth": 60.0}},
                               "levant": {"type": "levant", "gains": {"order": 2, "L": 50.0, "use_model": True}},
                               "levant3": {"type": "levant", "gains": {"order": 3, "L": 200.0,
                                                                       "discretisation": "taylor"}},
                               "ndob": {"type": "ndob", "gains": {"X": [0.01, 0.02, 0.05]}},
                               "ndob_levant": {"type": "ndob_levant", "gains": {"X": 0.02, "L": 50.0}},
                               "kalman": {"type": "kalman", "gains": {"process_d": 100.0, "measurement": 1e-9}},
                               "momentum": {"type": "momentum", "gains": {"K": [50.0, 60.0, 90.0]}},
                               "momentum_levant": {"type": "momentum_levant", "gains": {"K": 50.0, "L": 50.0}}}},
    "tosmo_sigmoid": {"observer": {"type": "tosmo", "gains": {"D": 22.0}},
                      "controller": {"type": "sigmoid_nftsmc", "gains": {
                          "kappa1": 6.0, "kappa2": 4.0, "mu1": 1.2, "mu2": 1.4, "alpha": 0.6, "bound": 0.5,
                          "mu": 0.5}}},
    "sosmo_ntsmc": {"observer": {"type": "sosmo", "gains": {"L": 22.0, "filter_time_constant": 0.01}},
                    "controller": {"type": "ntsmc", "gains": {"beta1": 1.5, "beta2": 0.4, "decay": 0.7,
                                                              "alpha": 0.3, "bound": 5.0, "mu": 0.5}}},
    "eso_smc": {"observer": {"type": "eso", "gains": {"bandwidth": 60.0}},
                "controller": {"type": "smc", "gains": {"c": 10.0, "bound": 5.0, "mu": 0.5}}},
    "kalman_smc": {"observer": {"type": "kalman", "gains": {"process_d": [50.0, 100.0, 200.0], "measurement": 1e-9,
                                                            "process_qd": 0.01}},
                   "controller": {"type": "smc", "gains": {"c": 10.0, "bound": 5.0, "mu": 0.5}}},
    "momentum_smc": {"observer": {"type": "momentum", "gains": {"K": 60.0}},
                     "controller": {"type": "smc", "gains": {"c": 10.0, "bound": 5.0, "mu": 0.5}}},
    "do_adaptive": {"observer": {"type": "do", "gains": {"k1": 8.0, "k2": 18.0, "p1": 10.0, "p2": 10.0}},
                    "controller": {"type": "a_nftsmc", "gains": {
                        "beta1": 15.0, "beta2": 10.0, "gamma1": 0.5, "rho": 5.0, "dead_zone": 0.01, "mu": 0.5}}},
    "tosmo_ctc": {"observer": {"type": "tosmo", "gains": {"D": 22.0}},
                  "controller": {"type": "computed_torque", "gains": {"kp": 100.0, "compensation": "estimate"}}},
    "eso_super_twisting": {"observer": {"type": "eso", "gains": {"bandwidth": 60.0}},
                           "controller": {"type": "super_twisting", "gains": {"c": 10.0, "L": 30.0}}},
    "hs_pid": {"observer": {"type": "hs_tosmo", "gains": {"D": 22.0, "gamma": 5.0}},
               "controller": {"type": "pid", "gains": {"kp": [2000.0, 4000.0, 1000.0], "ki": [4000.0, 8000.0, 2000.0],
                                                       "kd": [100.0, 200.0, 50.0],
                                                       "torque_limit": [100.0, 200.0, 100.0]}}},
}

#: Per member: its own seed, gains, parameter, masses; member 3 diverges at once (its velocity is beyond
#: ``divergence.max_velocity``), member 4 differs only in its seed.
MEMBERS = [
    {},
    {"seed": 11, "parameters.fault_scale": 0.5, "variants.hs_nftsmc.controller.gains.mu": 2.0,
     "variants.eso_smc.observer.gains.bandwidth": 40.0, "variants.hs_nftsmc.monitors.eso.gains.bandwidth": 90.0,
     "variants.hs_nftsmc.monitors.levant.gains.L": [30.0, 60.0, 90.0],
     "variants.hs_nftsmc.monitors.ndob_levant.gains.lambda1": 2.0,
     "variants.hs_nftsmc.monitors.kalman.gains.process_d": 20.0, "variants.kalman_smc.observer.gains.measurement": 1e-8,
     "variants.eso_super_twisting.controller.gains.L": 50.0, "variants.hs_nftsmc.monitors.momentum.gains.K": 30.0,
     "variants.momentum_smc.observer.gains.K": [40.0, 50.0, 70.0]},
    {"nominal.mass_scale": 1.2, "plant.mass_scale": 0.9, "parameters.amplitude": 0.5, "variants.do_adaptive.controller.gains.rho": [1.0, 2.0, 3.0],
     "variants.tosmo_sigmoid.observer.gains.D": 30.0, "variants.hs_nftsmc.monitors.ndob.gains.X": 0.03, "initial.q": [-0.4, -0.6, -0.5], "parameters.fault_rate": 3.0,
     "variants.tosmo_ctc.controller.gains.kd": [15.0, 20.0, 25.0], "variants.hs_pid.controller.gains.torque_limit": [40.0, 60.0, 30.0]},
    {"initial.qd.1": 5000.0},
    {"seed": 7, "variants.sosmo_ntsmc.controller.gains.decay": 1.1},
]


def scenario_dict() -> dict:
    return {
        "name": "batch_test",
        "robot": {"model": str(PUMA), "sensors": ["position", "velocity"]},
        "seed": 3,
        "duration": 0.25,
        "control_dt": 1e-3,
        "timestep": 5e-4,
        "initial": {"q": [-0.5, -0.5, -0.5], "qd": [0.0, 0.0, 0.0]},
        "observer_initial": {"qd_hat": [0.5, 0.5, 0.5]},
        "parameters": {"fault_scale": 1.0, "amplitude": 0.0, "fault_rate": 20.0},
        "reference": ["cos(pi*t/5) - 1", "sin(pi*t/5 + pi/2) - 1", "0.3*sin(2*t) - 0.5 + amplitude*t**2"],
        "terms": [
            {"kind": "friction", "space": "torque", "sign": -1, "value": ["1.9*sin(qd1)", "2.03*sin(qd2)", "1.76*sin(qd3)"]},
            {"kind": "fault", "space": "acceleration", "sign": 1, "onset": 0.1, "rate": "fault_rate",
             "value": ["fault_scale*(10*sin(q1*q2) + 3.7*cos(qd1*q2))", "fault_scale*15*sin(q1*q2)", "0"]},
        ],
        "actuator_faults": [{"kind": "lock", "joints": [3], "profile": {"onset": 0.15, "end": 0.2}}],
        "sensors": {"position": {"counts_per_rev": 65536, "noise_std": 1e-5, "delay_samples": 1},
                    "velocity": {"noise_std": 1e-3}},
        "diagnosis": {"space": "torque", "baseline": {"start": 0.02, "end": 0.09}, "threshold": {"k": 5.0},
                      "persistence": {"samples": 3}},
        "variants": VARIANTS,
        "metrics": {"window_start": 0.05, "estimation_window_start": 0.05},
        "divergence": {"max_velocity": 1000.0},
    }


@pytest.fixture(scope="module")
def scenario(tmp_path_factory) -> Scenario:
    path = tmp_path_factory.mktemp("batch") / "batch.yaml"
    path.write_text(yaml.safe_dump(scenario_dict(), sort_keys=False), encoding="utf-8")
    return load_scenario(path)


@pytest.fixture(scope="module")
def batch_run(scenario):
    return simulate(scenario, members_from_overrides(scenario, MEMBERS), nthread=2)


SERIES = ("q_ref", "qd_ref", "qdd_ref", "q_meas", "q_true", "qd_true", "qdd_true", "qd_hat", "luaf_hat", "luaf_true", "tau", "sliding", "fault",
          "tau_delivered", "fault_torque", "fault_acceleration", "qd_meas")


@pytest.mark.parametrize("member", range(len(MEMBERS)))
def test_every_member_equals_its_own_run(scenario, batch_run, member):
    seed = scenario.spec.seed + member  # a member without its own seed has seed + its index
    alone = simulate(scenario, members_from_overrides(scenario, [{"seed": seed, **MEMBERS[member]}]), nthread=1)
    for v, variant in enumerate(scenario.variants):
        batched, single = variant_result(scenario, batch_run, v, member), variant_result(scenario, alone, v, 0)
        assert batched.status == single.status and batched.diverged_at == single.diverged_at
        for name in SERIES:
            np.testing.assert_array_equal(getattr(batched, name), getattr(single, name),
                                          err_msg=f"{variant.name}: {name}")  # bit for bit
        for name, values in batched.extras.items():
            np.testing.assert_array_equal(values, single.extras[name])
        for a, b in zip(batched.monitors, single.monitors):
            np.testing.assert_array_equal(a.luaf_hat, b.luaf_hat, err_msg=a.name)
            np.testing.assert_array_equal(a.qd_hat, b.qd_hat, err_msg=a.name)
            assert set(a.extras) == set(b.extras), a.name
            for name, values in a.extras.items():
                np.testing.assert_array_equal(values, b.extras[name], err_msg=f"{a.name}: {name}")
        np.testing.assert_array_equal(batched.diagnosis.alarm, single.diagnosis.alarm)


def test_members_differ_where_they_should(scenario, batch_run):
    """Not a batch of copies: each override changes its member (else the test above proves little)."""
    first = variant_result(scenario, batch_run, 0, 0)
    for member in (1, 2, 4):
        other = variant_result(scenario, batch_run, 0, member)
        assert np.abs(other.q_meas - first.q_meas).max() > 1e-7, member


def test_the_diverging_member_stops_and_the_others_finish(scenario, batch_run):
    for v in range(len(scenario.variants)):
        for member in range(len(MEMBERS)):
            result = variant_result(scenario, batch_run, v, member)
            if member == 3:
                assert result.status == "diverged" and result.diverged_at == 0.0 and len(result.t) == 0
            else:
                assert result.status == "ok" and len(result.t) == len(scenario.times)
                assert np.isfinite(result.q_true).all()


def test_members_without_a_seed_get_the_scenario_seed_plus_their_index(scenario):
    members = members_from_overrides(scenario, [{}, {"seed": 40}, {}])
    np.testing.assert_array_equal(members.seeds, [scenario.spec.seed, 40, scenario.spec.seed + 2])


def test_replicates_differ_in_their_seed_only(scenario):
    members = replicates(scenario, 3)
    np.testing.assert_array_equal(members.seeds, scenario.spec.seed + np.arange(3))
    run = simulate(scenario, members)
    noise = [variant_result(scenario, run, 0, m).q_meas - variant_result(scenario, run, 0, m).q_true for m in range(3)]
    assert not np.allclose(noise[0], noise[1])


def test_thread_count_does_not_change_a_run(scenario):
    members = members_from_overrides(scenario, MEMBERS[:3])
    one, two = simulate(scenario, members, nthread=1), simulate(scenario, members, nthread=2)
    for name in ("q_true", "tau", "luaf_hat"):
        np.testing.assert_array_equal(one.series[name], two.series[name])


def test_chunks_give_the_metrics_of_one_batch(scenario):
    """Members stepped in chunks (a small memory budget) give the same metrics as all at once."""
    members = members_from_overrides(scenario, [MEMBERS[0], MEMBERS[1], MEMBERS[4]])
    whole = run_batch(scenario, members)
    chunked = run_batch(scenario, members, memory_budget=1)  # one member per chunk
    assert [(o.member, o.variant) for o in whole] == [(o.member, o.variant) for o in chunked]
    for a, b in zip(whole, chunked):
        assert a.status == b.status
        for metric, values in a.metrics.items():
            np.testing.assert_allclose(values, b.metrics[metric], rtol=1e-12, atol=0, err_msg=metric)  # sums in another order


@pytest.mark.parametrize("group", [4, runner.METRICS_ROWS])
def test_member_outcomes_are_each_results_own_metrics(scenario, batch_run, monkeypatch, group):
    """The finished rows' metrics computed together (in groups of 4 rows: across members and variants, 5 members
    of 3 joints) are bit for bit what :func:`compute_metrics` gives each result alone; the diverged member and
    the monitors, evaluated one by one, too."""
    monkeypatch.setattr(runner, "METRICS_ROWS", group)
    outcomes = iter(runner.member_outcomes(scenario, batch_run))
    finished = runner._finished_metrics(scenario, batch_run, scenario.joint_fault_onsets)
    assert sorted(finished) == [v * batch_run.members + m for v in range(len(scenario.variants))
                                for m in range(batch_run.members) if m != 3]
    for m in range(batch_run.members):
        for v in range(len(scenario.variants)):
            result = variant_result(scenario, batch_run, v, m)
            for one in (result, *result.monitors):
                outcome = next(outcomes)
                alone = compute_metrics(one, scenario.spec.metrics, scenario.fault_onsets,
                                        scenario.joint_fault_onsets, scenario.torque_limits)
                assert (outcome.member, outcome.variant, outcome.status) == (m, one.name, one.status)
                assert list(outcome.metrics) == list(alone)
                for metric, values in alone.items():
                    np.testing.assert_array_equal(outcome.metrics[metric], values, err_msg=f"{one.name} {metric}")
    assert next(outcomes, None) is None


def test_interleaved_halves_give_the_outcomes_of_one_run(scenario, monkeypatch):
    """A chunk on two threads as two interleaved halves (of 3 and 2 members): the same outcomes bit for bit, in
    the same order, and ``on_result`` sees the members in order, as one run on one thread gives them."""
    members = members_from_overrides(scenario, MEMBERS)
    seen: dict[int, list[tuple[int, list[str]]]] = {1: [], 2: []}
    outcomes = {}
    monkeypatch.setattr(runner, "INTERLEAVED_ROWS", 0)  # halves whatever the chunk's size
    for threads in (1, 2):
        outcomes[threads] = run_batch(scenario, members, nthread=threads, on_result=lambda member, results, t=threads:
                                      seen[t].append((member, [result.name for result in results])))
    assert seen[1] == seen[2] and [member for member, _ in seen[2]] == list(range(len(MEMBERS)))
    one, halves = outcomes[1], outcomes[2]
    assert [(o.member, o.variant, o.status) for o in one] == [(o.member, o.variant, o.status) for o in halves]
    for a, b in zip(one, halves):
        for metric, values in a.metrics.items():
            np.testing.assert_array_equal(values, b.metrics[metric], err_msg=f"{a.member} {a.variant} {metric}")


def test_quiet_warnings_restores_the_handler_after_overlapping_runs():
    """Runs on several threads overlap in the silenced-warnings section; the last one out restores the handler."""
    import mujoco

    def mine(message: str) -> None:
        pass

    previous = mujoco.get_mju_user_warning()
    mujoco.set_mju_user_warning(mine)
    try:
        outer, inner = quiet_warnings(), quiet_warnings()
        outer.__enter__()
        inner.__enter__()
        outer.__exit__(None, None, None)  # the first to leave is not the last: still silent
        assert mujoco.get_mju_user_warning() is not mine
        inner.__exit__(None, None, None)
        assert mujoco.get_mju_user_warning() is mine
    finally:
        mujoco.set_mju_user_warning(previous)


@pytest.mark.parametrize("override, message", [
    ({"duration": 1.0}, "cannot differ between the members"),
    ({"variants.eso_smc.observer.type": "sosmo"}, "cannot differ between the members"),
    ({"variants.hs_nftsmc.controller.gains.compensation": "none"}, "selects the law's form"),
    ({"parameters.other": 1.0}, "do not add any"),
    ({"nominal.mass_scale": -1.0}, "nominal.mass_scale"),
    ({"parameters.fault_rate": 0.0}, "rate of terms.1: it must be positive"),
])
def test_member_overrides_are_checked(scenario, override, message):
    with pytest.raises((InputError, ValueError), match=message):
        members_from_overrides(scenario, [{}, override])


def test_members_select_keeps_member_values(scenario):
    members = members_from_overrides(scenario, MEMBERS)
    picked = members.select(slice(1, 3))
    assert isinstance(picked, Members) and picked.count == 2
    np.testing.assert_array_equal(picked.seeds, members.seeds[1:3])
    np.testing.assert_array_equal(picked.variants[0].controller.mu, members.variants[0].controller.mu[1:3])


def test_the_plants_own_mass_matrix_is_the_nominal_one(tmp_path, monkeypatch):
    """Where MuJoCo evaluates the nominal model (here forced: the compiled model declines), the controller's
    model is the plant's and the encoders read the state exactly, the engine takes M(q_meas), its factorisation
    and the truth's M and bias from the plant instead of evaluating the nominal model again: the run is the
    same bit for bit."""
    import ftc_mj.engine.loop as loop
    import ftc_mj.robot.nominal as nominal

    monkeypatch.setattr(nominal.RigidTree, "from_model", classmethod(lambda cls, model: None))

    spec = scenario_dict()
    del spec["sensors"]
    spec["robot"]["sensors"] = ["position"]
    spec["variants"] = {name: v for name, v in VARIANTS.items()
                        if name not in ("do_adaptive", "momentum_smc")}  # those on encoders only
    spec["variants"]["hs_nftsmc"] = {**VARIANTS["hs_nftsmc"], "monitors": {
        name: monitor for name, monitor in VARIANTS["hs_nftsmc"]["monitors"].items()
        if name not in ("ndob", "momentum")}}
    path = tmp_path / "exact.yaml"
    path.write_text(yaml.safe_dump(spec, sort_keys=False), encoding="utf-8")
    scenario = load_scenario(path)
    shortcut = simulate(scenario, replicates(scenario, 2))

    plant_for = loop.plant_for

    def evaluated_plant(*args, **kwargs):
        plant = plant_for(*args, **kwargs)
        plant.reads_state_exactly = False  # forces the nominal model's own M points
        return plant

    monkeypatch.setattr(loop, "plant_for", evaluated_plant)
    general = simulate(scenario, replicates(scenario, 2))
    for name, values in shortcut.series.items():
        np.testing.assert_array_equal(values, general.series[name], err_msg=name)


def test_a_monitors_signals_are_recorded_as_its_own(tmp_path):
    """A monitor's plugin signals (the momentum observer's residual, the Kalman filter's innovation) are its
    result's extras, member by member: a momentum monitor of the momentum observer's own loop records the
    residual that observer records (the same estimator on the same run), and a monitor without signals none."""
    spec = scenario_dict()
    spec["variants"] = {"momentum_smc": {**VARIANTS["momentum_smc"], "monitors": {
        "twin": {"type": "momentum", "gains": {"K": 60.0}},
        "kalman": VARIANTS["hs_nftsmc"]["monitors"]["kalman"],
        "eso": VARIANTS["hs_nftsmc"]["monitors"]["eso"]}}}
    path = tmp_path / "monitor_signals.yaml"
    path.write_text(yaml.safe_dump(spec, sort_keys=False), encoding="utf-8")
    scenario = load_scenario(path)
    run = simulate(scenario, members_from_overrides(scenario, [{}, {"seed": 11, "parameters.fault_scale": 0.5}]))
    residuals = []
    for member in range(2):
        result = variant_result(scenario, run, 0, member)
        twin, kalman, eso = result.monitors
        assert set(twin.extras) == {"residual"} and set(kalman.extras) == {"innovation"} and eso.extras == {}
        np.testing.assert_array_equal(twin.extras["residual"], result.extras["residual"])
        assert kalman.extras["innovation"].shape == (len(result.t), 3)
        assert np.abs(kalman.extras["innovation"]).max() > 0
        residuals.append(twin.extras["residual"])
    assert np.abs(residuals[0] - residuals[1]).max() > 1e-3  # each member its own, not a copy


def test_a_member_follows_its_own_parameterised_reference(scenario, batch_run):
    """Parameters reach the reference too: member 2's joint 3 follows 0.3 sin 2t - 0.5 + 0.5 t^2, with its exact
    derivatives; the others the scenario's."""
    t = scenario.times
    plain, shifted = variant_result(scenario, batch_run, 0, 0), variant_result(scenario, batch_run, 0, 2)
    np.testing.assert_allclose(shifted.q_ref[:, 2] - plain.q_ref[:, 2], 0.5 * t**2, rtol=0, atol=1e-12)
    np.testing.assert_allclose(shifted.qd_ref[:, 2] - plain.qd_ref[:, 2], t, rtol=0, atol=1e-12)
    np.testing.assert_allclose(shifted.qdd_ref[:, 2] - plain.qdd_ref[:, 2], 1.0, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(shifted.q_ref[:, :2], plain.q_ref[:, :2])


def test_a_rate_parameter_must_be_one_of_the_parameters(tmp_path):
    raw = scenario_dict()
    raw["terms"][1]["rate"] = "zeta"
    path = tmp_path / "bad.yaml"
    path.write_text(yaml.safe_dump(raw))
    with pytest.raises(InputError, match="terms.1.rate: 'zeta' is not one of the parameters"):
        load_scenario(path)


def test_a_seven_joint_arm_in_a_large_batch_equals_its_single_runs():
    """Five members: the batched sparse solve must sum M's longer rows (four and more entries) as mj_solveM
    does, or the members drift from their single runs."""
    scenario = load_scenario(ROOT / "scenarios" / "robots" / "panda_fault.yaml", duration=0.3)
    assert scenario.n_joints == 7
    count = 5
    run = simulate(scenario, replicates(scenario, count), nthread=2)
    for member in (0, count - 1):
        alone = simulate(scenario, members_from_overrides(scenario, [{"seed": scenario.spec.seed + member}]))
        for v, variant in enumerate(scenario.variants):
            batched, single = variant_result(scenario, run, v, member), variant_result(scenario, alone, v, 0)
            for name in ("qd_hat", "luaf_hat", "tau", "q_true", "luaf_true"):
                np.testing.assert_array_equal(getattr(batched, name), getattr(single, name),
                                              err_msg=f"{variant.name}, member {member}: {name}")
