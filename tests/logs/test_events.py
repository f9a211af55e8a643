"""Labelled windows of a log (ftc_mj/logs/events.py): a perfect detector scores as one and a useless one as
useless; the joints are checked against the robot; a log's table keeps only the metrics it defines."""

from __future__ import annotations

import numpy as np
import pytest

from ftc_mj.config.errors import InputError
from ftc_mj.logs.events import EventSpec, compile_events, event_metrics, log_metrics
from ftc_mj.results import Diagnosis

JOINTS = ["a", "b", "c"]
T = np.arange(0.0, 10.0, 0.01)
EVENTS = compile_events([EventSpec(start=2.0, end=3.0, joints=[1], label="push a"),
                         EventSpec(start=5.0, end=6.0, joints=["b", 3], label="push b and c")], JOINTS, "f.yaml")


def diagnosis(alarm: np.ndarray, armed_from: float = 0.5) -> Diagnosis:
    zeros = np.zeros(alarm.shape)
    return Diagnosis(space="torque", t=T, signal=zeros, fault_estimate=zeros, residual=zeros, threshold=zeros,
                     alarm=alarm, armed=T >= armed_from, mean=np.zeros(3), std=np.zeros(3), injected=zeros)


def test_a_perfect_detector_scores_as_one():
    alarm = np.zeros((len(T), 3), dtype=bool)
    alarm[(T >= 2.1) & (T <= 3.0), 0] = True
    alarm[(T >= 5.3) & (T <= 6.0), 1:] = True
    metrics = event_metrics(diagnosis(alarm), EVENTS, 3)
    np.testing.assert_array_equal(metrics["events_detected"], [1.0, 1.0, 1.0])
    np.testing.assert_allclose(metrics["event_delay"], [0.1, 0.3, 0.3], atol=1e-9)
    np.testing.assert_array_equal(metrics["alarms_outside_events"], 0.0)
    np.testing.assert_array_equal(metrics["alarms_on_other_joints"], 0.0)


def test_useless_detectors_score_as_useless():
    silent = event_metrics(diagnosis(np.zeros((len(T), 3), dtype=bool)), EVENTS, 3)
    np.testing.assert_array_equal(silent["events_detected"], 0.0)
    assert np.isnan(silent["event_delay"]).all()
    # Alarming in pulses everywhere: every push "detected", and every pulse outside the pushes or on the wrong
    # joint counted.
    pulses = np.zeros((len(T), 3), dtype=bool)
    pulses[(np.round(T * 100).astype(int) % 50) < 10] = True
    noisy = event_metrics(diagnosis(pulses), EVENTS, 3)
    np.testing.assert_array_equal(noisy["events_detected"], 1.0)
    # 20 pulses, every 0.5 s: the first unarmed, 3 in each window (both ends included), 13 outside them
    np.testing.assert_array_equal(noisy["alarms_outside_events"], 13.0)
    np.testing.assert_array_equal(noisy["alarms_on_other_joints"], 3.0)  # the 3 of the window not naming it


def test_joints_are_checked_and_an_unknown_one_is_one_error():
    with pytest.raises(InputError, match=r"log.events.0.joints.1: 'd' is not a joint"):
        compile_events([EventSpec(start=0.0, end=1.0, joints=[1, "d"])], JOINTS, "f.yaml")
    with pytest.raises(InputError, match=r"log.events.0.joints.0: joint 4: the robot has 3 joints"):
        compile_events([EventSpec(start=0.0, end=1.0, joints=[4])], JOINTS, "f.yaml")
    with pytest.raises(ValueError, match="end 1.0 must be after start 2.0"):
        EventSpec(start=2.0, end=1.0, joints=[1])


class _Result:
    def __init__(self, name: str, alarm: np.ndarray):
        self.name, self.diagnosis = name, diagnosis(alarm)


def test_a_logs_table_keeps_what_it_defines():
    """Metrics no result defines (ground truth) are left out, and with events the false alarms counted
    against no fault (they would count the pushes) and the logged torque's chattering; the event metrics come
    after."""
    results = [_Result("x", np.zeros((len(T), 3), dtype=bool))]
    metrics = {"x": {"rms_luaf_error": np.full(3, np.nan), "false_alarms": np.zeros(3),
                     "chattering": np.ones(3), "rms_error": np.ones(3)}}
    shown = log_metrics(EVENTS, results, metrics, ["rms_luaf_error", "false_alarms", "chattering", "rms_error"])
    assert shown == ["rms_error", "events_detected", "alarms_outside_events", "alarms_on_other_joints"]
    assert log_metrics([], results, metrics, ["rms_luaf_error", "false_alarms"]) == ["false_alarms"]


def test_a_shortened_run_scores_the_events_it_reaches_and_an_event_past_the_log_is_refused(tmp_path):
    """``--set duration=...`` on a log with events keeps the events that start within the run; an event that
    starts after the log itself ends is a mistake in the file and is refused in one line."""
    from ftc_mj.scenario.loading import load_scenario

    pushed = "scenarios/real/ur10e_pushed.yaml"
    whole = load_scenario(pushed)
    short = load_scenario(pushed, overrides=["duration=5"])
    assert 0 < len(short.log.events) < len(whole.log.events)
    assert [event.start for event in short.log.events] == [e.start for e in whole.log.events if e.start < 5 - 1e-9]
    with pytest.raises(InputError, match=r"log.events.0.start: 1000 s is after the log.s end"):
        load_scenario(pushed, overrides=["log.events.0.start=1000", "log.events.0.end=1001"])
