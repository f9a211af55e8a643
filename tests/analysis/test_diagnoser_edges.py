"""The edges of the diagnoser (ftc_mj.analysis.diagnosis): a residual exactly at the threshold, a run that ends
within rounding of (or well before) its baseline's end, integer inputs, the diagnosis metrics of runs of one and
two samples, a joint whose onset is past the run's end beside one inside it, an alarm at the onset sample, and
the debounce and CUSUM on columns whose first True comes late or on integer input, and NumPy's sums (in time order,
pairwise for one joint) in the baseline and the fault estimate's RMS."""

from __future__ import annotations

import numpy as np

from ftc_mj.analysis.diagnosis import Diagnoser, cusum, diagnosis_metrics, persistent
from ftc_mj.results import Diagnosis

DT = 0.25  # exact in binary: sample times and window ends compare exactly


def _diagnoser(**kwargs) -> Diagnoser:
    values = {"space": "acceleration", "dt": DT, "start": 0.0, "fixed": np.ones(1), "k": 0.0, "persistence": 1}
    return Diagnoser(**{**values, **kwargs})


def _diagnose(diagnoser: Diagnoser, estimate: np.ndarray, t0: float = 0.0) -> Diagnosis:
    t = t0 + np.arange(len(estimate)) * DT
    zeros = np.zeros(np.shape(estimate))
    return diagnoser.diagnose(t, estimate, zeros, zeros, zeros)


def test_a_residual_at_the_threshold_is_not_above_it():
    """r > threshold alarms, r = threshold does not (fixed threshold 1, no baseline: r = |estimate|)."""
    diagnosis = _diagnose(_diagnoser(space="torque"), np.array([[1.0], [1.5], [-1.0], [-1.25]]))
    np.testing.assert_array_equal(diagnosis.alarm[:, 0], [False, True, False, True])
    assert diagnosis.space == "torque"


def test_integer_recordings_give_float_series():
    """Integer estimates and faults are taken as floats (the fault-estimate error and the recording are float)."""
    estimate = np.array([[0], [2], [3]])
    t = np.arange(3) * DT
    diagnosis = _diagnoser().diagnose(t, estimate, np.zeros((3, 1)), np.zeros((3, 1)), np.array([[0], [1], [1]]))
    assert diagnosis.signal.dtype == np.float64 and diagnosis.injected.dtype == np.float64
    np.testing.assert_array_equal(diagnosis.signal, estimate)
    np.testing.assert_array_equal(diagnosis.injected, [[0.0], [1.0], [1.0]])


def test_the_baseline_is_learned_by_a_run_that_reaches_its_end():
    """Samples 0 .. 0.75 s cover [0, 1) s: the window is learned when it ends at 1 s, or 1e-9 s later (rounding
    of the end), not when it ends at 1.5 s (the run stops half a second short)."""
    estimate = np.array([[1.0], [2.0], [3.0], [4.0]])
    for end in (1.0, 1.0 + 1e-9):
        diagnosis = _diagnose(_diagnoser(baseline=(0.0, end), start=end, k=1.0), estimate)
        assert diagnosis.mean[0] == 2.5 and diagnosis.std[0] == np.sqrt(1.25), end
    short = _diagnose(_diagnoser(baseline=(0.0, 1.5), start=1.5, k=1.0), estimate)
    assert np.isnan(short.mean).all() and np.isnan(short.std).all() and not short.alarm.any()


def _alarms(alarm: list[list[bool]], t0: float = 0.0, armed_from: float = 0.0) -> Diagnosis:
    alarm = np.array(alarm, dtype=bool)
    steps, n = alarm.shape
    t = t0 + np.arange(steps) * DT
    residual = alarm.astype(float) * 2.0
    return Diagnosis(space="acceleration", t=t, signal=residual, fault_estimate=residual, residual=residual,
                     threshold=np.ones((steps, n)), alarm=alarm, armed=t >= armed_from, mean=np.zeros(n),
                     std=np.zeros(n), injected=np.zeros((steps, n)))


def test_a_one_sample_run_counts_its_alarm_but_has_no_rate():
    """One armed sample: no period, so no false-alarm rate (NaN, not a division by 0 or by 1 s); the count and
    the isolation are defined."""
    m = diagnosis_metrics(_alarms([[True, False]]), np.array([np.nan, np.nan]), np.inf, 2)
    np.testing.assert_array_equal(m["false_alarms"], [1.0, 0.0])
    assert np.isnan(m["false_alarm_rate"]).all()
    np.testing.assert_array_equal(m["isolation_correct"], [0.0, 1.0])


def test_a_two_sample_run_off_zero_has_its_rate_per_period():
    """Two armed samples at 10 s and 10.25 s: 2 samples x 0.25 s of fault-free time, one alarm: 2 per second."""
    m = diagnosis_metrics(_alarms([[False, False], [True, False]], t0=10.0), np.array([np.nan, np.nan]), np.inf, 2)
    np.testing.assert_array_equal(m["false_alarms"], [1.0, 0.0])
    np.testing.assert_array_equal(m["false_alarm_rate"], [1.0 / (2 * DT), 0.0])


def test_an_onset_past_the_end_beside_one_inside_it():
    """Joint 0 faulty from sample 2, its alarm on from that very sample: detected with zero delay. Joint 1's
    onset is after the run's last sample: its fault never acted, its detection metrics stay undefined even
    though the diagnoser was armed before it and the first onset (joint 0's) is inside the run."""
    diagnosis = _alarms([[False, False], [False, False], [True, False], [True, False]])
    m = diagnosis_metrics(diagnosis, np.array([2 * DT, 10.0]), 2 * DT, 2)
    assert m["detection_delay"][0] == 0.0 and m["missed_detection"][0] == 0.0
    assert m["isolation_correct"][0] == 1.0 and m["fault_estimate_rms"][0] == 2.0
    for name in ("detection_delay", "missed_detection", "isolation_correct", "fault_estimate_rms"):
        assert np.isnan(m[name][1]), name
    np.testing.assert_array_equal(m["false_alarms"], [0.0, 0.0])


def test_persistence_of_a_column_whose_first_true_comes_before_the_others():
    """Column 1 is True from the first sample, column 0 never: with 2 samples column 1 raises at sample 1 (the
    debounce starts at the first True of any column, not at the index of the first column holding one)."""
    exceeded = np.zeros((6, 2), dtype=bool)
    exceeded[:3, 1] = True
    np.testing.assert_array_equal(persistent(exceeded, 2)[:, 1], [False, True, True, True, False, False])
    assert not persistent(exceeded, 2)[:, 0].any()


def test_persistence_of_integer_input_is_that_of_its_truth_values():
    """0/1 integers debounce as False/True, and come back as booleans, with or without persistence."""
    levels = np.array([[0], [1], [1], [0], [0], [2]])
    for samples in (1, 2):
        alarm = persistent(levels, samples)
        assert alarm.dtype == np.bool_
        np.testing.assert_array_equal(alarm, persistent(levels != 0, samples))


def test_cusum_of_a_series_of_integers():
    """One series (N,) of integer levels: g = max(0, g + z - 0.5) from 0, in floats, in the series' shape."""
    g = cusum(np.array([1, 2, 0, 3]), 0.5)
    assert g.shape == (4,)
    np.testing.assert_array_equal(g, [0.5, 2.0, 1.5, 4.0])


def test_the_baseline_sums_in_time_order_and_the_estimates_rms_is_numpys_for_one_joint_and_several():
    """The causal diagnoser's baseline sums each column in time order (the samples as they come), whatever the
    number of joints: NumPy's mean and deviation to 1e-13 relative (NumPy sums one column pairwise), and the
    time-ordered sums exactly; the metrics' RMS of the fault estimate from detection on is NumPy's."""
    rng = np.random.default_rng(5)
    for n in (1, 2, 3):
        for samples in (7, 130, 1500):
            scale = 10.0 ** rng.uniform(-3, 3, n)
            estimate = rng.normal(size=(samples + 10, n)) * scale
            estimate[samples + 2:] += 100.0 * scale  # a fault after the baseline
            t = np.arange(len(estimate)) * DT
            end = float(t[samples])
            diagnoser = _diagnoser(fixed=np.zeros(n), k=3.0, baseline=(0.0, end), start=end)
            injected = rng.normal(size=estimate.shape)
            diagnosis = diagnoser.diagnose(t, estimate, estimate, estimate, injected)
            window = estimate[t < end]
            total = np.zeros(n)
            for sample in window:
                total += sample
            mean = total / len(window)
            squares = np.zeros(n)
            for sample in window:
                squares += (sample - mean) ** 2
            assert np.array_equal(diagnosis.mean, mean)
            assert np.array_equal(diagnosis.std, np.sqrt(squares / len(window)))
            np.testing.assert_allclose(diagnosis.mean, window.mean(axis=0), rtol=1e-13, atol=0)
            np.testing.assert_allclose(diagnosis.std, window.std(axis=0), rtol=1e-13, atol=0)
            onsets = np.zeros(n)
            metrics = diagnosis_metrics(diagnosis, onsets, 0.0, n)
            for j in range(n):
                first = np.flatnonzero(diagnosis.alarm[:, j])[0]
                error = diagnosis.fault_estimate[first:, j] - injected[first:, j]
                assert metrics["fault_estimate_rms"][j] == np.sqrt(np.mean(error**2))
