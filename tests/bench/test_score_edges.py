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
