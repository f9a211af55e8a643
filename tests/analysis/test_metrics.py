"""ftc_mj.analysis.metrics on synthetic VariantResults with known signals.

The sample time is 2^-10 s, so every sample time, window start, fault onset and settle end below is exact in
binary and the expected sample counts are exact integers.
"""

from __future__ import annotations

import numpy as np
import pytest

from ftc_mj.analysis.metrics import METRICS, RecordedSeries, compute_metrics, evaluation_mask, series_metrics
from ftc_mj.analysis.metrics import MetricsSpec
from ftc_mj.results import VariantResult

DT = 2.0**-10
N = 2049  # t = 0 .. 2 s
T = np.arange(N) * DT
NJ = 2


def make_result(t: np.ndarray = T, **series: np.ndarray) -> VariantResult:
    """A VariantResult whose unspecified per-joint series are zero; ``error`` sets q_true = q_ref + error."""
    n = len(t)
    zeros = np.zeros((n, NJ))
    q_ref = np.stack([np.sin(t), np.cos(2 * t)], axis=1)
    error = series.pop("error", zeros)
    fields = {
        name: series.pop(name, zeros.copy())
        for name in ("qd_ref", "qdd_ref", "q_meas", "qd_true", "qdd_true", "qd_hat", "luaf_hat", "luaf_true",
                     "tau", "sliding", "fault")
    }
    assert not series, f"unknown series {sorted(series)}"
    return VariantResult(name="v", observer="obs", controller="ctl", t=t, q_ref=q_ref, q_true=q_ref + error,
                         fault_active=np.zeros(n, dtype=bool), **fields)


def metrics_spec(**kwargs) -> MetricsSpec:
    values = {"window_start": 0.5, "estimation_window_start": 0.25, "fault_settle": 0.25,
              "tracking_tolerance": 0.01, "velocity_tolerance": 0.05}
    values.update(kwargs)
    return MetricsSpec(**values)


def index(time: float) -> int:
    k = time / DT
    assert k == int(k)
    return int(k)


# ------------------------------------------------------------------------------------------ windows


def test_evaluation_mask_excludes_settle_interval_after_each_onset() -> None:
    mask = evaluation_mask(T, 0.5, [1.0, 1.5], 0.25)
    expected = np.zeros(N, dtype=bool)
    expected[index(0.5):] = True
    expected[index(1.0):index(1.25)] = False  # [onset, onset + settle): the onset sample out, the end sample in
    expected[index(1.5):index(1.75)] = False
    np.testing.assert_array_equal(mask, expected)
    assert mask[index(1.0) - 1] and not mask[index(1.0)] and not mask[index(1.25) - 1] and mask[index(1.25)]


def test_evaluation_mask_edge_cases() -> None:
    np.testing.assert_array_equal(evaluation_mask(T, 0.0, [], 1.0), np.ones(N, dtype=bool))
    # No settle time: nothing is excluded.
    np.testing.assert_array_equal(evaluation_mask(T, 0.5, [1.0], 0.0), T >= 0.5)
    # An onset before the window start only removes what is still inside its settle interval.
    np.testing.assert_array_equal(evaluation_mask(T, 0.5, [0.25], 0.5), T >= 0.75)
    # Overlapping settle intervals.
    np.testing.assert_array_equal(evaluation_mask(T, 0.0, [1.0, 1.125], 0.25), (T < 1.0) | (T >= 1.375))


def test_rms_and_max_over_the_run_and_the_window() -> None:
    onset = 1.0
    start, settle_end = index(0.5), index(1.25)
    error = np.zeros((N, NJ))
    # Joint 1: 1 before the window, 0.1 inside it, -5 in the settle interval (excluded from the window).
    error[:start, 0] = 1.0
    error[start:, 0] = 0.1
    error[index(onset):settle_end, 0] = -5.0
    # Joint 2: 3 before the window, +-0.2 alternating inside it, 0 in the settle interval.
    error[:start, 1] = 3.0
    error[start:, 1] = 0.2 * (-1.0) ** np.arange(N - start)
    error[index(onset):settle_end, 1] = 0.0
    result = make_result(error=error)
    m = compute_metrics(result, metrics_spec(), [onset])

    n_before, n_settle = start, settle_end - index(onset)
    n_window = N - n_before - n_settle
    np.testing.assert_allclose(m["rms_error_converged"], [0.1, 0.2], rtol=1e-12)
    np.testing.assert_allclose(m["max_error_converged"], [0.1, 0.2], rtol=1e-12)
    np.testing.assert_allclose(m["max_error"], [5.0, 3.0], rtol=1e-12)
    expected_rms = np.sqrt([
        (n_before * 1.0 + n_settle * 25.0 + n_window * 0.01) / N,
        (n_before * 9.0 + n_settle * 0.0 + n_window * 0.04) / N,
    ])
    np.testing.assert_allclose(m["rms_error"], expected_rms, rtol=1e-12)


def test_estimation_metrics_use_their_window_and_truth_minus_estimate() -> None:
    start = index(0.25)
    qd_true = np.ones((N, NJ))
    qd_hat = np.ones((N, NJ))
    qd_hat[:start] = -100.0  # before the estimation window: ignored
    qd_hat[start:, 0] = 1.0 - 0.3  # velocity error +0.3
    qd_hat[start:, 1] = 1.0 + 0.4 * (-1.0) ** np.arange(N - start)
    luaf_true = np.full((N, NJ), 2.0)
    luaf_hat = np.full((N, NJ), 2.0)
    luaf_hat[start:] = [1.5, 2.0]
    luaf_hat[index(1.0):index(1.25)] = 1e6  # inside the settle interval: excluded
    result = make_result(qd_true=qd_true, qd_hat=qd_hat, luaf_true=luaf_true, luaf_hat=luaf_hat)
    m = compute_metrics(result, metrics_spec(), [1.0])
    np.testing.assert_allclose(m["rms_velocity_error"], [0.3, 0.4], rtol=1e-12)
    np.testing.assert_allclose(m["rms_luaf_error"], [0.5, 0.0], rtol=1e-12, atol=0)


def test_rms_torque_over_the_whole_run() -> None:
    tau = np.zeros((N, NJ))
    tau[:, 0] = 3.0
    tau[:, 1] = 4.0 * (-1.0) ** np.arange(N)
    m = compute_metrics(make_result(tau=tau), metrics_spec(window_start=1.9), [0.1])
    np.testing.assert_allclose(m["rms_torque"], [3.0, 4.0], rtol=1e-12)


def test_all_metrics_per_joint() -> None:
    m = compute_metrics(make_result(), metrics_spec(), [])
    assert set(m) == set(METRICS)
    for name, value in m.items():
        assert np.shape(value) == (NJ,), name


# ------------------------------------------------------------------------------------------ settling time


def settling_time(t: np.ndarray, error: np.ndarray, tolerance: float, until: float) -> np.ndarray:
    """The convergence time of a tracking error ``(T, n)`` with a fault at ``until`` (inf: none)."""
    zeros = np.zeros_like(error)
    series = RecordedSeries(error, zeros, zeros, zeros, zeros, zeros, zeros, zeros)
    onsets = [until] if np.isfinite(until) else []
    spec = metrics_spec(tracking_tolerance=tolerance)
    return series_metrics(t, series, spec, onsets, np.full(error.shape[1], np.nan))["convergence_time"]


def test_settling_time_is_the_last_entry_into_tolerance() -> None:
    error = np.full((N, 3), 1e-3)
    error[:300, 0] = 1.0  # decays: inside from sample 300 on
    error[:100, 1] = -1.0
    error[600:610, 1] = 0.5  # leaves the tolerance again: the last exit counts
    error[:, 2] = 0.01  # exactly at the tolerance counts as inside
    np.testing.assert_array_equal(settling_time(T, error, 0.01, np.inf), [T[300], T[610], T[0]])


def test_settling_time_ignores_everything_from_the_first_fault_on() -> None:
    error = np.full((N, 2), 1e-3)
    error[:300] = 1.0
    error[index(1.0):] = 10.0  # the fault kicks the error out again
    np.testing.assert_array_equal(settling_time(T, error, 0.01, 1.0), [T[300], T[300]])
    # via compute_metrics: convergence_time stops at the first of several onsets
    result = make_result(error=error)
    m = compute_metrics(result, metrics_spec(), [1.5, 1.0])
    np.testing.assert_array_equal(m["convergence_time"], [T[300], T[300]])


def test_settling_time_nan_and_start_cases() -> None:
    t = 0.5 + T  # does not start at 0, so "the start time" is distinguishable from 0
    always_in = np.zeros((N, 1))
    never_in = np.ones((N, 1))
    out_at_the_end = np.zeros((N, 1))
    out_at_the_end[-1] = 1.0  # not settled at the end of the run
    with_nan = np.zeros((N, 1))
    with_nan[1000] = np.nan  # NaN counts as outside
    assert settling_time(t, always_in, 0.01, np.inf)[0] == t[0]
    assert np.isnan(settling_time(t, never_in, 0.01, np.inf)[0])
    assert np.isnan(settling_time(t, out_at_the_end, 0.01, np.inf)[0])
    assert settling_time(t, with_nan, 0.01, np.inf)[0] == t[1001]
    # Outside right up to the fault: not settled before it.
    out_before_fault = np.zeros((N, 1))
    out_before_fault[index(0.875):] = 1.0
    assert np.isnan(settling_time(t, out_before_fault, 0.01, t[index(1.0)])[0])
    # A fault before the first sample leaves nothing to settle in.
    assert np.isnan(settling_time(t, always_in, 0.01, t[0])[0])


def test_observer_convergence_time_uses_velocity_tolerance() -> None:
    qd_true = np.zeros((N, NJ))
    qd_hat = np.zeros((N, NJ))
    qd_hat[:200] = 0.5
    qd_hat[200:400, 0] = 0.04  # inside velocity_tolerance 0.05 (outside tracking_tolerance 0.01)
    qd_hat[200:400, 1] = 0.06  # outside
    m = compute_metrics(make_result(qd_true=qd_true, qd_hat=qd_hat), metrics_spec(), [])
    np.testing.assert_array_equal(m["observer_convergence_time"], [T[200], T[400]])
    assert m["convergence_time"][0] == T[0]  # the tracking error is 0 throughout


# ------------------------------------------------------------------------------------------ chattering


def square_wave(amplitude: float, half_period: int) -> np.ndarray:
    return amplitude * np.where((np.arange(N) // half_period) % 2 == 0, 1.0, -1.0)


def test_chattering_of_a_square_wave_and_a_ramp() -> None:
    """A square wave of amplitude A and frequency f varies by 2A twice per period: 4 A f per second.
    A ramp of slope c varies by c per second."""
    half_period = 32  # samples; f = 1 / (64 DT) = 16 Hz
    f = 1.0 / (2 * half_period * DT)
    amplitude, slope = 2.5, 3.0
    tau = np.stack([square_wave(amplitude, half_period), slope * T], axis=1)
    tau[: index(0.5)] = 1e3 * np.arange(index(0.5))[:, None]  # before the window: ignored
    m = compute_metrics(make_result(tau=tau), metrics_spec(window_start=0.5), [])
    # The window [0.5, 2] s holds 1536 pairs = 1.5 s = 24 periods: 48 switches of 2A.
    assert f == 16.0
    np.testing.assert_allclose(m["chattering"], [4 * amplitude * f, slope], rtol=1e-12)
    np.testing.assert_allclose(m["chattering"][0], 48 * 2 * amplitude / 1.5, rtol=1e-12)


def test_chattering_skips_pairs_that_leave_the_window() -> None:
    """Only differences between two consecutive samples both in the window count, and the window length is
    the number of such pairs times the sample time."""
    half_period, amplitude, slope = 32, 2.5, 3.0
    tau = np.stack([square_wave(amplitude, half_period), slope * T], axis=1)
    onset, settle_end = index(1.0), index(1.25)
    tau[onset:settle_end] = 1e6  # a huge excursion inside the settle interval: excluded with its edges
    m = compute_metrics(make_result(tau=tau), metrics_spec(window_start=0.5, fault_settle=0.25), [1.0])

    inside = np.zeros(N, dtype=bool)
    inside[index(0.5):] = True
    inside[onset:settle_end] = False
    pairs = [k for k in range(N - 1) if inside[k] and inside[k + 1]]
    switches = sum(tau[k + 1, 0] != tau[k, 0] for k in pairs)
    assert (len(pairs), switches) == (511 + 768, 15 + 24)
    expected = [switches * 2 * amplitude / (len(pairs) * DT), slope]
    np.testing.assert_allclose(m["chattering"], expected, rtol=1e-12)


# ------------------------------------------------------------------------------------------ NaN handling


def test_windows_past_the_end_give_nan() -> None:
    tau = np.stack([square_wave(1.0, 32), T], axis=1)
    result = make_result(error=np.full((N, NJ), 0.5), tau=tau, qd_hat=np.ones((N, NJ)))
    m = compute_metrics(result, metrics_spec(window_start=3.0, estimation_window_start=2.5), [])
    for name in ("rms_error_converged", "max_error_converged", "chattering", "rms_velocity_error", "rms_luaf_error"):
        assert np.all(np.isnan(m[name])), name
    for name in ("rms_error", "max_error", "rms_torque"):
        assert np.all(np.isfinite(m[name])), name
    np.testing.assert_allclose(m["rms_error"], 0.5, rtol=1e-12)
    assert np.all(np.isnan(m["convergence_time"]))  # 0.5 rad is never within 0.01


def test_window_covered_by_settle_interval_gives_nan() -> None:
    m = compute_metrics(make_result(error=np.full((N, NJ), 0.5)), metrics_spec(window_start=1.5, fault_settle=1.0), [1.25])
    assert np.all(np.isnan(m["rms_error_converged"])) and np.all(np.isnan(m["chattering"]))


def test_single_sample_window_has_rms_but_no_chattering() -> None:
    m = compute_metrics(make_result(error=np.full((N, NJ), 0.5)), metrics_spec(window_start=T[-1]), [])
    np.testing.assert_allclose(m["rms_error_converged"], 0.5, rtol=1e-12)
    assert np.all(np.isnan(m["chattering"]))


def test_truncated_result_of_a_diverged_run() -> None:
    """A diverged run ends early: windows that start after its end are NaN, the rest still computes."""
    error = np.full((N, NJ), 1e-3)
    result = make_result(error=error, tau=np.stack([square_wave(1.0, 32), T], axis=1)).truncated(index(0.75))
    assert len(result.t) == index(0.75)
    m = compute_metrics(result, metrics_spec(window_start=1.0, estimation_window_start=0.25), [])
    assert np.all(np.isnan(m["rms_error_converged"])) and np.all(np.isnan(m["chattering"]))
    np.testing.assert_allclose(m["rms_error"], 1e-3, rtol=1e-9)
    np.testing.assert_array_equal(m["convergence_time"], [0.0, 0.0])


@pytest.mark.parametrize("n_samples", [0, 1])
def test_degenerate_lengths_do_not_raise(n_samples: int) -> None:
    result = make_result().truncated(n_samples)
    m = compute_metrics(result, metrics_spec(window_start=0.0, estimation_window_start=0.0), [])
    assert np.all(np.isnan(m["chattering"]))
    if n_samples == 0:
        assert all(np.all(np.isnan(value)) for value in m.values())


# ------------------------------------------------------------------------------ sliding and fault response


def test_reaching_time_is_when_the_sliding_variable_stays_within_tolerance() -> None:
    sliding = np.zeros((N, NJ))
    sliding[: index(0.25), 0] = 1.0       # joint 1 reaches the surface at 0.25 s
    sliding[index(0.5), 1] = -0.02        # joint 2 leaves the band once at 0.5 s
    m = compute_metrics(make_result(sliding=sliding), metrics_spec(sliding_tolerance=0.01), [])
    np.testing.assert_array_equal(m["reaching_time"], [0.25, 0.5 + DT])


def test_fault_peak_and_recovery_per_faulty_joint() -> None:
    error = np.zeros((N, NJ))
    # Joint 1 faulty from 1.0 s: the error jumps to 0.3 and is back within 0.01 at 1.25 s.
    error[index(1.0) : index(1.25), 0] = 0.3
    error[index(1.0) : index(1.125), 1] = 0.5   # joint 2 is healthy: no value whatever its error
    m = compute_metrics(make_result(error=error), metrics_spec(), [1.0], np.array([1.0, np.nan]))
    assert m["fault_peak_error"][0] == pytest.approx(0.3)
    assert m["recovery_time"][0] == pytest.approx(0.25)
    assert np.isnan(m["fault_peak_error"][1]) and np.isnan(m["recovery_time"][1])


def test_fault_response_stops_at_the_next_onset_and_can_fail() -> None:
    error = np.zeros((N, NJ))
    error[index(0.5) :, 0] = 0.2                 # never recovers
    error[index(1.5) :, 1] = 0.9                 # after the next onset: not counted for joint 2's first fault
    m = compute_metrics(make_result(error=error), metrics_spec(), [0.5, 1.5], np.array([0.5, 0.5]))
    assert m["fault_peak_error"][0] == pytest.approx(0.2) and np.isnan(m["recovery_time"][0])
    assert m["fault_peak_error"][1] == 0.0 and m["recovery_time"][1] == 0.0


def test_without_joint_onsets_every_joint_counts_from_the_first_fault() -> None:
    m = compute_metrics(make_result(), metrics_spec(), [1.0])
    np.testing.assert_array_equal(m["recovery_time"], [0.0, 0.0])
    m = compute_metrics(make_result(), metrics_spec(), [])
    assert np.isnan(m["recovery_time"]).all()


def test_luaf_convergence_overshoot_and_accuracy_after_the_fault() -> None:
    luaf_true = np.ones((N, NJ))
    luaf_hat = np.zeros((N, NJ))
    ramp = np.minimum(T / 0.125, 1.0)
    luaf_hat[:, 0] = ramp                          # joint 1: converges monotonically at 0.125 s
    luaf_hat[:, 1] = ramp + 2.0 * (T < 0.0625)     # joint 2: overshoots to 2.5 (error -1.5) before settling
    luaf_hat[index(1.5) :, 0] = 0.8                # joint 1: error 0.2 after the fault (settle ends 1.25 s)
    result = make_result(luaf_true=luaf_true, luaf_hat=luaf_hat)
    m = compute_metrics(result, metrics_spec(luaf_tolerance=0.1), [1.0])
    assert m["luaf_convergence_time"][0] == pytest.approx(0.125 - 0.1 * 0.125, abs=DT)
    np.testing.assert_allclose(m["peak_luaf_error_transient"], [1.0, 1.5], atol=DT / 0.125 * 2)
    after = (T >= 1.25)
    expected = np.sqrt(np.mean(np.where(T[after] >= 1.5, 0.2, 0.0) ** 2))
    assert m["rms_luaf_error_fault"][0] == pytest.approx(expected)
    assert m["rms_luaf_error_fault"][1] == 0.0
    assert np.isnan(compute_metrics(result, metrics_spec(), [])["rms_luaf_error_fault"]).all()


def test_overshoot_is_how_far_the_estimate_goes_past_the_truth() -> None:
    """One definition for every observer: the largest error of the sign opposite to the initial error in the
    transient. Joint 1 converges from an initial error of 3 without crossing (its peak is its initial error:
    no overshoot); joint 2 starts with error 1 and swings to -2.5 (an overshoot of 2.5)."""
    luaf_true = np.ones((N, NJ))
    luaf_hat = np.ones((N, NJ))
    decay = np.exp(-T / 0.02)
    luaf_hat[:, 0] = 1.0 - 3.0 * decay                                   # error 3 e^(-t/0.02) > 0
    luaf_hat[:, 1] = 1.0 - decay + 3.5 * np.sin(np.pi * T / 0.1) * (T < 0.1)
    m = compute_metrics(make_result(luaf_true=luaf_true, luaf_hat=luaf_hat), metrics_spec(), [])
    assert m["luaf_overshoot"][0] == 0.0
    assert m["peak_luaf_error_transient"][0] == pytest.approx(3.0)
    assert m["luaf_overshoot"][1] == pytest.approx(3.5 - np.exp(-2.5), rel=1e-3)
    # An estimate that starts exact (initial error 0): any departure counts.
    exact = compute_metrics(make_result(luaf_true=luaf_true, luaf_hat=luaf_true + 0.3 * (T > 0.1)[:, None]),
                            metrics_spec(), [])
    np.testing.assert_allclose(exact["luaf_overshoot"], [0.3, 0.3])


def test_first_and_for_good_reaching_times() -> None:
    """Joint 1 reaches the surface at 0.25 s and is kicked off it at 0.75 s until 1 s: first 0.25 s, for good
    1 s. Joint 2 never reaches it."""
    sliding = np.zeros((N, NJ))
    sliding[: index(0.25), 0] = 1.0
    sliding[index(0.75) : index(1.0), 0] = 0.5
    sliding[:, 1] = 0.2
    m = compute_metrics(make_result(sliding=sliding), metrics_spec(sliding_tolerance=0.01), [])
    assert m["first_reaching_time"][0] == 0.25 and m["reaching_time"][0] == 1.0
    assert np.isnan(m["first_reaching_time"][1]) and np.isnan(m["reaching_time"][1])
    # Only before the first fault: an entry after it does not count.
    sliding[index(1.5) :, 1] = 0.0
    m = compute_metrics(make_result(sliding=sliding), metrics_spec(sliding_tolerance=0.01), [1.25])
    assert np.isnan(m["first_reaching_time"][1])


def test_converged_window_starts_per_joint_at_its_own_convergence() -> None:
    """window_start 0.5 s, fault_settle 0.25 s; joint 1 converges at 0.125 s (window from 0.5 s), joint 2
    only at 1 s: its after-convergence metrics and chattering start at 1.25 s, not at 0.5 s."""
    error = np.zeros((N, NJ))
    error[: index(0.125), 0] = 0.5
    error[: index(1.0), 1] = 0.02                          # outside the 0.01 tolerance until 1 s
    error[index(1.0) : index(1.25), 1] = 0.008             # the terminal phase: inside, not yet steady
    tau = np.zeros((N, NJ))
    tau[: index(1.25) : 2, 1] = 1.0                        # joint 2 switches every other sample until 1.25 s
    m = compute_metrics(make_result(error=error, tau=tau), metrics_spec(), [])
    np.testing.assert_array_equal(m["convergence_time"], [0.125, 1.0])
    np.testing.assert_array_equal(m["rms_error_converged"], [0.0, 0.0])
    np.testing.assert_array_equal(m["max_error_converged"], [0.0, 0.0])
    np.testing.assert_array_equal(m["chattering"], [0.0, 0.0])
    # A later excursion that is no fault (a sensor effect) moves convergence_time but not the window.
    error[index(1.75) : index(1.875), 1] = 0.05
    m = compute_metrics(make_result(error=error), metrics_spec(), [])
    assert m["convergence_time"][1] == 1.875
    assert m["max_error_converged"][1] == pytest.approx(0.05)
    # A joint that never converges keeps window_start: its error counts.
    error[:, 1] = 0.02
    m = compute_metrics(make_result(error=error), metrics_spec(), [])
    assert np.isnan(m["convergence_time"][1]) and m["rms_error_converged"][1] == pytest.approx(0.02)


def test_fault_peak_error_looks_at_the_fault_window_only() -> None:
    """A spike 0.75 s after the onset is outside a 0.5 s fault window (but inside the next-onset span the
    metric used before); recovery_time still spans up to the next onset."""
    error = np.zeros((N, NJ))
    error[index(0.5) + 10, :] = 0.004       # within the window: the response to the fault
    error[index(1.25), :] = 0.3             # a spike far from the onset
    m = compute_metrics(make_result(error=error), metrics_spec(fault_window=0.5), [0.5], np.array([0.5, 0.5]))
    np.testing.assert_allclose(m["fault_peak_error"], [0.004, 0.004], rtol=1e-12)
    np.testing.assert_array_equal(m["recovery_time"], [1.25 + DT - 0.5] * 2)
    m = compute_metrics(make_result(error=error), metrics_spec(fault_window=1.0), [0.5], np.array([0.5, 0.5]))
    np.testing.assert_allclose(m["fault_peak_error"], [0.3, 0.3], rtol=1e-12)


def test_saturation_time_is_the_share_beyond_the_limit() -> None:
    tau = np.zeros((N, NJ))
    tau[: N // 4, 0] = 3.0  # a quarter of the run above joint 1's limit of 2 N m
    tau[: N // 2, 1] = -2.0  # at joint 2's limit, not beyond it: delivered as asked
    m = compute_metrics(make_result(tau=tau), metrics_spec(), [], torque_limits=np.array([2.0, 2.0]))
    np.testing.assert_allclose(m["saturation_time"], [(N // 4) / N, 0.0])
    lower = compute_metrics(make_result(tau=tau), metrics_spec(), [], torque_limits=np.array([np.inf, 1.0]))
    np.testing.assert_allclose(lower["saturation_time"], [0.0, (N // 2) / N])  # inf: never clipped
    assert not compute_metrics(make_result(tau=tau), metrics_spec(), [])["saturation_time"].any()  # no limits


# ------------------------------------------------------------------------------------------ columns side by side


def test_series_metrics_of_results_side_by_side_are_each_results_own() -> None:
    """Five results side by side in one call (``(T, 5, n)`` series; joint onsets and torque limits per joint)
    give each result's metrics bit for bit, with the reference as each result's own or as one broadcast to all
    (the batch's way): every metric is per column, every sum over time in time order, NumPy's sum over the time
    axis of ``(T, n)``."""
    rng = np.random.default_rng(4)
    spec = metrics_spec(sliding_tolerance=0.05, luaf_tolerance=0.5)
    onsets, joint_onsets, limits = [1.0, 1.5], np.array([1.0, np.nan]), np.array([0.8, np.inf])
    results = []
    for r in range(5):
        decay = np.exp(-T * (2.0 + r))[:, None]
        series = {name: decay * rng.normal(size=(N, NJ)) + 1e-3 * rng.normal(size=(N, NJ))
                  for name in ("error", "qd_true", "qd_hat", "luaf_true", "luaf_hat", "tau", "sliding")}
        series["tau"][T > 1.0] += rng.choice([-1.0, 1.0], size=(int((T > 1.0).sum()), NJ))  # crosses the limit
        if r == 2:
            series["luaf_hat"][700:710, 1] = np.nan  # a NaN estimate counts as outside the tolerance
        results.append(make_result(**series))
    side_by_side_series = RecordedSeries(*(np.stack([getattr(r, name) for r in results], axis=1)
                                           for name in RecordedSeries._fields))
    side_by_side = series_metrics(T, side_by_side_series, spec, onsets, joint_onsets, limits)
    shared = series_metrics(
        T, side_by_side_series._replace(q_ref=np.broadcast_to(results[0].q_ref[:, None], (N, 5, NJ))), spec, onsets,
        joint_onsets, limits)
    for metric, values in side_by_side.items():
        np.testing.assert_array_equal(shared[metric], values, err_msg=metric)
    error = results[1].tracking_error
    assert side_by_side["rms_error"][1].tobytes() == np.sqrt(np.square(error).sum(axis=0) / N).tobytes()
    for r, result in enumerate(results):
        alone = compute_metrics(result, spec, onsets, joint_onsets, limits)
        assert list(alone)[: len(side_by_side)] == list(side_by_side)
        for metric, values in side_by_side.items():
            np.testing.assert_array_equal(values[r], alone[metric], err_msg=f"{r} {metric}")
    assert np.isfinite(side_by_side["recovery_time"][:, 0]).any() and np.isnan(side_by_side["recovery_time"][:, 1]).all()
    assert (side_by_side["saturation_time"][:, 0] > 0).all() and (side_by_side["saturation_time"][:, 1] == 0).all()
