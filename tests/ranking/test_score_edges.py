"""The benchmark's scores at their bounds (ftc_mj.ranking.score): a run is detected or alarmed when its held
level z exceeds the threshold, z > 1, not at z = 1 exactly, as the diagnoser's own comparison (residual >
threshold) decides; healthy runs never armed count for no false-alarm rate; the ROC's first point and diverged
runs; the bootstrap intervals step by step."""

from __future__ import annotations

import numpy as np
import pytest

from ftc_mj.ranking import score as sc
from ftc_mj.campaign import statistics as st


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
    """Healthy and faulty runs resampled apart with the fixed seed, each resample as large as its sample, the
    central 95 % of the resampled AUCs: reproduced here step by step, bit for bit, and the same on a second call.
    The peaks overlap and are many, so that another seed, resample size or percentile gives another interval."""
    draw = np.random.default_rng(7)
    healthy, fault = draw.normal(1.0, 0.5, 30), draw.normal(1.5, 0.5, 25)
    resamples = 200
    rng = np.random.default_rng(sc.BOOTSTRAP_SEED)
    values = np.empty(resamples)
    for b in range(resamples):
        values[b] = sc.mann_whitney(healthy[rng.integers(0, healthy.size, healthy.size)],
                                    fault[rng.integers(0, fault.size, fault.size)])
    expected = tuple(np.percentile(values, [2.5, 97.5]))
    scores = sc.diagnosis_scores(_runs(healthy, fault), resamples=resamples)
    assert (scores["auc"].low, scores["auc"].high) == expected
    assert scores["auc"].low < scores["auc"].value < scores["auc"].high  # measured: 0.66 < 0.77 < 0.87
    assert scores["auc"].count == 55
    again = sc.diagnosis_scores(_runs(healthy, fault), resamples=resamples)
    assert (again["auc"].low, again["auc"].high) == expected


def test_the_auc_needs_both_kinds_of_runs():
    assert np.isnan(sc.auc(np.array([]), np.array([1.0, 2.0])))
    assert np.isnan(sc.auc(np.array([1.0, 2.0]), np.array([])))
    assert sc.auc(np.array([0.5]), np.array([1.0])) == 1.0  # one run of each is enough
    assert sc.auc(np.array([1.0]), np.array([0.5])) == 0.0


def test_the_roc_starts_below_every_peak_and_ranks_diverged_runs_first():
    """The first threshold lies below every peak (every run alarms: the point (1, 1)); a diverged faulty run
    (inf) is detected at every threshold, also when no run has a finite peak."""
    p_fa, p_d = sc.roc_curve(np.array([0.5, 1.0]), np.array([np.inf, 0.7]))
    assert (p_fa[0], p_d[0]) == (1.0, 1.0)
    # Thresholds: 1 below the least peak, the peaks 0.5, 0.7, 1.0, and 2.0 (the diverged run's stand-in, 1 above
    # every finite peak, where nothing alarms).
    np.testing.assert_array_equal(p_d, [1.0, 1.0, 0.5, 0.5, 0.0])
    np.testing.assert_array_equal(p_fa, [1.0, 0.5, 0.5, 0.0, 0.0])
    p_fa, p_d = sc.roc_curve(np.array([np.inf]), np.array([np.inf]))
    np.testing.assert_array_equal(p_fa, [1.0, 0.0])
    np.testing.assert_array_equal(p_d, [1.0, 0.0])


def test_detection_at_the_operating_threshold_counts_peaks_above_it_only():
    """20 healthy peaks 0.1 ... 2.0: at most 1 of 20 above c makes c = 1.9; a faulty peak of exactly 1.9 is not
    detected there."""
    healthy = np.arange(1, 21) / 10
    assert sc.operating_threshold(healthy) == pytest.approx(1.9)
    scores = sc.diagnosis_scores(_runs(healthy, [1.9, 2.5]), resamples=20)
    assert scores["pd_at_pfa"].value == 0.5


def test_a_run_armed_for_less_than_a_second_counts_for_the_false_alarm_rate():
    scores = sc.diagnosis_scores(_runs([0.1], [2.0], seconds=[0.5]), resamples=20)
    assert scores["false_alarms_per_hour"].value == pytest.approx(7200.0)  # 1 alarm in 0.5 s


def test_delay_and_false_alarm_intervals_use_the_resamples_given():
    """The delay and false-alarm intervals are the summaries' bootstrap with the resamples asked for (many
    spread values, so that another number of resamples gives another interval)."""
    draw = np.random.default_rng(11)
    delays, alarms, seconds = draw.uniform(0.05, 0.5, 20), draw.integers(0, 5, 20).astype(float), np.full(20, 900.0)
    runs = sc.DiagnosisRuns(healthy_peak=np.full(20, 0.1), healthy_alarms=alarms, healthy_seconds=seconds,
                            fault_peak=np.full(20, 2.0), fault_delay=delays, isolated_right=np.ones(20, bool))
    scores = sc.diagnosis_scores(runs, resamples=16)
    expected = st.summarise(delays, 16)
    assert (scores["delay_median"].low, scores["delay_median"].high) == (expected.median.low, expected.median.high)
    assert (scores["delay_p95"].low, scores["delay_p95"].high) == (expected.p95.low, expected.p95.high)
    rates = st.summarise(alarms / (seconds / 3600.0), 16)
    assert (scores["false_alarms_per_hour"].low, scores["false_alarms_per_hour"].high) == (rates.mean.low,
                                                                                          rates.mean.high)
    default = st.summarise(alarms / (seconds / 3600.0))  # 2000 resamples: another interval of the mean (the
    assert (default.mean.low, default.mean.high) != (rates.mean.low, rates.mean.high)  # percentiles' need none)


def test_no_auc_without_healthy_runs():
    scores = sc.diagnosis_scores(_runs([], [2.0, 0.5]), resamples=20)
    assert np.isnan(scores["auc"].value) and scores["auc"].count == 0
    assert scores["detection_rate"].value == pytest.approx(0.5)


def test_tracking_intervals_use_the_resamples_given():
    tracking = sc.TrackingRuns(healthy_rms=np.array([1e-3, 3e-3, 2e-3]), faulty_rms=np.array([2e-3, 4e-3]),
                               fault_peak=np.array([0.1, 0.3]), chattering=np.array([10.0, 30.0, 20.0]),
                               diverged=np.zeros(3, bool))
    scores = sc.tracking_scores(tracking, resamples=16)
    mean = st.summarise(np.array([1e-3, 3e-3, 2e-3]), 16).mean
    assert (scores["rms_healthy"].low, scores["rms_healthy"].high) == (mean.low, mean.high)
