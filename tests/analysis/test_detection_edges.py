"""The edges of the threshold-free detection statistics (ftc_mj.analysis.diagnosis.detection_statistics):
the column names, an onset that falls on a sample (that sample is faulty, not fault-free), a residual exactly
at the threshold (not above it), runs shorter than the persistence and of one or two samples."""

from __future__ import annotations

import numpy as np
import pytest

from ftc_mj.analysis.diagnosis import detection_statistics, persistent, scale_tag
from ftc_mj.results import Diagnosis

DT = 0.25  # exact in binary: sample times and onsets compare exactly


def _diagnosis(residual: np.ndarray, persistence: int = 1, armed_from: float = 0.0) -> Diagnosis:
    steps, n = residual.shape
    t = np.arange(steps) * DT
    threshold = np.ones((steps, n))
    armed = t >= armed_from
    threshold[~armed] = np.nan
    return Diagnosis(space="torque", t=t, signal=residual, fault_estimate=residual, residual=residual,
                     threshold=threshold, alarm=persistent(residual > threshold, persistence), armed=armed,
                     mean=np.zeros(n), std=np.ones(n), injected=np.zeros((steps, n)))


def test_scale_tags():
    assert [scale_tag(c) for c in (1.0, 2, 1.5, 0.25)] == ["x1", "x2", "x1p5", "x0p25"]


@pytest.mark.parametrize("diagnosis", [None, "empty", "run"])
def test_the_columns_are_exactly_the_documented_ones(diagnosis):
    """No column more, none less (NaN columns of a misspelt name would reach the tables)."""
    expected = {"residual_peak_healthy", "residual_peak_fault", "healthy_time", "isolated",
                "false_alarms_x1", "detection_delay_x1", "false_alarms_x1p5", "detection_delay_x1p5"}
    if diagnosis == "empty":
        diagnosis = _diagnosis(np.zeros((0, 2)))
    elif diagnosis == "run":
        diagnosis = _diagnosis(np.zeros((8, 2)))
    stats = detection_statistics(diagnosis, 2, np.array([np.nan, 1.0]), [1.0, 1.5], 2)
    assert set(stats) == expected
    if diagnosis is None or diagnosis.t.size == 0:
        assert all(np.isnan(column).all() for column in stats.values())


def test_an_onset_on_a_sample_makes_that_sample_faulty():
    """Joint 1's onset is sample 4's time exactly, where the residual (3x) starts: an alarm there is a
    detection with zero delay, not a false alarm, and its level counts for the fault, not the healthy peak."""
    residual = np.zeros((10, 2))
    residual[4:, 1] = 3.0
    stats = detection_statistics(_diagnosis(residual), 1, np.array([np.nan, 4 * DT]), [1.0, 2.0], 2)
    assert stats["residual_peak_healthy"][1] == 0.0 and stats["residual_peak_fault"][1] == 3.0
    np.testing.assert_array_equal(stats["false_alarms_x1"], [0, 0])
    np.testing.assert_array_equal(stats["detection_delay_x1"], [np.nan, 0.0])
    np.testing.assert_array_equal(stats["detection_delay_x2"], [np.nan, 0.0])
    np.testing.assert_array_equal(stats["healthy_time"], [10 * DT, 4 * DT])


def test_a_residual_at_the_threshold_raises_nothing():
    """z > c raises, z = c does not: a residual exactly twice the threshold alarms at c = 1, not at c = 2."""
    residual = np.full((6, 1), 2.0)
    stats = detection_statistics(_diagnosis(residual), 1, np.array([np.nan]), [1.0, 2.0], 1)
    assert stats["false_alarms_x1"][0] == 1 and stats["false_alarms_x2"][0] == 0


@pytest.mark.parametrize("steps", [1, 2])
def test_one_and_two_sample_runs(steps):
    """healthy time = armed samples x dt: 0 for one sample (no step), 2 dt for two."""
    stats = detection_statistics(_diagnosis(np.zeros((steps, 1))), 1, np.array([np.nan]), [1.0], 1)
    assert stats["healthy_time"][0] == (0.0 if steps == 1 else 2 * DT)
    assert stats["residual_peak_healthy"][0] == 0.0


def test_persistence_as_long_as_the_run_or_longer():
    """A run of exactly p samples holds one window; a shorter one holds none (NaN peaks, no error)."""
    residual = np.full((4, 1), 3.0)
    exact = detection_statistics(_diagnosis(residual, 4), 4, np.array([np.nan]), [1.0], 1)
    assert exact["residual_peak_healthy"][0] == 3.0
    short = detection_statistics(_diagnosis(residual, 5), 5, np.array([0.0]), [1.0], 1)
    assert np.isnan(short["residual_peak_healthy"][0]) and np.isnan(short["residual_peak_fault"][0])


def test_the_period_is_the_difference_of_the_first_two_times():
    """dt = t[1] - t[0] on a run that does not start at 0 (a log's own clock, say)."""
    diagnosis = _diagnosis(np.zeros((4, 1)))
    diagnosis.t = diagnosis.t + 10.0
    stats = detection_statistics(diagnosis, 1, np.array([np.nan]), [1.0], 1)
    assert stats["healthy_time"][0] == 4 * DT


def test_the_fault_peak_includes_the_onset_sample():
    """The held level at the onset sample itself is the fault's: a peak there alone is the fault peak."""
    residual = np.zeros((10, 1))
    residual[4, 0], residual[5:, 0] = 3.0, 1.5
    stats = detection_statistics(_diagnosis(residual), 1, np.array([4 * DT]), [1.0], 1)
    assert stats["residual_peak_fault"][0] == 3.0 and stats["residual_peak_healthy"][0] == 0.0


def test_isolation_without_faults_and_with_an_onset_on_the_last_sample():
    """Without faults every armed sample counts: the joint that alarms is named faulty, the other not. An onset
    on the last sample leaves one armed sample at or after it: isolation is defined (not NaN)."""
    residual = np.zeros((6, 2))
    residual[2:4, 1] = 3.0
    healthy = detection_statistics(_diagnosis(residual), 1, np.array([np.nan, np.nan]), [], 2)
    np.testing.assert_array_equal(healthy["isolated"], [0.0, 1.0])
    residual[5, 0] = 3.0
    last = detection_statistics(_diagnosis(residual), 1, np.array([5 * DT, np.nan]), [], 2)
    np.testing.assert_array_equal(last["isolated"], [1.0, 0.0])
