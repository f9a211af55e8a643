"""Fault diagnosis (ftc_mj.analysis.diagnosis and its metrics in ftc_mj.analysis.metrics): persistence against
chattering, baseline and thresholds, detection delay, false alarms, missed detections, isolation and the
fault-estimate error on synthetic residuals, each joint from its own fault onset when the onsets differ; then
closed-loop PUMA runs with realistic encoders: no alarm without a fault, detection within a stated delay and the
right joints with one fault or two at different times; the schema's errors; the recording, table and JSON
outputs."""

from __future__ import annotations

import json
import math
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
from fault_scenarios import FAULTS, assert_input_error, run, scenario_data, write
from nominal_oracle import NominalModel
from rerun.chunk import RrdReader

from ftc_mj.analysis.diagnosis import Diagnoser, low_pass, persistent
from ftc_mj.analysis.diagnosis import detection_statistics, diagnosis_metrics
from ftc_mj.analysis.metrics import compute_metrics
from ftc_mj.outputs.recording import read_series
from ftc_mj.run import main
from ftc_mj.config.expressions import StateFunction, parse, state_variables
from ftc_mj.scenario.loading import load_scenario

DT = 1e-3
T = np.arange(10000) * DT  # 10 s
NJ = 3


def column(*values: bool) -> np.ndarray:
    return np.array(values, dtype=bool)[:, None]


# ------------------------------------------------------------------------------------------ persistence


def test_persistence_suppresses_chattering() -> None:
    chatter = (np.arange(1000) % 2 == 0)[:, None]  # above the threshold every other sample
    assert not persistent(chatter, 2).any()
    bursts = ((np.arange(1000) % 50) < 19)[:, None]  # 19 samples above, 31 below, over and over
    assert not persistent(bursts, 20).any()
    # With 19, each burst raises the alarm at its 19th sample and the 19th sample below clears it.
    phase = np.arange(1000) % 50
    np.testing.assert_array_equal(persistent(bursts, 19)[:, 0], (phase >= 18) & (phase < 37))
    np.testing.assert_array_equal(persistent(chatter, 1), chatter)


def test_persistence_raises_and_clears_after_n_samples() -> None:
    x = column(*([False] * 5 + [True] * 4 + [False] * 2 + [True] * 3 + [False] * 3 + [True]))
    got = persistent(x, 3)[:, 0]
    # raised at the 3rd sample of the first run (index 7); the 2-sample dip does not clear it; cleared at the
    # 3rd sample of the 3-sample dip (index 16); the last lone True does not raise it again.
    expected = np.zeros(len(x), dtype=bool)
    expected[7:16] = True
    np.testing.assert_array_equal(got, expected)


# ------------------------------------------------------------------------------------------ synthetic runs


def synthetic(persistence: int = 20, **kwargs) -> Diagnoser:
    values = dict(space="acceleration", dt=DT, start=4.0, fixed=np.zeros(NJ), k=5.0, persistence=persistence,
                  baseline=(1.0, 4.0))
    values.update(kwargs)
    return Diagnoser(**values)


def healthy_signal() -> np.ndarray:
    """A healthy estimate: per-joint offset plus a bounded oscillation (std 0.1 / sqrt 2 about)."""
    return np.array([0.3, -0.2, 1.0]) + 0.1 * np.sin(np.outer(T, [50.0, 37.0, 23.0]))


def diagnose(diagnoser: Diagnoser, luaf: np.ndarray, injected: np.ndarray | None = None):
    zeros = np.zeros((len(T), NJ))
    return diagnoser.diagnose(T, luaf, zeros, zeros, zeros if injected is None else injected)


@pytest.mark.slow  # a closed-loop run of seconds
def test_baseline_threshold_and_detection_delay() -> None:
    luaf = healthy_signal()
    injected = np.zeros_like(luaf)
    injected[6000:, 0] = 2.0
    luaf = luaf + injected
    diagnosis = diagnose(synthetic(), luaf, injected)
    window = (T >= 1.0) & (T < 4.0)
    np.testing.assert_allclose(diagnosis.mean, luaf[window].mean(axis=0), rtol=1e-12)
    np.testing.assert_allclose(diagnosis.std, luaf[window].std(axis=0), rtol=1e-12)
    armed = T >= 4.0
    np.testing.assert_array_equal(diagnosis.armed, armed)
    assert np.isnan(diagnosis.threshold[~armed]).all()
    np.testing.assert_allclose(diagnosis.threshold[armed], np.broadcast_to(5 * diagnosis.std, luaf[armed].shape),
                               rtol=1e-12)
    # Causal: the fault estimate is known from the window's last sample on (NaN before: no mean yet).
    known = T >= 4.0 - DT - 1e-9
    np.testing.assert_allclose(diagnosis.fault_estimate[known], (luaf - diagnosis.mean)[known], rtol=1e-12)
    assert np.isnan(diagnosis.fault_estimate[~known]).all()
    np.testing.assert_array_equal(diagnosis.residual, np.abs(diagnosis.fault_estimate))
    assert not diagnosis.alarm[T < 4.0].any()  # not armed before the baseline's end
    # The step of 2 (about 28 standard deviations) exceeds the threshold from sample 6000 on: the alarm comes
    # with the 20th sample, 19 periods later.
    assert diagnosis.alarm_times() == [[T[6019]], [], []]
    m = diagnosis_metrics(diagnosis, np.array([6.0, np.nan, np.nan]), 6.0, NJ)
    np.testing.assert_allclose(m["detection_delay"], [19 * DT, np.nan, np.nan], rtol=1e-9)
    np.testing.assert_array_equal(m["missed_detection"], [0.0, np.nan, np.nan])
    np.testing.assert_array_equal(m["false_alarms"], [0, 0, 0])
    np.testing.assert_array_equal(m["false_alarm_rate"], [0, 0, 0])
    np.testing.assert_array_equal(m["isolation_correct"], [1, 1, 1])
    # Fault estimate from detection on: luaf - mean - injected = the healthy oscillation about its mean.
    error = (luaf - diagnosis.mean - injected)[6019:, 0]
    np.testing.assert_allclose(m["fault_estimate_rms"][0], np.sqrt(np.mean(error**2)), rtol=1e-12)
    assert m["fault_estimate_rms"][0] < 0.1
    assert np.isnan(m["fault_estimate_rms"][1:]).all()


@pytest.mark.slow  # a closed-loop run of seconds
def test_false_alarms_missed_detection_and_isolation() -> None:
    luaf = healthy_signal()
    luaf[5000:5030, 0] += 3.0  # 30 samples before joint 1's onset: a false alarm
    luaf[6000:, 0] += 3.0  # joint 1's fault
    luaf[7000:7100, 1] += 3.0  # healthy joint 2 alarms after the onset: false alarm and a wrong isolation
    luaf[6000:, 2] += 0.05  # joint 3's fault is far below its threshold: missed
    diagnosis = diagnose(synthetic(), luaf)
    onsets = np.array([6.0, np.nan, 6.0])
    m = diagnosis_metrics(diagnosis, onsets, 6.0, NJ)
    np.testing.assert_array_equal(m["false_alarms"], [1, 1, 0])
    # Armed fault-free time: 4 s to the onset (2 s) on joints 1 and 3, 4 s to the end (6 s) on joint 2.
    np.testing.assert_allclose(m["false_alarm_rate"], [1 / 2.0, 1 / 6.0, 0.0], rtol=1e-9)
    np.testing.assert_array_equal(m["missed_detection"], [0, np.nan, 1])
    np.testing.assert_array_equal(m["isolation_correct"], [1, 0, 0])
    assert m["detection_delay"][0] == pytest.approx(19 * DT)  # the first alarm at or after the onset
    assert np.isnan(m["detection_delay"][2]) and np.isnan(m["fault_estimate_rms"][2])
    np.testing.assert_array_equal(diagnosis.isolated(6.0), [True, True, False])


@pytest.mark.slow  # a closed-loop run of seconds
def test_a_fault_after_the_runs_end_is_neither_detected_nor_missed() -> None:
    """A run shortened below a fault's onset: the fault never acted, so its detection metrics are undefined
    (NaN), not a miss; the fault-free metrics keep their values over the samples there are."""
    luaf = healthy_signal()
    luaf[6000:6030, 1] += 3.0  # a false alarm on healthy joint 2, inside the run
    diagnosis = diagnose(synthetic(), luaf)
    end = T[-1]
    m = diagnosis_metrics(diagnosis, np.array([end + 1.0, np.nan, np.nan]), end + 1.0, NJ)
    for name in ("missed_detection", "detection_delay", "isolation_correct", "fault_estimate_rms"):
        assert np.isnan(m[name]).all(), name
    np.testing.assert_array_equal(m["false_alarms"], [0, 1, 0])
    # The fault at the last sample acts for one sample: defined again.
    m = diagnosis_metrics(diagnosis, np.array([end, np.nan, np.nan]), end, NJ)
    np.testing.assert_array_equal(m["missed_detection"], [1, np.nan, np.nan])
    np.testing.assert_array_equal(m["isolation_correct"], [0, 1, 1])
    statistics = detection_statistics(diagnosis, 20, np.array([end + 1.0, np.nan, np.nan]), [1.0], NJ)
    assert np.isnan(statistics["isolated"]).all() and np.isnan(statistics["residual_peak_fault"]).all()


def test_a_diagnoser_never_armed_counts_no_false_alarms() -> None:
    """A run that ends before the diagnoser is armed: no fault-free armed sample, so no count of false alarms."""
    diagnosis = diagnose(synthetic(baseline=(1.0, 20.0), start=20.0), healthy_signal())
    m = diagnosis_metrics(diagnosis, np.array([6.0, np.nan, np.nan]), 6.0, NJ)
    for name in ("false_alarms", "false_alarm_rate", "missed_detection", "isolation_correct"):
        assert np.isnan(m[name]).all(), name


# Staggered onsets: joint 1 faulty from 2 s, joint 2 from 5 s, joint 3 healthy. Every metric that uses an onset
# must take the joint's own, not the scenario's first.
STAGGERED_ONSETS = np.array([2.0, 5.0, np.nan])


def staggered_run():
    """Diagnoser armed from 1.5 s (baseline [0.5, 1.5)), persistence 20 samples. Joint 1's fault (+2) shows at
    its onset; joint 2's (-1.5) shows 50 samples after its onset (an observer's lag), and joint 2 has a
    30-sample blip at 3 s: after joint 1's onset, before its own, so a false alarm of joint 2."""
    injected = np.zeros((len(T), NJ))
    injected[2000:, 0] = 2.0
    injected[5000:, 1] = -1.5
    luaf = healthy_signal()
    luaf[2000:, 0] += 2.0
    luaf[5050:, 1] += -1.5
    luaf[3000:3030, 1] += 3.0
    return luaf, injected, diagnose(synthetic(baseline=(0.5, 1.5), start=1.5), luaf, injected)


def test_staggered_onsets_each_joint_from_its_own_onset() -> None:
    luaf, injected, diagnosis = staggered_run()
    assert diagnosis.alarm_times() == [[T[2019]], [T[3019], T[5069]], []]
    m = diagnosis_metrics(diagnosis, STAGGERED_ONSETS, 2.0, NJ)
    # Joint 1 at its 20th sample above, 19 periods after 2 s; joint 2 at 5.05 s + 19 periods, 69 periods after
    # 5 s (from the first onset it would be the blip's alarm, 1.019 s after 2 s).
    np.testing.assert_allclose(m["detection_delay"], [19 * DT, 69 * DT, np.nan], rtol=1e-9,
                               err_msg="detection_delay is not measured from each joint's own onset")
    np.testing.assert_array_equal(m["missed_detection"], [0, 0, np.nan])
    # The blip at 3 s is before joint 2's onset: a false alarm of joint 2, over 1.5 s to 5 s of fault-free time.
    np.testing.assert_array_equal(m["false_alarms"], [0, 1, 0], err_msg="false alarms not counted up to each "
                                  "joint's own onset")
    np.testing.assert_allclose(m["false_alarm_rate"], [0.0, 1 / 3.5, 0.0], rtol=1e-9)
    np.testing.assert_array_equal(m["isolation_correct"], [1, 1, 1])
    # The fault-estimate error from each joint's own detection: joint 2's from 5.069 s, after the lag.
    for joint, first in ((0, 2019), (1, 5069)):
        error = (luaf - diagnosis.mean - injected)[first:, joint]
        np.testing.assert_allclose(m["fault_estimate_rms"][joint], np.sqrt(np.mean(error**2)), rtol=1e-12)
    assert m["fault_estimate_rms"][1] < 0.1 and np.isnan(m["fault_estimate_rms"][2])


def test_staggered_onsets_in_the_detection_statistics() -> None:
    """The threshold-free statistics split each joint's run at its own onset, and at 1x the threshold give the
    diagnoser's own delays and false alarms."""
    from ftc_mj.analysis.diagnosis import detection_statistics

    _, _, diagnosis = staggered_run()
    m = diagnosis_metrics(diagnosis, STAGGERED_ONSETS, 2.0, NJ)
    stats = detection_statistics(diagnosis, 20, STAGGERED_ONSETS, [1.0], NJ)
    np.testing.assert_array_equal(stats["detection_delay_x1"], m["detection_delay"])
    np.testing.assert_array_equal(stats["false_alarms_x1"], m["false_alarms"])
    np.testing.assert_allclose(stats["healthy_time"], [0.5, 3.5, 8.5], rtol=1e-9)
    # Joint 2: the blip (about 3 / 0.35 of the threshold) is on the healthy side, the fault (about 1.5 / 0.35)
    # on the faulty one; joint 1 is healthy only in [1.5, 2) s.
    assert stats["residual_peak_healthy"][1] > 7.0 and 3.0 < stats["residual_peak_fault"][1] < 5.0
    assert stats["residual_peak_healthy"][0] < 1.0 and stats["residual_peak_fault"][0] > 4.0
    np.testing.assert_array_equal(stats["isolated"], [1, 1, 0])


def test_a_healthy_runs_diagnosis_through_compute_metrics() -> None:
    """Without fault onsets compute_metrics still scores the diagnosis: every alarm is a false one, over the
    armed run (no first fault to split it at)."""
    from ftc_mj.analysis.metrics import MetricsSpec
    from ftc_mj.results import Diagnosis, VariantResult

    t = np.arange(400) * DT
    residual = np.zeros((len(t), 2))
    residual[100:150, 1] = 2.0  # 50 samples above a threshold of 1: one alarm on joint 2
    threshold = np.ones((len(t), 2))
    diagnosis = Diagnosis(space="torque", t=t, signal=residual, fault_estimate=residual, residual=residual,
                          threshold=threshold, alarm=persistent(residual > threshold, 5), armed=np.ones(len(t), bool),
                          mean=np.zeros(2), std=np.ones(2), injected=np.zeros((len(t), 2)))
    zeros = np.zeros((len(t), 2))
    result = VariantResult(name="v", observer="obs", controller="ctl", t=t, q_ref=zeros, q_true=zeros,
                           fault_active=np.zeros(len(t), bool), diagnosis=diagnosis,
                           **{name: zeros for name in ("qd_ref", "qdd_ref", "q_meas", "qd_true", "qdd_true", "qd_hat",
                                                       "luaf_hat", "luaf_true", "tau", "sliding", "fault")})
    m = compute_metrics(result, MetricsSpec(window_start=0.1, estimation_window_start=0.1), [])
    np.testing.assert_array_equal(m["false_alarms"], [0.0, 1.0])
    np.testing.assert_array_equal(m["isolation_correct"], [1.0, 0.0])  # joint 2 named faulty on a healthy robot
    assert np.isnan(m["detection_delay"]).all()


def test_an_alarm_on_the_first_sample_is_a_detection_without_delay() -> None:
    """Armed from the first sample, a fault from t = 0 above every scaled threshold there, one sample of
    persistence: the alarm is raised at sample 0 and detected with a delay of 0 at every scale it exceeds."""
    from ftc_mj.results import Diagnosis

    t = np.arange(50) * DT
    residual = np.full((len(t), 1), 3.0)
    threshold = np.ones((len(t), 1))
    diagnosis = Diagnosis(space="torque", t=t, signal=residual, fault_estimate=residual, residual=residual,
                          threshold=threshold, alarm=persistent(residual > threshold, 1), armed=np.ones(len(t), bool),
                          mean=np.zeros(1), std=np.ones(1), injected=residual)
    stats = detection_statistics(diagnosis, 1, np.array([0.0]), [1.0, 2.0, 4.0], 1)
    assert stats["detection_delay_x1"][0] == 0.0 and stats["detection_delay_x2"][0] == 0.0
    assert np.isnan(stats["detection_delay_x4"][0])  # 3 is never above 4 times the threshold
    assert diagnosis_metrics(diagnosis, np.array([0.0]), 0.0, 1)["detection_delay"][0] == 0.0


def test_staggered_onsets_through_compute_metrics() -> None:
    """compute_metrics hands each joint's onset to the diagnosis metrics and to the fault response: joint 2's
    tracking excursion at 3 s (before its onset) is not its fault peak."""
    from ftc_mj.analysis.metrics import MetricsSpec
    from ftc_mj.results import VariantResult

    _, _, diagnosis = staggered_run()
    zeros = np.zeros((len(T), NJ))
    error = zeros.copy()
    error[2000:2250, 0] = 0.3
    error[3000:3100, 1] = 0.4
    error[5000:5500, 1] = -0.2
    result = VariantResult(name="v", observer="obs", controller="ctl", t=T, q_ref=zeros, q_true=error,
                           fault_active=T >= 2.0, diagnosis=diagnosis,
                           **{name: zeros for name in ("qd_ref", "qdd_ref", "q_meas", "qd_true", "qdd_true", "qd_hat",
                                                       "luaf_hat", "luaf_true", "tau", "sliding", "fault")})
    spec = MetricsSpec(window_start=1.0, estimation_window_start=1.0, tracking_tolerance=0.01)
    m = compute_metrics(result, spec, [2.0, 5.0], STAGGERED_ONSETS)
    expected = diagnosis_metrics(diagnosis, STAGGERED_ONSETS, 2.0, NJ)
    for name, values in expected.items():
        np.testing.assert_array_equal(m[name], values, err_msg=name)
    np.testing.assert_allclose(m["fault_peak_error"], [0.3, 0.2, np.nan], rtol=1e-12,
                               err_msg="fault_peak_error is not measured from each joint's own onset")
    np.testing.assert_allclose(m["recovery_time"], [0.25, 0.5, np.nan], rtol=1e-9)


def test_persistence_against_chattering_estimate() -> None:
    """Single-sample spikes (the chattering of a discrete sliding-mode estimate) raise alarms without
    persistence and none with it."""
    luaf = healthy_signal()
    luaf[4000::97, 1] += 5.0
    assert diagnosis_metrics(diagnose(synthetic(persistence=1), luaf), np.full(NJ, np.nan), math.inf, NJ)[
        "false_alarms"][1] > 50
    m = diagnosis_metrics(diagnose(synthetic(persistence=5), luaf), np.full(NJ, np.nan), math.inf, NJ)
    np.testing.assert_array_equal(m["false_alarms"], [0, 0, 0])
    np.testing.assert_array_equal(m["isolation_correct"], [1, 1, 1])
    assert np.isnan(m["detection_delay"]).all() and np.isnan(m["missed_detection"]).all()


def test_fixed_and_adaptive_threshold_without_baseline() -> None:
    """threshold = fixed + bound(t, q_meas, qd_hat); no baseline: the estimate is its own fault estimate."""
    n = NJ
    bound = StateFunction([parse(text, state_variables(n)) for text in ("abs(qd1)", "0.1*t", "q3**2")], n)
    diagnoser = synthetic(k=0.0, baseline=None, start=0.5, fixed=np.array([1.0, 2.0, 3.0]), bound=bound)
    q = np.stack([np.sin(T)] * n, axis=1)
    qd = np.stack([np.cos(T)] * n, axis=1)
    luaf = healthy_signal()
    diagnosis = diagnoser.diagnose(T, luaf, q, qd, np.zeros_like(luaf))
    expected = np.stack([1.0 + np.abs(qd[:, 0]), 2.0 + 0.1 * T, 3.0 + q[:, 2] ** 2], axis=1)
    armed = T >= 0.5
    np.testing.assert_allclose(diagnosis.threshold[armed], expected[armed], rtol=1e-12)
    np.testing.assert_array_equal(diagnosis.mean, 0.0)
    np.testing.assert_array_equal(diagnosis.fault_estimate, luaf)
    assert not diagnosis.alarm.any()


def test_filter() -> None:
    """The optional low-pass filter is the exact discretisation y[k] = a y[k-1] + (1 - a) x[k], from x[0]."""
    t = T[:300]
    estimate = np.stack([np.cos(5 * t + j) + (np.arange(len(t)) % 2) for j in range(NJ)], axis=1)
    diagnoser = synthetic(baseline=None, k=0.0, fixed=np.ones(NJ), filter_time_constant=0.01)
    diagnosis = diagnoser.diagnose(t, estimate, *np.zeros((3, len(t), NJ)))
    a = math.exp(-DT / 0.01)
    y = estimate[0].copy()
    filtered = [y]
    for k in range(1, len(t)):
        y = a * y + (1 - a) * estimate[k]
        filtered.append(y)
    np.testing.assert_allclose(diagnosis.signal, filtered, rtol=1e-12)
    np.testing.assert_allclose(low_pass(estimate, DT, 0.01), filtered, rtol=1e-12)


def test_a_baseline_beyond_the_run_raises_nothing() -> None:
    """A run shorter than the baseline window (e.g. --duration, or a divergence): never armed, no alarm."""
    diagnosis = diagnose(synthetic(baseline=(1.0, 20.0), start=20.0), healthy_signal() * 100)
    assert not diagnosis.alarm.any() and np.isnan(diagnosis.mean).all()


# ------------------------------------------------------------------------------------------ closed loop


@pytest.fixture(scope="module")
def loe_runs(tmp_path_factory: pytest.TempPathFactory):
    """scenarios/faults/puma_loss_of_effectiveness.yaml (encoders 2^16 counts/rev, 1e-5 rad noise), the
    proposed method, without and with its fault."""
    tmp = tmp_path_factory.mktemp("loe")
    healthy = scenario_data()
    healthy["actuator_faults"] = []
    faulty = scenario_data()
    return run(tmp, healthy, "healthy.yaml"), run(tmp, faulty, "faulty.yaml")


def metrics_of(scenario, result) -> dict[str, np.ndarray]:
    return compute_metrics(result, scenario.spec.metrics, scenario.fault_onsets, scenario.joint_fault_onsets)


@pytest.mark.slow  # a closed-loop run of seconds
def test_torque_space_signal_is_nominal_mass_times_estimate(loe_runs) -> None:
    """In torque space the diagnosis signal is M(q_meas) luaf_hat with the controller's nominal model."""
    (scenario, result), _ = loe_runs
    nominal = NominalModel(scenario.model, scenario.spec.nominal.mass_scale)
    for k in range(0, len(result.t), 997):
        expected = nominal.mass_matrix(result.q_meas[k]) @ result.luaf_hat[k]
        np.testing.assert_allclose(result.diagnosis.signal[k], expected, rtol=1e-12, atol=1e-12)


@pytest.mark.slow  # a closed-loop run of seconds
def test_no_alarm_without_a_fault(loe_runs) -> None:
    (scenario, result), _ = loe_runs
    assert result.status == "ok" and result.t[-1] > 11.9
    assert not result.diagnosis.alarm.any()
    m = metrics_of(scenario, result)
    np.testing.assert_array_equal(m["false_alarms"], [0, 0, 0])
    np.testing.assert_array_equal(m["isolation_correct"], [1, 1, 1])
    # Margin: the armed residual stays below 0.8 of the threshold (measured at most 0.55).
    armed = result.diagnosis.armed
    assert (result.diagnosis.residual[armed] < 0.8 * result.diagnosis.threshold[armed]).all()
    # The sensors were realistic: the measurement is off the truth by up to about half a count plus noise.
    assert 4e-5 < np.abs(result.q_meas - result.q_true).max() < 1e-4


@pytest.mark.slow  # a closed-loop run of seconds
def test_loss_of_effectiveness_detected_and_isolated(loe_runs) -> None:
    """Measured: joint 2 detected 0.171 s after the onset, nothing else alarmed, fault estimate error 3.4 N m
    RMS (the fault grows to about 25 N m)."""
    _, (scenario, result) = loe_runs
    m = metrics_of(scenario, result)
    assert m["detection_delay"][1] < 0.3
    np.testing.assert_array_equal(m["missed_detection"], [np.nan, 0, np.nan])
    np.testing.assert_array_equal(m["false_alarms"], [0, 0, 0])
    np.testing.assert_array_equal(m["isolation_correct"], [1, 1, 1])
    assert result.diagnosis.alarm_times()[0] == [] and result.diagnosis.alarm_times()[2] == []
    assert m["fault_estimate_rms"][1] < 0.25 * np.abs(result.fault_torque[:, 1]).max()


@pytest.mark.slow  # a closed-loop run of seconds
def test_staggered_onsets_in_the_closed_loop(tmp_path: Path) -> None:
    """scenarios/faults/puma_loss_of_effectiveness.yaml with a second fault, a 10 N m bias on joint 1 from 9.5 s,
    through the command line: each joint's delay from its own onset (joint 2's LoE at 8 s, joint 1's bias at
    9.5 s). Measured: joint 1 detected at 9.600 s (0.100 s), joint 2 at 8.171 s (0.171 s), no false alarm."""
    data = scenario_data()
    data["actuator_faults"].append({"name": "joint1_bias", "kind": "bias", "joints": [1], "offset": 10.0,
                                    "profile": {"onset": 9.5}})
    out = tmp_path / "out.json"
    assert main([str(write(tmp_path, data)), "--quiet", "--no-record", "--json", str(out)]) == 0
    variant = json.loads(out.read_text())["variants"]["proposed"]
    alarms, m = variant["diagnosis"]["alarms"], variant["metrics"]
    assert alarms[2] == [] and len(alarms[0]) >= 1 and len(alarms[1]) >= 1
    onsets = [9.5, 8.0]
    for joint, onset in enumerate(onsets):
        first = min(time for time in alarms[joint] if time >= onset)
        assert m["detection_delay"][joint] == pytest.approx(first - onset), (
            f"joint {joint + 1}: detection_delay is not measured from its own onset ({onset:g} s)")
    # Margin about 2x on each measured delay; from the first onset joint 1's would be 1.6 s.
    assert m["detection_delay"][0] < 0.25 and m["detection_delay"][1] < 0.35
    assert m["detection_delay"][2] is None
    assert m["missed_detection"] == [0.0, 0.0, None]
    assert m["false_alarms"] == [0.0, 0.0, 0.0] and m["isolation_correct"] == [1.0, 1.0, 1.0]


@pytest.mark.slow  # a closed-loop run of seconds
def test_bias_detected_against_the_uncertainty_bound(tmp_path: Path) -> None:
    """scenarios/faults/puma_bias.yaml: threshold from the declared friction and disturbance bound, no
    baseline. Measured: joint 3 detected after 0.224 s, no false alarm from 2 s (armed) on."""
    scenario, result = run(tmp_path, scenario_data("puma_bias"))
    m = metrics_of(scenario, result)
    assert m["detection_delay"][2] < 0.4
    np.testing.assert_array_equal(m["false_alarms"], [0, 0, 0])
    np.testing.assert_array_equal(m["isolation_correct"], [1, 1, 1])
    assert result.diagnosis.armed[np.searchsorted(result.t, 2.0)] and not result.diagnosis.armed[0]


# ------------------------------------------------------------------------------------------ schema


def diagnosis_data(diagnosis: dict | None) -> dict:
    data = scenario_data()
    data["diagnosis"] = diagnosis
    return data


VALID = {"space": "torque", "baseline": {"start": 2.0, "end": 7.5}, "threshold": {"k": 5.0},
         "persistence": {"samples": 10}}
INVALID = [
    ({**VALID, "space": "jerk"}, "diagnosis.space", "'acceleration' or 'torque'"),
    ({**VALID, "baseline": None}, "diagnosis", "threshold.k needs a baseline"),
    ({**VALID, "threshold": {}}, "diagnosis.threshold", "the threshold is zero"),
    ({**VALID, "threshold": {"fixed": -1.0}}, "diagnosis.threshold.fixed", "greater than or equal to 0"),
    ({**VALID, "threshold": {"fixed": [1.0, 2.0]}}, "diagnosis.threshold.fixed", "has 2 values"),
    ({**VALID, "threshold": {"k": 1, "bound": ["1", "2"]}}, "diagnosis.threshold.bound", "has 2 values"),
    ({**VALID, "threshold": {"bound": ["1", "abs(qd4)", "1"]}}, "diagnosis.threshold.bound.1", "unknown name 'qd4'"),
    ({**VALID, "persistence": {"samples": 3, "time": 0.01}}, "diagnosis.persistence", "exactly one"),
    ({**VALID, "persistence": {}}, "diagnosis.persistence", "exactly one"),
    ({**VALID, "persistence": {"samples": 0}}, "diagnosis.persistence.samples", "greater than 0"),
    ({**VALID, "baseline": {"start": 5.0, "end": 5.0}}, "diagnosis.baseline", "must be after start"),
    ({**VALID, "baseline": {"start": 2.0, "end": 9.0}}, "diagnosis.baseline.end", "must be fault-free"),
    ({**VALID, "start": 3.0}, "diagnosis", "before the baseline's end"),
    ({**VALID, "filter_time_constant": -0.1}, "diagnosis.filter_time_constant", "greater than or equal to 0"),
    ({**VALID, "alarm": "loud"}, "diagnosis.alarm", "unknown key"),
    ({**VALID, "rule": {"kind": "sprt"}}, "diagnosis.rule", "does not match any of the expected tags: 'threshold', 'cusum'"),
    ({**VALID, "rule": {"kind": "cusum", "drift": 0.5}}, "diagnosis.rule.cusum.h", "required field is missing"),
    ({**VALID, "rule": {"kind": "cusum", "drift": -0.1, "h": 5.0}}, "diagnosis.rule.cusum.drift", "greater than"),
    ({**VALID, "rule": {"kind": "threshold", "h": 5.0}}, "diagnosis.rule.threshold.h", "unknown key"),
]


@pytest.mark.parametrize(("diagnosis", "field", "fragment"), INVALID, ids=[f"{i}" for i in range(len(INVALID))])
def test_invalid_diagnosis(tmp_path: Path, diagnosis: dict, field: str, fragment: str) -> None:
    assert_input_error(tmp_path, diagnosis_data(diagnosis), field, fragment)


def test_persistence_time_in_samples(tmp_path: Path) -> None:
    scenario = load_scenario(write(tmp_path, diagnosis_data({**VALID, "persistence": {"time": 0.02}})))
    assert scenario.diagnoser.persistence == 20 and scenario.diagnoser.start == 7.5
    scenario = load_scenario(write(tmp_path, diagnosis_data({**VALID, "persistence": {"time": 0.0201}})))
    assert scenario.diagnoser.persistence == 21


# ------------------------------------------------------------------------------------------ outputs


@pytest.mark.slow  # a subprocess
def test_table_json_and_recording(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    rec, out = tmp_path / "rec.rrd", tmp_path / "out.json"
    status = main([str(FAULTS / "puma_loss_of_effectiveness.yaml"), "--variant", "proposed", "--duration", "9",
                   "--out", str(rec), "--json", str(out), "--metrics", "all"])
    assert status == 0
    table = capsys.readouterr().out
    for metric in ("detection_delay", "false_alarms", "isolation_correct", "fault_estimate_rms"):
        assert metric in table
    assert "N m" in table
    document = json.loads(out.read_text())
    assert document["seed"] == 1
    variant = document["variants"]["proposed"]
    assert variant["diagnosis"]["space"] == "torque"
    assert variant["diagnosis"]["isolated_joints"] == [2]
    alarms = variant["diagnosis"]["alarms"]
    assert alarms[0] == [] and alarms[2] == [] and len(alarms[1]) == 1 and 8.0 < alarms[1][0] < 8.3
    assert variant["metrics"]["detection_delay"][1] == pytest.approx(alarms[1][0] - 8.0)
    assert variant["metrics"]["missed_detection"] == [None, 0.0, None]
    # Recording: residual and threshold per joint, the alarm as an event, the ground truth of the fault.
    _, residual = read_series(rec, "/diagnosis/residual/proposed")
    _, threshold = read_series(rec, "/diagnosis/threshold/proposed")
    assert residual.shape == threshold.shape == (9000, 3)
    above = residual[:, 1] > threshold[:, 1]
    assert above[int(8.0 / DT):].any() and not above[:int(8.0 / DT)].any()
    _, alarm = read_series(rec, "/diagnosis/alarm/proposed")
    assert alarm[:, 1].max() == 1.0 and alarm[:, [0, 2]].max() == 0.0
    _, delivered = read_series(rec, "/torque_delivered/proposed")
    _, commanded = read_series(rec, "/torque/proposed")
    np.testing.assert_array_equal(delivered[:8000], commanded[:8000])
    assert np.abs(delivered[8100:, 1] / commanded[8100:, 1] - 1).max() > 0.3
    texts = [text for chunk in RrdReader(rec).stream().to_chunks() if chunk.entity_path == "/events"
             and not chunk.is_static for text in chunk.to_record_batch().column("TextLog:text").to_pylist()]
    flat = [t for group in texts for t in (group if isinstance(group, list) else [group])]
    assert any("alarm raised on joint 2" in text for text in flat), flat
    exe = shutil.which("rerun")
    if exe is not None:
        verify = subprocess.run([exe, "rrd", "verify", str(rec)], capture_output=True, text=True, timeout=120)
        assert verify.returncode == 0, verify.stdout + verify.stderr


def test_detection_statistics_at_every_threshold_multiple():
    """The held residual peak decides the alarm at each multiple, and the scaled diagnoser's delays and false
    alarms follow from the residual as the diagnoser's own do."""
    from ftc_mj.results import Diagnosis
    from ftc_mj.analysis.diagnosis import detection_statistics, persistent

    dt = 0.01
    t = np.arange(200) * dt
    residual = np.zeros((200, 2))
    residual[50:53, 0] = 3.0  # a 3-sample blip at 3x the threshold before the onset: too short to alarm
    residual[60:70, 0] = 1.5  # 10 samples at 1.5x: a false alarm at c <= 1.5
    residual[120:, 1] = 4.0   # the fault on joint 2 from 1.2 s, at 4x
    threshold = np.ones((200, 2))
    threshold[:20] = np.nan  # armed from 0.2 s
    armed = t >= 0.2
    diagnosis = Diagnosis(space="torque", t=t, signal=residual, fault_estimate=residual, residual=residual,
                          threshold=threshold, alarm=persistent(residual > threshold, 5), armed=armed,
                          mean=np.zeros(2), std=np.ones(2), injected=np.zeros((200, 2)))
    onsets = np.array([np.nan, 1.2])
    stats = detection_statistics(diagnosis, 5, onsets, [1.0, 2.0, 5.0], 2)
    assert stats["residual_peak_healthy"][0] == 1.5  # the 3x blip is not held for 5 samples
    assert stats["residual_peak_healthy"][1] == 0.0 and np.isnan(stats["residual_peak_fault"][0])
    assert stats["residual_peak_fault"][1] == 4.0
    np.testing.assert_array_equal(stats["false_alarms_x1"], [1, 0])
    np.testing.assert_array_equal(stats["false_alarms_x2"], [0, 0])
    assert stats["detection_delay_x1"][1] == pytest.approx(4 * dt)  # raised on the 5th sample above
    assert stats["detection_delay_x2"][1] == pytest.approx(4 * dt)
    assert np.isnan(stats["detection_delay_x5"][1])  # never above 5x: missed
    np.testing.assert_array_equal(stats["isolated"], [0, 1])
    assert stats["healthy_time"][0] == pytest.approx(1.8) and stats["healthy_time"][1] == pytest.approx(1.0)


def _debounced(column: np.ndarray, samples: int) -> np.ndarray:
    """The alarm as a per-sample state machine: it switches at the ``samples``-th consecutive sample that
    differs from it."""
    alarm, state, count = np.zeros(len(column), dtype=bool), False, 0
    for k, value in enumerate(column.tolist()):
        count = count + 1 if value != state else 0
        if count == samples:
            state, count = value, 0
        alarm[k] = state
    return alarm


def test_persistence_equals_the_state_machine_on_every_column_at_once():
    """persistent() debounces all columns (any trailing shape, along any axis) as the state machine does."""
    rng = np.random.default_rng(3)
    for trial in range(60):
        samples = int(rng.integers(1, 9))
        length = int(rng.integers(0, 120))
        exceeded = rng.uniform(size=(length, 2, 3)) < rng.uniform(0.1, 0.9)
        if trial % 2:  # long runs as well as chatter
            exceeded = np.repeat(exceeded, 4, axis=0)[:length]
        expected = np.zeros_like(exceeded)
        for i in range(2):
            for j in range(3):
                expected[:, i, j] = _debounced(exceeded[:, i, j], samples)
        np.testing.assert_array_equal(persistent(exceeded, samples), expected)
        np.testing.assert_array_equal(persistent(np.moveaxis(exceeded, 0, 2), samples, axis=2),
                                      np.moveaxis(expected, 0, 2))


def test_detection_statistics_equal_the_scaled_diagnoser_one_scale_at_a_time():
    """Every scale at once gives, bit for bit, the false alarms and delays of persistent() on the residual against
    c times the threshold, scale by scale and joint by joint; the held peaks are the windows' minima."""
    from ftc_mj.results import Diagnosis
    from ftc_mj.analysis.diagnosis import detection_statistics, scale_tag

    rng = np.random.default_rng(8)
    scales = [0.25, 0.5, 1.0, 1.5, 3.0, 16.0]
    for trial in range(40):
        length, n, samples = int(rng.integers(1, 300)), 3, int(rng.integers(1, 12))
        t = np.arange(length) * 0.01
        residual = np.abs(rng.normal(size=(length, n))) * rng.uniform(0.2, 2.0)
        residual[length // 2:, trial % n] += rng.uniform(0.0, 4.0)
        threshold = np.ones((length, n)) * rng.uniform(0.3, 2.0, n)
        armed = t >= rng.uniform(0.0, 1.0)
        threshold[~armed] = np.nan
        diagnosis = Diagnosis(space="torque", t=t, signal=residual, fault_estimate=residual, residual=residual,
                              threshold=threshold, alarm=persistent(residual > threshold, samples), armed=armed,
                              mean=np.zeros(n), std=np.ones(n), injected=np.zeros((length, n)))
        onsets = np.array([np.nan, rng.uniform(0.0, 3.0), rng.uniform(0.0, 3.0)])
        stats = detection_statistics(diagnosis, samples, onsets, scales, n)
        level = np.where(armed[:, None], residual / threshold, np.nan)
        for j in range(n):
            onset = onsets[j] if np.isfinite(onsets[j]) else np.inf
            windows = [level[k - samples + 1:k + 1, j].min() for k in range(samples - 1, length)
                       if t[k] < onset and np.isfinite(level[k - samples + 1:k + 1, j]).all()]
            np.testing.assert_array_equal(stats["residual_peak_healthy"][j], max(windows) if windows else np.nan)
            for c in scales:
                alarm = _debounced(residual[:, j] > c * threshold[:, j], samples)
                raised = alarm & ~np.concatenate([[False], alarm[:-1]])
                assert stats[f"false_alarms_{scale_tag(c)}"][j] == raised[armed & (t < onset)].sum()
                detected = np.flatnonzero(alarm & (t >= onset))
                delay = t[detected[0]] - onset if detected.size else np.nan
                np.testing.assert_array_equal(stats[f"detection_delay_{scale_tag(c)}"][j], delay)



def test_scaled_alarms_skip_no_scale_that_a_sample_changes():
    """The scaled diagnosers step only the scales a sample can change (the order of the scales' alarms): with
    levels that drift slowly through every scale (long settled runs), thresholds and residuals of either sign
    (where that order reverses), NaN and zero thresholds, and scales given unsorted, every scale's false
    alarms and delay are those of its own diagnoser run alone."""
    from ftc_mj.results import Diagnosis
    from ftc_mj.analysis.diagnosis import detection_statistics, scale_tag

    rng = np.random.default_rng(21)
    scales = [3.0, 0.25, 16.0, 1.0, 0.5, 8.0, 1.5]
    for trial in range(30):
        length, n, samples = int(rng.integers(50, 2000)), 2, int(rng.integers(1, 25))
        t = np.arange(length) * 0.01
        drift = np.exp(np.cumsum(rng.normal(scale=0.08, size=(length, n)), axis=0))
        residual = drift * rng.uniform(0.5, 2.0) * (1.0 + 0.3 * rng.normal(size=(length, n)))
        threshold = np.full((length, n), rng.uniform(0.5, 2.0))
        if trial % 2:
            threshold[rng.random((length, n)) < 0.01] *= -1.0
            residual[rng.random((length, n)) < 0.02] *= -1.0
        threshold[rng.random((length, n)) < 0.01] = 0.0
        threshold[rng.random((length, n)) < 0.01] = np.nan
        armed = t >= rng.uniform(0.0, 2.0)
        diagnosis = Diagnosis(space="torque", t=t, signal=residual, fault_estimate=residual, residual=residual,
                              threshold=threshold, alarm=persistent(residual > threshold, samples), armed=armed,
                              mean=np.zeros(n), std=np.ones(n), injected=np.zeros((length, n)))
        onsets = np.array([np.nan, rng.uniform(0.0, t[-1])])
        stats = detection_statistics(diagnosis, samples, onsets, scales, n)
        for j in range(n):
            onset = onsets[j] if np.isfinite(onsets[j]) else np.inf
            for c in scales:
                alarm = _debounced(residual[:, j] > c * threshold[:, j], samples)
                raised = alarm & ~np.concatenate([[False], alarm[:-1]])
                assert stats[f"false_alarms_{scale_tag(c)}"][j] == raised[armed & (t < onset)].sum(), (trial, j, c)
                detected = np.flatnonzero(alarm & (t >= onset))
                delay = t[detected[0]] - onset if detected.size else np.nan
                np.testing.assert_array_equal(stats[f"detection_delay_{scale_tag(c)}"][j], delay)


def test_a_scale_on_where_the_order_reversed_still_clears():
    """Where a negative threshold reverses the order of the scales (a negative residual exceeds c times it for
    the large c only), a higher scale can be on while a lower one is off; it must still clear, and raise again,
    as its own diagnoser does: two alarms at 2x, not one."""
    from ftc_mj.results import Diagnosis
    from ftc_mj.analysis.diagnosis import detection_statistics

    residual = np.zeros(40)
    residual[:10], residual[10], residual[25:31] = 5.0, -1.5, 5.0
    threshold = np.ones(40)
    threshold[10] = -1.0  # -1.5 > -1 is False, -1.5 > -2 is True
    t = np.arange(40) * 0.01
    diagnosis = Diagnosis(space="torque", t=t, signal=residual[:, None], fault_estimate=residual[:, None],
                          residual=residual[:, None], threshold=threshold[:, None],
                          alarm=persistent(residual[:, None] > threshold[:, None], 3), armed=np.ones(40, dtype=bool),
                          mean=np.zeros(1), std=np.ones(1), injected=np.zeros((40, 1)))
    stats = detection_statistics(diagnosis, 3, np.array([np.nan]), [1.0, 2.0], 1)
    expected = _debounced(residual > 2.0 * threshold, 3)
    assert (expected & ~np.concatenate([[False], expected[:-1]])).sum() == 2
    np.testing.assert_array_equal(stats["false_alarms_x2"], [2.0])
    np.testing.assert_array_equal(stats["false_alarms_x1"], [2.0])

# ------------------------------------------------------------------------------------------ CUSUM


def cusum_diagnoser(drift: float, h: float, persistence: int = 1, **kwargs) -> Diagnoser:
    return synthetic(persistence, rule="cusum", drift=drift, h=h, **kwargs)


def test_cusum_alarm_time_on_a_step_is_the_hand_computed_crossing() -> None:
    """A constant residual: the threshold is fixed (1 per joint, no baseline), so z is the residual itself; a
    step of 2 on joint 1 from sample 6000, drift 0.5: g grows by 1.5 a sample and crosses h = 10 at its 7th
    sample (g = 10.5 > 10 after 6 * 1.5 = 9), i.e. at sample 6006; with a persistence of 3, at 6008."""
    luaf = np.zeros((len(T), NJ))
    luaf[6000:, 0] = 2.0
    for persistence, first in ((1, 6006), (3, 6008)):
        diagnosis = diagnose(cusum_diagnoser(0.5, 10.0, persistence, fixed=np.ones(NJ), k=0.0, baseline=None), luaf)
        assert diagnosis.alarm_times() == [[T[first]], [], []]
        np.testing.assert_array_equal(diagnosis.residual[6000:6007, 0], 1.5 * np.arange(1, 8))  # g, exactly
        assert (diagnosis.threshold[T >= 4.0] == 10.0).all() and np.isnan(diagnosis.threshold[T < 4.0]).all()
    m = diagnosis_metrics(diagnosis, np.array([6.0, np.nan, np.nan]), 6.0, NJ)
    np.testing.assert_allclose(m["detection_delay"], [8 * DT, np.nan, np.nan], rtol=1e-9)
    np.testing.assert_array_equal(m["false_alarms"], [0, 0, 0])


def test_cusum_normalises_by_the_threshold_and_detects_either_sign() -> None:
    """z = |s - m| / (k sd): the same step in a healthy signal of another scale alarms at the same sample, and a
    negative step alarms too (as fast, within the healthy oscillation's share)."""
    healthy = healthy_signal()
    times = []
    for scale, sign in ((1.0, 1.0), (10.0, 1.0), (1.0, -1.0)):
        luaf = scale * healthy
        luaf[6000:, 0] += sign * scale * 2.0
        times.append(diagnose(cusum_diagnoser(0.5, 20.0), luaf).alarm_times()[0])
    assert times[0] == times[1] and len(times[0]) == len(times[2]) == 1
    assert abs(times[2][0] - times[0][0]) <= 2 * DT


def test_cusum_raises_nothing_on_a_zero_mean_residual_below_the_drift() -> None:
    """Healthy noise whose normalised residual stays below the drift keeps g at 0: no alarm, ever, while the
    threshold rule at the same level would alarm on its spikes."""
    rng = np.random.default_rng(2)
    luaf = rng.uniform(-1.0, 1.0, size=(len(T), NJ))  # zero mean, |s - m| <= 1 about
    luaf[3000:3001] = 1.2  # an outlier after the baseline
    diagnoser = cusum_diagnoser(drift=1.1 * np.abs(luaf).max() / (5 * luaf[1000:4000].std(axis=0).min()), h=0.5)
    diagnosis = diagnose(diagnoser, luaf)
    assert not diagnosis.alarm.any()
    assert np.nanmax(diagnosis.residual) == 0.0  # g never left 0


def test_cusum_in_the_detection_statistics_scales_h() -> None:
    """The campaign statistics see g as the residual and h as the threshold: the alarm at c times the threshold is
    the CUSUM with h scaled by c."""
    from ftc_mj.analysis.diagnosis import detection_statistics

    luaf = np.zeros((len(T), NJ))
    luaf[6000:, 0] = 2.0
    diagnosis = diagnose(cusum_diagnoser(0.5, 10.0, fixed=np.ones(NJ), k=0.0, baseline=None), luaf)
    stats = detection_statistics(diagnosis, 1, np.array([6.0, np.nan, np.nan]), [1.0, 2.0], NJ)
    assert stats["detection_delay_x1"][0] == pytest.approx(6 * DT)  # g > 10 at the 7th sample
    assert stats["detection_delay_x2"][0] == pytest.approx(13 * DT)  # g > 20 at the 14th (1.5 * 14 = 21)
    scaled = diagnose(cusum_diagnoser(0.5, 20.0, fixed=np.ones(NJ), k=0.0, baseline=None), luaf)
    assert scaled.alarm_times()[0] == [T[6013]]


def test_cusum_restarts_after_a_gap_and_is_causal() -> None:
    from ftc_mj.analysis.diagnosis import cusum

    z = np.array([0.2, 1.5, 2.0, 0.1, np.nan, 3.0, 0.0])
    np.testing.assert_array_equal(cusum(z[:, None], 0.5)[:, 0], [0.0, 1.0, 2.5, 2.1, np.nan, 2.5, 2.0])
    np.testing.assert_array_equal(cusum(z[:4, None], 0.5), cusum(z[:, None], 0.5)[:4])  # the past alone


def test_cusum_rule_from_the_scenario(tmp_path: Path) -> None:
    scenario = load_scenario(write(tmp_path, diagnosis_data({**VALID, "rule": {"kind": "cusum", "drift": 0.4,
                                                                              "h": 12.0}})))
    assert (scenario.diagnoser.rule, scenario.diagnoser.drift, scenario.diagnoser.h) == ("cusum", 0.4, 12.0)
    assert load_scenario(write(tmp_path, diagnosis_data(VALID))).diagnoser.rule == "threshold"


def test_a_floor_raises_a_fixed_threshold_and_is_refused_beside_a_bound_or_k():
    from ftc_mj.analysis.diagnosis import DiagnosisSpec, compile_diagnoser

    spec = DiagnosisSpec(threshold={"fixed": [1.0, 5.0], "floor": [3.0, 3.0]})
    diagnoser = compile_diagnoser(spec, 0.01, 0.0, "f.yaml", 2, [])
    np.testing.assert_array_equal(diagnoser.fixed, [3.0, 5.0])
    for threshold in ({"fixed": 1.0, "floor": 3.0, "bound": ["1", "1"]},
                      {"fixed": 1.0, "floor": 3.0, "k": 2.0}):
        with pytest.raises(ValueError, match="floor is for a fixed threshold"):
            DiagnosisSpec(threshold=threshold, baseline={"start": 0.0, "end": 1.0})
