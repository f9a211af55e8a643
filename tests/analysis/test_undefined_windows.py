"""Which metrics a run leaves undefined because their window starts after its last sample, and the reason given
for each (ftc_mj.analysis.metrics.windows_after_the_end): a start on the last sample is inside the run, the
first reason of a metric wins, a diagnoser never armed names its start, an empty run leaves every window out."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from ftc_mj.analysis.metrics import MetricsSpec, windows_after_the_end

DT = 0.25  # exact in binary
T = np.arange(5) * DT  # the last sample at 1 s

CONVERGED = ("rms_error_converged", "max_error_converged", "chattering")
ESTIMATION = ("rms_velocity_error", "rms_luaf_error", "rms_luaf_error_fault")
FAULT = ("fault_peak_error", "recovery_time", "detection_delay", "missed_detection", "isolation_correct",
         "fault_estimate_rms")


def _undefined(t: np.ndarray, fault_onsets: list[float], armed: np.ndarray | None = None, **spec) -> dict:
    diagnosis = None if armed is None else SimpleNamespace(t=t, armed=armed)
    return windows_after_the_end(SimpleNamespace(t=t, diagnosis=diagnosis), MetricsSpec(**spec), fault_onsets)


def test_a_window_from_the_last_sample_is_inside_the_run():
    """window_start 2 s is after the end (1 s); estimation_window_start 1 s is the last sample: defined; no
    fault, no diagnosis: nothing else."""
    assert _undefined(T, [], window_start=2.0, estimation_window_start=1.0) == {
        metric: "metrics.window_start = 2 s" for metric in CONVERGED}


def test_every_reason_and_the_first_one_wins():
    """The estimation window (1.5 s) and the first of the onsets (2 s, listed second) start after the end; the
    fault RMS keeps the estimation window's reason; a diagnoser never armed leaves its other metrics (the false
    alarms) undefined for its start."""
    undefined = _undefined(T, [3.0, 2.0], np.zeros(len(T), dtype=bool), window_start=0.5,
                           estimation_window_start=1.5)
    expected = {metric: "metrics.estimation_window_start = 1.5 s" for metric in ESTIMATION}
    expected |= {metric: "the first fault onset = 2 s" for metric in FAULT}
    expected |= {"false_alarms": "the diagnoser's start", "false_alarm_rate": "the diagnoser's start"}
    assert undefined == expected


def test_an_armed_diagnoser_and_windows_within_the_run_leave_nothing_undefined():
    armed = T >= 0.5
    assert _undefined(T, [0.75], armed, window_start=0.0, estimation_window_start=0.25) == {}


def test_an_empty_run_leaves_every_window_with_a_start_undefined():
    """No sample: every window starts after the (missing) end, even at 0 s; an empty diagnosis adds nothing."""
    empty = np.zeros(0)
    expected = {metric: "metrics.window_start = 0 s" for metric in CONVERGED}
    expected |= {metric: "metrics.estimation_window_start = 0 s" for metric in ESTIMATION}
    assert _undefined(empty, [], np.zeros(0, dtype=bool)) == expected
