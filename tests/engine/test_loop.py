"""The closed loop of ftc_mj.engine.loop: measurement timing, ground truth, model mismatch, substeps,
divergence, body poses, determinism and the plugins' isolation from the simulation's MjData.

Every scenario is a small YAML file written to tmp_path (PUMA560 with joints 4-6 locked, 0.2-1 s). Tolerances
are set from measured values (in the comments) with a wide margin.
"""

from __future__ import annotations

import copy
from pathlib import Path

import mujoco
import mujoco.batch
import numpy as np
import pytest
import yaml

from ftc_mj.analysis.metrics import compute_metrics
from ftc_mj.engine.loop import simulate
from ftc_mj.engine.members import single
from ftc_mj.engine.runner import simulate_variant
from ftc_mj.results import VariantResult
from ftc_mj.engine.runner import run_scenario
from ftc_mj.methods import controllers, observers, registry
from ftc_mj.methods.controllers.nftsmc import NFTSMC
from ftc_mj.methods.observers.tosmo import HighSpeedTOSMO
from ftc_mj.scenario.loading import load_scenario
from ftc_mj.scenario.definition import Scenario

ROOT = Path(__file__).resolve().parents[2]
PUMA = ROOT / "models" / "puma560.xml"
DT = 1e-3

#: The compensated NFTSMC of scenarios/puma_fault.yaml.
NFTSMC_GAINS = {"beta1": 15.0, "beta2": 10.0, "beta3": 10.0, "beta4": 5.0, "gamma1": 0.5, "bound": 0.5, "mu": 0.5}
PROPOSED = {
    "observer": {"type": "hs_tosmo", "gains": {"D": 22.0, "gamma": 5.0}},
    "controller": {"type": "nftsmc", "gains": NFTSMC_GAINS},
}


def scenario_dict(**overrides) -> dict:
    """A PUMA560 scenario like puma_fault.yaml, without terms, 0.2 s; keyword arguments replace top-level keys."""
    spec = {
        "name": "sim_test",
        "robot": {"model": str(PUMA)},
        "duration": 0.2,
        "control_dt": DT,
        "initial": {"q": [-0.5, -0.5, -0.5], "qd": [0.0, 0.0, 0.0]},
        "observer_initial": {"qd_hat": [0.5, 0.5, 0.5]},
        "reference": ["cos(pi*t/5) - 1", "sin(pi*t/5 + pi/2) - 1", "0.3*sin(2*t) - 0.5"],
        "variants": {"proposed": copy.deepcopy(PROPOSED)},
        "metrics": {"window_start": 0.1, "estimation_window_start": 0.1},
    }
    spec.update(overrides)
    return spec


def write_scenario(tmp_path: Path, spec: dict, name: str = "scenario.yaml") -> Path:
    path = tmp_path / name
    path.write_text(yaml.safe_dump(spec, sort_keys=False), encoding="utf-8")
    return path


def run(tmp_path: Path, spec: dict, variant: int = 0, **kwargs) -> tuple[Scenario, VariantResult]:
    scenario = load_scenario(write_scenario(tmp_path, spec))
    return scenario, simulate_variant(scenario, scenario.variants[variant], **kwargs)


class Dynamics:
    """M(q) from a fresh MjModel and MjData, independent of the runner's and the nominal model's."""

    def __init__(self, path: Path = PUMA):
        self.model = mujoco.MjModel.from_xml_path(str(path))
        self.data = mujoco.MjData(self.model)
        self.n = self.model.nv

    def mass(self, q: np.ndarray) -> np.ndarray:
        self.data.qpos[:] = q
        mujoco.mj_fwdPosition(self.model, self.data)
        out = np.zeros((self.n, self.n))
        mujoco.mj_fullM(self.model, self.data, out)
        return out


def array_fields(result: VariantResult) -> dict[str, np.ndarray]:
    return {name: value for name, value in vars(result).items() if isinstance(value, np.ndarray)}


# ------------------------------------------------------------------------------------------ measurement


def test_measurement_is_the_state_of_its_own_sample(tmp_path: Path) -> None:
    """No one-step sensor lag: q_meas[k] is exactly q_true[k], q_true[0] is the initial state, and q_true[k+1]
    is q_true[k] advanced by one (semi-implicit) step with the recorded velocity and acceleration."""
    scenario, result = run(tmp_path, scenario_dict())
    assert result.status == "ok"
    np.testing.assert_array_equal(result.q_meas, result.q_true)
    np.testing.assert_array_equal(result.q_true[0], scenario.q0)  # a lagging sensor would read 0 here
    np.testing.assert_array_equal(result.qd_true[0], scenario.qd0)
    # The arm moves (so the check above means something): one step changes q by more than rounding.
    assert np.abs(np.diff(result.q_true, axis=0)[50:]).min() > 1e-7
    # qd[k+1] = qd[k] + dt qdd[k], q[k+1] = q[k] + dt qd[k+1]: the recorded sample k is the state at t_k and
    # qdd_true[k] the acceleration over the period that follows. Measured: 0 and 0.
    np.testing.assert_allclose(result.qd_true[1:], result.qd_true[:-1] + DT * result.qdd_true[:-1], rtol=0, atol=1e-10)
    np.testing.assert_allclose(result.q_true[1:], result.q_true[:-1] + DT * result.qd_true[1:], rtol=0, atol=1e-12)


# ------------------------------------------------------------------------------------------ ground truth


def test_luaf_true_is_zero_without_terms(tmp_path: Path) -> None:
    _, result = run(tmp_path, scenario_dict())
    # Measured: exactly 0.
    assert np.abs(result.luaf_true).max() < 1e-8
    assert not result.fault_active.any()
    np.testing.assert_array_equal(result.fault, 0.0)


def test_acceleration_term_is_mapped_through_true_mass_matrix(tmp_path: Path) -> None:
    """A constant acceleration-space term with sign +1 shows up unchanged in luaf_true."""
    value = np.array([1.5, -2.0, 0.5])
    term = {"kind": "disturbance", "space": "acceleration", "sign": 1, "value": value.tolist()}
    _, result = run(tmp_path, scenario_dict(terms=[term]))
    assert result.status == "ok"
    # Measured: 4.4e-15.
    np.testing.assert_allclose(result.luaf_true, np.broadcast_to(value, result.luaf_true.shape), rtol=0, atol=1e-8)


def test_state_dependent_acceleration_term_uses_true_state(tmp_path: Path) -> None:
    """A term of q and qd is evaluated on the true state (qd_hat starts 0.5 rad/s away from qd_true)."""
    term = {"kind": "fault", "space": "acceleration", "sign": -1, "value": ["sin(q1) + 0.3*qd2", "2*qd3", "q2*q3"]}
    _, result = run(tmp_path, scenario_dict(terms=[term]))
    q, qd = result.q_true, result.qd_true
    expected = -np.stack([np.sin(q[:, 0]) + 0.3 * qd[:, 1], 2 * qd[:, 2], q[:, 1] * q[:, 2]], axis=1)
    np.testing.assert_allclose(result.luaf_true, expected, rtol=0, atol=1e-8)
    np.testing.assert_allclose(result.fault, expected, rtol=0, atol=1e-12)


def test_torque_term_with_negative_sign(tmp_path: Path) -> None:
    """A torque-space term f with sign -1 gives luaf_true = -M(q)^-1 f, M from an independent MjData."""
    term = {"kind": "friction", "space": "torque", "sign": -1, "value": ["3 + 2*qd1", "-1", "1.5*sin(q3)"]}
    _, result = run(tmp_path, scenario_dict(terms=[term]))
    dynamics = Dynamics()
    q, qd = result.q_true, result.qd_true
    f = np.stack([3 + 2 * qd[:, 0], -np.ones(len(q)), 1.5 * np.sin(q[:, 2])], axis=1)
    expected = np.array([-np.linalg.solve(dynamics.mass(q[k]), f[k]) for k in range(len(q))])
    assert np.abs(expected).min() > 0.05  # the term is visible on every joint
    # Measured: 4.0e-15 (|expected| >= 0.17).
    np.testing.assert_allclose(result.luaf_true, expected, rtol=0, atol=1e-8)
    assert not result.fault_active.any()  # friction is not a fault
    np.testing.assert_array_equal(result.fault, 0.0)


def test_fault_profile_with_rate(tmp_path: Path) -> None:
    onset, rate = 0.1, 20.0
    value = np.array([1.0, -2.0, 3.0])
    term = {"kind": "fault", "space": "acceleration", "sign": 1, "value": value.tolist(), "onset": onset, "rate": rate}
    _, result = run(tmp_path, scenario_dict(terms=[term]))
    t = result.t
    on = t >= onset
    assert on.any() and not on.all()
    np.testing.assert_array_equal(result.fault_active, on)
    weight = np.where(on, 1.0 - np.exp(-rate * (t - onset)), 0.0)
    expected = weight[:, None] * value
    # Measured: 4.7e-15 and 5.6e-15.
    np.testing.assert_allclose(result.fault, expected, rtol=0, atol=1e-12)
    np.testing.assert_allclose(result.luaf_true, expected, rtol=0, atol=1e-8)
    np.testing.assert_array_equal(result.fault[~on], 0.0)
    assert weight[-1] > 0.8  # the profile has clearly risen by the end


def test_fault_profile_per_joint_rates(tmp_path: Path) -> None:
    onset, rates = 0.05, np.array([5.0, 20.0, 80.0])
    term = {"kind": "fault", "space": "acceleration", "sign": 1, "value": [1, 1, 1], "onset": onset, "rate": rates.tolist()}
    _, result = run(tmp_path, scenario_dict(terms=[term]))
    t = result.t[:, None]
    expected = np.where(t >= onset, 1.0 - np.exp(-rates * (t - onset)), 0.0)
    np.testing.assert_allclose(result.fault, expected, rtol=0, atol=1e-12)


def test_abrupt_fault_without_rate(tmp_path: Path) -> None:
    onset = 0.12
    value = np.array([0.0, 4.0, -1.0])
    term = {"kind": "fault", "space": "acceleration", "sign": 1, "value": value.tolist(), "onset": onset}
    _, result = run(tmp_path, scenario_dict(terms=[term]))
    on = result.t >= onset
    np.testing.assert_array_equal(result.fault_active, on)
    np.testing.assert_array_equal(result.fault, np.where(on[:, None], value, 0.0))
    np.testing.assert_allclose(result.luaf_true, np.where(on[:, None], value, 0.0), rtol=0, atol=1e-8)


# MuJoCo's data.time accumulates rounding (after 1010 steps of 1 ms it is 1.0099999999999996); the plant terms
# use the loop's k*dt, so an onset on a sample time switches at that very sample.
@pytest.mark.parametrize("substeps", [1, 4])
def test_fault_onset_on_a_sample_time_switches_at_that_sample(tmp_path: Path, substeps: int) -> None:
    onset = 1.01
    term = {"kind": "fault", "space": "acceleration", "sign": 1, "value": [1, 1, 1], "onset": onset}
    spec = scenario_dict(duration=1.02, timestep=DT / substeps, terms=[term],
                         metrics={"window_start": 0.5, "estimation_window_start": 0.5})
    _, result = run(tmp_path, spec)
    first = int(np.flatnonzero(result.t >= onset)[0])
    assert first == 1010
    assert int(np.flatnonzero(result.fault_active)[0]) == first


def test_mass_scale_mismatch_enters_luaf_true(tmp_path: Path) -> None:
    """mass_scale s scales M, C and G of the nominal model alike, so Psi is exact and the whole mismatch is
    luaf_true = (1 - 1/s) M_true(q)^-1 tau."""
    s = 1.2
    _, result = run(tmp_path, scenario_dict(nominal={"mass_scale": s}))
    assert result.status == "ok"
    # Measured: max |luaf_true| 3.9 rad/s^2.
    assert np.abs(result.luaf_true).max() > 0.5
    dynamics = Dynamics()
    expected = np.array([(1 - 1 / s) * np.linalg.solve(dynamics.mass(q), tau) for q, tau in zip(result.q_true, result.tau)])
    # Measured: 2.1e-14.
    np.testing.assert_allclose(result.luaf_true, expected, rtol=0, atol=1e-8)


# ------------------------------------------------------------------------------------------ substeps


def test_substeps_give_nearly_the_same_tracking(tmp_path: Path) -> None:
    metrics = {"window_start": 0.5, "estimation_window_start": 0.5}
    base = scenario_dict(duration=1.0, metrics=metrics)
    fine = scenario_dict(duration=1.0, metrics=metrics, timestep=DT / 4)
    s1, r1 = run(tmp_path, base)
    s4, r4 = run(tmp_path, fine)
    assert (s1.substeps, s4.substeps) == (1, 4)
    assert s4.model.opt.timestep == pytest.approx(DT / 4)
    assert r1.status == r4.status == "ok"
    assert r4.t.shape == r1.t.shape
    # Measured: max |q_true difference| 2.9e-4 rad (the transient error itself is up to 0.5 rad).
    assert np.abs(r4.q_true - r1.q_true).max() < 2e-3
    m1 = compute_metrics(r1, s1.spec.metrics, [])
    m4 = compute_metrics(r4, s4.spec.metrics, [])
    # Measured: joints 1-2 (0.5 rad transient) differ by at most 1.3e-3 relative; joint 3 starts on its
    # reference (rms_error 6.8e-3 rad) and differs by at most 5.7e-5 rad absolute.
    for name in ("rms_error", "rms_error_converged", "max_error_converged"):
        np.testing.assert_allclose(m4[name], m1[name], rtol=1e-2, atol=2e-4, err_msg=name)
    # Both converge: measured final |e| about 1e-5 rad.
    assert np.abs(r1.tracking_error[-1]).max() < 1e-4
    assert np.abs(r4.tracking_error[-1]).max() < 1e-4
    # Ground truth stays exact with substeps.
    assert np.abs(r4.luaf_true).max() < 1e-8


def test_substeps_hold_command_and_terms_over_the_period(tmp_path: Path) -> None:
    """With timestep = control_dt / 4, the recorded run equals an independent replay that evaluates the
    (time- and state-dependent) term once per control period on the true state and holds it, like the
    recorded torque, over the period's physics steps (the documented design of ftc_mj.engine.loop)."""
    term = {"kind": "fault", "space": "acceleration", "sign": 1, "value": ["5*sin(40*t) + 20*qd2", "-3*qd1", "2"]}
    scenario, result = run(tmp_path, scenario_dict(timestep=DT / 4, terms=[term]))
    assert scenario.substeps == 4 and result.status == "ok"
    model = mujoco.MjModel.from_xml_path(str(PUMA))
    model.opt.timestep = DT / 4
    data = mujoco.MjData(model)
    data.qpos[:], data.qvel[:] = scenario.q0, scenario.qd0
    accel, mapped = np.zeros(3), np.zeros(3)
    max_dev = 0.0
    for k in range(len(result.t)):
        max_dev = max(max_dev, np.abs(data.qpos - result.q_true[k]).max(), np.abs(data.qvel - result.qd_true[k]).max())
        data.ctrl[:] = result.tau[k]
        for substep in range(4):
            mujoco.mj_step1(model, data)
            if substep == 0:
                q, qd, t = data.qpos, data.qvel, data.time
                accel[:] = [5 * np.sin(40 * t) + 20 * qd[1], -3 * qd[0], 2.0]
                mujoco.mj_mulM(model, data, mapped, accel)
                data.qfrc_applied[:] = mapped
            mujoco.mj_step2(model, data)
    # Measured: 0 (bit-identical). Re-evaluating the term at every physics step instead gives 4.9e-3.
    assert max_dev < 1e-10
    # Ground truth stays exact with substeps: luaf_true is the term at the period's start.
    q, qd = result.q_true, result.qd_true
    expected = np.stack([5 * np.sin(40 * result.t) + 20 * qd[:, 1], -3 * qd[:, 0], np.full(len(q), 2.0)], axis=1)
    np.testing.assert_allclose(result.luaf_true, expected, rtol=0, atol=1e-8)


# ------------------------------------------------------------------------------------------ divergence


def _diverging_spec() -> dict:
    wild = copy.deepcopy(PROPOSED)
    # u_sw = 5e5 sign(s): the sampled switching blows up. Measured: diverges at 64 ms (3e5: 98 ms, 7e5: 7 ms,
    # 1e6 and more: at the first step; 2e5 and less stays bounded).
    wild["controller"]["gains"]["bound"] = 5e5
    return scenario_dict(variants={"stable": copy.deepcopy(PROPOSED), "wild": wild})


def test_diverging_variant_is_truncated_and_others_unaffected(tmp_path: Path) -> None:
    scenario = load_scenario(write_scenario(tmp_path, _diverging_spec()))
    stable, wild = (simulate_variant(scenario, v, record_poses=True) for v in scenario.variants)
    steps = int(round(scenario.spec.duration / DT))

    assert wild.status == "diverged"
    assert isinstance(wild.diverged_at, float)
    done = len(wild.t)
    assert 10 < done < steps
    assert wild.diverged_at == pytest.approx(done * DT)
    assert wild.t[-1] < wild.diverged_at
    for name, value in array_fields(wild).items():
        assert len(value) == done, name
    assert np.all(np.isfinite(wild.q_true)) and np.all(np.isfinite(wild.tau))
    assert np.all(np.isfinite(wild.luaf_true))  # truncated where the recording stops, no NaN tail

    assert stable.status == "ok" and stable.diverged_at is None
    assert len(stable.t) == steps
    # The diverged variant did not disturb the other: a scenario with only the stable variant gives the
    # same arrays, bit for bit.
    alone = load_scenario(write_scenario(tmp_path, _diverging_spec(), "alone.yaml"), variants=["stable"])
    reference = simulate_variant(alone, alone.variants[0], record_poses=True)
    for name, value in array_fields(reference).items():
        np.testing.assert_array_equal(getattr(stable, name), value, err_msg=name)


def test_batch_series_are_nan_from_each_rows_stop_on(tmp_path: Path) -> None:
    """The raw batch run (what the campaign's metrics read): every series of a stopped row holds NaN from its
    stop on, whatever its buffer held before (the buffers are not filled up front), and the running row's
    series are finite throughout."""
    scenario = load_scenario(write_scenario(tmp_path, _diverging_spec()))
    run = simulate(scenario, single(scenario))
    stable, wild = 0, 1  # rows: one member, the variants in the file's order
    done = int(run.done[wild])
    assert 10 < done < len(run.times) and run.done[stable] == len(run.times)
    for name, values in run.series.items():
        assert np.all(np.isnan(values[done:, wild])), name
        assert np.all(np.isfinite(values[:done, wild])), name
        assert np.all(np.isfinite(values[:, stable])), name


def test_a_stopped_rows_nominal_points_are_at_rest_in_every_period_after_its_stop(tmp_path: Path, monkeypatch):
    """From the period a row stops in on, the nominal model evaluates that row's reading's M and the same Psi
    points at rest (q = qd = 0) every period, and before it nothing at rest."""
    import ftc_mj.engine.loop as loop_module

    def indices(points: np.ndarray | None) -> list[int]:  # a mask or indices, as either is passed
        points = np.zeros(0, int) if points is None else np.asarray(points)
        return [int(i) for i in (np.flatnonzero(points) if points.dtype == bool else points)]

    scenario = load_scenario(write_scenario(tmp_path, _diverging_spec()))
    rested: list[list[int]] = []
    prepared: list[list[int]] = []
    real_at_rest, real_set_up = loop_module.at_rest, loop_module._Run.set_up
    monkeypatch.setattr(loop_module, "at_rest",
                        lambda batch, points: rested.append(indices(points)) or real_at_rest(batch, points))

    def set_up(*args, **kwargs):
        run = real_set_up(*args, **kwargs)
        prepare = run.mass.prepare
        run.mass.prepare = lambda q_meas, stopped: prepared.append(indices(stopped)) or prepare(q_meas, stopped)
        return run

    monkeypatch.setattr(loop_module._Run, "set_up", set_up)
    run = simulate(scenario, single(scenario))
    wild, periods = 1, len(run.times)
    done = int(run.done[wild])
    assert 10 < done < periods
    assert prepared == [[]] * done + [[wild]] * (periods - done)
    points = rested[0]
    assert points and rested == [points] * (periods - done)


def test_diverging_plant_term_does_not_raise(tmp_path: Path) -> None:
    """A positive velocity feedback 1e6 qd1 on the torque: caught by the state bounds."""
    term = {"kind": "disturbance", "space": "torque", "sign": 1, "value": ["1e6*qd1", "0", "0"]}
    _, result = run(tmp_path, scenario_dict(terms=[term]))
    assert result.status == "diverged"
    # Measured: diverged at 4 ms.
    assert result.diverged_at is not None and result.diverged_at < 0.05
    assert len(result.t) == len(result.q_true) == len(result.luaf_true) == round(result.diverged_at / DT)


def test_divergence_faster_than_the_state_check_is_not_reset_silently(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """1e15 qd1 makes qacc exceed MuJoCo's limit within one step; MuJoCo then resets the state to qpos0 (a
    plausible-looking state). The run must still report divergence rather than continue from the reset."""
    monkeypatch.chdir(tmp_path)  # MuJoCo appends its warning to ./MUJOCO_LOG.TXT: keep it out of the repository
    term = {"kind": "disturbance", "space": "torque", "sign": 1, "value": ["1e15*qd1", "0", "0"]}
    _, result = run(tmp_path, scenario_dict(terms=[term]))
    assert result.status == "diverged"
    assert result.diverged_at is not None and result.diverged_at < 0.01
    # No sample after a reset: q never jumps to qpos0 = 0.
    assert np.all(np.abs(result.q_true + 0.5) < 0.01)


# ------------------------------------------------------------------------------------------ body poses


def test_record_poses_match_forward_kinematics(tmp_path: Path) -> None:
    _, result = run(tmp_path, scenario_dict(), record_poses=True)
    dynamics = Dynamics()
    model, data = dynamics.model, dynamics.data
    n_samples = len(result.t)
    assert result.body_xpos.shape == (n_samples, model.nbody, 3)
    assert result.body_xquat.shape == (n_samples, model.nbody, 4)
    # Measured: identical (difference 0).
    for k in range(n_samples):
        data.qpos[:] = result.q_true[k]
        mujoco.mj_kinematics(model, data)
        np.testing.assert_allclose(result.body_xpos[k], data.xpos, rtol=0, atol=1e-12)
        np.testing.assert_allclose(result.body_xquat[k], data.xquat, rtol=0, atol=1e-12)
    # The poses move with the arm.
    assert np.abs(result.body_xpos[-1] - result.body_xpos[0]).max() > 1e-3


def test_no_poses_unless_asked(tmp_path: Path) -> None:
    _, result = run(tmp_path, scenario_dict(duration=0.05))
    assert result.body_xpos.size == 0 and result.body_xquat.size == 0


# ------------------------------------------------------------------------------------------ determinism


def test_two_runs_are_bit_identical(tmp_path: Path) -> None:
    terms = [
        {"kind": "friction", "space": "torque", "sign": -1, "value": ["1.9*sin(qd1)", "2.03*sin(qd2)", "1.76*sin(qd3)"]},
        {"kind": "fault", "space": "acceleration", "sign": 1, "value": ["10*sin(q1*q2)", "3.6*cos(qd1*q2)", "0"],
         "onset": 0.1, "rate": 5.0},
    ]
    variants = {
        "proposed": copy.deepcopy(PROPOSED),
        "sosmo": {"observer": {"type": "sosmo", "gains": {"L": 22.0, "filter_time_constant": 0.01}},
                  "controller": {"type": "nftsmc", "gains": NFTSMC_GAINS}},
    }
    spec = scenario_dict(terms=terms, variants=variants)
    first = load_scenario(write_scenario(tmp_path, spec, "a.yaml"))
    second = load_scenario(write_scenario(tmp_path, spec, "b.yaml"))
    for v1, v2 in zip(first.variants, second.variants):
        r1 = simulate_variant(first, v1, record_poses=True)
        r2 = simulate_variant(second, v2, record_poses=True)
        r3 = simulate_variant(first, v1, record_poses=True)  # same Scenario object run again
        assert r1.status == "ok"
        for name, value in array_fields(r1).items():
            np.testing.assert_array_equal(getattr(r2, name), value, err_msg=name)
            np.testing.assert_array_equal(getattr(r3, name), value, err_msg=name)


# ------------------------------------------------------------------------------------------ isolation


class _Spy:
    """Collects every argument the plugins receive."""

    calls: list[tuple[str, tuple]] = []
    #: Copies of the controller's q_meas argument (the runner reuses one buffer).
    q_meas: list[np.ndarray] = []


class SpyObserver(HighSpeedTOSMO):
    name = "spy_observer"

    def reset(self, *args):
        _Spy.calls.append(("observer.reset", args))
        super().reset(*args)

    def update(self, *args):
        _Spy.calls.append(("observer.update", args))
        super().update(*args)

    def advance(self, *args):
        _Spy.calls.append(("observer.advance", args))
        super().advance(*args)


class SpyController(NFTSMC):
    name = "spy_controller"

    def reset(self, *args):
        _Spy.calls.append(("controller.reset", args))
        super().reset(*args)

    def compute(self, *args):
        _Spy.calls.append(("controller.compute", args))
        _Spy.q_meas.append(np.array(args[4]))
        return super().compute(*args)


@pytest.fixture
def spies(monkeypatch: pytest.MonkeyPatch):
    """Register the spies as built-ins for the duration of one test."""
    registry._discover.cache_clear()
    monkeypatch.setitem(observers.BUILTIN, SpyObserver.name, SpyObserver)
    monkeypatch.setitem(controllers.BUILTIN, SpyController.name, SpyController)
    _Spy.calls, _Spy.q_meas = [], []
    try:
        yield _Spy
    finally:
        registry._discover.cache_clear()
        _Spy.calls, _Spy.q_meas = [], []


def _reachable(obj, depth: int, seen: set[int]):
    """obj and the objects reachable from it through attributes and containers, up to ``depth`` levels."""
    if id(obj) in seen:
        return
    seen.add(id(obj))
    yield obj
    if depth == 0 or isinstance(obj, (np.ndarray, str, bytes, int, float, mujoco.MjModel)):
        return
    if isinstance(obj, dict):
        children = list(obj.values())
    elif isinstance(obj, (list, tuple)):
        children = list(obj)
    else:
        children = list(getattr(obj, "__dict__", {}).values())
    for child in children:
        yield from _reachable(child, depth - 1, seen)


def test_plugins_never_receive_the_simulation(tmp_path: Path, spies, monkeypatch: pytest.MonkeyPatch) -> None:
    """Observers and controllers get readings, time, the reference and the nominal model's arrays: never the
    plant, its MjData, any batch, or a view of any array the plant binds (its live state). (An MjData they can
    reach is a private scratch one of the nominal model's solver.)"""
    from ftc_mj.engine import plant as plant_module

    plants: list = []
    real_plant = plant_module.plant_for

    def tracking_plant(*args, **kwargs):
        plants.append(real_plant(*args, **kwargs))
        return plants[-1]

    monkeypatch.setattr("ftc_mj.engine.loop.plant_for", tracking_plant)
    spec = scenario_dict(variants={"spy": {"observer": {"type": "spy_observer", "gains": {"D": 22.0, "gamma": 5.0}},
                                           "controller": {"type": "spy_controller", "gains": NFTSMC_GAINS}}})
    scenario, result = run(tmp_path, spec)
    assert result.status == "ok"
    assert (result.observer, result.controller) == ("spy_observer", "spy_controller")
    assert len(plants) == 1
    plant = plants[0]
    assert isinstance(plant, plant_module.OneRowPlant)  # a single run: one MjData
    plant_buffers = [plant.qpos, plant.qvel, plant.qacc, plant.ctrl, plant.applied, plant._sensordata,
                     plant._sparse_M, plant.factor]

    calls = spies.calls
    kinds = {kind for kind, _ in calls}
    assert kinds == {"observer.reset", "observer.update", "observer.advance", "controller.reset", "controller.compute"}
    steps = len(result.t)
    assert sum(kind == "controller.compute" for kind, _ in calls) == steps
    for kind, args in calls:
        for obj in _reachable(args, depth=5, seen=set()):
            assert obj is not plant.data and obj is not plant, f"{kind} can reach the plant"
            assert not isinstance(obj, mujoco.batch.Batch), f"{kind} can reach a batch"  # MjData: only scratch ones
            if isinstance(obj, np.ndarray):
                for buffer in plant_buffers:
                    assert not np.shares_memory(obj, buffer), f"{kind} received a view of the plant's state"
    # What the controller saw as the measurement is the true position of its sample.
    np.testing.assert_array_equal(np.array(spies.q_meas).reshape(result.q_true.shape), result.q_true)


# ------------------------------------------------------------------------------------------ monitors


def test_monitors_estimate_the_host_trajectory_without_touching_it(tmp_path: Path) -> None:
    """A monitor identical to the variant's observer reproduces its estimates bit for bit (same readings, same
    commands, its own nominal model); other monitors leave the host's result bit-identical."""
    terms = [{"kind": "fault", "space": "acceleration", "sign": 1, "value": ["10*sin(q1*q2)", "3*cos(qd1)", "0"],
              "onset": 0.1, "rate": 5.0}]
    host_only = scenario_dict(terms=terms)
    monitored = copy.deepcopy(host_only)
    monitored["variants"]["proposed"]["monitors"] = {
        "twin": copy.deepcopy(PROPOSED["observer"]),
        "sosmo": {"type": "sosmo", "gains": {"L": 22.0, "filter_time_constant": 0.01}},
    }
    _, alone = run(tmp_path, host_only)
    _, host = run(tmp_path, monitored)
    for name, value in array_fields(alone).items():
        np.testing.assert_array_equal(getattr(host, name), value, err_msg=name)
    twin, sosmo = host.monitors
    assert (twin.name, twin.observer, sosmo.name, sosmo.observer) == ("proposed.twin", "hs_tosmo", "proposed.sosmo", "sosmo")
    np.testing.assert_array_equal(twin.qd_hat, host.qd_hat)
    np.testing.assert_array_equal(twin.luaf_hat, host.luaf_hat)
    # The SOSMO estimates the same trajectory (same truth and commands) with its own estimates: in the first
    # 0.2 s it is the faster one (RMS velocity error from 0.1 s: 0.021 against the HS-TOSMO's 0.118 rad/s).
    np.testing.assert_array_equal(sosmo.tau, host.tau)
    np.testing.assert_array_equal(sosmo.luaf_true, host.luaf_true)
    late = host.t >= 0.1
    assert np.sqrt(np.mean(sosmo.velocity_error[late] ** 2)) < np.sqrt(np.mean(host.velocity_error[late] ** 2)) / 2
    assert sosmo.body_xpos.size == 0 and not sosmo.monitors


def test_monitors_become_columns_of_the_run(tmp_path: Path) -> None:
    spec = scenario_dict()
    spec["variants"]["proposed"]["monitors"] = {"tosmo": {"type": "tosmo", "gains": {"D": 22.0}}}
    spec["variants"]["second"] = copy.deepcopy(PROPOSED)
    results = run_scenario(load_scenario(write_scenario(tmp_path, spec)))
    assert [r.name for r in results] == ["proposed", "proposed.tosmo", "second"]
    assert [r.host for r in results] == [None, "proposed", None]  # a monitor says whose loop it observes


# ------------------------------------------------------------------------------ controller velocity

TWO_LINK = ROOT / "models" / "two_link.xml"


def test_controller_velocity_is_the_scenarios_choice_not_the_observers(tmp_path: Path) -> None:
    """2-link arm with tachometers, an NFTSMC that compensates nothing, fed by a SOSMO or an ESO started
    0.5 rad/s off. On measured velocity the controller reads nothing from its observer, so the two loops give
    the same torques bit for bit; on the estimated velocity they differ from the first period on."""
    controller = {"type": "nftsmc", "gains": {"beta1": 14.0, "beta2": 10.0, "beta3": 10.0, "beta4": 5.0,
                                              "gamma1": 0.5, "bound": 16.0, "mu": 0.1, "compensation": "none"}}
    spec = scenario_dict(
        robot={"model": str(TWO_LINK), "sensors": ["position", "velocity"]},
        duration=0.3,
        initial={"q": [0.0, 0.0]},
        observer_initial={"qd_hat": [0.5, 0.5]},
        reference=["1.05*cos(pi*t/6) - 1", "1.2*sin(pi*t/7 + pi/2) - 1"],
        variants={
            "sosmo": {"observer": {"type": "sosmo", "gains": {"L": 30.0, "filter_time_constant": 0.01}},
                      "controller": controller},
            "eso": {"observer": {"type": "eso", "gains": {"bandwidth": 40.0}}, "controller": controller},
        },
    )
    scenario = load_scenario(write_scenario(tmp_path, spec))
    assert [v.controller_velocity for v in scenario.variants] == ["measured", "measured"]
    sosmo, eso = (simulate_variant(scenario, v) for v in scenario.variants)
    np.testing.assert_array_equal(sosmo.tau, eso.tau)
    assert np.abs(sosmo.qd_hat - eso.qd_hat).max() > 1e-2  # the observers themselves differ
    # The first command: e_dot from the tachometer (0 - qd_ref(0)), not from qd_hat(0) = 0.5.
    spec["controller_velocity"] = "estimated"
    scenario = load_scenario(write_scenario(tmp_path, spec))
    sosmo_est, eso_est = (simulate_variant(scenario, v) for v in scenario.variants)
    assert np.abs(sosmo_est.tau - eso_est.tau).max() > 1.0
    assert np.abs(sosmo_est.tau[0] - sosmo.tau[0]).max() > 1.0


def test_an_observer_may_need_only_the_quantities_the_nominal_model_gives() -> None:
    """``Observer.needs`` is empty by default (the engine computes nothing more); a name the nominal model does
    not give is refused with the names it does."""
    from ftc_mj.engine.loop import _needs

    class Wanting(HighSpeedTOSMO):
        needs = frozenset({"coriolis_transpose", "jacobian"})

    assert _needs(HighSpeedTOSMO) == frozenset()
    assert _needs(observers.BUILTIN["momentum"]) == {"coriolis_transpose", "gravity"}
    with pytest.raises(ValueError, match=r"needs \['jacobian'\].*'coriolis_transpose', 'gravity'"):
        _needs(Wanting)
