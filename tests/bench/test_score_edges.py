"""The benchmark's scores at their bounds (ftc_mj.bench.score): a run is detected or alarmed when its held
level z exceeds the threshold, z > 1, not at z = 1 exactly, as the diagnoser's own comparison (residual >
threshold) decides; healthy runs never armed count for no false-alarm rate."""

from __future__ import annotations

import numpy as np
import pytest

from ftc_mj.bench import score as sc


def _runs(healthy, fault, seconds=None) -> sc.DiagnosisRuns:
    healthy, fault = np.asarray(healthy, float), np.asarray(fault, float)
    return sc.DiagnosisRuns(
        healthy_peak=healthy, healthy_alarms=np.ones(healthy.size),
        healthy_seconds=np.full(healthy.size, 1800.0) if seconds is None else np.asarray(seconds, float),
        fault_peak=fault, fault_delay=np.full(fault.size, 0.1), isolated_right=np.ones(fault.size, bool))


def test_a_fault_at_exactly_the_threshold_is_not_detected():
    scores = sc.diagnosis_scores(_runs([0.5], [1.0, 1.0, 2.0, 1.0]), resamples=20)
    assert scores["detection_rate"].value == pytest.approx(1 / 4)
    assert scores["isolation_accuracy"].count == 1 and scores["delay_median"].count == 1


def test_a_healthy_run_at_exactly_the_threshold_raises_no_alarm():
    scores = sc.diagnosis_scores(_runs([1.0, 1.0, 1.5, 0.0], [2.0]), resamples=20)
    assert scores["specificity"].value == pytest.approx(3 / 4)


def test_only_armed_healthy_runs_count_for_the_false_alarm_rate():
    """1 alarm in half an hour is 2 per hour; the never armed run (0 s) is left out, not divided by."""
    scores = sc.diagnosis_scores(_runs([0.1, 0.2], [2.0], seconds=[1800.0, 0.0]), resamples=20)
    assert scores["false_alarms_per_hour"].value == pytest.approx(2.0)
    assert scores["false_alarms_per_hour"].count == 1


def test_a_missing_score_is_nan_from_no_runs():
    missing = sc.Score.missing()
    assert np.isnan([missing.value, missing.low, missing.high]).all() and missing.count == 0


def test_the_auc_interval_is_the_seeded_percentile_bootstrap():
    """Healthy and faulty runs resampled apart with the fixed seed, every index drawn from 0, the central 95 %
    of the resampled AUCs: reproduced here step by step, bit for bit, and the same on a second call."""
    healthy, fault = np.array([0.0, 2.0, 0.5]), np.array([1.0, 3.0])
    resamples = 64
    rng = np.random.default_rng(sc.BOOTSTRAP_SEED)
    values = np.empty(resamples)
    for b in range(resamples):
        values[b] = sc.mann_whitney(healthy[rng.integers(0, healthy.size, healthy.size)],
                                    fault[rng.integers(0, fault.size, fault.size)])
    expected = tuple(np.percentile(values, [2.5, 97.5]))
    scores = sc.diagnosis_scores(_runs(healthy, fault), resamples=resamples)
    assert (scores["auc"].low, scores["auc"].high) == expected
    assert scores["auc"].count == 5
    again = sc.diagnosis_scores(_runs(healthy, fault), resamples=resamples)
    assert (again["auc"].low, again["auc"].high) == expected


def test_no_auc_without_healthy_runs():
    scores = sc.diagnosis_scores(_runs([], [2.0, 0.5]), resamples=20)
    assert np.isnan(scores["auc"].value) and scores["auc"].count == 0
    assert scores["detection_rate"].value == pytest.approx(0.5)


def test_tracking_intervals_use_the_resamples_given():
    from ftc_mj.campaign import statistics as st

    tracking = sc.TrackingRuns(healthy_rms=np.array([1e-3, 3e-3, 2e-3]), faulty_rms=np.array([2e-3, 4e-3]),
                               fault_peak=np.array([0.1, 0.3]), chattering=np.array([10.0, 30.0, 20.0]),
                               diverged=np.zeros(3, bool))
    scores = sc.tracking_scores(tracking, resamples=16)
    mean = st.summarise(np.array([1e-3, 3e-3, 2e-3]), 16).mean
    assert (scores["rms_healthy"].low, scores["rms_healthy"].high) == (mean.low, mean.high)
