"""The edges of the metrics' building blocks (ftc_mj.analysis.metrics): the units, inclusive and exclusive
bounds of the first entry, the overshoot's initial sign and its per-joint peak, a partial time mask, and which
estimate the diagnoser gets in each space (ftc_mj.analysis.diagnosis.diagnose_result)."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from ftc_mj.analysis.diagnosis import diagnose_result
from ftc_mj.analysis.metrics import UNITS, MetricsSpec, RecordedSeries, series_metrics, unit

DT = 0.25  # exact in binary


def metrics_of(t: np.ndarray, spec: MetricsSpec | None = None, onsets: list[float] = (),
               joint_onsets: np.ndarray | None = None, **errors: np.ndarray) -> dict[str, np.ndarray]:
    """The series metrics of errors given as ``error``, ``velocity_error``, ``luaf_error``, ``tau``,
    ``sliding`` (the others zero)."""
    zeros = np.zeros_like(next(iter(errors.values())))
    error, velocity, luaf, tau, sliding = (errors.pop(name, zeros) for name in
                                            ("error", "velocity_error", "luaf_error", "tau", "sliding"))
    assert not errors, errors
    series = RecordedSeries(error, zeros, velocity, zeros, luaf, zeros, tau, sliding)
    joint_onsets = np.full(zeros.shape[1], np.nan) if joint_onsets is None else joint_onsets
    return series_metrics(t, series, spec or MetricsSpec(), list(onsets), joint_onsets)


def test_units_of_the_fault_estimate_follow_the_diagnosis_space():
    assert unit("fault_estimate_rms", "torque") == "N m"
    assert unit("fault_estimate_rms", "acceleration") == "rad/s^2"
    assert unit("fault_estimate_rms") == UNITS["fault_estimate_rms"]
    assert unit("rms_error", "torque") == "rad" and unit("detection_delay", "acceleration") == "s"


def test_first_entry_bounds():
    """|e| = tolerance is inside; the sample at ``until`` (the first fault onset) itself is not looked at; none
    before: NaN."""
    t = np.arange(6) * DT
    error = np.array([[2.0, 2.0], [1.0, 2.0], [0.5, 2.0], [0.0, 2.0], [0.0, 0.0], [0.0, 0.0]])
    spec = MetricsSpec(sliding_tolerance=0.5)

    def first_entry(onsets: list[float]) -> np.ndarray:
        return metrics_of(t, spec, onsets, sliding=error)["first_reaching_time"]

    np.testing.assert_array_equal(first_entry([]), [2 * DT, 4 * DT])
    np.testing.assert_array_equal(first_entry([4 * DT]), [2 * DT, np.nan])
    np.testing.assert_array_equal(first_entry([0.0]), [np.nan, np.nan])


def test_overshoot_from_the_first_sample_and_per_joint():
    """The initial sign is the first transient sample's (not the second's); an initial error of 0 takes each
    joint's own largest |error|, not the largest of all joints."""
    error = np.array([[1.0, 0.0], [-0.5, 0.1], [-2.0, -0.2], [0.5, 0.0]])
    t = np.arange(4) * DT

    def overshoot(t: np.ndarray, error: np.ndarray, transient_end: float) -> np.ndarray:
        spec = MetricsSpec(estimation_window_start=transient_end)
        return metrics_of(t, spec, luaf_error=error)["luaf_overshoot"]

    np.testing.assert_array_equal(overshoot(t, error, 4 * DT), [2.0, 0.2])
    # From the second sample on, joint 1 starts negative: its overshoot is the largest positive error.
    np.testing.assert_array_equal(overshoot(t[1:], error[1:], 4 * DT), [0.5, 0.2])
    assert np.isnan(overshoot(t, error, 0.0)).all()  # no transient


def test_a_partial_time_mask_leaves_its_samples_out():
    """The samples outside a window count for neither the peak nor the RMS (nor the count)."""
    x = np.array([[10.0, -10.0], [1.0, 2.0], [-3.0, 4.0]])
    t = np.arange(3) * DT
    estimation = metrics_of(t, MetricsSpec(estimation_window_start=DT), velocity_error=x)
    np.testing.assert_allclose(estimation["rms_velocity_error"], [np.sqrt(5.0), np.sqrt(10.0)], rtol=1e-15)
    transient = metrics_of(t, MetricsSpec(estimation_window_start=2 * DT), luaf_error=x[::-1])
    np.testing.assert_array_equal(transient["peak_luaf_error_transient"], [3.0, 4.0])
    assert np.isnan(metrics_of(t, MetricsSpec(), luaf_error=x)["peak_luaf_error_transient"]).all()
    assert np.isnan(metrics_of(t, MetricsSpec(estimation_window_start=1.0), velocity_error=x)["rms_velocity_error"]).all()


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
    t = np.arange(12) * DT
    error = np.zeros((12, 3))
    error[4:, 2] = 0.5
    error[8, 2] = 3.0  # at onset + window exactly: outside the peak's window
    error[10:, 2] = 0.0  # back within the tolerance from sample 10
    spec = MetricsSpec(tracking_tolerance=0.01, fault_window=4 * DT)
    for onsets in ([np.nan, np.nan, 4 * DT], [np.nan, 100.0, 4 * DT]):
        metrics = metrics_of(t, spec, [4 * DT], np.array(onsets), error=error)
        np.testing.assert_array_equal(metrics["fault_peak_error"], [np.nan, np.nan, 0.5])
        np.testing.assert_array_equal(metrics["recovery_time"], [np.nan, np.nan, 6 * DT])


def _result(t: np.ndarray, tau: np.ndarray, luaf_error: np.ndarray | None = None) -> SimpleNamespace:
    zeros = np.zeros((len(t), tau.shape[1]))
    return SimpleNamespace(t=t, q_true=zeros, q_ref=zeros, qd_true=zeros, qd_hat=zeros,
                           luaf_true=zeros if luaf_error is None else luaf_error, luaf_hat=zeros, tau=tau,
                           sliding=zeros, diagnosis=None)


def test_chattering_per_second_of_a_short_window_off_zero():
    """Total variation / window length, the length from the period t[1] - t[0] on a clock that starts at 10 s,
    a window shorter than a second, and a run of two samples (one pair)."""
    from ftc_mj.analysis.metrics import compute_metrics

    spec = MetricsSpec(window_start=0.0, estimation_window_start=0.0, fault_settle=0.0)
    t = 10.0 + np.arange(4) * DT
    tau = np.array([[0.0], [1.0], [0.0], [1.0]])
    assert compute_metrics(_result(t, tau), spec, [])["chattering"][0] == 3.0 / (3 * DT)
    assert compute_metrics(_result(t[:2], tau[:2]), spec, [])["chattering"][0] == 1.0 / DT


def test_the_transient_ends_before_the_estimation_window_start():
    """The sample at estimation_window_start belongs to the estimation window, not to the transient."""
    from ftc_mj.analysis.metrics import compute_metrics

    spec = MetricsSpec(window_start=0.0, estimation_window_start=2 * DT, fault_settle=0.0)
    t = np.arange(4) * DT
    luaf_error = np.array([[1.0], [0.5], [9.0], [0.0]])
    metrics = compute_metrics(_result(t, np.zeros((4, 1)), luaf_error), spec, [])
    assert metrics["peak_luaf_error_transient"][0] == 1.0
    assert metrics["rms_luaf_error"][0] == np.sqrt(81.0 / 2)


def test_settling_on_the_last_sample_and_a_joint_without_samples():
    """Settled from the last sample when only it is inside; a converged window empty on one joint gives NaN
    there (it entered the tolerance at once, and its settle interval runs past the end)."""
    t = np.arange(4) * DT
    error = np.array([[1.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    np.testing.assert_array_equal(metrics_of(t, MetricsSpec(tracking_tolerance=0.5), error=error)["convergence_time"],
                                  [3 * DT, np.nan])
    error = np.array([[1.0, 0.0], [1.0, 0.0], [1.0, 1.0], [1.0, 1.0]])
    metrics = metrics_of(t, MetricsSpec(tracking_tolerance=0.5, fault_settle=4 * DT), error=error)
    np.testing.assert_array_equal(metrics["max_error_converged"], [1.0, np.nan])
    np.testing.assert_array_equal(metrics["rms_error_converged"], [1.0, np.nan])


def test_the_fault_rms_starts_at_the_onset_sample():
    from ftc_mj.analysis.metrics import compute_metrics

    spec = MetricsSpec(window_start=0.0, estimation_window_start=0.0, fault_settle=0.0)
    t = np.arange(4) * DT
    luaf_error = np.array([[5.0], [5.0], [3.0], [0.0]])
    metrics = compute_metrics(_result(t, np.zeros((4, 1)), luaf_error), spec, [2 * DT])
    assert metrics["rms_luaf_error_fault"][0] == np.sqrt(9.0 / 2)


def test_a_nan_sample_poisons_every_peak_it_is_in():
    """A NaN error makes each maximum over a window holding it NaN, as NumPy's maximum does, wherever it falls
    (before a larger sample, or after one); a peak whose window leaves it out stays a number."""
    t = np.arange(6) * DT
    error = np.array([[0.5, 0.0], [np.nan, 0.1], [2.0, 0.2], [0.1, np.nan], [0.0, 0.0], [0.0, 0.0]])
    spec = MetricsSpec(window_start=4 * DT, estimation_window_start=3 * DT, fault_settle=0.0)
    metrics = metrics_of(t, spec, error=error, luaf_error=error)
    assert np.isnan(metrics["max_error"]).all() and np.isnan(metrics["rms_error"]).all()
    assert np.isnan(metrics["peak_luaf_error_transient"][0]) and metrics["peak_luaf_error_transient"][1] == 0.2
    np.testing.assert_array_equal(metrics["max_error_converged"], [0.0, 0.0])  # from sample 4: no NaN in it


def test_chattering_counts_no_pair_before_the_first_sample():
    """A window that starts at the run's first sample has one pair fewer than samples: no pair of the first
    sample with anything before it (least of all the last sample)."""
    t = np.arange(4) * DT
    tau = np.array([[0.0], [1.0], [1.0], [3.0]])  # variation 1 + 0 + 2 over three pairs
    assert metrics_of(t, MetricsSpec(fault_settle=0.0), tau=tau)["chattering"][0] == 3.0 / (3 * DT)


def test_integer_inputs_give_the_metrics_of_their_float_values():
    """Times, series, onsets and limits given as integers are read as the floats they are (the compiled pass
    reads float arrays only), so the metrics equal those of the same values as floats, bit for bit."""
    t = np.arange(12)
    rng = np.random.default_rng(3)
    errors = {name: rng.integers(-3, 4, size=(12, 2)) for name in ("error", "velocity_error", "luaf_error", "tau",
                                                                  "sliding")}
    spec = MetricsSpec(window_start=2.0, estimation_window_start=3.0, fault_settle=1.0, fault_window=3.0,
                       tracking_tolerance=1.0, velocity_tolerance=1.0, luaf_tolerance=1.0, sliding_tolerance=1.0)

    def metrics(cast: type) -> dict[str, np.ndarray]:
        series = {name: values.astype(cast) for name, values in errors.items()}
        zeros = np.zeros((12, 2), dtype=cast)
        recorded = RecordedSeries(series["error"], zeros, series["velocity_error"], zeros, series["luaf_error"],
                                  zeros, series["tau"], series["sliding"])
        return series_metrics(t.astype(cast), recorded, spec, [6], np.array([6, 8], dtype=cast),
                              np.array([2, 3], dtype=cast))

    as_integers, as_floats = metrics(int), metrics(float)
    assert np.isfinite(as_floats["recovery_time"]).any() and as_floats["saturation_time"].any()
    for name, values in as_floats.items():
        np.testing.assert_array_equal(as_integers[name], values, err_msg=name)
