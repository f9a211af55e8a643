"""The benchmark's scores on synthetic runs with hand-computed values, so that a sign error, an off-by-one in
the operating threshold or the wrong denominator of the isolation accuracy fails."""

from __future__ import annotations

import numpy as np
import pytest

from ftc_mj.ranking import score as sc

NAN = np.nan


def runs(healthy, fault, *, delay=None, isolated=None, alarms=None, seconds=None) -> sc.DiagnosisRuns:
    healthy, fault = np.asarray(healthy, float), np.asarray(fault, float)
    return sc.DiagnosisRuns(
        healthy_peak=healthy,
        healthy_alarms=np.zeros(healthy.size) if alarms is None else np.asarray(alarms, float),
        healthy_seconds=np.full(healthy.size, 3600.0) if seconds is None else np.asarray(seconds, float),
        fault_peak=fault,
        fault_delay=np.full(fault.size, NAN) if delay is None else np.asarray(delay, float),
        isolated_right=np.zeros(fault.size, bool) if isolated is None else np.asarray(isolated, bool))


@pytest.mark.parametrize(("healthy", "fault", "expected"), [
    ([0.1, 0.2, 0.3], [1.5, 2.0], 1.0),               # perfect: every faulty peak above every healthy one
    ([1.0, 2.0, 3.0, 4.0], [1.0, 2.0, 3.0, 4.0], 0.5),  # random: the same peaks (ties count half)
    ([2.0, 3.0], [0.5, 1.0], 0.0),                    # inverted: a sign error
    ([0.2, 0.6, 1.4], [0.4, 1.0, 2.0], 6 / 9),        # 6 of the 9 (faulty, healthy) pairs ordered right
])
def test_auc_of_known_detectors(healthy, fault, expected):
    healthy, fault = np.asarray(healthy), np.asarray(fault)
    assert sc.auc(healthy, fault) == pytest.approx(expected)
    assert sc.mann_whitney(healthy, fault) == pytest.approx(expected)  # the bootstrap's statistic agrees


def test_a_diverged_healthy_run_alarms_at_every_threshold():
    assert sc.auc(np.array([0.1, np.inf]), np.array([1.0, 2.0])) == pytest.approx(0.5)
    assert sc.mann_whitney(np.array([0.1, np.inf]), np.array([1.0, 2.0])) == pytest.approx(0.5)


def test_the_auc_interval_brackets_it_and_a_perfect_detector_has_no_width():
    s = sc.diagnosis_scores(runs([0.1, 0.2, 0.3], [1.5, 2.0]))["auc"]
    assert (s.value, s.low, s.high) == (1.0, 1.0, 1.0)
    s = sc.diagnosis_scores(runs([0.2, 0.6, 1.4, 0.3], [0.4, 1.0, 2.0, 0.1]))["auc"]
    assert s.low < s.value < s.high


HEALTHY = 0.05 * np.arange(1, 21)       # 20 healthy runs: 0.05, 0.10, ..., 1.00
FAULT = [0.5, 0.96, 0.99, 1.2, 3.0]


def test_the_operating_threshold_allows_at_most_five_percent_false_alarms():
    # One healthy run of 20 above 0.95 (5%): the lowest threshold allowed; at 0.90 two would alarm (10%).
    assert sc.operating_threshold(HEALTHY) == pytest.approx(0.95)
    s = sc.diagnosis_scores(runs(HEALTHY, FAULT))["pd_at_pfa"]
    assert (s.value, s.count) == (pytest.approx(4 / 5), 5)   # 0.96, 0.99, 1.2, 3.0 (3/5 at a threshold of 1)
    assert s.low < 0.8 < s.high


def test_rates_at_the_methods_own_threshold():
    scores = sc.diagnosis_scores(runs(HEALTHY, FAULT))
    assert scores["detection_rate"].value == pytest.approx(2 / 5)  # 1.2 and 3.0 exceed 1; 0.99 does not
    assert scores["specificity"].value == pytest.approx(1.0)       # 1.00 does not exceed 1: no alarm
    scores = sc.diagnosis_scores(runs([0.5, 1.5, 2.0, 0.2], FAULT))
    assert scores["specificity"].value == pytest.approx(2 / 4)


def test_isolation_accuracy_counts_the_detected_faults_only():
    # Detected at c = 1: the runs with peaks 1.2 and 3.0; of them one is isolated to the right joint. The
    # undetected runs isolated right (0.5) do not count: 1/2, not 3/5 nor 2/2.
    scores = sc.diagnosis_scores(runs(HEALTHY, FAULT, isolated=[True, True, False, False, True]))
    assert (scores["isolation_accuracy"].value, scores["isolation_accuracy"].count) == (pytest.approx(0.5), 2)


def test_delay_percentiles_over_the_detected_faults():
    fault = [1.5, 2.0, 3.0, 4.0, 5.0, 0.7]
    delay = [0.05, 0.1, 0.2, 0.4, 1.0, 0.01]  # the last run is not detected at c = 1: left out
    scores = sc.diagnosis_scores(runs(HEALTHY, fault, delay=delay))
    assert scores["delay_median"].value == pytest.approx(0.2)
    assert scores["delay_p95"].value == pytest.approx(0.4 + 0.8 * 0.6)  # linear: position 0.95 x 4 = 3.8
    assert scores["delay_median"].count == 5


def test_false_alarms_per_hour():
    scores = sc.diagnosis_scores(runs([0.1, 2.0, 3.0], [2.0], alarms=[0, 1, 2], seconds=[1800.0] * 3))
    assert scores["false_alarms_per_hour"].value == pytest.approx(2.0)  # 0, 2 and 4 per hour


def test_tracking_scores():
    tracking = sc.TrackingRuns(healthy_rms=np.array([1e-3, 3e-3]), faulty_rms=np.array([2e-3, NAN, 4e-3]),
                               fault_peak=np.array([0.1, NAN, 0.3]), chattering=np.array([10.0, 30.0]),
                               diverged=np.array([False, False, False, True, False]))
    scores = sc.tracking_scores(tracking)
    assert scores["rms_healthy"].value == pytest.approx(2e-3)
    # The diverged faulty run counts at the capped penalty, never left out (that would flatter it).
    assert (scores["rms_faulty"].value, scores["rms_faulty"].count) == (pytest.approx((6e-3 + sc.DIVERGED_RMS) / 3), 3)
    assert scores["rms_faulty_median"].value == pytest.approx(4e-3)
    assert scores["fault_peak"].value == pytest.approx(0.2)
    assert scores["chattering"].value == pytest.approx(20.0)
    assert (scores["divergence_rate"].value, scores["divergence_rate"].count) == (pytest.approx(1 / 5), 5)


def test_kind_medians_and_the_cap():
    tracking = sc.TrackingRuns(healthy_rms=np.array([1e-3]), faulty_rms=np.array([2e-3, NAN, 4e-3, 5.0]),
                               fault_peak=np.zeros(4), chattering=np.ones(1), diverged=np.zeros(5, bool),
                               faulty_kind=np.array(["bias", "float", "bias", "lock"]))
    assert sc.kind_medians(tracking) == {"bias": pytest.approx(3e-3), "float": sc.DIVERGED_RMS,
                                         "lock": sc.DIVERGED_RMS}


def test_arm_rms_combines_the_joints():
    assert sc.arm_rms(np.array([[3.0, 4.0]]))[0] == pytest.approx(np.sqrt(12.5))
