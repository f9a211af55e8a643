"""The edges of the metrics' building blocks (ftc_mj.analysis.metrics): the units, inclusive and exclusive
bounds of the first entry, the overshoot's initial sign and its per-joint peak, a partial time mask, and which
estimate the diagnoser gets in each space (ftc_mj.analysis.diagnosis.diagnose_result)."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from ftc_mj.analysis.diagnosis import diagnose_result
from ftc_mj.analysis.metrics import UNITS, _max_abs, _rms, first_entry_time, overshoot, unit

DT = 0.25  # exact in binary


def test_units_of_the_fault_estimate_follow_the_diagnosis_space():
    assert unit("fault_estimate_rms", "torque") == "N m"
    assert unit("fault_estimate_rms", "acceleration") == "rad/s^2"
    assert unit("fault_estimate_rms") == UNITS["fault_estimate_rms"]
    assert unit("rms_error", "torque") == "rad" and unit("detection_delay", "acceleration") == "s"


def test_first_entry_bounds():
    """|e| = tolerance is inside; the sample at ``until`` itself is not looked at; none before: NaN."""
    t = np.arange(6) * DT
    error = np.array([[2.0, 2.0], [1.0, 2.0], [0.5, 2.0], [0.0, 2.0], [0.0, 0.0], [0.0, 0.0]])
    np.testing.assert_array_equal(first_entry_time(t, error, 0.5, np.inf), [2 * DT, 4 * DT])
    np.testing.assert_array_equal(first_entry_time(t, error, 0.5, 4 * DT), [2 * DT, np.nan])
    np.testing.assert_array_equal(first_entry_time(t, error, 0.5, 0.0), [np.nan, np.nan])


def test_overshoot_from_the_first_sample_and_per_joint():
    """The initial sign is the first masked sample's (not the second's); an initial error of 0 takes each
    joint's own largest |error|, not the largest of all joints."""
    error = np.array([[1.0, 0.0], [-0.5, 0.1], [-2.0, -0.2], [0.5, 0.0]])
    mask = np.ones(4, dtype=bool)
    np.testing.assert_array_equal(overshoot(error, mask), [2.0, 0.2])
    # From the second sample on, joint 1 starts negative: its overshoot is the largest positive error.
    mask[0] = False
    np.testing.assert_array_equal(overshoot(error, mask), [0.5, 0.2])
    assert np.isnan(overshoot(error, np.zeros(4, dtype=bool))).all()


def test_a_partial_time_mask_leaves_its_samples_out():
    """The samples outside a (T,) mask count for neither the peak nor the RMS (nor the count)."""
    x = np.array([[10.0, -10.0], [1.0, 2.0], [-3.0, 4.0]])
    mask = np.array([False, True, True])
    np.testing.assert_array_equal(_max_abs(x, mask), [3.0, 4.0])
    np.testing.assert_allclose(_rms(x, mask), [np.sqrt(5.0), np.sqrt(10.0)], rtol=1e-15)
    assert np.isnan(_max_abs(x, np.zeros(3, dtype=bool))).all()
    assert np.isnan(_rms(x, np.zeros(3, dtype=bool))).all()


class _Recorder:
    def __init__(self, space: str):
        self.space, self.calls = space, []

    def diagnose(self, *args):
        self.calls.append(args)
        return "diagnosis"


def test_diagnose_result_hands_the_estimate_of_its_space():
    """Torque space: M(q) luaf_hat (cut to the run's length) against the fault torque; acceleration space:
    luaf_hat against the fault acceleration; no diagnoser: nothing stored."""
    t = np.arange(3) * DT
    result = SimpleNamespace(t=t, luaf_hat=np.full((3, 2), 1.0), fault_acceleration=np.full((3, 2), 2.0),
                             fault_torque=np.full((3, 2), 3.0), q_meas=np.full((3, 2), 4.0),
                             qd_hat=np.full((3, 2), 5.0), diagnosis=None)
    luaf_torque = np.arange(10.0).reshape(5, 2)
    for space, estimate, injected in [("torque", luaf_torque[:3], result.fault_torque),
                                      ("acceleration", result.luaf_hat, result.fault_acceleration)]:
        recorder = _Recorder(space)
        diagnose_result(recorder, result, luaf_torque)
        (args,) = recorder.calls
        assert args[0] is t and args[2] is result.q_meas and args[3] is result.qd_hat
        np.testing.assert_array_equal(args[1], estimate)
        assert args[4] is injected
        assert result.diagnosis == "diagnosis"
    result.diagnosis = None
    diagnose_result(None, result, luaf_torque)
    assert result.diagnosis is None


def test_fault_response_per_joint_and_its_window_end():
    """A healthy joint or one whose onset is past the end does not stop the next joints from being scored;
    the fault window [onset, onset + window) leaves its end sample out."""
    from ftc_mj.analysis.metrics import fault_response

    t = np.arange(12) * DT
    error = np.zeros((12, 3))
    error[4:, 2] = 0.5
    error[8, 2] = 3.0  # at onset + window exactly: outside the peak's window
    error[10:, 2] = 0.0  # back within the tolerance from sample 10
    for onsets in ([np.nan, np.nan, 4 * DT], [np.nan, 100.0, 4 * DT]):
        peak, recovery = fault_response(t, error, np.array(onsets), [4 * DT], 0.01, window=4 * DT)
        np.testing.assert_array_equal(peak, [np.nan, np.nan, 0.5])
        np.testing.assert_array_equal(recovery, [np.nan, np.nan, 6 * DT])


def _result(t: np.ndarray, tau: np.ndarray, luaf_error: np.ndarray | None = None) -> SimpleNamespace:
    zeros = np.zeros((len(t), tau.shape[1]))
    return SimpleNamespace(t=t, tracking_error=zeros, tau=tau, velocity_error=zeros,
                           luaf_error=zeros if luaf_error is None else luaf_error, sliding=zeros, diagnosis=None)


def test_chattering_per_second_of_a_short_window_off_zero():
    """Total variation / window length, the length from the period t[1] - t[0] on a clock that starts at 10 s,
    a window shorter than a second, and a run of two samples (one pair)."""
    from ftc_mj.analysis.metrics import MetricsSpec, compute_metrics

    spec = MetricsSpec(window_start=0.0, estimation_window_start=0.0, fault_settle=0.0)
    t = 10.0 + np.arange(4) * DT
    tau = np.array([[0.0], [1.0], [0.0], [1.0]])
    assert compute_metrics(_result(t, tau), spec, [])["chattering"][0] == 3.0 / (3 * DT)
    assert compute_metrics(_result(t[:2], tau[:2]), spec, [])["chattering"][0] == 1.0 / DT


def test_the_transient_ends_before_the_estimation_window_start():
    """The sample at estimation_window_start belongs to the estimation window, not to the transient."""
    from ftc_mj.analysis.metrics import MetricsSpec, compute_metrics

    spec = MetricsSpec(window_start=0.0, estimation_window_start=2 * DT, fault_settle=0.0)
    t = np.arange(4) * DT
    luaf_error = np.array([[1.0], [0.5], [9.0], [0.0]])
    metrics = compute_metrics(_result(t, np.zeros((4, 1)), luaf_error), spec, [])
    assert metrics["peak_luaf_error_transient"][0] == 1.0
    assert metrics["rms_luaf_error"][0] == np.sqrt(81.0 / 2)


def test_settling_on_the_last_sample_and_a_joint_without_samples():
    """Settled from the last sample when only it is inside; a (T, n) mask empty on one joint gives NaN there."""
    from ftc_mj.analysis.metrics import settling_time

    t = np.arange(4) * DT
    error = np.array([[1.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    np.testing.assert_array_equal(settling_time(t, error, 0.5, np.inf), [3 * DT, np.nan])
    mask = np.array([[True, False], [True, False], [False, False], [False, False]])
    np.testing.assert_array_equal(_max_abs(error, mask), [1.0, np.nan])


def test_the_fault_rms_starts_at_the_onset_sample():
    from ftc_mj.analysis.metrics import MetricsSpec, compute_metrics

    spec = MetricsSpec(window_start=0.0, estimation_window_start=0.0, fault_settle=0.0)
    t = np.arange(4) * DT
    luaf_error = np.array([[5.0], [5.0], [3.0], [0.0]])
    metrics = compute_metrics(_result(t, np.zeros((4, 1)), luaf_error), spec, [2 * DT])
    assert metrics["rms_luaf_error_fault"][0] == np.sqrt(9.0 / 2)
